//! The poses of the hang and remove flows, as pure geometry in `base_link`.
//!
//! # The rod stays upright
//! The camera looks along `tool0 z`, which is the rod's `x` when the rod is held
//! ([`robot::grounding_rod::rod_from_tool0_grasp`]): with the rod upright the wrist camera
//! looks horizontally. So every capture is taken level with its target (the wire, the hung
//! rod's handle) from the robot's side, and the hook, 1.81 m above `tool0`, is brought onto
//! the wire by lowering the lift from the look height and moving the rod horizontally across
//! the wire: the rod never swings near the wire.
//!
//! # Frames
//! * **Hook goal** ([`hook_goal`]): origin on the measured wire axis, `x` horizontal across
//!   the wire pointing away from the robot (the hook's mouth faces the wire: the rod moves
//!   along `+x` to seat it), `y` along the wire, `z = x × y` (up).
//! * **Look pose** ([`level_look_pose`]): the camera `standoff_m` from the target on the
//!   robot's side, level with it, optical axis horizontal through the target, image up =
//!   `up_hint` (world `+z` for the wire: the wire crosses the image horizontally and the
//!   held rod points up; the wire direction for the handle: the vertical handle spans the
//!   image's width).
//! * **Rod of a hung rod** ([`hung_rod_from_handle`]): from the measured handle centre and
//!   axis, the rod's `x` horizontal across the wire away from the robot, as the hang left it.

use nalgebra::{Isometry3, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};
use robot::grounding_rod::{HANDLE_CENTER_IN_ROD_M, rod_from_hook, rod_from_tool0_grasp};
use robot::se3::world_from_camera_looking_at;

/// Why a task pose cannot be formed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PoseError {
    /// The geometry is degenerate.
    #[error("degenerate geometry: {what}")]
    Degenerate {
        /// What.
        what: &'static str,
    },
}

/// Lines steeper than this count as vertical in [`horizontal_normal`], deg: between the
/// wire's slope (a sagging span at its ends, well under 30 deg) and a hanging handle's
/// (within a few degrees of vertical).
pub const STEEP_LINE_DEG: f64 = 45.0;

/// The horizontal unit direction perpendicular to `line_dir` pointing from `from` towards
/// `to` (zero vertical component). A line steeper than [`STEEP_LINE_DEG`] (a handle) counts
/// as vertical: every horizontal direction is then perpendicular enough, and the one from
/// `from` to `to` is taken. The exact perpendicular of a measured, almost vertical axis
/// would turn with the axis' last tenth of a degree of tilt (a look at the hung rod's
/// handle once swung 60 deg round it for a 0.06 deg change).
///
/// # Errors
/// [`PoseError::Degenerate`] for points on the same vertical line through the axis.
pub fn horizontal_normal(
    line_dir: &Vector3<f64>,
    from: &Point3<f64>,
    to: &Point3<f64>,
) -> Result<Vector3<f64>, PoseError> {
    let mut d = to - from;
    d.z = 0.0;
    let mut a = *line_dir;
    a.z = 0.0;
    let steep = a.norm() < STEEP_LINE_DEG.to_radians().cos() * line_dir.norm();
    let n = match a.try_normalize(1e-9) {
        // A line nearer horizontal (the wire): remove the along-line part.
        Some(a) if !steep => d - a * d.dot(&a),
        // A steep line (the handle): every horizontal direction is perpendicular enough.
        _ => d,
    };
    n.try_normalize(1e-9).ok_or(PoseError::Degenerate {
        what: "target and robot on one vertical line",
    })
}

/// `base_from_hook` of the hook seated on the wire at `wire_point` (module docs); the robot
/// stands at `robot_point`.
///
/// # Errors
/// [`PoseError::Degenerate`] for a vertical wire or a robot on the wire's vertical plane.
pub fn hook_goal(
    wire_point: &Point3<f64>,
    wire_dir: &Vector3<f64>,
    robot_point: &Point3<f64>,
) -> Result<Isometry3<f64>, PoseError> {
    let x = horizontal_normal(wire_dir, robot_point, wire_point)?;
    let y = (wire_dir - x * wire_dir.dot(&x))
        .try_normalize(1e-9)
        .ok_or(PoseError::Degenerate {
            what: "wire direction across the approach",
        })?;
    let z = x.cross(&y);
    // Keep z up: flip y when the wire's given direction made it point down.
    let (y, z) = if z.z < 0.0 { (-y, -z) } else { (y, z) };
    Ok(Isometry3::from_parts(
        Translation3::from(wire_point.coords),
        UnitQuaternion::from_rotation_matrix(&Rotation3::from_basis_unchecked(&[x, y, z])),
    ))
}

/// `base_from_tool0` holding the rod whose hook is at `base_from_hook`.
#[must_use]
pub fn tool0_for_hook(base_from_hook: &Isometry3<f64>) -> Isometry3<f64> {
    *base_from_hook * rod_from_hook().inverse() * rod_from_tool0_grasp()
}

/// `base_from_tool0` grasping the rod at `base_from_rod`.
#[must_use]
pub fn grasp_tool0(base_from_rod: &Isometry3<f64>) -> Isometry3<f64> {
    *base_from_rod * rod_from_tool0_grasp()
}

/// `pose` moved by `distance_m` along its own `z` (negative: backwards).
#[must_use]
pub fn along_own_z(pose: &Isometry3<f64>, distance_m: f64) -> Isometry3<f64> {
    *pose * Isometry3::translation(0.0, 0.0, distance_m)
}

/// `pose` moved by `offset` given in `frame` axes (e.g. the rack's or the hook's).
#[must_use]
pub fn shifted(
    pose: &Isometry3<f64>,
    frame: &Isometry3<f64>,
    offset: &Vector3<f64>,
) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::from(frame.rotation * offset),
        UnitQuaternion::identity(),
    ) * *pose
}

/// `base_from_camera` level with `target`, `standoff_m` away on the robot's side, looking
/// at it horizontally with the image's up side towards `up_hint` (module docs).
///
/// # Errors
/// [`PoseError::Degenerate`] when the view direction and `up_hint` are parallel, or the
/// robot is on the target's vertical.
pub fn level_look_pose(
    target: &Point3<f64>,
    line_dir: &Vector3<f64>,
    robot_point: &Point3<f64>,
    standoff_m: f64,
    up_hint: &Vector3<f64>,
) -> Result<Isometry3<f64>, PoseError> {
    let n = horizontal_normal(line_dir, target, robot_point)?;
    let eye = target + n * standoff_m;
    world_from_camera_looking_at(&eye, target, up_hint).ok_or(PoseError::Degenerate {
        what: "view direction parallel to the image's up hint",
    })
}

/// `base_from_rod` of a rod hanging on the wire, from its handle's measured centre and axis
/// (sign free), the wire direction and the robot's position (module docs).
///
/// # Errors
/// [`PoseError::Degenerate`] for a handle axis along the wire or a robot on its vertical.
pub fn hung_rod_from_handle(
    handle_centre: &Point3<f64>,
    handle_axis: &Vector3<f64>,
    wire_dir: &Vector3<f64>,
    robot_point: &Point3<f64>,
) -> Result<Isometry3<f64>, PoseError> {
    // The rod's z is the handle axis pointing up.
    let z = handle_axis
        .try_normalize(1e-9)
        .map(|a| if a.z < 0.0 { -a } else { a })
        .ok_or(PoseError::Degenerate {
            what: "handle axis",
        })?;
    let x0 = horizontal_normal(wire_dir, robot_point, handle_centre)?;
    let x = (x0 - z * x0.dot(&z))
        .try_normalize(1e-9)
        .ok_or(PoseError::Degenerate {
            what: "handle axis horizontal across the wire",
        })?;
    let y = z.cross(&x);
    let [hx, hy, hz] = HANDLE_CENTER_IN_ROD_M;
    let rotation =
        UnitQuaternion::from_rotation_matrix(&Rotation3::from_basis_unchecked(&[x, y, z]));
    let origin = handle_centre - rotation * Vector3::new(hx, hy, hz);
    Ok(Isometry3::from_parts(
        Translation3::from(origin.coords),
        rotation,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn the_hook_goal_faces_the_wire_from_the_robot_and_the_rod_stands_up() {
        let wire = Point3::new(1.3, 0.0, 3.7);
        let robot = Point3::new(0.0, 0.0, 0.63);
        for dir in [Vector3::y(), -Vector3::y()] {
            let hook = hook_goal(&wire, &dir, &robot).expect("hook");
            assert_relative_eq!(hook.rotation * Vector3::x(), Vector3::x(), epsilon = 1e-12);
            assert_relative_eq!(hook.rotation * Vector3::z(), Vector3::z(), epsilon = 1e-12);
            let tool = tool0_for_hook(&hook);
            // tool0 1.81 m below the hook, 60 mm on the robot's side, z towards the wire.
            assert_relative_eq!(
                tool.translation.vector,
                Vector3::new(1.24, 0.0, 3.7 - 1.81),
                epsilon = 1e-12
            );
            assert_relative_eq!(tool.rotation * Vector3::z(), Vector3::x(), epsilon = 1e-12);
            assert_relative_eq!(tool.rotation * Vector3::x(), Vector3::z(), epsilon = 1e-12);
        }
    }

    #[test]
    fn the_level_look_is_horizontal_and_on_the_robot_side() {
        let wire = Point3::new(1.3, 0.0, 3.7);
        let robot = Point3::new(0.0, 0.2, 2.0);
        let cam = level_look_pose(&wire, &Vector3::y(), &robot, 0.45, &Vector3::z()).expect("look");
        assert_relative_eq!(
            cam.translation.vector,
            Vector3::new(0.85, 0.0, 3.7),
            epsilon = 1e-12
        );
        assert_relative_eq!(cam.rotation * Vector3::z(), Vector3::x(), epsilon = 1e-12);
        // Image down is world down.
        assert_relative_eq!(cam.rotation * Vector3::y(), -Vector3::z(), epsilon = 1e-12);
    }

    #[test]
    fn a_hung_rod_is_recovered_from_its_handle() {
        let robot = Point3::new(0.0, 0.0, 0.63);
        let hook = hook_goal(&Point3::new(1.3, 0.1, 3.7), &Vector3::y(), &robot).expect("hook");
        let rod = hook * rod_from_hook().inverse();
        let [hx, hy, hz] = HANDLE_CENTER_IN_ROD_M;
        let centre = rod * Point3::new(hx, hy, hz);
        let recovered =
            hung_rod_from_handle(&centre, &-Vector3::z(), &Vector3::y(), &robot).expect("rod");
        assert_relative_eq!(
            recovered.to_homogeneous(),
            rod.to_homogeneous(),
            epsilon = 1e-12
        );
    }

    #[test]
    fn a_nearly_vertical_handle_is_seen_from_the_robot_whatever_its_tilt() {
        // The demo's measured axes of one hung handle, 0.06 deg apart: with the exact
        // perpendicular the second look stood 60 deg round the handle from the first.
        let handle = Point3::new(1.3, 0.002, 1.89);
        let robot = Point3::new(0.0, 0.0, 0.6);
        for axis in [
            Vector3::new(-0.000_117, -0.001_184, 1.0),
            Vector3::new(0.001_006, 0.000_441, 1.0),
            Vector3::z(),
        ] {
            let cam = level_look_pose(&handle, &axis, &robot, 0.45, &Vector3::y()).expect("look");
            let seen_from = (cam.translation.vector - handle.coords).normalize();
            let towards_robot = Vector3::new(-1.3, -0.002, 0.0).normalize();
            assert_relative_eq!(seen_from, towards_robot, epsilon = 1e-12);
        }
        // A wire sloping 30 deg (steeper than any span end) keeps the exact perpendicular.
        let slope = Vector3::new(0.0, 30f64.to_radians().cos(), 30f64.to_radians().sin());
        let n = horizontal_normal(&slope, &robot, &handle).expect("normal");
        assert_relative_eq!(n.dot(&slope), 0.0, epsilon = 1e-12);
        assert_relative_eq!(n, Vector3::x(), epsilon = 1e-12);
    }
}
