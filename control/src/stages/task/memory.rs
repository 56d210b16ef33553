//! What the task has measured and decided so far: where the rod is, the wrist captures of
//! the step under way, the perception results and the goals derived from them, the
//! calibration stage's answer, the counts of attempts, and the recovery in progress.

use msgs::rodlog_msgs::TaskEvent;
use msgs::sensor_msgs::Image;
use nalgebra::{Isometry3, Point3, Vector3};

use super::action::Action;
use super::config::TaskKind;
use super::flow::AfterRecovery;
use crate::stages::wire_flow::WristCapture;
use crate::tasks::site::CONDUCTOR_SWAY_MARGIN_M;

/// What the robot believes about the rod.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Rod {
    /// In the rack.
    OnRack,
    /// In the gripper.
    Held,
    /// On the wire at this `base_from_rod` (estimated).
    OnWire(Isometry3<f64>),
    /// Not known yet (remove: before the handle is measured).
    Unknown,
}

/// Where a handle is looked for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum HandleSite {
    /// The stored rod in the rack (hang).
    Rack,
    /// The rod hung on the wire (remove).
    Wire,
}

/// What the task knows (module docs).
#[derive(Debug)]
pub(crate) struct Memory {
    /// Where the rod is.
    pub rod: Rod,
    /// Failed perception-and-act cycles this operation.
    pub attempts: usize,
    /// Holds for a swaying handle so far this operation.
    pub sway_holds: usize,
    /// Holds for a wire swinging too wide so far this operation.
    pub wire_sway_holds: usize,
    /// The wrist captures of the capture step under way.
    pub captures: Vec<WristCapture>,
    /// The panoramic frame the panoramic step waited for.
    pub panoramic_image: Option<Image>,
    /// The calibration stage's answer to the views.
    pub calibration_answer: Option<TaskEvent>,
    /// Why the drift check could not tell, while the recalibration that answers it runs.
    pub unverified_check: Option<String>,
    /// The drift check has had its four more views.
    pub check_extended: bool,
    /// The wire captures have had their sway captures (`capture_wire_more`).
    pub wire_extended: bool,
    /// Clearance the collision world adds to each conductor's radius for its sway (m):
    /// [`CONDUCTOR_SWAY_MARGIN_M`] until the captures measured the sway's band.
    pub conductor_sway_margin_m: f64,
    /// The measured wire (point on the hanging point's axis, direction; `base_link`).
    pub wire_in_base: Option<(Point3<f64>, Vector3<f64>)>,
    /// `base_from_hook` at the hang.
    pub hook_goal: Option<Isometry3<f64>>,
    /// `base_from_tool0` of the grasp of the measured handle.
    pub grasp_goal: Option<Isometry3<f64>>,
    /// `map_from_rod` of the stored rod as the wrist camera saw it.
    pub stored_rod_seen: Option<Isometry3<f64>>,
    /// `map_from_rack` as `capture_empty_rack` measured it: the remove's collision world
    /// puts the rack's parts there.
    pub rack_seen: Option<Isometry3<f64>>,
    /// The lift height of the look at the wire.
    pub look_lift_m: Option<f64>,
    /// A view cut the stored rod's handle at both ends: the looks at it stand
    /// [`HANDLE_LOOK_FARTHER`](super::planning::HANDLE_LOOK_FARTHER) times farther back.
    pub look_farther: bool,
    /// The base has moved towards a wire beyond the arm's reach
    /// ([`reposition`](super::steps::reposition)); once per task.
    pub repositioned: bool,
    /// The recovery's actions and where it leads.
    pub recovery: Option<(Vec<Action>, AfterRecovery)>,
    /// The `reason_code` of the final `done` event.
    pub done_reason: &'static str,
    /// What the final `done` event adds to its text (the check's verdict).
    pub done_text: String,
}

impl Memory {
    /// Nothing measured: the rod in the rack for a hang (and the demo), unknown otherwise.
    pub fn new(kind: TaskKind) -> Self {
        Self {
            rod: match kind {
                TaskKind::Hang | TaskKind::Demo => Rod::OnRack,
                TaskKind::Remove | TaskKind::Check | TaskKind::SelfCalibrate => Rod::Unknown,
            },
            attempts: 0,
            sway_holds: 0,
            wire_sway_holds: 0,
            captures: Vec::new(),
            panoramic_image: None,
            calibration_answer: None,
            unverified_check: None,
            check_extended: false,
            wire_extended: false,
            conductor_sway_margin_m: CONDUCTOR_SWAY_MARGIN_M,
            wire_in_base: None,
            hook_goal: None,
            grasp_goal: None,
            stored_rod_seen: None,
            rack_seen: None,
            look_lift_m: None,
            look_farther: false,
            repositioned: false,
            recovery: None,
            done_reason: "done",
            done_text: String::new(),
        }
    }
}
