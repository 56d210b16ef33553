//! Collision checks: the arm (and the rod it holds) as capsules against the platform (boxes)
//! and the rod and wire (capsules), with a clearance margin.
//!
//! # Shapes and distances
//! A capsule is a segment `[a, b]` swept by a sphere of radius `r`; a cylinder (wire, rod) is
//! checked as its enclosing capsule (conservative by at most `r` at the ends). Capsule-capsule
//! clearance = segment-segment distance - `r1 - r2` (closest points of two segments, Ericson,
//! *Real-Time Collision Detection*, 2005, s5.1.9). Capsule-box clearance = segment-box distance
//! `- r`: in the box frame the point-to-box distance `‖max(|x| - h, 0)‖` is convex along
//! the segment, so its minimum is found by golden-section search (60 iterations, 1e-12 of
//! the segment), exact up to that tolerance.
//!
//! # The arm
//! Link capsules join consecutive DH frame origins of [`robot::RobotModel::arm_base_from_links`]
//! (each AUBO row has either `d` or `a` non-zero, so each segment runs along the real link),
//! with radii [`ARM_LINK_RADII_M`]; the tool capsule runs from tool0 along its z axis
//! (the clamp and the held rod). The base link (arm base to shoulder) sits on the lift and is
//! not checked against the platform it is bolted to.
//!
//! # The robot's own body and self-collision
//! [`CollisionWorld::robot_body`] holds the chassis, the lift mast (growing with the lift) and
//! the lift plate as boxes in `base_link` (the URDF's outline, `robot::urdf`), so the arm is
//! checked against the platform it stands on. Self-collision checks the link pairs of
//! [`SELF_COLLISION_PAIRS`]: every pair that is not adjacent and not in the wrist cluster.
//! Excluded, as an SRDF's "adjacent"/"never" lists do: consecutive links (they share a joint),
//! and wrist 1 - wrist 3 and wrist 2 - tool, which are one short link (0.1025 m, 0.094 m)
//! apart with radii summing to more than that length, so their capsules always overlap
//! whatever the joints; the real wrist housings are shaped to clear each other.

use super::MotionError;
use nalgebra::{Isometry3, Point3, Vector3};
use robot::RobotModel;

/// Radii of the arm's link capsules (m): shoulder column, upper arm, forearm, wrist 1,
/// wrist 2, wrist 3 (from the AUBO i10's published outline, rounded up).
pub const ARM_LINK_RADII_M: [f64; 6] = [0.08, 0.075, 0.065, 0.055, 0.055, 0.05];
/// Names of the checked bodies, in capsule order.
pub const ARM_LINK_NAMES: [&str; 7] = [
    "arm_shoulder_link",
    "arm_upperarm_link",
    "arm_forearm_link",
    "arm_wrist1_link",
    "arm_wrist2_link",
    "arm_wrist3_link",
    "tool",
];

/// Link pairs (indices into [`ARM_LINK_NAMES`]) checked for self-collision (module docs).
pub const SELF_COLLISION_PAIRS: [(usize, usize); 13] = [
    (0, 2),
    (0, 3),
    (0, 4),
    (0, 5),
    (0, 6),
    (1, 3),
    (1, 4),
    (1, 5),
    (1, 6),
    (2, 4),
    (2, 5),
    (2, 6),
    (3, 6),
];

/// Arm links checked against the payload: shoulder column to wrist 2 (wrist 3 and the tool
/// hold it).
pub const PAYLOAD_CHECKED_LINKS: usize = 5;

/// Chassis outline in `base_link` (m): 1.2 x 0.8, from 0.1 to 0.45 m high (`robot::urdf`).
pub const CHASSIS_HALF_EXTENTS_M: [f64; 3] = [0.6, 0.4, 0.175];
/// Chassis box centre height in `base_link` (m).
pub const CHASSIS_CENTRE_Z_M: f64 = 0.275;
/// Lift mast half width (m): a 0.22 m square column from the chassis top to the lift plate.
pub const LIFT_MAST_HALF_WIDTH_M: f64 = 0.11;
/// Lift plate half extents (m): 0.4 x 0.4 x 0.03 below `lift_link`.
pub const LIFT_PLATE_HALF_EXTENTS_M: [f64; 3] = [0.2, 0.2, 0.015];

/// A capsule: segment `a-b` swept by a sphere of radius `radius_m`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Capsule {
    /// One end of the core segment.
    pub a: Point3<f64>,
    /// The other end.
    pub b: Point3<f64>,
    /// Radius (m).
    pub radius_m: f64,
}

/// An oriented box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OrientedBox {
    /// `frame_from_box` (centred).
    pub frame_from_box: Isometry3<f64>,
    /// Half extents (m).
    pub half_extents_m: Vector3<f64>,
}

/// Closest points `(s, t)` of segments `p1 + s (q1 - p1)` and `p2 + t (q2 - p2)`, both in
/// `[0, 1]`, and their distance (Ericson s5.1.9).
#[must_use]
pub fn segment_segment(
    p1: &Point3<f64>,
    q1: &Point3<f64>,
    p2: &Point3<f64>,
    q2: &Point3<f64>,
) -> (f64, f64, f64) {
    let (d1, d2, r) = (q1 - p1, q2 - p2, p1 - p2);
    let (a, e, f) = (d1.norm_squared(), d2.norm_squared(), d2.dot(&r));
    let eps = 1e-18;
    let (s, t) = if a <= eps && e <= eps {
        (0.0, 0.0)
    } else if a <= eps {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = d1.dot(&r);
        if e <= eps {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = d1.dot(&d2);
            let denom = a * e - b * b;
            let mut s = if denom > eps {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let mut t = (b * s + f) / e;
            if t < 0.0 {
                t = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if t > 1.0 {
                t = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            }
            (s, t)
        }
    };
    let distance = ((p1 + d1 * s) - (p2 + d2 * t)).norm();
    (s, t, distance)
}

/// Clearance between two capsules (negative = overlap).
#[must_use]
pub fn capsule_capsule(c1: &Capsule, c2: &Capsule) -> f64 {
    segment_segment(&c1.a, &c1.b, &c2.a, &c2.b).2 - c1.radius_m - c2.radius_m
}

/// Distance from a point to a box (0 inside).
#[must_use]
pub fn point_box_distance(p: &Point3<f64>, b: &OrientedBox) -> f64 {
    let local = b.frame_from_box.inverse_transform_point(p);
    let outside = local.coords.abs() - b.half_extents_m;
    outside.map(|x| x.max(0.0)).norm()
}

/// Clearance between a capsule and a box (golden-section search, module docs).
#[must_use]
pub fn capsule_box(c: &Capsule, b: &OrientedBox) -> f64 {
    let f = |s: f64| point_box_distance(&(c.a + (c.b - c.a) * s), b);
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    let (mut x1, mut x2) = (hi - g * (hi - lo), lo + g * (hi - lo));
    let (mut f1, mut f2) = (f(x1), f(x2));
    for _ in 0..60 {
        if f1 <= f2 {
            hi = x2;
            x2 = x1;
            f2 = f1;
            x1 = hi - g * (hi - lo);
            f1 = f(x1);
        } else {
            lo = x1;
            x1 = x2;
            f1 = f2;
            x2 = lo + g * (hi - lo);
            f2 = f(x2);
        }
    }
    f(0.0).min(f(1.0)).min(f1).min(f2) - c.radius_m
}

/// Obstacles in `base_link`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CollisionWorld {
    /// Named boxes (platform, lift column, rack).
    pub boxes: Vec<(String, OrientedBox)>,
    /// Named capsules (wire span, a rod on the rack or on the wire).
    pub capsules: Vec<(String, Capsule)>,
    /// Contacts that are the point of the motion, `(body, obstacle)`: not checked (the hook
    /// on the target wire, the handle in the rack's holder).
    pub allowed: Vec<(&'static str, String)>,
}

impl CollisionWorld {
    /// Adds `other`'s obstacles and allowed contacts.
    pub fn extend(&mut self, other: &Self) {
        self.boxes.extend(other.boxes.iter().cloned());
        self.capsules.extend(other.capsules.iter().cloned());
        self.allowed.extend(other.allowed.iter().cloned());
    }

    /// Allows contact between `body` (an arm link or payload name) and `obstacle`.
    #[must_use]
    pub fn allowing(mut self, body: &'static str, obstacle: &str) -> Self {
        self.allowed.push((body, obstacle.to_owned()));
        self
    }

    fn is_allowed(&self, body: &str, obstacle: &str) -> bool {
        self.allowed
            .iter()
            .any(|(b, o)| *b == body && o == obstacle)
    }
}

/// A body carried by the tool (the grounding rod): capsules in `tool0` coordinates.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Payload {
    /// Named capsules, `tool0_from` coordinates.
    pub capsules_in_tool0: Vec<(&'static str, Capsule)>,
}

impl Payload {
    /// The grounding rod held at the grasp ([`robot::grounding_rod`]).
    #[must_use]
    pub fn grounding_rod() -> Self {
        let tool0_from_rod = robot::grounding_rod::rod_from_tool0_grasp().inverse();
        Self {
            capsules_in_tool0: robot::grounding_rod::rod_capsules_in_rod()
                .iter()
                .map(|(name, a, b, r)| {
                    (
                        *name,
                        Capsule {
                            a: tool0_from_rod * a,
                            b: tool0_from_rod * b,
                            radius_m: *r,
                        },
                    )
                })
                .collect(),
        }
    }
}

impl CollisionWorld {
    /// The robot's own platform in `base_link` at lift height `lift_m`: `chassis`,
    /// `lift_mast` (chassis top to the lift plate) and `lift_plate` (module docs).
    #[must_use]
    pub fn robot_body(model: &RobotModel, lift_m: f64) -> Self {
        let chassis = OrientedBox {
            frame_from_box: Isometry3::translation(0.0, 0.0, CHASSIS_CENTRE_Z_M),
            half_extents_m: Vector3::from(CHASSIS_HALF_EXTENTS_M),
        };
        let base_from_lift = model.base_from_lift(lift_m);
        let plate_top = base_from_lift * Point3::origin();
        let chassis_top = CHASSIS_CENTRE_Z_M + CHASSIS_HALF_EXTENTS_M[2];
        let plate_bottom_z = plate_top.z - 2.0 * LIFT_PLATE_HALF_EXTENTS_M[2];
        let mast_half_height = (0.5 * (plate_bottom_z - chassis_top)).max(0.0);
        let mast = OrientedBox {
            frame_from_box: Isometry3::translation(
                plate_top.x,
                plate_top.y,
                chassis_top + mast_half_height,
            ),
            half_extents_m: Vector3::new(
                LIFT_MAST_HALF_WIDTH_M,
                LIFT_MAST_HALF_WIDTH_M,
                mast_half_height,
            ),
        };
        let plate = OrientedBox {
            frame_from_box: base_from_lift
                * Isometry3::translation(0.0, 0.0, -LIFT_PLATE_HALF_EXTENTS_M[2]),
            half_extents_m: Vector3::from(LIFT_PLATE_HALF_EXTENTS_M),
        };
        Self {
            boxes: ROBOT_BODY_NAMES
                .iter()
                .map(|n| (*n).to_owned())
                .zip([chassis, mast, plate])
                .collect(),
            capsules: Vec::new(),
            allowed: Vec::new(),
        }
    }
}

/// The boxes of [`CollisionWorld::robot_body`]: the robot's own body, whose clearance to
/// the arm and its payload is held to [`ArmCollisionModel::self_margin_m`].
pub const ROBOT_BODY_NAMES: [&str; 3] = ["chassis", "lift_mast", "lift_plate"];

/// The arm's capsule model.
#[derive(Debug, Clone, PartialEq)]
pub struct ArmCollisionModel {
    /// The robot.
    pub model: RobotModel,
    /// Link radii (m).
    pub link_radii_m: [f64; 6],
    /// Tool capsule: length along tool0's z (m) and radius (m). Default 0.12 m, 0.05 m: the
    /// clamp body and its jaws around the rod's handle (the rod axis is 0.06 m out,
    /// [`robot::grounding_rod::rod_from_tool0_grasp`]) and the wrist camera (0.09 m out).
    pub tool_length_m: f64,
    /// Tool capsule radius (m).
    pub tool_radius_m: f64,
    /// Required clearance from the world (m): the site's obstacles, the conductors, the
    /// robot's body. Default 0.02 (their poses come from a survey, odometry and perception).
    pub margin_m: f64,
    /// Required clearance between the arm's own links, and between the arm or its payload
    /// and the robot's links and body ([`ROBOT_BODY_NAMES`]) (m). Default 0.01: both sides
    /// are the robot's own geometry, known to the millimetre through the joint encoders and
    /// the lift's, and the capsules and boxes already enclose the parts.
    pub self_margin_m: f64,
    /// Required clearance between the arm's links and the lift plate, mast and chassis it is
    /// bolted onto (m). Default 0.005: only the encoders of the joints between them and the
    /// arm's kinematic error (about a millimetre) separate the model from the truth. A held
    /// rod keeps [`Self::self_margin_m`]: it may sit up to the grasp's 5 mm off in the
    /// gripper.
    pub arm_body_margin_m: f64,
    /// What the tool carries (checked against the world and the arm's links up to wrist 2).
    /// Default none.
    pub payload: Payload,
}

impl ArmCollisionModel {
    /// The nominal robot with the default radii.
    #[must_use]
    pub fn nominal() -> Self {
        Self {
            model: RobotModel::nominal(),
            link_radii_m: ARM_LINK_RADII_M,
            tool_length_m: 0.12,
            tool_radius_m: 0.05,
            margin_m: 0.02,
            self_margin_m: 0.01,
            arm_body_margin_m: 0.005,
            payload: Payload::default(),
        }
    }

    /// The same arm carrying `payload`.
    #[must_use]
    pub fn carrying(&self, payload: Payload) -> Self {
        Self {
            payload,
            ..self.clone()
        }
    }

    /// The payload's capsules in `base_link` at `(lift_m, q)`.
    #[must_use]
    pub fn payload_capsules(&self, lift_m: f64, q_rad: &[f64; 6]) -> Vec<(&'static str, Capsule)> {
        if self.payload.capsules_in_tool0.is_empty() {
            return Vec::new();
        }
        let base_from_tool0 = self.model.base_from_tool0(lift_m, q_rad);
        self.payload
            .capsules_in_tool0
            .iter()
            .map(|(name, c)| {
                (
                    *name,
                    Capsule {
                        a: base_from_tool0 * c.a,
                        b: base_from_tool0 * c.b,
                        radius_m: c.radius_m,
                    },
                )
            })
            .collect()
    }

    /// The capsules of [`ARM_LINK_NAMES`] in `base_link` at `(lift_m, q)`.
    #[must_use]
    pub fn capsules(&self, lift_m: f64, q_rad: &[f64; 6]) -> [Capsule; 7] {
        let base_from_arm = self.model.base_from_arm_base(lift_m);
        let frames = self.model.dh.dh_frames(q_rad);
        let origin = |k: usize| base_from_arm * Point3::from(frames[k].translation.vector);
        let mut out = [Capsule {
            a: Point3::origin(),
            b: Point3::origin(),
            radius_m: 0.0,
        }; 7];
        for (k, slot) in out.iter_mut().take(6).enumerate() {
            *slot = Capsule {
                a: origin(k),
                b: origin(k + 1),
                radius_m: self.link_radii_m[k],
            };
        }
        let base_from_tool0 = base_from_arm * frames[6];
        out[6] = Capsule {
            a: base_from_tool0 * Point3::origin(),
            b: base_from_tool0 * Point3::new(0.0, 0.0, self.tool_length_m),
            radius_m: self.tool_radius_m,
        };
        out
    }

    /// Smallest clearance of the configuration and where it is, `(clearance, link, obstacle)`.
    #[must_use]
    pub fn clearance(
        &self,
        world: &CollisionWorld,
        lift_m: f64,
        q_rad: &[f64; 6],
    ) -> (f64, &'static str, String) {
        let (outside, own, body) = self.clearances(world, lift_m, q_rad);
        [own, body]
            .into_iter()
            .fold(outside, |a, b| if b.0 < a.0 { b } else { a })
    }

    /// The pair that falls shortest of its required clearance ([`Self::margin_m`] from the
    /// world, [`Self::self_margin_m`] within the robot), `(clearance, link, obstacle)`;
    /// `None` when every pair keeps its margin.
    #[must_use]
    pub fn shortfall(
        &self,
        world: &CollisionWorld,
        lift_m: f64,
        q_rad: &[f64; 6],
    ) -> Option<(f64, &'static str, String)> {
        let (outside, own, body) = self.clearances(world, lift_m, q_rad);
        self.short_of_margins(outside, own, body)
    }

    fn short_of_margins(
        &self,
        outside: (f64, &'static str, String),
        own: (f64, &'static str, String),
        body: (f64, &'static str, String),
    ) -> Option<(f64, &'static str, String)> {
        [
            (self.margin_m - outside.0, outside),
            (self.self_margin_m - own.0, own),
            (self.arm_body_margin_m - body.0, body),
        ]
        .into_iter()
        .filter(|(short, _)| *short > 0.0)
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, pair)| pair)
    }

    /// The smallest clearance from the world, the smallest within the robot (links with
    /// links, the payload with the links and the body) and the smallest of the arm's links
    /// to the body it is bolted onto, each `(clearance, link, obstacle)`.
    #[allow(clippy::type_complexity)]
    fn clearances(
        &self,
        world: &CollisionWorld,
        lift_m: f64,
        q_rad: &[f64; 6],
    ) -> (
        (f64, &'static str, String),
        (f64, &'static str, String),
        (f64, &'static str, String),
    ) {
        let capsules = self.capsules(lift_m, q_rad);
        let payload = self.payload_capsules(lift_m, q_rad);
        let mut best = (f64::INFINITY, "", String::new());
        let bodies = capsules
            .iter()
            .enumerate()
            .map(|(k, c)| (ARM_LINK_NAMES[k], k == 0, true, c))
            .chain(payload.iter().map(|(name, c)| (*name, false, false, c)));
        let mut own = (f64::INFINITY, "", String::new());
        let mut body = (f64::INFINITY, "", String::new());
        for (name, bolted, link, capsule) in bodies {
            for (obstacle, b) in &world.boxes {
                if bolted || world.is_allowed(name, obstacle) {
                    continue; // the shoulder column is bolted to the platform
                }
                let c = capsule_box(capsule, b);
                let slot = match (ROBOT_BODY_NAMES.contains(&obstacle.as_str()), link) {
                    (true, true) => &mut body,
                    (true, false) => &mut own,
                    (false, _) => &mut best,
                };
                if c < slot.0 {
                    *slot = (c, name, obstacle.clone());
                }
            }
            for (obstacle, other) in &world.capsules {
                if world.is_allowed(name, obstacle) {
                    continue;
                }
                let c = capsule_capsule(capsule, other);
                if c < best.0 {
                    best = (c, name, obstacle.clone());
                }
            }
        }
        for &(i, j) in &SELF_COLLISION_PAIRS {
            let c = capsule_capsule(&capsules[i], &capsules[j]);
            if c < own.0 {
                own = (c, ARM_LINK_NAMES[i], ARM_LINK_NAMES[j].to_owned());
            }
        }
        // The payload against the links up to wrist 2 (wrist 3 and the tool hold it).
        for (name, p) in &payload {
            for (k, link) in capsules.iter().enumerate().take(PAYLOAD_CHECKED_LINKS) {
                let c = capsule_capsule(p, link);
                if c < own.0 {
                    own = (c, name, ARM_LINK_NAMES[k].to_owned());
                }
            }
        }
        (best, own, body)
    }

    /// Checks every `stride`-th sample (and the last) of a joint trajectory at a fixed lift.
    ///
    /// # Errors
    /// [`MotionError::Collision`] for the first sample closer than its margin
    /// ([`Self::shortfall`]).
    pub fn check_samples(
        &self,
        world: &CollisionWorld,
        lift_m: f64,
        samples: &[[f64; 6]],
        stride: usize,
    ) -> Result<f64, MotionError> {
        let mut min_clearance = f64::INFINITY;
        let n = samples.len();
        for (k, q) in samples.iter().enumerate() {
            if k % stride.max(1) != 0 && k + 1 != n {
                continue;
            }
            let (outside, own, body) = self.clearances(world, lift_m, q);
            let clearance = outside.0.min(own.0).min(body.0);
            if let Some((clearance, link, obstacle)) = self.short_of_margins(outside, own, body) {
                return Err(MotionError::Collision {
                    sample: k,
                    link,
                    obstacle,
                    clearance_m: clearance,
                });
            }
            min_clearance = min_clearance.min(clearance);
        }
        Ok(min_clearance)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn working_poses_are_free_and_a_folded_arm_collides_with_itself() {
        let arm = ArmCollisionModel::nominal();
        let world = CollisionWorld::robot_body(&arm.model, 1.0);
        for q in [
            [0.0, 0.3, 1.6, 0.2, 1.4, 0.0],
            [-0.45, 0.3, 1.6, 0.2, 1.4, -0.45],
            [-1.2, 0.2, 1.7, 0.0, -1.2, 0.0],
        ] {
            let (c, link, other) = arm.clearance(&world, 1.0, &q);
            assert!(c > arm.margin_m, "{q:?}: {link} vs {other} at {c} m");
        }
        // Elbow folded to 170 deg: the forearm lies on the upper arm, the wrist on the
        // shoulder column.
        let folded = [0.0, 0.0, 170f64.to_radians(), 0.0, 0.0, 0.0];
        let no_obstacles = CollisionWorld::default();
        let (c, link, other) = arm.clearance(&no_obstacles, 1.0, &folded);
        assert!(c < 0.0, "folded arm: {link} vs {other} at {c} m");
        assert!(
            SELF_COLLISION_PAIRS
                .iter()
                .any(|&(i, j)| ARM_LINK_NAMES[i] == link && ARM_LINK_NAMES[j] == other),
            "{link} vs {other} is not a self-collision pair"
        );
    }

    #[test]
    fn a_forearm_hanging_beside_the_lowered_platform_hits_the_chassis() {
        let arm = ArmCollisionModel::nominal();
        let world = CollisionWorld::robot_body(&arm.model, 0.0);
        // Upper arm horizontal, forearm hanging down beside the chassis edge (x = 0.6 m).
        let q = [
            0.0,
            -std::f64::consts::FRAC_PI_2,
            std::f64::consts::FRAC_PI_2,
            0.0,
            0.0,
            0.0,
        ];
        let (c, link, other) = arm.clearance(&world, 0.0, &q);
        assert!(c < 0.0, "{link} vs {other}: {c}");
        assert_eq!((link, other.as_str()), ("arm_forearm_link", "chassis"));
        // Raised by the lift, the same pose is clear of the chassis.
        let raised = CollisionWorld::robot_body(&arm.model, 1.0);
        let (c, link, other) = arm.clearance(&raised, 1.0, &q);
        assert!(c > arm.margin_m, "{link} vs {other}: {c}");
    }

    #[test]
    fn each_pair_is_held_to_its_own_margin() {
        let arm = ArmCollisionModel::nominal();
        let pair = |c: f64, link: &'static str, other: &str| (c, link, other.to_owned());
        let far = || pair(1.0, "", "");
        // An arm link 7 mm from the lift plate keeps the 5 mm it needs ...
        let link_to_plate = pair(0.007, "arm_upperarm_link", "lift_plate");
        assert_eq!(arm.short_of_margins(far(), far(), link_to_plate), None);
        // ... a held rod 7 mm from it does not (1 cm), nor a site obstacle at 15 mm (2 cm).
        let rod_to_plate = pair(0.007, "rod_shaft", "lift_plate");
        assert_eq!(
            arm.short_of_margins(far(), rod_to_plate.clone(), far()),
            Some(rod_to_plate)
        );
        let near_rack = pair(0.015, "tool", "rack_post");
        assert_eq!(
            arm.short_of_margins(near_rack.clone(), far(), far()),
            Some(near_rack.clone())
        );
        // The pair farthest short of its margin is the one reported.
        let link_grazing = pair(-0.002, "arm_upperarm_link", "lift_plate");
        assert_eq!(
            arm.short_of_margins(near_rack, far(), link_grazing.clone()),
            Some(link_grazing)
        );
    }
}
