//! `drive`: the base to the site's working spot (`/base/goal` in `map`), unless it is there
//! already; done when the odometry is at the spot and still.

use msgs::RobotDuration;
use msgs::frames::MAP;
use msgs::geometry_msgs::PoseStamped;
use msgs::topics::BASE_GOAL;

use crate::stages::task::Task;
use crate::stages::task::action::{Action, BASE_ARRIVED_M, BASE_ARRIVED_RAD, Until};
use crate::stages::task::flow::{StepDef, Stop, next_in_flow};
use crate::stages::task::inputs::base_pose_of;
use crate::stages::task::outputs::pose_msg;

/// The step's event name.
pub(crate) const NAME: &str = "drive";
/// The step.
pub(crate) const STEP: StepDef = StepDef {
    name: NAME,
    plan,
    finish: next_in_flow,
};

/// Speed assumed for the timeout (m/s) ...
const DRIVE_SPEED_M_S: f64 = 0.5;
/// ... and turn rate (rad/s, a full turn is allowed for).
const TURN_RATE_RAD_S: f64 = 0.6;

fn plan(task: &mut Task) -> Result<Vec<Action>, Stop> {
    let spot = task.config.site.work_spot;
    let map_from_base = task.robot.base_from_map()?.inverse();
    let here = base_pose_of(&map_from_base);
    let distance = (spot.x_m - here.x_m).hypot(spot.y_m - here.y_m);
    if distance < BASE_ARRIVED_M
        && robot::se3::wrap_to_pi(spot.yaw_rad - here.yaw_rad).abs() < BASE_ARRIVED_RAD
    {
        return Ok(Vec::new());
    }
    let goal = PoseStamped {
        header: task.out.header(task.robot.now, MAP),
        pose: pose_msg(&spot.isometry()),
    };
    let seconds = distance / DRIVE_SPEED_M_S + std::f64::consts::TAU / TURN_RATE_RAD_S;
    Ok(vec![Action {
        outputs: vec![(BASE_GOAL.to_owned(), goal.into())],
        command: true,
        until: Until::Base(spot),
        timeout: RobotDuration::from_secs_f64(seconds * 1.5 + 10.0)
            .unwrap_or(RobotDuration::from_secs(120)),
        label: "base to the working spot",
    }])
}
