//! The site as the robot knows it: the surveyed fixed bodies (rod rack, cabinet, ...) and the
//! grounding rod, whose pose the sink follows from what the robot perceived and did
//! ([`RodBelief`]).
//!
//! viz depends on neither the robot nor the control crate: the caller (`rodlog view`, `record
//! --viz`) describes the site as plain [`Body`]s ([`Site`]) from the site map and the rod's
//! dimensions.
//!
//! # The rod, as the robot believes it to be
//! | when | the rod is drawn |
//! |---|---|
//! | start | on the rack ([`Site::map_from_stored_rod`], the survey), when known |
//! | a handle perception (`/perception/target_pose` that is a grasp) | where it was seen (`map`) |
//! | task state [`HELD_FROM_STATES`] entered | in the gripper: `tool0` * [`Site::tool0_from_rod`] |
//! | task state [`LEFT_AT_STATES`] entered while held | where the gripper left it (`map`) |
//!
//! The task states are the control crate's step names (`rodlog_msgs/TaskEvent.state`).

use crate::convert::Pose;
use crate::urdf::Shape;

/// A rigid body drawn with primitive shapes.
#[derive(Debug, Clone, PartialEq)]
pub struct Body {
    /// Entity name (a path part).
    pub name: String,
    /// `frame_from_shape` (the frame: `map` for fixed bodies, the rod frame for rod parts).
    pub pose: Pose,
    /// Geometry.
    pub shape: Shape,
    /// sRGBA.
    pub rgba: [u8; 4],
}

/// What the robot knows of its site (module docs).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Site {
    /// Surveyed fixed bodies, in `map`.
    pub fixed: Vec<Body>,
    /// The rod's parts, in the rod frame.
    pub rod_parts: Vec<Body>,
    /// `map_from_rod` of the rod stored on the rack.
    pub map_from_stored_rod: Option<Pose>,
    /// `tool0_from_rod` of the held rod (the grasp).
    pub tool0_from_rod: Pose,
    /// `rod_from_handle`: where `/sim/handle_pose` (the handle centre) sits in the rod frame.
    pub rod_from_handle: Pose,
    /// Conductor radius (m).
    pub wire_radius_m: f32,
}

/// Task states from which the rod is in the gripper (hang: lifted out of the rack; remove:
/// grasped on the wire, then opened).
pub const HELD_FROM_STATES: [&str; 2] = ["lift_out", "open_clamp"];
/// Task states at which a held rod is left where it is (hang: released on the wire; remove:
/// back on the rack, retreating).
pub const LEFT_AT_STATES: [&str; 2] = ["release", "retreat"];

/// Where the rod is believed to be: `parent_from_rod` under a named frame.
#[derive(Debug, Clone, PartialEq)]
pub struct RodBelief {
    /// Parent frame (`map` or `tool0`).
    pub parent: String,
    /// `parent_from_rod`.
    pub pose: Pose,
}

impl RodBelief {
    /// Whether the rod is in the gripper.
    pub fn held(&self) -> bool {
        self.parent == msgs::frames::TOOL0
    }

    /// The belief after entering task state `state`: in the gripper from a
    /// [`HELD_FROM_STATES`] state, left in `map` at `map_from_tool0 * tool0_from_rod` from a
    /// [`LEFT_AT_STATES`] state (when held and the tool's pose is known); else unchanged
    /// (`None`).
    pub fn after_state(
        current: Option<&RodBelief>,
        state: &str,
        site: &Site,
        map_from_tool0: Option<&Pose>,
    ) -> Option<RodBelief> {
        let held = current.is_some_and(RodBelief::held);
        if HELD_FROM_STATES.contains(&state) && !held {
            return Some(RodBelief {
                parent: msgs::frames::TOOL0.to_owned(),
                pose: site.tool0_from_rod,
            });
        }
        if LEFT_AT_STATES.contains(&state) && held {
            let tool = map_from_tool0?;
            return Some(RodBelief {
                parent: msgs::frames::MAP.to_owned(),
                pose: tool.compose(&site.tool0_from_rod),
            });
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shift(x: f64) -> Pose {
        Pose {
            t: [x, 0.0, 0.0],
            q: [0.0, 0.0, 0.0, 1.0],
        }
    }

    #[test]
    fn the_rod_is_taken_then_left_where_the_gripper_was() {
        let site = Site {
            tool0_from_rod: shift(0.06),
            ..Site::default()
        };
        let on_rack = RodBelief {
            parent: "map".into(),
            pose: shift(5.0),
        };
        // Unrelated states change nothing; leaving needs a held rod.
        assert_eq!(
            RodBelief::after_state(Some(&on_rack), "look_rack", &site, None),
            None
        );
        assert_eq!(
            RodBelief::after_state(Some(&on_rack), "release", &site, Some(&shift(1.0))),
            None
        );
        let held = RodBelief::after_state(Some(&on_rack), "lift_out", &site, None);
        assert!(held.as_ref().is_some_and(RodBelief::held), "{held:?}");
        let left = RodBelief::after_state(held.as_ref(), "release", &site, Some(&shift(1.0)));
        assert_eq!(
            left,
            Some(RodBelief {
                parent: "map".into(),
                pose: shift(1.06)
            })
        );
    }
}
