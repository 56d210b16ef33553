//! The crew's survey of the simulated bay: a site file (ARCHITECTURE.md section 5) written
//! from the layout's truth with a survey's error, the way a real crew's measurements reach
//! the robot (`rodlog survey`, then `record --site FILE`). The robot never sees the truth.
//!
//! Every surveyed position is off by [`SURVEY_POSITION_SIGMA_M`] per axis (1-sigma: RTK GNSS
//! gives 8 mm + 1 ppm horizontally and 15 mm vertically, a total station 2 mm + 2 ppm, plus
//! marking the points on the equipment) and every heading by [`SURVEY_HEADING_SIGMA_DEG`]
//! (a heading from two points 1-2 m apart, each a centimetre or two off), drawn from the
//! scenario's seed (stream [`crate::rng::streams::SURVEY`]). There is no switch for an
//! error-free survey: that would be the truth.

use std::fmt::Write as _;

use nalgebra::{Point3, Vector3};

use crate::rng::{self, streams};
use crate::scene::SubstationLayout;

/// 1-sigma error of each surveyed coordinate (m).
pub const SURVEY_POSITION_SIGMA_M: f64 = 0.02;
/// 1-sigma error of each surveyed heading (deg).
pub const SURVEY_HEADING_SIGMA_DEG: f64 = 1.0;
/// Half length of the surveyed conductor segment the finders search (m).
pub const SURVEYED_HALF_LENGTH_M: f64 = 1.5;
/// Half length of the other phases' surveyed segments (m).
pub const PHASE_HALF_LENGTH_M: f64 = 4.0;

/// What the crew measured (module docs): the site file's values.
#[derive(Debug, Clone, PartialEq)]
pub struct SiteSurvey {
    /// A point on the target conductor's axis at the working spot's span position (m).
    pub wire_point_m: Point3<f64>,
    /// The conductor's direction there.
    pub wire_direction: Vector3<f64>,
    /// The other phases near the work, `[ax, ay, az, bx, by, bz]` (m): south, north.
    pub phases_m: [[f64; 6]; 2],
    /// The working spot (m).
    pub work_spot_xy_m: [f64; 2],
    /// The base's heading there (deg).
    pub work_spot_yaw_deg: f64,
    /// The rack's plate centre (m).
    pub rack_xyz_m: Point3<f64>,
    /// The rack's heading (deg).
    pub rack_yaw_deg: f64,
    /// The calibration cabinet's face centre (m).
    pub cabinet_face_center_m: Point3<f64>,
    /// Heading of the face's outward normal (deg).
    pub cabinet_facing_deg: f64,
}

/// The survey of `layout`, its errors drawn from `seed`.
///
/// # Errors
/// A layout without its three conductors.
pub fn survey(layout: &SubstationLayout, seed: u64) -> Result<SiteSurvey, String> {
    let mut i = 0;
    let mut n = || {
        i += 1;
        rng::normal(seed, streams::SURVEY, i)
    };
    let spot = layout.world_from_robot_spot;
    let [south, target, north] = [0, 1, 2].map(|k| layout.conductors.get(k));
    let (Some(south), Some(target), Some(north)) = (south, target, north) else {
        return Err("the layout has fewer than three conductors".to_owned());
    };
    let u = spot.translation.x - target.start.x;
    let mut p = |q: Point3<f64>| q + Vector3::new(n(), n(), n()) * SURVEY_POSITION_SIGMA_M;
    let wire_point_m = p(target.point_at(u));
    let mut segment = |c: &crate::scene::Catenary| {
        let a = p(c.point_at(u - PHASE_HALF_LENGTH_M));
        let b = p(c.point_at(u + PHASE_HALF_LENGTH_M));
        [a.x, a.y, a.z, b.x, b.y, b.z]
    };
    let phases_m = [segment(south), segment(north)];
    let spot_p = p(Point3::from(spot.translation.vector));
    let rack_xyz_m = p(Point3::from(layout.world_from_rack.translation.vector));
    let cabinet_face_center_m = p(layout.calibration_target_center);
    let mut h = || SURVEY_HEADING_SIGMA_DEG * n();
    let tangent = target.tangent_at(u);
    let direction_yaw = tangent.y.atan2(tangent.x) + h().to_radians();
    let normal = layout.calibration_target_normal;
    Ok(SiteSurvey {
        wire_point_m,
        wire_direction: Vector3::new(direction_yaw.cos(), direction_yaw.sin(), tangent.z),
        phases_m,
        work_spot_xy_m: [spot_p.x, spot_p.y],
        work_spot_yaw_deg: spot.rotation.euler_angles().2.to_degrees() + h(),
        rack_xyz_m,
        rack_yaw_deg: layout
            .world_from_rack
            .rotation
            .euler_angles()
            .2
            .to_degrees()
            + h(),
        cabinet_face_center_m,
        cabinet_facing_deg: normal.y.atan2(normal.x).to_degrees() + h(),
    })
}

impl SiteSurvey {
    /// The site file (ARCHITECTURE.md section 5) of this survey.
    #[must_use]
    pub fn to_site_file(&self) -> String {
        let v = |x: &[f64]| {
            let items: Vec<String> = x.iter().map(|v| format!("{v:?}")).collect();
            format!("[{}]", items.join(", "))
        };
        let p = |q: &Point3<f64>| v(&[q.x, q.y, q.z]);
        let d = &self.wire_direction;
        let mut out = String::new();
        let _ = writeln!(
            out,
            "# rodlog site file: the simulated crew's survey (rodlog survey), {SURVEY_POSITION_SIGMA_M} m / {SURVEY_HEADING_SIGMA_DEG} deg 1-sigma error.\n"
        );
        let _ = writeln!(out, "[survey.wire]");
        let _ = writeln!(out, "point_m = {}", p(&self.wire_point_m));
        let _ = writeln!(out, "direction = {}", v(&[d.x, d.y, d.z]));
        let _ = writeln!(out, "half_length_m = {SURVEYED_HALF_LENGTH_M:?}\n");
        let _ = writeln!(out, "[survey.phases]");
        let _ = writeln!(out, "south_m = {}", v(&self.phases_m[0]));
        let _ = writeln!(out, "north_m = {}\n", v(&self.phases_m[1]));
        let _ = writeln!(out, "[survey.work_spot]");
        let _ = writeln!(out, "xy_m = {}", v(&self.work_spot_xy_m));
        let _ = writeln!(out, "yaw_deg = {:?}\n", self.work_spot_yaw_deg);
        let _ = writeln!(out, "[survey.rack]");
        let _ = writeln!(out, "xyz_m = {}", p(&self.rack_xyz_m));
        let _ = writeln!(out, "yaw_deg = {:?}\n", self.rack_yaw_deg);
        let _ = writeln!(out, "[survey.cabinet]");
        let _ = writeln!(out, "face_center_m = {}", p(&self.cabinet_face_center_m));
        let _ = writeln!(out, "facing_deg = {:?}", self.cabinet_facing_deg);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{SubstationBuilder, SubstationParams};

    /// Over 200 seeds of one seeded bay the survey is off the truth by the stated errors:
    /// per-axis position and heading sample standard deviations within 15% of the sigmas,
    /// means near zero.
    #[test]
    fn the_survey_carries_the_stated_error() -> Result<(), String> {
        let (_, l) = SubstationBuilder::new(9)
            .params(SubstationParams::seeded(9))
            .build()
            .map_err(|e| e.to_string())?;
        let (mut pos, mut yaw) = (Vec::new(), Vec::new());
        for seed in 0..200 {
            let s = survey(&l, seed)?;
            let truth_rack = l.world_from_rack.translation.vector;
            pos.extend((s.rack_xyz_m.coords - truth_rack).iter().copied());
            pos.extend(
                (s.cabinet_face_center_m - l.calibration_target_center)
                    .iter()
                    .copied(),
            );
            let truth_yaw = l.world_from_rack.rotation.euler_angles().2.to_degrees();
            let mut e = s.rack_yaw_deg - truth_yaw;
            e -= 360.0 * (e / 360.0).round();
            yaw.push(e);
        }
        let stats = |v: &[f64]| {
            let m = v.iter().sum::<f64>() / v.len() as f64;
            let sd = (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt();
            (m, sd)
        };
        let (m, sd) = stats(&pos);
        assert!(
            (sd / SURVEY_POSITION_SIGMA_M - 1.0).abs() < 0.15 && m.abs() < 0.004,
            "{m} {sd}"
        );
        let (m, sd) = stats(&yaw);
        assert!(
            (sd / SURVEY_HEADING_SIGMA_DEG - 1.0).abs() < 0.15 && m.abs() < 0.3,
            "{m} {sd}"
        );
        Ok(())
    }
}
