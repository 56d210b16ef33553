//! The grounding rod: grasp, hook, clamp, unhook and return decided by the physical
//! tolerances of ARCHITECTURE.md section 6 (shared with the controller through these pure functions).
//!
//! # Frames
//! The rod's frames, grasp and tolerances are the robot crate's ([`robot::grounding_rod`],
//! re-exported here): the controller plans with the same numbers the world decides with.
//! Rod frame: origin at the bottom of the handle, `z` along the rod, `x` towards the open
//! side of the hook. The **hook frame** sits at [`HOOK_CENTER_IN_ROD`] with the rod's axes:
//! the wire seats along its `y` axis; the hook is put onto the wire by moving the rod along
//! `+x` (the wire enters the mouth), and "across the wire" is `z`.
//! The end effector holds the handle with `tool0` at [`rod_from_tool0_grasp`]: 60 mm from the
//! rod axis on the `-x` side, halfway up the handle, `tool0 z` pointing at the rod axis.
//!
//! # Tolerances ([`HookTolerance::DESIGN`])
//! The hook captures the wire when, in the hook frame, the closest point of the wire axis is
//! within +-15 mm across (`|z|`), +-10 mm along the approach (`|x|`), and the wire direction
//! is within +-5 deg of the hook's `y` in yaw (about the hook's `z`). Grasping the handle
//! needs `tool0` within [`GRASP_TOLERANCE_M`] and [`GRASP_TOLERANCE_RAD`] of the grasp pose.
//!
//! # States (`/sim/rod_state`)
//! * `on_rack`: stored; a `tool0` reaching the grasp pose **holds** it (passive coupling);
//!   a held rod lifted more than [`RACK_LIFT_OUT_M`] along the rack's z leaves the rack:
//!   `in_gripper`. A held rod on the rack is released when the tool moves more than
//!   [`RELEASE_DISTANCE_M`] from the grasp pose sideways.
//! * `in_gripper`: follows `tool0`; becomes `hooked` when the hook captures the wire, or
//!   `on_rack` again when brought within [`RACK_TOLERANCE_M`] / [`GRASP_TOLERANCE_RAD`] of
//!   the stored pose.
//! * `hooked`: on the wire; while held it follows the tool and returns to `in_gripper` when
//!   the hook leaves the capture window (unhook); the clamp closing onto the wire (jaw at the
//!   contact travel) makes it `clamped`. Not held, it hangs where it was left.
//! * `clamped`: fixed on the wire (moves with the wire's sway); the tool moving more than
//!   [`RELEASE_DISTANCE_M`] away releases it (the rod's screw is self-locking: it stays
//!   clamped); held again, opening the clamp below [`UNCLAMP_TRAVEL_M`] makes it `hooked`.
//!   While the end effector holds the rod its motor drives the rod's screw and `clamp_joint`
//!   reads the rod's jaw travel (re-grasping a clamped rod couples at the contact travel).
//! * `dropped`: a held rod whose hook is inside the window across the wire but more than
//!   45 deg off in yaw falls off (the only failure modelled).

use msgs::RobotTime;
#[cfg(test)]
use nalgebra::UnitQuaternion;
use nalgebra::{Isometry3, Point3, Vector3};

pub use robot::grounding_rod::{
    DROP_YAW_RAD, GRASP_TOLERANCE_M, GRASP_TOLERANCE_RAD, HOOK_CENTER_IN_ROD, HookDecision,
    HookOffset, HookTolerance, RACK_LIFT_OUT_M, RACK_TOLERANCE_M, RELEASE_DISTANCE_M,
    UNCLAMP_TRAVEL_M, hook_decision, hook_offset, rod_from_hook, rod_from_tool0_grasp, within,
};

/// The rod's state (`/sim/rod_state` strings).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RodState {
    /// Stored on the rack.
    OnRack,
    /// Held, free in the air.
    InGripper,
    /// Hooked on the wire.
    Hooked,
    /// Clamped on the wire.
    Clamped,
    /// Fell off.
    Dropped,
}

impl RodState {
    /// The `/sim/rod_state` text.
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            Self::OnRack => "on_rack",
            Self::InGripper => "in_gripper",
            Self::Hooked => "hooked",
            Self::Clamped => "clamped",
            Self::Dropped => "dropped",
        }
    }
}

/// What the rod needs to know about the world at one instant.
#[derive(Debug, Clone, Copy)]
pub struct RodInputs {
    /// True `map_from_tool0`.
    pub world_from_tool0: Isometry3<f64>,
    /// A point on the target wire's axis near the hook and the axis direction (world).
    pub wire_near_hook: (Point3<f64>, Vector3<f64>),
    /// Motion of the wire since the last update (sway), applied to a rod fixed on it.
    pub wire_motion: Isometry3<f64>,
    /// The clamp jaw presses on the wire.
    pub clamp_pressing: bool,
    /// Lead-screw travel (m); read only while the rod is held (coupled to the motor).
    pub clamp_travel_m: f64,
}

/// The rod.
#[derive(Debug, Clone, PartialEq)]
pub struct Rod {
    /// State.
    pub state: RodState,
    /// Whether the end effector holds it.
    pub held: bool,
    /// True pose.
    pub world_from_rod: Isometry3<f64>,
    /// Stored pose on the rack.
    pub world_from_rod_stored: Isometry3<f64>,
    /// Time of the last state change.
    pub changed_at: RobotTime,
}

impl Rod {
    /// A rod stored on the rack.
    #[must_use]
    pub fn on_rack(world_from_rod_stored: Isometry3<f64>) -> Self {
        Self {
            state: RodState::OnRack,
            held: false,
            world_from_rod: world_from_rod_stored,
            world_from_rod_stored,
            changed_at: RobotTime::ZERO,
        }
    }

    /// A rod clamped on the wire at `world_from_rod`, not held (its rack pose is
    /// `world_from_rod_stored`).
    #[must_use]
    pub fn clamped(world_from_rod_stored: Isometry3<f64>, world_from_rod: Isometry3<f64>) -> Self {
        Self {
            state: RodState::Clamped,
            held: false,
            world_from_rod,
            world_from_rod_stored,
            changed_at: RobotTime::ZERO,
        }
    }

    /// `world_from_hook`.
    #[must_use]
    pub fn world_from_hook(&self) -> Isometry3<f64> {
        self.world_from_rod * rod_from_hook()
    }

    /// Pose where `tool0` grasps it.
    #[must_use]
    pub fn world_from_grasp(&self) -> Isometry3<f64> {
        self.world_from_rod * rod_from_tool0_grasp()
    }

    /// One update at `now`; returns true when the state changed.
    pub fn update(&mut self, now: RobotTime, inp: &RodInputs) -> bool {
        let before = self.state;
        let grasp = self.world_from_grasp();
        let at_grasp = within(
            &inp.world_from_tool0,
            &grasp,
            GRASP_TOLERANCE_M,
            GRASP_TOLERANCE_RAD,
        );
        let tool_distance = (grasp.inverse() * inp.world_from_tool0)
            .translation
            .vector
            .norm();
        if matches!(self.state, RodState::Clamped) {
            self.world_from_rod = inp.wire_motion * self.world_from_rod;
        }
        if !self.held {
            if at_grasp && self.state != RodState::Dropped {
                self.held = true;
            }
        } else {
            let follow = inp.world_from_tool0 * rod_from_tool0_grasp().inverse();
            match self.state {
                RodState::OnRack => {
                    let rack_from_follow = self.world_from_rod_stored.inverse() * follow;
                    let t = rack_from_follow.translation.vector;
                    let lateral = t.x.hypot(t.y);
                    if lateral <= RACK_TOLERANCE_M
                        && rack_from_follow.rotation.angle() <= GRASP_TOLERANCE_RAD
                        && t.z >= -1e-3
                    {
                        self.world_from_rod = follow;
                        if t.z > RACK_LIFT_OUT_M {
                            self.state = RodState::InGripper;
                        }
                    } else if tool_distance > RELEASE_DISTANCE_M {
                        self.held = false;
                        self.world_from_rod = self.world_from_rod_stored;
                    }
                }
                RodState::InGripper | RodState::Hooked => {
                    self.world_from_rod = follow;
                    let offset = hook_offset(
                        &self.world_from_hook(),
                        &inp.wire_near_hook.0,
                        &inp.wire_near_hook.1,
                    );
                    match hook_decision(&offset, &HookTolerance::DESIGN) {
                        HookDecision::Captured => {
                            self.state = if inp.clamp_pressing {
                                RodState::Clamped
                            } else {
                                RodState::Hooked
                            };
                        }
                        HookDecision::Knocked => {
                            self.state = RodState::Dropped;
                            self.held = false;
                        }
                        HookDecision::Missed => {
                            let stored = within(
                                &follow,
                                &self.world_from_rod_stored,
                                RACK_TOLERANCE_M,
                                GRASP_TOLERANCE_RAD,
                            );
                            self.state = if stored {
                                RodState::OnRack
                            } else {
                                RodState::InGripper
                            };
                        }
                    }
                }
                RodState::Clamped => {
                    if inp.clamp_travel_m < UNCLAMP_TRAVEL_M {
                        self.state = RodState::Hooked;
                    } else if tool_distance > RELEASE_DISTANCE_M {
                        self.held = false;
                    }
                }
                RodState::Dropped => self.held = false,
            }
        }
        if self.state != before {
            self.changed_at = now;
            true
        } else {
            false
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hook_at(offset_in_hook: Vector3<f64>, yaw_deg: f64) -> HookOffset {
        // A wire along the hook's y, rotated by yaw about z and shifted.
        let r = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw_deg.to_radians());
        let world_from_hook = Isometry3::translation(1.0, 2.0, 3.0);
        let p = world_from_hook * Point3::from(offset_in_hook);
        hook_offset(&world_from_hook, &p, &(r * -Vector3::y()))
    }

    #[test]
    fn hook_tolerances_decide_capture() {
        let tol = HookTolerance::DESIGN;
        // Along-wire offsets do not matter for a straight wire (0.3 m when not twisted).
        let cap = |x: f64, z: f64, yaw: f64| {
            let y = if yaw == 0.0 { 0.3 } else { 0.0 };
            hook_decision(&hook_at(Vector3::new(x, y, z), yaw), &tol)
        };
        assert_eq!(cap(0.0, 0.0, 0.0), HookDecision::Captured);
        assert_eq!(cap(0.0, 0.0149, 0.0), HookDecision::Captured);
        assert_eq!(cap(0.0, -0.0151, 0.0), HookDecision::Missed);
        assert_eq!(cap(0.0099, 0.0, 0.0), HookDecision::Captured);
        assert_eq!(cap(-0.0101, 0.0, 0.0), HookDecision::Missed);
        assert_eq!(cap(0.0, 0.0, 4.9), HookDecision::Captured);
        assert_eq!(cap(0.0, 0.0, -5.1), HookDecision::Missed);
        assert_eq!(
            cap(0.0, 0.0, 179.0),
            HookDecision::Captured,
            "a wire has no direction"
        );
        assert_eq!(cap(0.0, 0.0, 60.0), HookDecision::Knocked);
        let o = hook_at(Vector3::new(0.004, 0.2, -0.007), 0.0);
        assert!((o.along_approach_m - 0.004).abs() < 1e-12 && (o.across_m + 0.007).abs() < 1e-12);
        let o = hook_at(Vector3::new(0.0, 0.0, 0.0), 2.0);
        assert!((o.yaw_rad.to_degrees().abs() - 2.0).abs() < 1e-9);
    }

    #[test]
    fn grasp_lift_hook_clamp_release() {
        let stored = Isometry3::translation(10.0, -2.0, 0.12);
        let mut rod = Rod::on_rack(stored);
        let wire_far = (Point3::new(0.0, 50.0, 6.0), Vector3::x());
        let mut inp = RodInputs {
            world_from_tool0: rod.world_from_grasp() * Isometry3::translation(0.0, 0.0, -0.1),
            wire_near_hook: wire_far,
            wire_motion: Isometry3::identity(),
            clamp_pressing: false,
            clamp_travel_m: 0.0,
        };
        let t = RobotTime::ZERO;
        rod.update(t, &inp);
        assert!(!rod.held, "tool 10 cm away does not grasp");
        inp.world_from_tool0 = rod.world_from_grasp() * Isometry3::translation(0.002, 0.0, 0.0);
        rod.update(t, &inp);
        assert!(rod.held && rod.state == RodState::OnRack);
        // Lift 0.5 m straight up: out of the rack.
        inp.world_from_tool0 = Isometry3::translation(0.0, 0.0, 0.5) * inp.world_from_tool0;
        rod.update(t, &inp);
        assert_eq!(rod.state, RodState::InGripper);
        // Bring the hook onto a wire 8 mm off across: captured.
        let hook = rod.world_from_hook();
        let wire_point = hook * Point3::new(0.0, 0.0, 0.008);
        inp.wire_near_hook = (wire_point, hook.rotation * Vector3::y());
        rod.update(t, &inp);
        assert_eq!(rod.state, RodState::Hooked);
        inp.clamp_pressing = true;
        inp.clamp_travel_m = crate::clamp::WIRE_CONTACT_TRAVEL_M;
        rod.update(t, &inp);
        assert_eq!(rod.state, RodState::Clamped);
        // Retreat 5 cm: released, the rod stays clamped.
        inp.world_from_tool0 *= Isometry3::translation(0.0, 0.0, -0.05);
        rod.update(t, &inp);
        assert!(!rod.held && rod.state == RodState::Clamped);
        assert_eq!(rod.state.as_str(), "clamped");
    }
}
