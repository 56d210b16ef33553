//! One test per refusal and failure: what the stage says and that it commands nothing
//! unsafe after it.

use msgs::RobotDuration;
use msgs::rodlog_msgs::TaskEvent;
use msgs::topics::{ARM_JOINT_TRAJECTORY, BASE_GOAL, CAMERA_TRIGGER, CLAMP_COMMAND, LIFT_COMMAND};
use nalgebra::{Isometry3, Point3, UnitQuaternion, Vector3};

use super::rig::Rig;
use super::{LIMIT_S, assert_done, assert_ended, steps_after, with_reason};
use crate::motion::collision::OrientedBox;
use crate::stages::task::TaskKind;

/// Commands (motions, clamp, triggers) issued after `at` (s).
fn commands_after(rig: &Rig, at_s: f64) -> usize {
    rig.outputs
        .iter()
        .filter(|o| o.at.as_secs_f64() > at_s)
        .filter(|o| {
            [
                ARM_JOINT_TRAJECTORY,
                LIFT_COMMAND,
                BASE_GOAL,
                CLAMP_COMMAND,
                CAMERA_TRIGGER,
            ]
            .contains(&o.topic.as_str())
        })
        .count()
}

fn ended_at_s(rig: &Rig) -> f64 {
    rig.outputs.last().map_or(0.0, |o| o.at.as_secs_f64())
}

#[test]
fn a_windy_start_holds_without_a_command_then_refuses() {
    let mut rig = Rig::with(TaskKind::Hang, |c, b| {
        c.self_maintenance = false;
        b.wind = |_| Some(4.5);
    });
    rig.run(LIMIT_S);
    let last = assert_ended(&rig, TaskEvent::REFUSED, "wind_above_limit");
    assert_eq!(last.state, "begin");
    assert!(last.text.starts_with("held 6"), "{last:?}");
    assert_eq!(with_reason(&rig, "holding_for_wind").len(), 1);
    assert_eq!(commands_after(&rig, 0.0), 0);
}

#[test]
fn a_gust_during_the_task_holds_the_commands_and_the_task_goes_on() {
    let mut rig = Rig::with(TaskKind::Hang, |c, b| {
        c.self_maintenance = false;
        // Calm until 3 s, a gust for 10 s, calm again.
        b.wind = |t| Some(if (3.0..13.0).contains(&t) { 4.5 } else { 0.5 });
    });
    rig.run(LIMIT_S);
    assert_done(&rig);
    let holds = with_reason(&rig, "holding_for_wind");
    assert_eq!(holds.len(), 1, "{holds:#?}");
    // Nothing was commanded while the gate was closed (the gust, plus the gate's
    // extrapolation of the rise and its reading period).
    let during = rig
        .outputs
        .iter()
        .filter(|o| (4.0..13.0).contains(&o.at.as_secs_f64()))
        .filter(|o| [ARM_JOINT_TRAJECTORY, LIFT_COMMAND, BASE_GOAL].contains(&o.topic.as_str()))
        .count();
    assert_eq!(during, 0);
}

#[test]
fn a_wire_swinging_wider_than_a_hang_allows_is_held_for_then_refused() {
    let mut rig = Rig::with(TaskKind::Hang, |c, b| {
        c.self_maintenance = false;
        b.wire_sway_m = 0.06;
    });
    rig.run(LIMIT_S);
    let last = assert_ended(&rig, TaskEvent::REFUSED, "wire_sway");
    assert!(last.text.contains("wait for calmer air"), "{last:?}");
    assert_eq!(
        with_reason(&rig, "holding_for_sway").len(),
        crate::stages::task::judging::MAX_WIRE_SWAY_HOLDS
    );
    // The hook never went towards the wire.
    let refused_at = ended_at_s(&rig);
    assert!(refused_at < 120.0, "refused at {refused_at} s");
    let steps = rig.steps();
    assert!(
        !steps
            .iter()
            .any(|s| s == "to_pre_approach" || s == "approach"),
        "{steps:?}"
    );
}

#[test]
fn a_clamped_rod_pulled_from_the_gripper_is_released_not_backed_off_with() {
    let mut rig = Rig::with(TaskKind::Hang, |c, b| {
        c.self_maintenance = false;
        b.rod_pulled = true;
    });
    rig.run(LIMIT_S);
    assert_done(&rig);
    let pulled = with_reason(&rig, "rod_pulled");
    assert_eq!(pulled.len(), 1, "{pulled:#?}");
    assert!(
        pulled[0].text.contains("pressed on the wire at 45.0 mm"),
        "{pulled:?}"
    );
    // No back-off and second look: one close, then the release.
    assert!(with_reason(&rig, "retry").is_empty());
    assert_eq!(
        steps_after(&rig, "close_clamp", 1),
        ["release"],
        "{:?}",
        rig.steps()
    );
}

#[test]
fn no_wind_reading_refuses_before_operating() {
    let mut rig = Rig::with(TaskKind::Hang, |c, b| {
        c.self_maintenance = false;
        b.wind = |_| None;
    });
    rig.run(LIMIT_S);
    let last = assert_ended(&rig, TaskEvent::REFUSED, "no_wind_reading");
    assert_eq!(last.state, "begin");
    assert_eq!(commands_after(&rig, 0.0), 0);
}

#[test]
fn gusts_that_keep_the_operation_past_its_time_refuse_for_the_wind() {
    let mut rig = Rig::with(TaskKind::Hang, |c, b| {
        c.self_maintenance = false;
        c.operation_timeout = RobotDuration::from_secs(20);
        c.wind.hold_timeout = RobotDuration::from_secs(60);
        b.wind = |t| Some(if t >= 3.0 { 4.5 } else { 0.5 });
    });
    rig.run(LIMIT_S);
    let last = assert_ended(&rig, TaskEvent::REFUSED, "wind_above_limit");
    assert!(
        last.text.contains("could not finish within 20 s"),
        "{last:?}"
    );
}

#[test]
fn gusts_that_keep_stopping_the_work_refuse_within_the_hold_budget() {
    let mut rig = Rig::with(TaskKind::Hang, |c, b| {
        c.self_maintenance = false;
        c.wind.hold_budget = RobotDuration::from_secs(10);
        // Gusts of 8 s every 9 s from the start: no single hold reaches the 60 s timeout,
        // and the calm seconds between them are too few to finish the hang.
        b.wind = |t| {
            Some(if t >= 1.2 && (t - 1.2) % 9.0 < 8.0 {
                4.5
            } else {
                0.5
            })
        };
    });
    rig.run(LIMIT_S);
    let last = assert_ended(&rig, TaskEvent::REFUSED, "wind_above_limit");
    assert!(last.text.contains("in all this operation"), "{last:?}");
    let ended = ended_at_s(&rig);
    // 10 s of holds: the second gust ends it, long before the 300 s operation limit.
    assert!((10.0..20.0).contains(&ended), "ended at {ended} s");
    assert_eq!(with_reason(&rig, "holding_for_wind").len(), 2);
}

#[test]
fn an_operation_past_its_time_fails_with_a_timeout() {
    let mut rig = Rig::with(TaskKind::Hang, |c, _| {
        c.self_maintenance = false;
        c.operation_timeout = RobotDuration::from_secs(2);
    });
    rig.run(LIMIT_S);
    let last = assert_ended(&rig, TaskEvent::FAILED, "timeout");
    assert!(last.text.contains("took longer than 2 s"), "{last:?}");
}

#[test]
fn an_action_that_does_not_complete_fails_with_a_timeout() {
    let mut rig = Rig::with(TaskKind::Hang, |c, b| {
        c.self_maintenance = false;
        b.base_moves = false;
    });
    rig.run(LIMIT_S);
    let last = assert_ended(&rig, TaskEvent::FAILED, "timeout");
    assert_eq!(last.state, "drive");
    assert!(
        last.text
            .starts_with("base to the working spot did not complete within"),
        "{last:?}"
    );
}

#[test]
fn a_check_that_cannot_tell_and_a_rejected_recalibration_refuse_as_unverifiable() {
    let mut rig = Rig::with(TaskKind::Hang, |_, b| {
        b.calibration = ["cannot_tell", "rejected"].into();
    });
    rig.run(LIMIT_S);
    let last = assert_ended(&rig, TaskEvent::REFUSED, "calibration_unverifiable");
    assert_eq!(last.state, "recalibrate");
    assert!(last.text.contains("could not be checked"), "{last:?}");
    assert_eq!(rig.steps().last().map(String::as_str), Some("recalibrate"));
}

#[test]
fn a_drift_with_a_rejected_recalibration_refuses_as_failed_calibration() {
    let mut rig = Rig::with(TaskKind::Hang, |_, b| {
        b.calibration = ["drifted", "rejected"].into();
    });
    rig.run(LIMIT_S);
    let last = assert_ended(&rig, TaskEvent::REFUSED, "calibration_failed");
    assert!(last.text.contains("recalibrate with a board"), "{last:?}");
}

#[test]
fn a_silent_calibration_stage_times_out() {
    let mut rig = Rig::with(TaskKind::Hang, |_, b| b.calibration = [].into());
    rig.run(LIMIT_S);
    let last = assert_ended(&rig, TaskEvent::FAILED, "timeout");
    assert_eq!(last.state, "check_calibration");
    assert!(
        last.text.starts_with("calibration answer did not complete"),
        "{last:?}"
    );
}

#[test]
fn no_wire_in_the_panoramic_frames_refuses_no_wire() {
    let mut rig = Rig::with(TaskKind::Hang, |c, b| {
        c.self_maintenance = false;
        b.panoramic_wire = false;
    });
    rig.run(LIMIT_S);
    let last = assert_ended(&rig, TaskEvent::REFUSED, "no_wire");
    assert_eq!(last.state, "panoramic");
    assert!(last.text.contains("in 5 frames"), "{last:?}");
    // One announcement per frame tried.
    let tries = rig.steps().iter().filter(|s| *s == "panoramic").count();
    assert_eq!(tries, 5);
}

#[test]
fn captures_without_the_wire_look_again_then_refuse_low_confidence() {
    let mut rig = Rig::with(TaskKind::Hang, |c, b| {
        c.self_maintenance = false;
        b.wrist_wire = false;
    });
    rig.run(LIMIT_S);
    let last = assert_ended(&rig, TaskEvent::REFUSED, "low_confidence");
    assert_eq!(last.state, "capture_wire");
    let retries = with_reason(&rig, "retry");
    assert_eq!(retries.len(), 1, "{retries:#?}");
    assert_eq!(retries[0].state, "look_wire");
    assert_eq!(rig.steps().iter().filter(|s| *s == "look_wire").count(), 2);
}

#[test]
fn a_noisy_wire_estimate_below_the_confidence_threshold_refuses() {
    let mut rig = Rig::with(TaskKind::Hang, |c, b| {
        c.self_maintenance = false;
        b.depth_noise_m = 0.002;
    });
    rig.run(LIMIT_S);
    let last = assert_ended(&rig, TaskEvent::REFUSED, "low_confidence");
    assert!(last.text.contains("confidence"), "{last:?}");
}

#[test]
fn a_missing_stored_rod_is_not_found_and_refused() {
    let mut rig = Rig::with(TaskKind::Hang, |c, b| {
        c.self_maintenance = false;
        b.stored_rod = None;
    });
    rig.run(LIMIT_S);
    let last = assert_ended(&rig, TaskEvent::REFUSED, "low_confidence");
    assert_eq!(last.state, "capture_rack");
    assert_eq!(with_reason(&rig, "retry").len(), 1);
    assert_eq!(commands_after(&rig, ended_at_s(&rig)), 0);
}

#[test]
fn a_tilted_stored_rod_is_refused() {
    let mut rig = Rig::with(TaskKind::Hang, |c, b| {
        c.self_maintenance = false;
        let tilt = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 10f64.to_radians());
        b.stored_rod = Some(
            c.site.map_from_stored_rod()
                * Isometry3::from_parts(nalgebra::Translation3::identity(), tilt),
        );
    });
    rig.run(LIMIT_S);
    let last = assert_ended(&rig, TaskEvent::REFUSED, "low_confidence");
    assert!(last.text.contains("off the vertical"), "{last:?}");
}

#[test]
fn a_swaying_hung_rod_is_waited_for() {
    let mut rig = Rig::with(TaskKind::Remove, |c, b| {
        c.self_maintenance = false;
        b.sway_m = 0.01;
    });
    rig.run_until(LIMIT_S, |r| r.steps().iter().any(|s| s == "recover"));
    let holds = with_reason(&rig, "holding_for_sway");
    assert_eq!(holds.len(), 1, "{:#?}", rig.events());
    assert_eq!(holds[0].state, "look_handle");
    // The hold sends nothing.
    rig.run_until(LIMIT_S, |r| {
        r.steps().iter().filter(|s| *s == "look_handle").count() == 2
    });
    assert_eq!(super::count(&rig, "recover", ARM_JOINT_TRAJECTORY), 0);
}

/// The last miss backs off the wire like the first, then refuses: the rod is not left
/// hooked and unclamped with the gripper on it.
#[test]
fn a_hook_that_keeps_missing_backs_off_and_refuses_hook_missed() {
    let mut rig = Rig::with(TaskKind::Hang, |c, b| {
        c.self_maintenance = false;
        b.hook_hits = vec![false];
    });
    rig.run(LIMIT_S);
    let last = assert_ended(&rig, TaskEvent::REFUSED, "hook_missed");
    assert!(last.text.contains("2 attempts"), "{last:?}");
    assert_eq!(last.state, "recover");
    assert_eq!(
        rig.steps().iter().filter(|s| *s == "close_clamp").count(),
        2
    );
    // One retry, and both misses backed off the wire; only the retry raised the lift to
    // look again.
    assert_eq!(with_reason(&rig, "retry").len(), 1);
    assert_eq!(rig.steps().iter().filter(|s| *s == "recover").count(), 2);
    assert_eq!(super::count(&rig, "recover", ARM_JOINT_TRAJECTORY), 2);
    assert_eq!(super::count(&rig, "recover", LIFT_COMMAND), 1);
}

#[test]
fn a_grasp_that_keeps_missing_fails_grasp_missed() {
    let mut rig = Rig::with(TaskKind::Hang, |c, b| {
        c.self_maintenance = false;
        b.grasp_couples = vec![false];
    });
    rig.run(LIMIT_S);
    let last = assert_ended(&rig, TaskEvent::FAILED, "grasp_missed");
    assert_eq!(last.state, "grasp_rack");
    assert_eq!(with_reason(&rig, "retry").len(), 1);
}

#[test]
fn an_unreachable_calibration_target_refuses_unreachable() {
    let mut rig = Rig::with(TaskKind::Hang, |c, _| {
        c.site.calibration_target += Vector3::new(5.0, 0.0, 0.0);
    });
    rig.run(LIMIT_S);
    let last = assert_ended(&rig, TaskEvent::REFUSED, "unreachable");
    assert_eq!(last.state, "check_calibration");
    assert_eq!(commands_after(&rig, ended_at_s(&rig) - 1e-9), 0);
}

#[test]
fn an_obstacle_over_the_arm_refuses_collision() {
    let mut rig = Rig::with(TaskKind::Hang, |c, _| {
        let spot = c.site.work_spot.isometry();
        let above = spot * Point3::new(0.0, 0.0, 1.6);
        c.site.obstacles.push((
            "canopy".to_owned(),
            OrientedBox {
                frame_from_box: Isometry3::translation(above.x, above.y, above.z),
                half_extents_m: Vector3::new(0.8, 0.8, 0.05),
            },
        ));
    });
    rig.run(LIMIT_S);
    let last = assert_ended(&rig, TaskEvent::REFUSED, "collision");
    assert!(last.text.contains("canopy"), "{last:?}");
}

#[test]
fn no_odometry_fails_the_drive() {
    let mut rig = Rig::with(TaskKind::Hang, |c, b| {
        c.self_maintenance = false;
        b.odometry = false;
    });
    rig.run(LIMIT_S);
    let last = assert_ended(&rig, TaskEvent::FAILED, "no_odometry");
    assert_eq!(last.state, "drive");
}

#[test]
fn no_wrist_camera_info_fails_the_first_fit() {
    let mut rig = Rig::with(TaskKind::Hang, |c, b| {
        c.self_maintenance = false;
        b.wrist_info = false;
    });
    rig.run(LIMIT_S);
    let last = assert_ended(&rig, TaskEvent::FAILED, "no_camera_info");
    assert_eq!(last.state, "capture_rack");
}

#[test]
fn an_unreadable_depth_image_fails_bad_depth() {
    let mut rig = Rig::with(TaskKind::Hang, |c, b| {
        c.self_maintenance = false;
        b.bad_depth = true;
    });
    rig.run(LIMIT_S);
    let last = assert_ended(&rig, TaskEvent::FAILED, "bad_depth");
    assert_eq!(last.state, "capture_rack");
}

#[test]
fn a_capture_without_the_arms_pose_fails_no_tf() {
    let mut rig = Rig::with(TaskKind::Hang, |c, b| {
        c.self_maintenance = false;
        b.arm_tf = false;
    });
    rig.run(LIMIT_S);
    let last = assert_ended(&rig, TaskEvent::FAILED, "no_tf");
    assert_eq!(last.state, "capture_rack");
}

/// Times (s) of the arm, lift, base and clamp commands after `at_s`.
fn motions_after(rig: &Rig, at_s: f64) -> Vec<f64> {
    rig.outputs
        .iter()
        .filter(|o| o.at.as_secs_f64() > at_s)
        .filter(|o| {
            [ARM_JOINT_TRAJECTORY, LIFT_COMMAND, BASE_GOAL, CLAMP_COMMAND]
                .contains(&o.topic.as_str())
        })
        .map(|o| o.at.as_secs_f64())
        .collect()
}

/// The remove with a gust from 2 s to 7 s: it comes while the clamp opens on the hung rod,
/// so the unhook (the next command) is held.
fn remove_through_a_gust(settle: RobotDuration) -> Rig {
    let mut rig = Rig::with(TaskKind::Remove, |c, b| {
        c.self_maintenance = false;
        c.wind.settle_on_wire = settle;
        b.wind = |t| Some(if (2.0..7.0).contains(&t) { 4.5 } else { 0.5 });
    });
    rig.run(LIMIT_S);
    assert_done(&rig);
    let holds = with_reason(&rig, "holding_for_wind");
    assert_eq!(holds.len(), 1, "{holds:#?}");
    assert_eq!(holds[0].state, "unhook", "{holds:#?}");
    rig
}

#[test]
fn after_a_gust_the_arm_waits_for_the_wires_swing_to_settle_before_moving_at_the_hung_rod() {
    let rig = remove_through_a_gust(RobotDuration::from_secs(15));
    let settling = with_reason(&rig, "settling_after_wind");
    assert_eq!(settling.len(), 1, "{settling:#?}");
    assert!(settling[0].text.contains("waiting 15 s"), "{settling:#?}");
    // The gate reopens with the reading at 7 s; the unhook goes 15 s later.
    let first = motions_after(&rig, 2.0)
        .first()
        .copied()
        .unwrap_or(f64::NAN);
    assert!(
        (22.0..23.0).contains(&first),
        "first command after the gust at {first} s"
    );
    // Without the settling time the same unhook goes as the gate reopens.
    let rig = remove_through_a_gust(RobotDuration::ZERO);
    assert!(with_reason(&rig, "settling_after_wind").is_empty());
    let first = motions_after(&rig, 2.0)
        .first()
        .copied()
        .unwrap_or(f64::NAN);
    assert!(
        (7.0..8.0).contains(&first),
        "first command after the gust at {first} s"
    );
}

#[test]
fn a_gust_before_the_rod_is_on_the_wire_needs_no_settling() {
    // The hang's gust comes before the hook: the rod is in the gripper.
    let mut rig = Rig::with(TaskKind::Hang, |c, b| {
        c.self_maintenance = false;
        b.wind = |t| Some(if (1.0..6.0).contains(&t) { 4.5 } else { 0.5 });
    });
    rig.run(LIMIT_S);
    assert_done(&rig);
    assert_eq!(with_reason(&rig, "holding_for_wind").len(), 1);
    assert!(with_reason(&rig, "settling_after_wind").is_empty());
}

#[test]
fn a_gust_within_the_settling_time_starts_a_new_hold_and_a_new_wait() {
    let mut rig = Rig::with(TaskKind::Remove, |c, b| {
        c.self_maintenance = false;
        // Gusts at 2-7 s and 10-12 s: the second comes 3 s into the 8 s of settling.
        b.wind = |t| {
            Some(if (2.0..7.0).contains(&t) || (10.0..12.0).contains(&t) {
                4.5
            } else {
                0.5
            })
        };
    });
    rig.run(LIMIT_S);
    assert_done(&rig);
    let holds = with_reason(&rig, "holding_for_wind");
    assert_eq!(holds.len(), 2, "{holds:#?}");
    assert!(holds.iter().all(|h| h.state == "unhook"), "{holds:#?}");
    assert_eq!(with_reason(&rig, "settling_after_wind").len(), 2);
    // The gate reopens with the reading at 12 s; the unhook goes 8 s later.
    let first = motions_after(&rig, 2.0)
        .first()
        .copied()
        .unwrap_or(f64::NAN);
    assert!(
        (20.0..21.0).contains(&first),
        "first command after the gusts at {first} s"
    );
}

/// In a swinging wire the pre-approach stands back by the sway's band; a miss backs off as
/// far, so the raise to look again clears the band and the second hook lands. (Backed off by
/// `approach_m` alone, the rod head was 19 mm from the wire and the raise was refused.)
#[test]
fn a_miss_in_a_swinging_wire_backs_off_past_its_band_and_the_second_hook_lands() {
    let mut rig = Rig::with(TaskKind::Hang, |c, b| {
        c.self_maintenance = false;
        b.wire_sway_m = 0.012;
        b.hook_hits = vec![false, true];
    });
    rig.run(LIMIT_S);
    assert_done(&rig);
    let sway = with_reason(&rig, "wire_sway");
    assert!(
        sway.iter().any(|e| e.text.contains("kept 36 mm clear")),
        "{sway:#?}"
    );
    assert_eq!(with_reason(&rig, "retry").len(), 1);
    assert_eq!(
        rig.steps().iter().filter(|s| *s == "close_clamp").count(),
        2
    );
    assert_eq!(super::count(&rig, "recover", LIFT_COMMAND), 1);
}
