//! The grounding rod and its interface with the end effector: dimensions, the grasp, the
//! hook's capture window and the clamp's lead-screw travel (ARCHITECTURE.md section 6).
//!
//! The rod is the robot's tool. Its geometry is known to the controller (it plans with it) and
//! to the simulator (it renders the rod and decides grasp, hook and clamp with it), so it lives
//! here, once: `sim` builds the rod's primitives from these numbers and decides the rod's
//! state with [`hook_decision`]; `control` plans the grasp, the hook approach and the rack
//! return with the same frames.
//!
//! # Frames
//! * **Rod frame** `rod`: origin on the axis at the bottom of the handle, `z` along the rod
//!   towards the clamp head, `x` towards the open side of the hook (the hook's mouth).
//!
//!   | part | z range (m) | radius (m) |
//!   |---|---|---|
//!   | handle (knurled rubber) | 0 .. [`HANDLE_LENGTH_M`] | [`HANDLE_RADIUS_M`] |
//!   | outer support rod (insulating tube) | 0.25 .. [`SUPPORT_TOP_M`] | [`SUPPORT_RADIUS_M`] |
//!   | inner drive rod (steel, lead screw) | 1.45 .. [`DRIVE_TOP_M`] | [`DRIVE_RADIUS_M`] |
//!   | clamp head body, moving jaw, hook | 1.78 .. [`ROD_TOP_M`] | [`HEAD_HALF_EXTENTS_M`] |
//!
//! * **Hook frame**: at [`HOOK_CENTER_IN_ROD`] with the rod's axes. The wire seats along its
//!   `y`; the mouth opens towards `+x`, so the hook is put onto a wire by moving the rod along
//!   `+x` until the wire axis is at the hook centre (the wire enters the mouth moving along
//!   `-x` in the hook frame); "across the wire" is `z`.
//! * **Grasp**: the end effector holds the handle with `tool0` at [`rod_from_tool0_grasp`]:
//!   60 mm from the rod axis on the `-x` side, halfway up the handle, `tool0 z` pointing at the
//!   rod axis (`= rod x`) and `tool0 x` along the rod (`= rod z`).
//! * **Rack**: the stored rod stands upright, `rack_from_rod` = `Tz(RACK_STORE_HEIGHT_M)`.
//!
//! # Tolerances
//! * Hook ([`HookTolerance::DESIGN`]): the wire is captured when, in the hook frame, the
//!   closest point of its axis is within +-15 mm across (`|z|`), +-10 mm along the approach
//!   (`|x|`), and its direction is within +-5 deg of the hook's `y` in yaw (about `z`).
//! * Grasp: `tool0` within [`GRASP_TOLERANCE_M`] and [`GRASP_TOLERANCE_RAD`] of the grasp
//!   pose couples the end effector to the handle (a passive latch); moving more than
//!   [`RELEASE_DISTANCE_M`] away from it, where the rod is held by something else (rack,
//!   clamped on the wire), uncouples it.
//! * Rack: stored again when within [`RACK_TOLERANCE_M`] and [`GRASP_TOLERANCE_RAD`] of the
//!   stored pose; a held rod leaves the rack when lifted more than [`RACK_LIFT_OUT_M`].
//!
//! # Clamp
//! The lead screw's travel is `clamp_joint` (m) in `[0, CLAMP_TRAVEL_M]`: `CLOSE` drives it up
//! until the jaw meets a seated wire at [`WIRE_CONTACT_TRAVEL_M`] (the motor then holds its
//! torque limit: effort rises), or to full travel when there is no wire in the hook (the
//! controller's evidence of a miss). Opening below [`UNCLAMP_TRAVEL_M`] frees the wire.

use nalgebra::{Isometry3, Matrix3, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};

/// Handle length (m).
pub const HANDLE_LENGTH_M: f64 = 0.25;
/// Handle radius (m).
pub const HANDLE_RADIUS_M: f64 = 0.021;
/// Outer support rod top (m, rod frame z).
pub const SUPPORT_TOP_M: f64 = 1.45;
/// Outer support rod radius (m).
pub const SUPPORT_RADIUS_M: f64 = 0.019;
/// Inner drive rod top (m).
pub const DRIVE_TOP_M: f64 = 1.78;
/// Inner drive rod radius (m).
pub const DRIVE_RADIUS_M: f64 = 0.009;
/// Top of the clamp head (m, rod frame z).
pub const ROD_TOP_M: f64 = 2.02;
/// Half extents of the clamp head's bounding box around the rod axis (m, rod x y z), centred
/// at [`HEAD_CENTER_Z_M`].
pub const HEAD_HALF_EXTENTS_M: [f64; 3] = [0.045, 0.026, 0.12];
/// Centre of the clamp head's bounding box (m, rod frame z).
pub const HEAD_CENTER_Z_M: f64 = 1.90;
/// Centre of the hook's mouth, where the wire axis sits when hung (rod frame, m).
pub const HOOK_CENTER_IN_ROD: [f64; 3] = [0.0, 0.0, 1.935];
/// The handle's reference point (rod frame, m): on the axis, halfway up the handle.
pub const HANDLE_CENTER_IN_ROD_M: [f64; 3] = [0.0, 0.0, 0.125];
/// Height of the rod frame's origin above the rack frame's origin when stored (m).
pub const RACK_STORE_HEIGHT_M: f64 = 0.12;

/// Grasp position tolerance (m).
pub const GRASP_TOLERANCE_M: f64 = 0.005;
/// Grasp and rack angle tolerance (rad): 5 deg.
pub const GRASP_TOLERANCE_RAD: f64 = 5.0 * std::f64::consts::PI / 180.0;
/// Rack position tolerance (m).
pub const RACK_TOLERANCE_M: f64 = 0.01;
/// Lift along the rack's z that takes a held rod out of the rack (m).
pub const RACK_LIFT_OUT_M: f64 = 0.3;
/// Tool distance from the grasp pose that releases a held, constrained rod (m).
pub const RELEASE_DISTANCE_M: f64 = 0.02;
/// Yaw beyond which a hook inside the window throws the rod off (rad): 45 deg.
pub const DROP_YAW_RAD: f64 = std::f64::consts::FRAC_PI_4;

/// Full travel of the clamp's lead screw (m).
pub const CLAMP_TRAVEL_M: f64 = 0.05;
/// Travel at which the jaw meets a 26.8 mm conductor seated in the hook (m).
pub const WIRE_CONTACT_TRAVEL_M: f64 = 0.045;
/// A held clamped rod unclamps when the lead screw opens below this travel (m): 1 mm off the
/// wire contact.
pub const UNCLAMP_TRAVEL_M: f64 = WIRE_CONTACT_TRAVEL_M - 0.001;

/// The capture window of the hook.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HookTolerance {
    /// Half width across the wire (m).
    pub across_m: f64,
    /// Half width along the approach (m).
    pub along_approach_m: f64,
    /// Half width in yaw (rad).
    pub yaw_rad: f64,
}

impl HookTolerance {
    /// ARCHITECTURE.md section 6: +-15 mm across, +-10 mm along the approach, +-5 deg yaw.
    pub const DESIGN: Self = Self {
        across_m: 0.015,
        along_approach_m: 0.010,
        yaw_rad: 5.0 * std::f64::consts::PI / 180.0,
    };
}

/// Where the wire is relative to the hook.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HookOffset {
    /// Wire axis offset across (hook `z`, m).
    pub across_m: f64,
    /// Wire axis offset along the approach (hook `x`, m).
    pub along_approach_m: f64,
    /// Yaw of the wire direction from the hook's `y` about its `z` (rad, folded to
    /// `[-pi/2, pi/2]`: the wire has no direction).
    pub yaw_rad: f64,
}

impl HookOffset {
    /// The offset as a fraction of the window: the largest of `|across| / across_tol`,
    /// `|along| / along_tol` and `|yaw| / yaw_tol` (<= 1 inside the window).
    #[must_use]
    pub fn window_fraction(&self, tol: &HookTolerance) -> f64 {
        (self.across_m.abs() / tol.across_m)
            .max(self.along_approach_m.abs() / tol.along_approach_m)
            .max(self.yaw_rad.abs() / tol.yaw_rad)
    }
}

/// Outcome of [`hook_decision`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HookDecision {
    /// Inside all three tolerances: the wire seats in the hook.
    Captured,
    /// Outside the window: nothing happens.
    Missed,
    /// Inside the position window but badly twisted: the rod is knocked off.
    Knocked,
}

/// `rod_from_hook`: the hook frame.
#[must_use]
pub fn rod_from_hook() -> Isometry3<f64> {
    let [x, y, z] = HOOK_CENTER_IN_ROD;
    Isometry3::translation(x, y, z)
}

/// `rod_from_tool0` of a held rod (module docs).
#[must_use]
pub fn rod_from_tool0_grasp() -> Isometry3<f64> {
    // tool0 z = rod x, tool0 x = rod z, tool0 y = -rod y.
    let r = Matrix3::new(0.0, 0.0, 1.0, 0.0, -1.0, 0.0, 1.0, 0.0, 0.0);
    Isometry3::from_parts(
        Translation3::new(-0.06, 0.0, 0.125),
        UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r)),
    )
}

/// `rack_from_rod` of the stored rod.
#[must_use]
pub fn rack_from_rod() -> Isometry3<f64> {
    Isometry3::translation(0.0, 0.0, RACK_STORE_HEIGHT_M)
}

/// The wire's offset in the hook frame from a point on its axis and its unit direction (both
/// in the same frame as `frame_from_hook`).
#[must_use]
pub fn hook_offset(
    frame_from_hook: &Isometry3<f64>,
    wire_point: &Point3<f64>,
    wire_dir: &Vector3<f64>,
) -> HookOffset {
    let hook_from_frame = frame_from_hook.inverse();
    let p = hook_from_frame * wire_point;
    let d = hook_from_frame.rotation * wire_dir;
    // Closest point of the (locally straight) wire to the hook centre.
    let dn = d.try_normalize(1e-12).unwrap_or_else(Vector3::y);
    let c = p.coords - dn * p.coords.dot(&dn);
    let mut yaw = d.x.atan2(d.y);
    if yaw > std::f64::consts::FRAC_PI_2 {
        yaw -= std::f64::consts::PI;
    } else if yaw < -std::f64::consts::FRAC_PI_2 {
        yaw += std::f64::consts::PI;
    }
    HookOffset {
        across_m: c.z,
        along_approach_m: c.x,
        yaw_rad: yaw,
    }
}

/// The tolerance decision (shared by simulator and controller).
#[must_use]
pub fn hook_decision(offset: &HookOffset, tol: &HookTolerance) -> HookDecision {
    let in_position = offset.across_m.abs() <= tol.across_m
        && offset.along_approach_m.abs() <= tol.along_approach_m;
    if !in_position {
        HookDecision::Missed
    } else if offset.yaw_rad.abs() <= tol.yaw_rad {
        HookDecision::Captured
    } else if offset.yaw_rad.abs() > DROP_YAW_RAD {
        HookDecision::Knocked
    } else {
        HookDecision::Missed
    }
}

/// Whether `frame_from_tool0` is within `tol_m` / `tol_rad` of `frame_from_target`.
#[must_use]
pub fn within(
    frame_from_tool0: &Isometry3<f64>,
    frame_from_target: &Isometry3<f64>,
    tol_m: f64,
    tol_rad: f64,
) -> bool {
    let d = frame_from_target.inverse() * frame_from_tool0;
    d.translation.vector.norm() <= tol_m && d.rotation.angle() <= tol_rad
}

/// The rod's segments for collision checking, in the rod frame: `(name, a, b, radius)`
/// capsules from the handle to the clamp head (the head as a capsule bounding its box).
#[must_use]
pub fn rod_capsules_in_rod() -> [(&'static str, Point3<f64>, Point3<f64>, f64); 3] {
    let [hx, hy, _] = HEAD_HALF_EXTENTS_M;
    [
        (
            "rod_handle",
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(0.0, 0.0, HANDLE_LENGTH_M + 0.03),
            0.026,
        ),
        (
            "rod_shaft",
            Point3::new(0.0, 0.0, HANDLE_LENGTH_M + 0.03),
            Point3::new(0.0, 0.0, HEAD_CENTER_Z_M - HEAD_HALF_EXTENTS_M[2]),
            SUPPORT_RADIUS_M.max(0.024),
        ),
        (
            "rod_head",
            Point3::new(0.0, 0.0, HEAD_CENTER_Z_M - HEAD_HALF_EXTENTS_M[2] + hx),
            Point3::new(0.0, 0.0, ROD_TOP_M - hx.min(0.02)),
            hx.hypot(hy),
        ),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn grasp_axes_are_as_documented() {
        let g = rod_from_tool0_grasp();
        assert_relative_eq!(g.rotation * Vector3::z(), Vector3::x(), epsilon = 1e-15);
        assert_relative_eq!(g.rotation * Vector3::x(), Vector3::z(), epsilon = 1e-15);
        assert_relative_eq!(g.rotation * Vector3::y(), -Vector3::y(), epsilon = 1e-15);
        // 60 mm from the axis on the -x side, halfway up the handle.
        assert_relative_eq!(
            g.translation.vector,
            Vector3::new(-0.06, 0.0, HANDLE_CENTER_IN_ROD_M[2]),
            epsilon = 1e-15
        );
    }

    #[test]
    fn hook_window_decides_capture_miss_and_knock() {
        let hook = rod_from_hook();
        let centre = hook * Point3::origin();
        let along_y = Vector3::y();
        let inside = hook_offset(
            &hook,
            &(centre + Vector3::new(0.009, 0.3, -0.014)),
            &along_y,
        );
        assert_eq!(
            hook_decision(&inside, &HookTolerance::DESIGN),
            HookDecision::Captured
        );
        assert!(inside.window_fraction(&HookTolerance::DESIGN) < 1.0);
        let beside = hook_offset(&hook, &(centre + Vector3::new(0.011, 0.0, 0.0)), &along_y);
        assert_eq!(
            hook_decision(&beside, &HookTolerance::DESIGN),
            HookDecision::Missed
        );
        let twisted = Vector3::new(1.0, 1.0, 0.0); // 45 deg + a little below: missed
        let skew = hook_offset(&hook, &centre, &twisted);
        assert_eq!(
            hook_decision(&skew, &HookTolerance::DESIGN),
            HookDecision::Missed
        );
        let across = hook_offset(&hook, &centre, &Vector3::x());
        assert_eq!(
            hook_decision(&across, &HookTolerance::DESIGN),
            HookDecision::Knocked
        );
    }

    #[test]
    fn capsules_cover_the_rod_from_handle_to_head() {
        let caps = rod_capsules_in_rod();
        assert_relative_eq!(caps[0].1.z, 0.0);
        assert!(caps[2].2.z + caps[2].3 >= ROD_TOP_M - 1e-12);
        for w in caps.windows(2) {
            assert!(w[1].1.z <= w[0].2.z + w[1].3, "no gap between segments");
        }
    }
}
