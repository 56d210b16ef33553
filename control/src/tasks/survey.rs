//! The site survey: what a crew measures of the bay, given to the robot as `survey.*`
//! parameters (a site file's keys; ARCHITECTURE.md section 6 documents the format), turned
//! into the [`SiteMap`] the tasks plan with.
//!
//! Without a survey the tasks use [`SiteMap::default_bay`], a copy of the simulator's fixed
//! bay. With one, every key below must be given (none falls back to the fixed bay), in `map`
//! (x east along the conductors, y north, z up; metres and degrees):
//!
//! | key | meaning |
//! |---|---|
//! | `survey.wire.point_m` | a point on the target conductor's axis where the rod is to hang |
//! | `survey.wire.direction` | the conductor's direction there (any length, any sign) |
//! | `survey.wire.half_length_m` | half length of the conductor segment the finders search |
//! | `survey.phases.south_m`, `survey.phases.north_m` | the two other phases near the work, each as a straight segment `[ax, ay, az, bx, by, bz]` |
//! | `survey.work_spot.xy_m`, `survey.work_spot.yaw_deg` | where the base stands to work, and its heading |
//! | `survey.rack.xyz_m`, `survey.rack.yaw_deg` | the rod rack's plate centre and heading |
//! | `survey.cabinet.face_center_m`, `survey.cabinet.facing_deg` | the calibration cabinet's front face: its centre, and the heading of its outward normal |
//!
//! The cabinet cluster's bodies (cabinet, junction box, cable tray) and the rack's parts
//! follow from those poses with the dimensions of the standard cabinet and of rodlog's rack.

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use scenario::ParamError;

use super::site::{BasePose, RACK_HOLDERS, RACK_PEDESTAL_M, SiteMap};
use crate::motion::collision::OrientedBox;
use crate::perception::panoramic::WirePrior;

/// The survey's section of the parameters.
pub const SURVEY_SECTION: &str = "survey";

/// The cabinet cluster's boxes in the face frame (`x` into the cabinet, `y` to the left of
/// someone facing the cabinet, `z` up; origin at the face centre): name, centre, half extents
/// (m). The standard cabinet: 0.6 x 1.4 x 2.1 m behind a face 1.1 m high at its centre.
const CABINET_BODIES: [(&str, [f64; 3], [f64; 3]); 3] = [
    ("cabinet", [0.304, 0.0, -0.04], [0.36, 0.76, 1.06]),
    ("junction_box", [0.304, -0.82, 0.1], [0.21, 0.12, 0.25]),
    ("cable_tray", [0.054, -1.95, -0.15], [0.16, 1.05, 0.9]),
];

/// The rack's parts in the rack frame: name, centre, half extents (m).
pub(crate) const RACK_PARTS: [(&str, [f64; 3], [f64; 3]); 5] = [
    ("rack_plate", [0.0, 0.05, 0.01], [0.2, 0.2, 0.01]),
    (
        "rack_pedestal",
        [0.0, 0.05, -0.5 * RACK_PEDESTAL_M],
        [0.22, 0.22, 0.5 * RACK_PEDESTAL_M],
    ),
    ("rack_post", [0.0, 0.13, 0.6], [0.025, 0.025, 0.6]),
    (RACK_HOLDERS[0], [0.0, 0.05, 0.75], [0.04, 0.085, 0.015]),
    (RACK_HOLDERS[1], [0.0, 0.05, 1.45], [0.04, 0.085, 0.015]),
];

/// The rack's post and base plate ([`RACK_PARTS`]) as the rack measurement's model: the
/// post's section where the camera on the stored rod's handle sees it (above the plate, up
/// to the handle's top), and the plate's top face.
pub(crate) fn rack_post_model() -> crate::perception::rack::PostModel {
    let part = |name: &str| {
        RACK_PARTS
            .iter()
            .find(|(n, _, _)| *n == name)
            .map_or(([0.0; 3], [0.0; 3]), |(_, c, h)| (*c, *h))
    };
    let (post, post_half) = part("rack_post");
    let (plate, plate_half) = part("rack_plate");
    let plate_top_m = plate[2] + plate_half[2];
    let handle_top_m = robot::grounding_rod::RACK_STORE_HEIGHT_M
        + robot::grounding_rod::HANDLE_CENTER_IN_ROD_M[2]
        + 0.5 * robot::grounding_rod::HANDLE_LENGTH_M;
    crate::perception::rack::PostModel {
        centre_xy_m: [post[0], post[1]],
        half_width_m: post_half[0],
        band_z_m: [plate_top_m + 0.03, handle_top_m],
        plate_centre_m: [plate[0], plate[1], plate_top_m],
        plate_half_xy_m: [plate_half[0], plate_half[1]],
    }
}

fn missing(key: &str) -> ParamError {
    ParamError::Value {
        key: format!("{SURVEY_SECTION}.{key}"),
        value: "(missing)".to_owned(),
        reason: "a survey gives every survey key (see `rodlog params`); none falls back to the built-in bay".to_owned(),
    }
}

fn invalid(key: &str, value: impl std::fmt::Debug, reason: &str) -> ParamError {
    ParamError::Value {
        key: format!("{SURVEY_SECTION}.{key}"),
        value: format!("{value:?}"),
        reason: reason.to_owned(),
    }
}

impl SiteMap {
    /// The site map of the parameters' survey (module docs), or [`SiteMap::default_bay`]
    /// when they have none.
    ///
    /// # Errors
    /// [`ParamError::Value`] naming the key: a missing key, a wrong type, a zero direction,
    /// a non-positive half length.
    pub fn from_params(r: &mut scenario::Reader<'_>) -> Result<Self, ParamError> {
        let mut s = r.section(SURVEY_SECTION);
        let present = s.present(
            "the crew's survey of the bay (a site file's keys); absent: the built-in fixed bay",
        );
        const SURVEYED: &str = "required with a survey";
        let point = s.f64s_opt::<3>(
            "wire.point_m",
            SURVEYED,
            "m",
            "a point on the target conductor's axis where the rod hangs",
        )?;
        let direction = s.f64s_opt::<3>(
            "wire.direction",
            SURVEYED,
            "",
            "the target conductor's direction there",
        )?;
        let half_length = s.f64_opt(
            "wire.half_length_m",
            SURVEYED,
            "m",
            "half length of the conductor segment the finders search",
        )?;
        let south = s.f64s_opt::<6>(
            "phases.south_m",
            SURVEYED,
            "m",
            "the phase south of the target near the work: segment [ax, ay, az, bx, by, bz]",
        )?;
        let north = s.f64s_opt::<6>(
            "phases.north_m",
            SURVEYED,
            "m",
            "the phase north of the target near the work: segment [ax, ay, az, bx, by, bz]",
        )?;
        let spot = s.f64s_opt::<2>(
            "work_spot.xy_m",
            SURVEYED,
            "m",
            "where the base stands to work",
        )?;
        let spot_yaw = s.f64_opt(
            "work_spot.yaw_deg",
            SURVEYED,
            "deg",
            "the base's heading there, from +x counter-clockwise",
        )?;
        let rack = s.f64s_opt::<3>("rack.xyz_m", SURVEYED, "m", "the rod rack's plate centre")?;
        let rack_yaw = s.f64_opt("rack.yaw_deg", SURVEYED, "deg", "the rod rack's heading")?;
        let face = s.f64s_opt::<3>(
            "cabinet.face_center_m",
            SURVEYED,
            "m",
            "centre of the calibration cabinet's front face",
        )?;
        let facing = s.f64_opt(
            "cabinet.facing_deg",
            SURVEYED,
            "deg",
            "heading of the face's outward normal, from +x counter-clockwise",
        )?;
        if !present {
            return Ok(Self::default_bay());
        }
        let req = |v: Option<f64>, key: &str| v.ok_or_else(|| missing(key));
        let point = point.ok_or_else(|| missing("wire.point_m"))?;
        let direction = direction.ok_or_else(|| missing("wire.direction"))?;
        let half_length_m = req(half_length, "wire.half_length_m")?;
        let [south, north] = [
            south.ok_or_else(|| missing("phases.south_m"))?,
            north.ok_or_else(|| missing("phases.north_m"))?,
        ];
        let [x_m, y_m] = spot.ok_or_else(|| missing("work_spot.xy_m"))?;
        let spot_yaw = req(spot_yaw, "work_spot.yaw_deg")?;
        let rack = rack.ok_or_else(|| missing("rack.xyz_m"))?;
        let rack_yaw = req(rack_yaw, "rack.yaw_deg")?;
        let face = face.ok_or_else(|| missing("cabinet.face_center_m"))?;
        let facing = req(facing, "cabinet.facing_deg")?;

        let direction = Vector3::from(direction);
        if direction.norm() <= 1e-9 {
            return Err(invalid(
                "wire.direction",
                direction,
                "a direction is not zero",
            ));
        }
        if half_length_m <= 0.0 {
            return Err(invalid(
                "wire.half_length_m",
                half_length_m,
                "a positive length",
            ));
        }
        let segment = |v: [f64; 6]| (Point3::new(v[0], v[1], v[2]), Point3::new(v[3], v[4], v[5]));
        let map_from_rack = Isometry3::from_parts(
            Translation3::from(Vector3::from(rack)),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), rack_yaw.to_radians()),
        );
        // The face frame: x into the cabinet (against the outward normal), z up.
        let facing_rad = facing.to_radians();
        let normal = Vector3::new(facing_rad.cos(), facing_rad.sin(), 0.0);
        let map_from_face = Isometry3::from_parts(
            Translation3::from(Vector3::from(face)),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), facing_rad + std::f64::consts::PI),
        );
        let body = |frame: &Isometry3<f64>, (name, c, h): (&str, [f64; 3], [f64; 3])| {
            (
                name.to_owned(),
                OrientedBox {
                    frame_from_box: frame * Isometry3::translation(c[0], c[1], c[2]),
                    half_extents_m: Vector3::from(h),
                },
            )
        };
        let obstacles = CABINET_BODIES
            .into_iter()
            .map(|b| body(&map_from_face, b))
            .chain(RACK_PARTS.into_iter().map(|b| body(&map_from_rack, b)))
            .collect();
        Ok(Self {
            wire: WirePrior {
                point: Point3::from(point),
                direction,
                half_length_m,
            },
            other_conductors: vec![segment(south), segment(north)],
            work_spot: BasePose {
                x_m,
                y_m,
                yaw_rad: spot_yaw.to_radians(),
            },
            map_from_rack,
            calibration_target: Point3::from(face),
            calibration_normal: normal,
            obstacles,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use scenario::{Params, Reader};

    /// The committed site file of the fixed bay (`config/sites/fixed_bay.toml`).
    const FIXED_BAY: &str = include_str!("../../../config/sites/fixed_bay.toml");

    fn read(text: &str) -> Result<(SiteMap, Vec<scenario::KeyProblem>), ParamError> {
        let table: toml::Table = text
            .parse()
            .map_err(|e: toml::de::Error| ParamError::Value {
                key: "file".into(),
                value: String::new(),
                reason: e.to_string(),
            })?;
        let params = Params::from_table(&table);
        let mut r = Reader::new(&params);
        let site = SiteMap::from_params(&mut r)?;
        Ok((site, r.problems()))
    }

    /// The fixed bay's site file describes the built-in bay: every pose and body within
    /// 1e-9 m (degrees round-trip through the file).
    #[test]
    fn the_fixed_bay_file_is_the_built_in_bay() -> Result<(), ParamError> {
        let (site, problems) = read(FIXED_BAY)?;
        assert!(problems.is_empty(), "{problems:?}");
        let d = SiteMap::default_bay();
        let close = |a: &Isometry3<f64>, b: &Isometry3<f64>| {
            (a.translation.vector - b.translation.vector).norm() < 1e-9
                && a.rotation.angle_to(&b.rotation) < 1e-9
        };
        assert!((site.wire.point - d.wire.point).norm() < 1e-12);
        assert_eq!(site.other_conductors, d.other_conductors);
        assert!(close(&site.work_spot.isometry(), &d.work_spot.isometry()));
        assert!(close(&site.map_from_rack, &d.map_from_rack));
        assert!((site.calibration_target - d.calibration_target).norm() < 1e-9);
        assert!((site.calibration_normal - d.calibration_normal).norm() < 1e-12);
        assert_eq!(site.obstacles.len(), d.obstacles.len());
        for ((na, a), (nb, b)) in site.obstacles.iter().zip(&d.obstacles) {
            assert_eq!(na, nb);
            assert!(close(&a.frame_from_box, &b.frame_from_box), "{na}");
            assert_eq!(a.half_extents_m, b.half_extents_m, "{na}");
        }
        Ok(())
    }

    #[test]
    fn no_survey_is_the_built_in_bay_and_a_partial_one_is_refused() -> Result<(), ParamError> {
        assert_eq!(read("")?.0, SiteMap::default_bay());
        let partial = "[survey.wire]\npoint_m = [12.0, 0.0, 3.7]\n";
        let err = read(partial)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(
            err.contains("survey.wire.direction") && err.contains("missing"),
            "{err}"
        );
        let typo = FIXED_BAY.replace("yaw_deg = 90.0", "yaw_dg = 90.0");
        let (_, problems) = match read(&typo) {
            Ok(v) => v,
            Err(e) => {
                assert!(e.to_string().contains("work_spot.yaw_deg"), "{e}");
                return Ok(());
            }
        };
        assert!(!problems.is_empty(), "a mistyped key is reported");
        Ok(())
    }

    /// A survey moved and turned: the bodies follow the cabinet's and rack's poses rigidly.
    #[test]
    fn the_bodies_follow_the_surveyed_poses() -> Result<(), ParamError> {
        let moved = FIXED_BAY
            .replace("facing_deg = 180.0", "facing_deg = 190.0")
            .replace(
                "face_center_m = [13.346, -1.3, 1.1]",
                "face_center_m = [13.4, -1.2, 1.1]",
            );
        let (site, _) = read(&moved)?;
        let (d, _) = read(FIXED_BAY)?;
        let turn = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 10f64.to_radians());
        for ((name, a), (_, b)) in site.obstacles.iter().zip(&d.obstacles).take(3) {
            let from_face = |s: &SiteMap, o: &OrientedBox| {
                o.frame_from_box.translation.vector - s.calibration_target.coords
            };
            let expect = turn * from_face(&d, b);
            assert!((from_face(&site, a) - expect).norm() < 1e-9, "{name}");
        }
        assert!((site.calibration_normal - turn * d.calibration_normal).norm() < 1e-12);
        Ok(())
    }
}
