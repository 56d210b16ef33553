//! The site map: what the robot knows of the bay before it starts, from the substation's
//! survey, in `map` (x east along the conductors, y north, z up, metres).
//!
//! The tasks plan with it: the working spot the base drives to, the target conductor's
//! prior (refined by the panoramic finder and then measured by the wrist camera), the rod
//! rack, the calibration target (a richly textured cabinet face the wrist camera can see at
//! 0.3-0.6 m from the working spot) and the fixed obstacles the arm and the rod must clear.
//! [`SiteMap::default_bay`] is a hand-kept copy of the simulator's default bay
//! (`sim::scene::substation`; control never depends on sim): the robot knows that bay by
//! heart, which a surveyed site file is to replace.
//!
//! Everything the robot measures (the wire's pose, the handle's pose) comes from its sensors;
//! the map only says where to look and what not to touch.

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use robot::grounding_rod::{self, rack_from_rod};
use robot::se3::planar_pose;

use crate::motion::collision::{Capsule, CollisionWorld, OrientedBox};
use crate::perception::panoramic::WirePrior;

/// Radius of the conductor (m): 26.8 mm diameter.
pub const CONDUCTOR_RADIUS_M: f64 = 0.0134;
/// Clearance added to a conductor's radius for its sway between measurement and motion (m):
/// ~4 mm at 2 m/s (`sim::environment`), with margin.
pub const CONDUCTOR_SWAY_MARGIN_M: f64 = 0.02;

/// A planar base pose in `map`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BasePose {
    /// x (m).
    pub x_m: f64,
    /// y (m).
    pub y_m: f64,
    /// Yaw (rad), about z from x.
    pub yaw_rad: f64,
}

impl BasePose {
    /// `map_from_base`.
    #[must_use]
    pub fn isometry(&self) -> Isometry3<f64> {
        planar_pose(self.x_m, self.y_m, self.yaw_rad)
    }
}

/// The site map (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct SiteMap {
    /// The target conductor near the hanging point (survey prior).
    pub wire: WirePrior,
    /// The other conductors of the bay near the work, as straight segments (m, `map`).
    pub other_conductors: Vec<(Point3<f64>, Point3<f64>)>,
    /// Where the base stands for the operation.
    pub work_spot: BasePose,
    /// `map_from_rack` of the rod rack (the stored rod stands at `rack_from_rod`).
    pub map_from_rack: Isometry3<f64>,
    /// Centre of the calibration target's face (m, `map`).
    pub calibration_target: Point3<f64>,
    /// Its outward unit normal (towards the working spot).
    pub calibration_normal: Vector3<f64>,
    /// Fixed obstacles (`map`): the cabinet cluster, the cable tray, the rack.
    pub obstacles: Vec<(String, OrientedBox)>,
}

/// Name of the target conductor in collision worlds.
pub const TARGET_WIRE: &str = "target_wire";
/// Names of the rack's parts that hold the rod (the rod may touch them while racked).
pub const RACK_HOLDERS: [&str; 2] = ["rack_holder_low", "rack_holder_high"];

fn obox(name: &str, map_from_box: Isometry3<f64>, half_m: [f64; 3]) -> (String, OrientedBox) {
    (
        name.to_owned(),
        OrientedBox {
            frame_from_box: map_from_box,
            half_extents_m: Vector3::from(half_m),
        },
    )
}

impl SiteMap {
    /// The simulator's default bay: conductors along x at y = -4.5, 0, 4.5 m, 3.7 m up at
    /// mid-span (x = 12 m); the working spot 1.3 m south of the middle phase, facing north;
    /// the rack 0.85 m from the spot's centre on the base's left; the calibration cabinet's
    /// face 1.35 m east of the spot, facing west.
    #[must_use]
    pub fn default_bay() -> Self {
        let work_spot = BasePose {
            x_m: 12.0,
            y_m: -1.3,
            yaw_rad: std::f64::consts::FRAC_PI_2,
        };
        let map_from_spot = work_spot.isometry();
        let rack_in_base = Vector3::new(RACK_IN_BASE_M[0], RACK_IN_BASE_M[1], 0.0);
        let rack_position = map_from_spot * Point3::from(rack_in_base);
        let map_from_rack = Isometry3::from_parts(
            Translation3::new(rack_position.x, rack_position.y, RACK_PEDESTAL_M),
            UnitQuaternion::from_axis_angle(
                &Vector3::z_axis(),
                work_spot.yaw_rad + rack_in_base.y.atan2(rack_in_base.x),
            ),
        );
        let x_front = work_spot.x_m + 1.35;
        let y = work_spot.y_m;
        let mut obstacles = vec![
            // Cabinet with its plinth and roof (0.6 x 1.4 x 2.1 m behind the face).
            obox(
                "cabinet",
                Isometry3::translation(x_front + 0.3, y, 1.06),
                [0.36, 0.76, 1.06],
            ),
            obox(
                "junction_box",
                Isometry3::translation(x_front + 0.3, y - 0.82, 1.2),
                [0.21, 0.12, 0.25],
            ),
            obox(
                "cable_tray",
                Isometry3::translation(x_front + 0.05, y - 1.95, 0.95),
                [0.16, 1.05, 0.9],
            ),
        ];
        for (name, c, h) in super::survey::RACK_PARTS {
            obstacles.push(obox(
                name,
                map_from_rack * Isometry3::translation(c[0], c[1], c[2]),
                h,
            ));
        }
        Self {
            wire: WirePrior {
                point: Point3::new(12.0, 0.0, 3.7),
                direction: Vector3::x(),
                half_length_m: 1.5,
            },
            other_conductors: [-4.5, 4.5]
                .iter()
                .map(|&yp| (Point3::new(8.0, yp, 3.75), Point3::new(16.0, yp, 3.75)))
                .collect(),
            work_spot,
            map_from_rack,
            calibration_target: Point3::new(x_front - 0.004, y, 1.1),
            calibration_normal: -Vector3::x(),
            obstacles,
        }
    }

    /// `map_from_rod` of the rod stored on the rack.
    #[must_use]
    pub fn map_from_stored_rod(&self) -> Isometry3<f64> {
        self.map_from_rack * rack_from_rod()
    }

    /// The same site with the rack, its parts and its stored rod moved rigidly to
    /// `map_from_rack` (a measured rack).
    #[must_use]
    pub fn with_rack_at(&self, map_from_rack: Isometry3<f64>) -> Self {
        let moved = map_from_rack * self.map_from_rack.inverse();
        let mut site = self.clone();
        for (name, b) in &mut site.obstacles {
            if crate::tasks::survey::RACK_PARTS
                .iter()
                .any(|(part, _, _)| part == name)
            {
                b.frame_from_box = moved * b.frame_from_box;
            }
        }
        site.map_from_rack = map_from_rack;
        site
    }

    /// The obstacles in `base_link` for `base_from_map` (odometry): the fixed boxes, the
    /// ground below `z = 0`, the other conductors and the target conductor `wire` (a segment
    /// in `map`, e.g. the measured axis, or the prior's when none is measured yet), each
    /// conductor widened by `sway_margin_m` for its sway (at least
    /// [`CONDUCTOR_SWAY_MARGIN_M`]: the hang widens it to the band the captures saw the wire
    /// swing in).
    #[must_use]
    pub fn collision_world(
        &self,
        base_from_map: &Isometry3<f64>,
        wire: Option<(Point3<f64>, Point3<f64>)>,
        sway_margin_m: f64,
    ) -> CollisionWorld {
        let mut world = CollisionWorld::default();
        for (name, b) in &self.obstacles {
            world.boxes.push((
                name.clone(),
                OrientedBox {
                    frame_from_box: base_from_map * b.frame_from_box,
                    half_extents_m: b.half_extents_m,
                },
            ));
        }
        world.boxes.push((
            "ground".to_owned(),
            OrientedBox {
                frame_from_box: base_from_map
                    * Isometry3::translation(
                        self.work_spot.x_m,
                        self.work_spot.y_m,
                        -GROUND_HALF_THICKNESS_M,
                    ),
                half_extents_m: Vector3::new(20.0, 20.0, GROUND_HALF_THICKNESS_M),
            },
        ));
        let radius_m = CONDUCTOR_RADIUS_M + sway_margin_m.max(CONDUCTOR_SWAY_MARGIN_M);
        let half = self.wire.direction.normalize() * self.wire.half_length_m * 2.0;
        let (a, b) = wire.unwrap_or((self.wire.point - half, self.wire.point + half));
        world.capsules.push((
            TARGET_WIRE.to_owned(),
            Capsule {
                a: base_from_map * a,
                b: base_from_map * b,
                radius_m,
            },
        ));
        for (k, (a, b)) in self.other_conductors.iter().enumerate() {
            world.capsules.push((
                format!("conductor_{k}"),
                Capsule {
                    a: base_from_map * a,
                    b: base_from_map * b,
                    radius_m,
                },
            ));
        }
        world
    }

    /// The stored rod's capsules (`map`), for a collision world while it stands on the rack.
    #[must_use]
    pub fn stored_rod_capsules(&self) -> Vec<(String, Capsule)> {
        rod_capsules(&self.map_from_stored_rod(), "stored_")
    }
}

/// Half thickness of the ground slab in collision worlds (m).
pub const GROUND_HALF_THICKNESS_M: f64 = 0.5;

/// Where the rack stands relative to the working spot (`base_link` at the spot, m): the
/// simulator's `sim::scene::substation::RACK_IN_BASE_M`.
pub const RACK_IN_BASE_M: [f64; 2] = [-0.3, 0.8];
/// Height of the rack's pedestal (m), `sim::scene::substation::RACK_PEDESTAL_M`.
pub const RACK_PEDESTAL_M: f64 = 0.6;

/// The rod's capsules at `frame_from_rod`, names prefixed with `prefix`.
#[must_use]
pub fn rod_capsules(frame_from_rod: &Isometry3<f64>, prefix: &str) -> Vec<(String, Capsule)> {
    grounding_rod::rod_capsules_in_rod()
        .iter()
        .map(|(name, a, b, r)| {
            (
                format!("{prefix}{name}"),
                Capsule {
                    a: frame_from_rod * a,
                    b: frame_from_rod * b,
                    radius_m: *r,
                },
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn the_rack_rod_opens_away_from_the_working_spot() {
        let site = SiteMap::default_bay();
        let rod = site.map_from_stored_rod();
        let spot = site.work_spot.isometry();
        let mut to_rod = rod.translation.vector - spot.translation.vector;
        to_rod.z = 0.0;
        let to_rod = to_rod.normalize();
        let rod_x = rod.rotation * Vector3::x();
        assert!(
            rod_x.dot(&to_rod) > 0.99,
            "hook mouth {rod_x:?} vs {to_rod:?}"
        );
        assert_relative_eq!(
            rod.translation.vector.z,
            RACK_PEDESTAL_M + 0.12,
            epsilon = 1e-12
        );
    }

    /// A measured rack moves the rack's parts and its stored rod, nothing else.
    #[test]
    fn a_measured_rack_moves_the_racks_bodies_only() {
        let site = SiteMap::default_bay();
        let shift = Vector3::new(0.03, -0.02, 0.01);
        let moved = site
            .with_rack_at(Isometry3::translation(shift.x, shift.y, shift.z) * site.map_from_rack);
        let rack_parts: Vec<&str> = crate::tasks::survey::RACK_PARTS
            .iter()
            .map(|p| p.0)
            .collect();
        for ((name, a), (_, b)) in site.obstacles.iter().zip(&moved.obstacles) {
            let d = b.frame_from_box.translation.vector - a.frame_from_box.translation.vector;
            let expected = if rack_parts.contains(&name.as_str()) {
                shift
            } else {
                Vector3::zeros()
            };
            assert!((d - expected).norm() < 1e-12, "{name}: {d}");
        }
        let d = moved.map_from_stored_rod().translation.vector
            - site.map_from_stored_rod().translation.vector;
        assert!((d - shift).norm() < 1e-12);
        assert!(
            rack_parts
                .iter()
                .all(|p| site.obstacles.iter().any(|(n, _)| n == p))
        );
    }

    #[test]
    fn the_collision_world_is_in_base_link() {
        let site = SiteMap::default_bay();
        let base_from_map = site.work_spot.isometry().inverse();
        let world = site.collision_world(&base_from_map, None, CONDUCTOR_SWAY_MARGIN_M);
        let (_, wire) = world
            .capsules
            .iter()
            .find(|(n, _)| n == TARGET_WIRE)
            .expect("target wire");
        // 1.3 m ahead of the base, 3.7 m up, running across the base's y axis.
        assert_relative_eq!(wire.a.x, 1.3, epsilon = 1e-9);
        assert_relative_eq!(wire.a.z, 3.7, epsilon = 1e-9);
        assert!((wire.a - wire.b).y.abs() > 5.0);
        assert!(world.boxes.iter().any(|(n, _)| n == "cabinet"));
    }
}
