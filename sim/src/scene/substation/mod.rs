//! A deterministic substation bay built from a seed.
//!
//! Layout (world = `map`, x east along the conductors, y north, z up, metres; defaults of
//! [`SubstationParams`]):
//!
//! * two lattice-steel gantries at `x = 0` and `x = span_m`, each two square lattice columns
//!   (corner angles, horizontals, alternating diagonals) at `y = +-gantry_half_width_m` and a
//!   lattice beam across the top, on concrete foundations;
//! * three phases at `y = -phase_spacing_m, 0, +phase_spacing_m`, each a tension insulator
//!   string (repetitive discs at 146 mm pitch) hanging from each beam down to an attachment
//!   point, and a 26.8 mm conductor between the two attachment points as a chain of
//!   cylinders sampled from the analytic [`Catenary`] (chord deviation < 0.2 mm); every
//!   conductor is a movable object (rigid sway about its chord);
//! * disconnect switches on galvanised pedestals (post insulators with sheds) near both
//!   gantries, equipment boxes (a kiosk with labels and louvres, a nearly textureless
//!   box, marshalling boxes) placed from the seed;
//! * next to the robot's working spot (below the middle phase, mid-span): a control cabinet
//!   with bolted doors, labels and vents, a cable tray and a junction box (the
//!   calibration scene, textured at the 1-5 mm scale), the rod rack and the grounding rod;
//! * gravel ground (plane `z = 0`) and a concrete road strip.
//!
//! The seed changes textures, rust, labels and the placement and number of equipment boxes;
//! the structures the robot works with (gantries, conductors, cabinet, rack) stay where the
//! [`SubstationLayout`] says.

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};

use super::catenary::{CONDUCTOR_DIAMETER_M, Catenary, CatenaryError};
use super::grounding_rod::{self, rack_from_rod};
use super::primitives::{Primitive, Shape};
use super::textures::{Material, Texture};
use super::{GroundPlane, ObjectId, Scene, SceneBuilder, SceneError};

mod equipment;
mod materials;

use equipment::{
    abox, calibration_cabinet, disconnect_switch, insulator_string, kiosk, lattice_beam,
    lattice_column, marshalling_box,
};
use materials::{Dice, Mats};

/// Errors of the substation builder.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SubstationError {
    /// Scene validation failed.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// The conductor geometry is impossible.
    #[error(transparent)]
    Catenary(#[from] CatenaryError),
    /// A parameter is out of its accepted range.
    #[error("parameter {name} = {value} is outside [{min}, {max}]")]
    Parameter {
        /// Name of the field.
        name: &'static str,
        /// Its value.
        value: f64,
        /// Smallest accepted value.
        min: f64,
        /// Largest accepted value.
        max: f64,
    },
}

/// Where the rod rack stands relative to the robot's working spot (`base_link` at the spot,
/// m): on the base's left, a little behind its centre.
pub const RACK_IN_BASE_M: [f64; 2] = [-0.3, 0.8];
/// Height of the rack's pedestal (m): the stored rod's handle is then 0.72-0.97 m up, where
/// the arm reaches it over the base's edge with the lift lowered.
pub const RACK_PEDESTAL_M: f64 = 0.6;

/// Geometry parameters of the bay.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SubstationParams {
    /// Distance between the two gantries along x (m). Default 24.
    pub span_m: f64,
    /// Gantry height (top of the beam, m). Default 6.1.
    pub gantry_height_m: f64,
    /// Distance between phases along y (m). Default 4.5.
    pub phase_spacing_m: f64,
    /// Height of the conductor attachment points (end of the insulator strings, m). Default
    /// 4.5: with the default sag the conductor is 3.7 m up at mid-span, where the robot's
    /// lift (2 m travel) brings the wrist camera level with it and the rod's hook (1.8 m above
    /// the gripper) onto it.
    pub attach_height_m: f64,
    /// Horizontal length of each tension insulator string (m). Default 2.6.
    pub string_length_m: f64,
    /// Mid-span sag of the conductors below their chord (m). Default 0.8.
    pub sag_m: f64,
    /// Lateral offset of the robot's working spot from the middle phase (m, towards -y).
    /// Default 1.3.
    pub robot_offset_m: f64,
    /// Position of the working spot along the span, from mid-span (m, +x). Default 0.
    pub work_position_m: f64,
    /// Shift of the calibration cabinet cluster (cabinet, junction box, cable tray) from its
    /// design place beside the working spot (m, `[x, y]`). Default 0.
    pub cabinet_shift_m: [f64; 2],
    /// Shift of the rod rack from its place beside the working spot (m, `[x, y]`) and its
    /// yaw error (rad). Default 0.
    pub rack_shift: [f64; 3],
    /// The yard's grade (rise over run along x and y) through the working spot's nominal
    /// point: the ground, the structures standing on it and the robot's base follow it
    /// ([`GroundPlane`]). Default level.
    pub ground_grade: [f64; 2],
}

impl Default for SubstationParams {
    fn default() -> Self {
        Self {
            span_m: 24.0,
            gantry_height_m: 6.1,
            phase_spacing_m: 4.5,
            attach_height_m: 4.5,
            string_length_m: 2.6,
            sag_m: 0.8,
            robot_offset_m: 1.3,
            work_position_m: 0.0,
            cabinet_shift_m: [0.0; 2],
            rack_shift: [0.0; 3],
            ground_grade: [0.0; 2],
        }
    }
}

/// Half widths of the seeded site's draws around the default bay ([`SubstationParams::seeded`]),
/// each uniform in `default +- half width`.
pub mod seeded_ranges {
    /// Mid-span sag (m): 0.8 m +- 20%, the sag's change between -20 and +80 C conductor
    /// temperature for strained bus spans (5-20%, up to more for slack spans; IEC 60865-2
    /// examples) and the erection tolerance.
    pub const SAG_M: f64 = 0.16;
    /// Height of the attachment points (m): the gantry's foundation top (+13 / -50 mm, ACI
    /// 117), its lean (<= 1/500 of the height, AISC 303) and the insulator string's length.
    pub const ATTACH_HEIGHT_M: f64 = 0.05;
    /// Phase spacing (m): the bay's design (the default 4.5 m is above the 500 kV phase-phase
    /// minimum A2 = 4.3 m of DL/T 5352 only in the scaled bay; strung buses use 6.5-8 m) is
    /// fixed, the string attachments vary by a few cm.
    pub const PHASE_SPACING_M: f64 = 0.05;
    /// Where along the span the work happens (m from mid-span).
    pub const WORK_POSITION_M: f64 = 1.5;
    /// Lateral offset of the working spot from the phase (m): where the crew can park.
    pub const ROBOT_OFFSET_M: f64 = 0.1;
    /// Cabinet cluster position, each axis (m): foundation placement tolerance (+-50 mm,
    /// ACI 117 for footings).
    pub const CABINET_SHIFT_M: f64 = 0.05;
    /// Rack position, each axis (m): placed by the crew beside the robot.
    pub const RACK_SHIFT_M: f64 = 0.04;
    /// Rack yaw (deg).
    pub const RACK_YAW_DEG: f64 = 4.0;
    /// The yard's grade (rise over run), drawn uniform in this range in a uniform direction:
    /// flat yards, the usual profile, are still graded so that rain drains off (NEA
    /// Engineering Bulletin SS1120, "Substation Site Design", after the REA/RUS guide), and a
    /// gravelled or paved surface is graded no flatter than 0.5 % and, as a rule, no steeper
    /// than 2 %.
    pub const GROUND_GRADE: [f64; 2] = [0.005, 0.02];
}

impl SubstationParams {
    /// A bay drawn from `seed` (stream [`crate::rng::streams::SITE`]): every value of
    /// [`seeded_ranges`] uniform around the default bay, and the ground graded by
    /// [`seeded_ranges::GROUND_GRADE`] in a uniform direction.
    #[must_use]
    pub fn seeded(seed: u64) -> Self {
        use seeded_ranges as r;
        let d = Self::default();
        let mut i = 0;
        let mut draw = |centre: f64, half: f64| {
            i += 1;
            crate::rng::uniform_in(
                seed,
                crate::rng::streams::SITE,
                i,
                centre - half,
                centre + half,
            )
        };
        Self {
            sag_m: draw(d.sag_m, r::SAG_M),
            attach_height_m: draw(d.attach_height_m, r::ATTACH_HEIGHT_M),
            phase_spacing_m: draw(d.phase_spacing_m, r::PHASE_SPACING_M),
            work_position_m: draw(0.0, r::WORK_POSITION_M),
            robot_offset_m: draw(d.robot_offset_m, r::ROBOT_OFFSET_M),
            cabinet_shift_m: [draw(0.0, r::CABINET_SHIFT_M), draw(0.0, r::CABINET_SHIFT_M)],
            rack_shift: [
                draw(0.0, r::RACK_SHIFT_M),
                draw(0.0, r::RACK_SHIFT_M),
                draw(0.0, r::RACK_YAW_DEG).to_radians(),
            ],
            ground_grade: {
                let [lo, hi] = r::GROUND_GRADE;
                let grade = draw(0.5 * (lo + hi), 0.5 * (hi - lo));
                let direction_rad = draw(0.0, std::f64::consts::PI);
                [grade * direction_rad.cos(), grade * direction_rad.sin()]
            },
            ..d
        }
    }
}

/// Where things are (ground truth for the world and for scoring).
#[derive(Clone, Debug)]
pub struct SubstationLayout {
    /// Parameters used.
    pub params: SubstationParams,
    /// Analytic axis of each phase's conductor at rest, ordered by y (index 1 = the middle
    /// phase the robot works on).
    pub conductors: Vec<Catenary>,
    /// Object ids of the conductors (same order).
    pub conductor_objects: Vec<ObjectId>,
    /// Index into `conductors` of the phase to ground.
    pub target_phase: usize,
    /// Suggested `world_from_base` of the robot's working spot (on the ground, x forward
    /// towards +y = towards the target conductor).
    pub world_from_robot_spot: Isometry3<f64>,
    /// Centre of the calibration cabinet's front face (m).
    pub calibration_target_center: Point3<f64>,
    /// Outward unit normal of that face.
    pub calibration_target_normal: Vector3<f64>,
    /// Pose of the rod rack.
    pub world_from_rack: Isometry3<f64>,
    /// Pose of the stored rod (`world_from_rack * rack_from_rod`).
    pub world_from_rod_stored: Isometry3<f64>,
    /// The rod's object id.
    pub rod_object: ObjectId,
    /// The ground ([`SubstationParams::ground_grade`] through the working spot's nominal
    /// point at height 0).
    pub ground: GroundPlane,
}

impl SubstationLayout {
    /// The conductor the robot works on.
    #[must_use]
    pub fn target_conductor(&self) -> Option<&Catenary> {
        self.conductors.get(self.target_phase)
    }

    /// `world_from_camera` of a typical calibration view of the wrist camera: 0.45 m in
    /// front of the calibration cabinet's face (8 cm aside, 12 cm up), looking at a point
    /// 25 cm above the face's centre. The renderer's benchmark and profiling view.
    #[must_use]
    pub fn cabinet_wrist_view(&self) -> Option<Isometry3<f64>> {
        let target = self.calibration_target_center;
        let eye = target + self.calibration_target_normal * 0.45 + Vector3::new(0.0, 0.08, 0.12);
        robot::se3::world_from_camera_looking_at(
            &eye,
            &(target + Vector3::new(0.0, 0.0, 0.25)),
            &Vector3::z(),
        )
    }
}

/// Builds the bay from a seed.
#[derive(Clone, Debug)]
pub struct SubstationBuilder {
    seed: u64,
    params: SubstationParams,
}

impl SubstationBuilder {
    /// Builder with default parameters.
    #[must_use]
    pub fn new(seed: u64) -> Self {
        Self {
            seed,
            params: SubstationParams::default(),
        }
    }

    /// Replaces the parameters.
    #[must_use]
    pub fn params(mut self, params: SubstationParams) -> Self {
        self.params = params;
        self
    }

    /// Builds the scene and its layout.
    ///
    /// # Errors
    /// [`SubstationError::Parameter`] for out-of-range parameters, and scene or catenary
    /// errors.
    pub fn build(self) -> Result<(Scene, SubstationLayout), SubstationError> {
        let p = self.params;
        check("span_m", p.span_m, 10.0, 80.0)?;
        check("gantry_height_m", p.gantry_height_m, 4.0, 30.0)?;
        check("phase_spacing_m", p.phase_spacing_m, 2.0, 15.0)?;
        check(
            "attach_height_m",
            p.attach_height_m,
            2.0,
            p.gantry_height_m - 0.8,
        )?;
        check("string_length_m", p.string_length_m, 0.8, p.span_m / 4.0)?;
        check(
            "robot_offset_m",
            p.robot_offset_m,
            0.5,
            p.phase_spacing_m - 0.5,
        )?;
        check(
            "work_position_m",
            p.work_position_m,
            -p.span_m / 4.0,
            p.span_m / 4.0,
        )?;
        for (name, v) in [
            ("cabinet_shift_m", p.cabinet_shift_m[0]),
            ("cabinet_shift_m", p.cabinet_shift_m[1]),
            ("rack_shift", p.rack_shift[0]),
            ("rack_shift", p.rack_shift[1]),
            ("rack_shift", p.rack_shift[2]),
        ] {
            check(name, v, -0.5, 0.5)?;
        }
        // Steeper than 5 % the yard is no longer "flat" and the robot's base would need its
        // outriggers: out of this bay's scope.
        check("ground_grade", p.ground_grade[0], -0.05, 0.05)?;
        check("ground_grade", p.ground_grade[1], -0.05, 0.05)?;
        let mut dice = Dice::new(self.seed);
        let mut b = SceneBuilder::new();
        let m = Mats::new(&mut b, &mut dice);
        let gravel = b.material(
            Material::matte(
                [0.32, 0.3, 0.27],
                Texture::Gravel { stone_m: 0.022 },
                dice.seed(),
            )
            .with_accent([0.2, 0.18, 0.16]),
        );
        // The working spot's nominal point: the ground's height is 0 there.
        let x_robot = p.span_m / 2.0 + p.work_position_m;
        let y_robot = -p.robot_offset_m;
        let ground = GroundPlane {
            height_m: 0.0,
            origin_xy_m: [x_robot, y_robot],
            grade: p.ground_grade,
        };
        b.ground(ground, gravel);
        // A level structure rests on the lowest point of the ground under its footprint
        // (the ground covers its foundation's uphill side).
        let rest = |x: f64, y: f64, half: [f64; 2]| ground.lowest_under(x, y, half);
        let tilt = ground.tilt().to_rotation_matrix().into_inner();

        // Road strip along x, south of the robot spot (slabs laid on the grade).
        // (Slabs of 3 m: one long box would give the BVH a node spanning the whole bay.)
        let (x0, x1) = (-6.0, p.span_m + 6.0);
        let slabs = ((x1 - x0) / 3.0).ceil() as usize;
        let slab = (x1 - x0) / slabs as f64;
        for i in 0..slabs {
            let xc = x0 + slab * (i as f64 + 0.5);
            b.add(
                Shape::Box {
                    center: ground.point_under(xc, y_robot - 2.6),
                    rotation: tilt,
                    half_extents_m: Vector3::new(slab / 2.0 - 0.005, 1.2, 0.02),
                },
                m.road,
            );
        }

        // Gantries: each column on its own foundation, up to a level beam; the beam's
        // height (and the strings' and conductors' with it) counts from the ground under the
        // gantry's centre.
        let half_w = 1.5 * p.phase_spacing_m + 1.2;
        let gantry_ground = |xg: f64| ground.height_at(xg, 0.0);
        for xg in [0.0, p.span_m] {
            for yc in [-half_w, half_w] {
                lattice_column(
                    &mut b,
                    m.steel,
                    m.concrete,
                    [xg, yc],
                    0.36,
                    [
                        ground.height_at(xg, yc),
                        gantry_ground(xg) + p.gantry_height_m,
                    ],
                );
            }
            lattice_beam(
                &mut b,
                m.steel,
                xg,
                -half_w,
                half_w,
                gantry_ground(xg) + p.gantry_height_m - 0.72,
                0.36,
            );
        }

        // Phases: insulator strings and conductors.
        let mut conductors = Vec::new();
        let mut conductor_objects = Vec::new();
        for (k, yp) in [-p.phase_spacing_m, 0.0, p.phase_spacing_m]
            .into_iter()
            .enumerate()
        {
            let top = p.gantry_height_m - 0.72;
            let (g0, g1) = (gantry_ground(0.0), gantry_ground(p.span_m));
            let a0 = Point3::new(p.string_length_m, yp, g0 + p.attach_height_m);
            let a1 = Point3::new(p.span_m - p.string_length_m, yp, g1 + p.attach_height_m);
            let disc = if k == 1 { m.glass } else { m.porcelain };
            insulator_string(&mut b, disc, m.cap, Point3::new(0.0, yp, g0 + top), a0);
            insulator_string(&mut b, disc, m.cap, Point3::new(p.span_m, yp, g1 + top), a1);
            let cat = Catenary::new(a0, a1, p.sag_m)?;
            let segs = (cat.span_m() / 0.2).ceil() as usize;
            let pts = cat.polyline(segs);
            let mut prims = Vec::with_capacity(segs);
            for w in pts.windows(2) {
                if let [s, e] = w {
                    let d = e - s;
                    prims.push(Primitive {
                        shape: Shape::Cylinder {
                            base: *s,
                            axis: d.normalize(),
                            length_m: d.norm(),
                            radius_m: CONDUCTOR_DIAMETER_M / 2.0,
                        },
                        material: m.conductor,
                    });
                }
            }
            let name = ["conductor_south", "conductor_middle", "conductor_north"][k];
            conductor_objects.push(b.object(name, prims, Isometry3::identity()));
            conductors.push(cat);
        }

        // Disconnect switches on pedestals near each gantry.
        for (k, yp) in [-p.phase_spacing_m, 0.0, p.phase_spacing_m]
            .into_iter()
            .enumerate()
        {
            for xs in [3.2, p.span_m - 4.7] {
                let x = xs + dice.range(-0.1, 0.1);
                let disc = if k == 1 { m.porcelain } else { m.glass };
                b.raised(rest(x + 0.75, yp, [1.15, 0.4]), |b| {
                    disconnect_switch(b, &m, disc, x, yp);
                });
            }
        }

        // Equipment boxes (seeded placement along the north side).
        let at = Point3::new(p.span_m * 0.5 + dice.range(-3.0, 3.0), half_w + 3.0, 0.0);
        b.raised(rest(at.x, at.y, [1.8, 1.2]), |b| {
            kiosk(b, &m, at, &mut dice)
        });
        let n_boxes = 3 + (dice.next() * 3.0) as usize;
        for i in 0..n_boxes {
            let x = p.span_m * (i as f64 + 0.5) / n_boxes as f64 + dice.range(-1.0, 1.0);
            let y = half_w + dice.range(-1.8, -0.6);
            let mat = if i % 2 == 0 { m.plain_box } else { m.kiosk };
            let size = dice.range(0.4, 0.8);
            b.raised(rest(x, y, [0.6 * size + 0.03, 0.03]), |b| {
                marshalling_box(b, &m, mat, Point3::new(x, y, 0.0), size);
            });
        }
        // A nearly textureless big box (transformer-like) on the south side.
        let (xt, yt) = (p.span_m * 0.3, -half_w - 3.5);
        b.raised(rest(xt, yt, [1.9, 1.5]), |b| {
            b.add(abox([xt, yt, 1.3], [1.6, 1.2, 1.3]), m.plain_box);
            b.add(abox([xt, yt, 0.1], [1.9, 1.5, 0.1]), m.concrete);
        });

        // Calibration scene next to the robot spot, the rack and the rod.
        let world_from_robot_spot = Isometry3::from_parts(
            Translation3::new(x_robot, y_robot, 0.0),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_2),
        );
        let (x_front, y_cabinet) = (
            x_robot + 1.35 + p.cabinet_shift_m[0],
            y_robot + p.cabinet_shift_m[1],
        );
        // The cluster's footprint: the cabinet's foundation and, towards -y, the tray's posts.
        let cabinet_ground = rest(x_front + 0.3, y_cabinet - 1.2, [0.4, 2.1]);
        let (calib_center, calib_normal) = b.raised(cabinet_ground, |b| {
            calibration_cabinet(b, &m, x_front, y_cabinet, &mut dice)
        });
        let calib_center = calib_center + Vector3::new(0.0, 0.0, cabinet_ground);
        // The rack stands beside the working spot on a pedestal, in the arm's reach with the
        // lift lowered (0.85 m from the base centre, on its left and a little behind), its
        // rod's hook opening facing away from the base so the gripper reaches the handle from
        // the robot.
        let rack_in_base = Vector3::new(RACK_IN_BASE_M[0], RACK_IN_BASE_M[1], 0.0);
        let rack_position = world_from_robot_spot * Point3::from(rack_in_base);
        let rack_yaw =
            world_from_robot_spot.rotation.euler_angles().2 + rack_in_base.y.atan2(rack_in_base.x);
        let (x_rack, y_rack) = (
            rack_position.x + p.rack_shift[0],
            rack_position.y + p.rack_shift[1],
        );
        // The pedestal's footprint is 0.44 m square (turned: 0.32 m half width covers it).
        let rack_ground = rest(x_rack, y_rack, [0.32, 0.32]);
        let world_from_rack = Isometry3::from_parts(
            Translation3::new(x_rack, y_rack, rack_ground + RACK_PEDESTAL_M),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), rack_yaw + p.rack_shift[2]),
        );
        grounding_rod::add_rack(&mut b, &world_from_rack, rack_ground);
        let world_from_rod_stored = world_from_rack * rack_from_rod();
        let rod_object = grounding_rod::add_rod(&mut b, world_from_rod_stored);

        let scene = b.build()?;
        let layout = SubstationLayout {
            params: p,
            conductors,
            conductor_objects,
            target_phase: 1,
            world_from_robot_spot,
            calibration_target_center: calib_center,
            calibration_target_normal: calib_normal,
            world_from_rack,
            world_from_rod_stored,
            rod_object,
            ground,
        };
        Ok((scene, layout))
    }
}

fn check(name: &'static str, value: f64, min: f64, max: f64) -> Result<(), SubstationError> {
    if value.is_finite() && (min..=max).contains(&value) {
        Ok(())
    } else {
        Err(SubstationError::Parameter {
            name,
            value,
            min,
            max,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Ray;

    /// The target conductor's point at the working spot's span position, in the spot's frame
    /// (the robot starts there).
    fn wire_from_spot(l: &SubstationLayout) -> Option<Point3<f64>> {
        let c = l.target_conductor()?;
        let u = l.world_from_robot_spot.translation.x - c.start.x;
        Some(l.world_from_robot_spot.inverse() * c.point_at(u))
    }

    /// Seeded bays differ where the robot works (the wire moves by 3 cm or more relative to
    /// its start between two seeds), every draw stays in its stated range and the ranges are
    /// used; the default is the fixed bay.
    #[test]
    fn seeded_sites_vary_within_their_ranges() -> Result<(), SubstationError> {
        use seeded_ranges as r;
        let d = SubstationParams::default();
        let (_, fixed) = SubstationBuilder::new(3).build()?;
        let w_fixed = wire_from_spot(&fixed).ok_or(SubstationError::Parameter {
            name: "wire",
            value: 0.0,
            min: 0.0,
            max: 0.0,
        })?;
        let mut wires = Vec::new();
        let (mut sag_lo, mut sag_hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for seed in 0..40 {
            let p = SubstationParams::seeded(seed);
            assert!((p.sag_m - d.sag_m).abs() <= r::SAG_M);
            assert!((p.attach_height_m - d.attach_height_m).abs() <= r::ATTACH_HEIGHT_M);
            assert!((p.phase_spacing_m - d.phase_spacing_m).abs() <= r::PHASE_SPACING_M);
            assert!(p.work_position_m.abs() <= r::WORK_POSITION_M);
            assert!((p.robot_offset_m - d.robot_offset_m).abs() <= r::ROBOT_OFFSET_M);
            assert!(
                p.cabinet_shift_m
                    .iter()
                    .all(|v| v.abs() <= r::CABINET_SHIFT_M)
            );
            assert!(p.rack_shift[2].abs() <= r::RACK_YAW_DEG.to_radians());
            let grade = p.ground_grade[0].hypot(p.ground_grade[1]);
            assert!(
                (r::GROUND_GRADE[0] - 1e-12..=r::GROUND_GRADE[1] + 1e-12).contains(&grade),
                "grade {grade}"
            );
            assert_eq!(
                p,
                SubstationParams::seeded(seed),
                "a pure function of the seed"
            );
            (sag_lo, sag_hi) = (sag_lo.min(p.sag_m), sag_hi.max(p.sag_m));
            if seed < 6 {
                let (_, l) = SubstationBuilder::new(seed).params(p).build()?;
                if let Some(w) = wire_from_spot(&l) {
                    wires.push(w);
                }
            }
        }
        assert!(sag_hi - sag_lo > r::SAG_M, "sag {sag_lo}..{sag_hi}");
        assert_eq!(wires.len(), 6);
        let mut pairs: Vec<f64> = Vec::new();
        for (i, a) in wires.iter().enumerate() {
            assert!(
                (a - w_fixed).norm() > 1e-3,
                "seed {i}: {a} vs fixed {w_fixed}"
            );
            pairs.extend(wires[i + 1..].iter().map(|b| (a - b).norm()));
        }
        pairs.sort_by(f64::total_cmp);
        let median = pairs[pairs.len() / 2];
        eprintln!("wire vs start between seeds: {pairs:.3?} m (median {median:.3})");
        assert!(pairs.iter().all(|d| *d > 1e-3));
        assert!(median >= 0.03, "median {median} m between two seeds");
        Ok(())
    }

    /// On a graded seeded bay the ground is the plane through the working spot, and the
    /// structures stand on it: the rack's pedestal and the cabinet's foundation rest on the
    /// ground's lowest point under them, and the conductors hang from gantries raised by the
    /// ground under each; the fixed bay is level.
    #[test]
    fn structures_stand_on_the_graded_ground() -> Result<(), SubstationError> {
        let (_, fixed) = SubstationBuilder::new(3).build()?;
        assert!(fixed.ground.is_level() && fixed.ground.height_m == 0.0);
        let mut steepest: f64 = 0.0;
        for seed in 0..6 {
            let p = SubstationParams::seeded(seed);
            let (scene, l) = SubstationBuilder::new(seed).params(p).build()?;
            let g = l.ground;
            assert_eq!(g.grade, p.ground_grade);
            steepest = steepest.max(g.steepest_grade());
            let spot = l.world_from_robot_spot.translation.vector;
            assert!(g.height_at(spot.x, spot.y).abs() < 1e-12);
            // A ray straight down 2.6 m from the spot (off the road) meets the graded ground.
            let (x, y) = (spot.x + 2.4, spot.y - 1.0);
            let ray = Ray {
                origin: Point3::new(x, y, 10.0),
                dir: -Vector3::z(),
            };
            let hit = scene.intersect(&ray, 0.0, f64::INFINITY);
            let z = hit.map(|h| ray.at(h.t_m).z);
            assert!(
                z.is_some_and(|z| (z - g.height_at(x, y)).abs() < 1e-9),
                "seed {seed}: {z:?} vs {}",
                g.height_at(x, y)
            );
            let rack = l.world_from_rack.translation.vector;
            let pedestal_bottom = rack.z - RACK_PEDESTAL_M;
            assert!((pedestal_bottom - g.lowest_under(rack.x, rack.y, [0.32, 0.32])).abs() < 1e-12);
            assert!(pedestal_bottom < g.height_at(rack.x, rack.y));
            let face = l.calibration_target_center;
            let above = face.z - g.height_at(face.x + 0.3, face.y);
            // The cluster's footprint reaches 0.7 m behind the face and 3.3 m along it (the
            // tray's posts).
            let lowest = 1.1 - 4.0 * g.steepest_grade();
            assert!(
                (lowest..=1.1 + 1e-12).contains(&above),
                "seed {seed}: face {above} m up"
            );
            for c in &l.conductors {
                let (a, b) = (
                    c.start.z - g.height_at(0.0, 0.0),
                    c.end.z - g.height_at(p.span_m, 0.0),
                );
                assert!(
                    (a - p.attach_height_m).abs() < 1e-12 && (b - p.attach_height_m).abs() < 1e-12
                );
            }
        }
        assert!(steepest > 0.01, "steepest grade {steepest}");
        Ok(())
    }

    #[test]
    fn same_seed_same_scene_and_conductor_is_where_the_catenary_says() -> Result<(), SubstationError>
    {
        let (s1, l1) = SubstationBuilder::new(7).build()?;
        let (s2, _) = SubstationBuilder::new(7).build()?;
        assert_eq!(s1.static_primitive_count(), s2.static_primitive_count());
        assert_eq!(s1.materials(), s2.materials());
        let cat = l1.target_conductor().ok_or(SubstationError::Parameter {
            name: "phase",
            value: 1.0,
            min: 0.0,
            max: 0.0,
        })?;
        // Shoot down onto the middle of the target wire from 0.5 m above.
        let mid = cat.point_at(cat.span_m() * 0.37);
        let ray = Ray::new(mid + Vector3::new(0.0, 0.0, 0.5), -Vector3::z());
        let hit = s1
            .intersect(&ray, 0.0, 10.0)
            .ok_or(SubstationError::Parameter {
                name: "hit",
                value: 0.0,
                min: 0.0,
                max: 0.0,
            })?;
        let expect = 0.5 - CONDUCTOR_DIAMETER_M / 2.0;
        assert!((hit.t_m - expect).abs() < 3e-4, "{} vs {expect}", hit.t_m);
        Ok(())
    }
}
