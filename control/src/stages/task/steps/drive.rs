//! `drive`: the base to the site's working spot (`/base/goal` in `map`), unless it is there
//! already; done when the odometry is at the spot and still.
//!
//! The spot is a survey's, known to a few cm and a degree: a correction shorter than
//! [`SPOT_TOLERANCE_M`] is not driven, since a differential base turns in place to drive
//! even 2 cm sideways and would sweep its corners through the rack beside it; at the spot, a
//! heading correction smaller than [`HEADING_TOLERANCE_RAD`] is not turned either (the
//! operations work from the odometry's pose and the robot's own measurements, not from the
//! survey's heading, and a turn in place sweeps the chassis' corners by 0.7 m x the angle
//! towards the rack). Every drive is checked before it is sent: the chassis along
//! the base's turn-drive-turn path against the site map's obstacles. When the direct path
//! comes closer than [`DRIVE_CLEARANCE_M`] (typically its last turn, in place beside the
//! rack), the base goes by a staging pose on the spot's heading behind it
//! ([`STAGING_DISTANCES_M`]) and drives straight onto the spot from there, as a driver
//! would; when no such path is clear, a correction shorter than [`STAY_DISTANCE_M`] is not
//! made (the survey's spot is no better known than where the robot stands: on seeded sites
//! the survey even put the robot's own start pose inside the rack's pedestal), and a longer
//! one is refused (`drive_blocked`).

use msgs::RobotDuration;
use msgs::frames::MAP;
use msgs::geometry_msgs::PoseStamped;
use msgs::topics::BASE_GOAL;
use nalgebra::Point3;

use crate::motion::collision::{
    CHASSIS_CENTRE_Z_M, CHASSIS_HALF_EXTENTS_M, Capsule, capsule_box, capsule_capsule,
};
use crate::stages::task::Task;
use crate::stages::task::action::{Action, BASE_ARRIVED_M, BASE_ARRIVED_RAD, Until};
use crate::stages::task::flow::{StepDef, Stop, next_in_flow};
use crate::stages::task::inputs::base_pose_of;
use crate::stages::task::outputs::pose_msg;
use crate::tasks::site::{BasePose, CONDUCTOR_SWAY_MARGIN_M, SiteMap};

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

/// A drive to the spot shorter than this is not made (m): three times a survey's 2 cm.
pub const SPOT_TOLERANCE_M: f64 = 0.06;
/// A correction shorter than this (m, five times the survey's 2 cm) that cannot be driven
/// clear of the site's obstacles is not driven: the robot works from where it stands.
pub const STAY_DISTANCE_M: f64 = 0.1;
/// At the spot, a heading correction smaller than this is not turned (rad): three times a
/// survey's 1 deg.
pub const HEADING_TOLERANCE_RAD: f64 = 3.0 * std::f64::consts::PI / 180.0;
/// The least clearance of the chassis to the site map's obstacles along a drive (m): the
/// survey's error on the obstacles' positions.
pub const DRIVE_CLEARANCE_M: f64 = 0.03;
/// Distances of the staging poses tried behind the spot, on its heading (m).
pub const STAGING_DISTANCES_M: [f64; 3] = [1.0, 1.5, 2.5];
/// Path sampling of the drive check (m along the drive, rad of a turn).
const DRIVE_CHECK_STEP: (f64, f64) = (0.05, 0.02);

fn plan(task: &mut Task) -> Result<Vec<Action>, Stop> {
    let site = &task.config.site;
    let map_from_base = task.robot.base_from_map()?.inverse();
    let here = base_pose_of(&map_from_base);
    let mut spot = site.work_spot;
    let mut distance = (spot.x_m - here.x_m).hypot(spot.y_m - here.y_m);
    if distance < SPOT_TOLERANCE_M {
        (spot.x_m, spot.y_m, distance) = (here.x_m, here.y_m, 0.0);
        if robot::se3::wrap_to_pi(spot.yaw_rad - here.yaw_rad).abs() < HEADING_TOLERANCE_RAD {
            spot.yaw_rad = here.yaw_rad;
        }
    }
    if distance < BASE_ARRIVED_M
        && robot::se3::wrap_to_pi(spot.yaw_rad - here.yaw_rad).abs() < BASE_ARRIVED_RAD
    {
        return Ok(Vec::new());
    }
    let (clearance_m, obstacle, at) = drive_clearance(site, &here, &spot);
    let legs = if clearance_m >= DRIVE_CLEARANCE_M {
        vec![(spot, distance)]
    } else {
        // By a staging pose behind the spot: the last leg is a straight drive, no turn.
        let staged = STAGING_DISTANCES_M.iter().find_map(|&d| {
            let stage = staging_pose(&spot, d);
            let first = drive_clearance(site, &here, &stage).0;
            let last = drive_clearance(site, &stage, &spot).0;
            (first.min(last) >= DRIVE_CLEARANCE_M).then(|| {
                let to_stage = (stage.x_m - here.x_m).hypot(stage.y_m - here.y_m);
                vec![(stage, to_stage), (spot, d)]
            })
        });
        if staged.is_none() && distance < STAY_DISTANCE_M {
            // The survey puts the robot where it cannot be (its own pose touching the
            // obstacle) or the correction is within the survey's reach of error: it works
            // from where it stands.
            let now = task.robot.now;
            task.out.event(
                now,
                msgs::rodlog_msgs::TaskEvent::INFO,
                NAME,
                "",
                format!(
                    "staying {:.0} mm from the survey's spot: driving there would bring the chassis within {:.0} mm of {obstacle} (at least {:.0} mm needed), and the spot is known only to 20 mm per axis",
                    distance * 1e3,
                    clearance_m * 1e3,
                    DRIVE_CLEARANCE_M * 1e3
                ),
            );
            return Ok(Vec::new());
        }
        staged.ok_or_else(|| {
            Stop::refused(
                "drive_blocked",
                format!(
                    "the drive to the working spot would bring the chassis within {:.0} mm of {obstacle} at ({:.2}, {:.2}) m (at least {:.0} mm needed), and so would a straight approach from {:.1}-{:.1} m behind the spot: park the robot nearer the spot, or check the site file's spot and obstacles",
                    clearance_m * 1e3,
                    at.x_m,
                    at.y_m,
                    DRIVE_CLEARANCE_M * 1e3,
                    STAGING_DISTANCES_M[0],
                    STAGING_DISTANCES_M[STAGING_DISTANCES_M.len() - 1],
                ),
            )
        })?
    };
    Ok(legs
        .into_iter()
        .map(|(goal_pose, leg_m)| base_action(task, goal_pose, leg_m, "base to the working spot"))
        .collect())
}

/// The base to `goal` in `map`, `leg_m` away: done when the odometry is there and still.
pub(crate) fn base_action(task: &Task, goal: BasePose, leg_m: f64, label: &'static str) -> Action {
    let message = PoseStamped {
        header: task.out.header(task.robot.now, MAP),
        pose: pose_msg(&goal.isometry()),
    };
    let seconds = leg_m / DRIVE_SPEED_M_S + std::f64::consts::TAU / TURN_RATE_RAD_S;
    Action {
        outputs: vec![(BASE_GOAL.to_owned(), message.into())],
        command: true,
        until: Until::Base(goal),
        timeout: RobotDuration::from_secs_f64(seconds * 1.5 + 10.0)
            .unwrap_or(RobotDuration::from_secs(120)),
        label,
    }
}

/// The pose `d` (m) behind `spot` on its heading, facing the same way.
fn staging_pose(spot: &BasePose, d: f64) -> BasePose {
    BasePose {
        x_m: spot.x_m - d * spot.yaw_rad.cos(),
        y_m: spot.y_m - d * spot.yaw_rad.sin(),
        yaw_rad: spot.yaw_rad,
    }
}

/// The poses of the base's motion from `from` to `to` (`sim`'s base and a differential
/// drive: turn in place towards the goal, drive straight, turn to the goal's heading),
/// sampled every [`DRIVE_CHECK_STEP`].
fn drive_path(from: &BasePose, to: &BasePose) -> Vec<BasePose> {
    let (dx, dy) = (to.x_m - from.x_m, to.y_m - from.y_m);
    let distance = dx.hypot(dy);
    let mut path = vec![*from];
    let turn = |path: &mut Vec<BasePose>, at: BasePose, to_yaw: f64| {
        let delta = robot::se3::wrap_to_pi(to_yaw - at.yaw_rad);
        let n = (delta.abs() / DRIVE_CHECK_STEP.1).ceil().max(1.0) as usize;
        path.extend((1..=n).map(|k| BasePose {
            yaw_rad: at.yaw_rad + delta * k as f64 / n as f64,
            ..at
        }));
    };
    let mut at = *from;
    if distance > 0.005 {
        let heading = dy.atan2(dx);
        turn(&mut path, at, heading);
        let n = (distance / DRIVE_CHECK_STEP.0).ceil().max(1.0) as usize;
        path.extend((1..=n).map(|k| BasePose {
            x_m: from.x_m + dx * k as f64 / n as f64,
            y_m: from.y_m + dy * k as f64 / n as f64,
            yaw_rad: heading,
        }));
        at = BasePose {
            yaw_rad: heading,
            ..*to
        };
    }
    turn(&mut path, at, to.yaw_rad);
    path
}

/// The least clearance of the chassis (spheres filling its box) to the site map's obstacles
/// and stored rod along [`drive_path`], the obstacle's name and the base pose there.
pub(crate) fn drive_clearance(
    site: &SiteMap,
    from: &BasePose,
    to: &BasePose,
) -> (f64, String, BasePose) {
    let [hx, hy, r] = CHASSIS_HALF_EXTENTS_M;
    let mut best = (f64::INFINITY, String::new(), *from);
    let spheres: Vec<Point3<f64>> = {
        let (nx, ny) = (
            ((hx - r) / 0.1).ceil() as i32,
            ((hy - r) / 0.1).ceil() as i32,
        );
        (-nx..=nx)
            .flat_map(|i| {
                (-ny..=ny).map(move |j| {
                    Point3::new(
                        (f64::from(i) * 0.1).clamp(-(hx - r), hx - r),
                        (f64::from(j) * 0.1).clamp(-(hy - r), hy - r),
                        CHASSIS_CENTRE_Z_M,
                    )
                })
            })
            .collect()
    };
    let rods = site.stored_rod_capsules();
    for pose in drive_path(from, to) {
        // The site (and the stored rod) in this pose's base frame, once per pose.
        let base_from_map = pose.isometry().inverse();
        let mut world = site.collision_world(&base_from_map, None, CONDUCTOR_SWAY_MARGIN_M);
        world.capsules.extend(rods.iter().map(|(n, c)| {
            (
                n.clone(),
                Capsule {
                    a: base_from_map * c.a,
                    b: base_from_map * c.b,
                    radius_m: c.radius_m,
                },
            )
        }));
        for p in &spheres {
            let s = Capsule {
                a: *p,
                b: *p,
                radius_m: r,
            };
            let boxes = world
                .boxes
                .iter()
                .filter(|(n, _)| n != "ground")
                .map(|(n, b)| (n, capsule_box(&s, b)));
            let capsules = world
                .capsules
                .iter()
                .map(|(n, c)| (n, capsule_capsule(&s, c)));
            for (name, c) in boxes.chain(capsules) {
                if c < best.0 {
                    best = (c, name.clone(), pose);
                }
            }
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fixed bay: a 2 cm correction is not driven; a 1.5 m drive along the spot's own
    /// heading is clear; a turn in place beside the rack, as a 2 cm sideways correction
    /// would need, would hit it.
    #[test]
    fn drives_are_checked_against_the_site_and_small_corrections_are_not_driven() {
        let site = SiteMap::default_bay();
        let spot = site.work_spot;
        let behind = BasePose {
            y_m: spot.y_m - 1.5,
            ..spot
        };
        let (clear_m, _, _) = drive_clearance(&site, &behind, &spot);
        assert!(clear_m > DRIVE_CLEARANCE_M, "{clear_m}");
        let sideways = BasePose {
            x_m: spot.x_m + 0.02,
            ..spot
        };
        let (clear_m, what, _) = drive_clearance(&site, &spot, &sideways);
        assert!(clear_m < 0.0, "{clear_m} {what}");
        assert!(what.contains("rack"), "{what}");
        let path = drive_path(&spot, &sideways);
        assert!(path.len() > 100, "two quarter turns sampled");
    }

    /// Arriving at the spot from the side ends with a turn in place beside the rack; the
    /// straight last leg from a staging pose behind the spot is clear.
    #[test]
    fn a_blocked_last_turn_is_replaced_by_a_straight_approach_from_behind() {
        let site = SiteMap::default_bay();
        let spot = site.work_spot;
        let side = BasePose {
            x_m: spot.x_m + 2.0 * spot.yaw_rad.sin(),
            y_m: spot.y_m - 2.0 * spot.yaw_rad.cos(),
            yaw_rad: spot.yaw_rad,
        };
        let (direct, what, _) = drive_clearance(&site, &side, &spot);
        assert!(direct < DRIVE_CLEARANCE_M, "{direct} {what}");
        let stage = staging_pose(&spot, STAGING_DISTANCES_M[0]);
        let (last, what, _) = drive_clearance(&site, &stage, &spot);
        assert!(last >= DRIVE_CLEARANCE_M, "{last} {what}");
    }
}
