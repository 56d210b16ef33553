//! End-to-end tests of the simulated world: determinism across thread counts and step
//! patterns, the camera-mount bump, capture timing and encodings, the calib-18 views.

// Wall-clock timings and hashed sets of a test, bench or example: not a stage, so the
// crate's determinism lints do not apply here.
#![allow(clippy::disallowed_methods, clippy::disallowed_types)]

mod common;

use msgs::drivers::World;
use msgs::sensor_msgs::{CameraInfo, Image, JointState};
use msgs::topics;
use msgs::{Msg, RobotTime};
use scenario::{CommandKind, Scenario};
use sim::render::{raycast_depth, wrist_camera};
use sim::world::mount_from_config;
use sim::{SimConfig, SimWorld};

type TestResult = Result<(), Box<dyn std::error::Error>>;

const SHORT: &str = r#"
name = "short"
seed = 11
duration_s = 4.0
hour = 17.0
[wind]
mean_mps = 3.0
[bump]
time_s = 2.0
[camera]
scale = 0.1
[panoramic]
period_s = 1.0
scale = 0.2
[[command]]
t_s = 0.1
kind = "lift"
values = [0.3]
[[command]]
t_s = 0.2
kind = "joints"
values = [-1.2, 0.2, 1.7, 0.0, -1.2, 0.0]
[[command]]
t_s = 0.3
kind = "base"
values = [12.0, -1.1, 1.5708]
[[command]]
t_s = 0.5
kind = "clamp"
values = [1, 6.0]
[[command]]
t_s = 1.0
kind = "capture"
[[command]]
t_s = 2.5
kind = "capture"
"#;

fn in_pool<T: Send>(
    threads: usize,
    f: impl FnOnce() -> T + Send,
) -> Result<T, rayon::ThreadPoolBuildError> {
    Ok(rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?
        .install(f))
}

#[test]
fn the_world_can_move_to_the_recorder_thread_and_every_committed_scenario_loads() -> TestResult {
    fn assert_send<T: Send + 'static>() {}
    assert_send::<SimWorld>();
    for name in ["calib-18", "op-5min", "sim-smoke"] {
        let s = Scenario::find(name)?;
        assert_eq!(s.name, name);
        SimWorld::new(&SimConfig::of_scenario(&s)?)?;
    }
    let smoke = Scenario::find("sim-smoke")?;
    let short = Scenario::parse(SHORT, "short")?;
    assert_eq!(smoke.commands.len(), short.commands.len());
    Ok(())
}

#[test]
fn same_scenario_and_seed_give_identical_bytes_with_1_and_2_threads() -> TestResult {
    let s = Scenario::parse(SHORT, "short")?;
    let end = RobotTime::ZERO + s.duration;
    let go = || -> Result<_, String> {
        let (_, out) = common::run(&s, end).map_err(|e| e.to_string())?;
        common::bytes(&out).map_err(|e| e.to_string())
    };
    let one = in_pool(1, go)??;
    let two = in_pool(2, go)??;
    assert_eq!(one.len(), two.len());
    assert!(one == two, "outputs differ between 1 and 2 threads");
    // Every producer and topic of the world is there.
    for topic in [
        topics::JOINT_STATES,
        topics::TF,
        topics::CAMERA_COLOR_IMAGE,
        topics::CAMERA_DEPTH_IMAGE,
        topics::CAMERA_COLOR_INFO,
        topics::PANORAMIC_IMAGE,
        topics::ENV_WIND,
        topics::ENV_ILLUMINANCE,
        topics::SIM_CAMERA_MOUNT,
        topics::SIM_WIRE_POSE,
        topics::SIM_HANDLE_POSE,
        topics::SIM_WIND,
        topics::SIM_ILLUMINANCE,
        topics::SIM_ROD_STATE,
    ] {
        assert!(one.iter().any(|o| o.3 == topic), "{topic} missing");
    }
    // Sorted by (log_time, producer, topic).
    assert!(
        one.windows(2)
            .all(|w| (w[0].0, &w[0].2, &w[0].3) <= (w[1].0, &w[1].2, &w[1].3))
    );
    // Another seed changes the noise.
    let mut s2 = s.clone();
    s2.seed = 12;
    let other = common::bytes(&common::run(&s2, end)?.1)?;
    assert!(other != one);
    Ok(())
}

#[test]
fn outputs_do_not_depend_on_how_the_caller_splits_its_steps() -> TestResult {
    let mut s = Scenario::parse(SHORT, "short")?;
    s.commands.clear();
    let mut a = SimWorld::new(&SimConfig::of_scenario(&s)?)?;
    let mut b = SimWorld::new(&SimConfig::of_scenario(&s)?)?;
    let end = RobotTime::from_millis(2_345);
    let big = a.step_until(end)?;
    let mut small = Vec::new();
    let mut t = 0;
    while t < 2_345 {
        t = (t + 7).min(2_345);
        small.extend(b.step_until(RobotTime::from_millis(t))?);
    }
    assert_eq!(common::bytes(&big)?, common::bytes(&small)?);
    assert!(matches!(
        b.step_until(RobotTime::from_millis(100)),
        Err(msgs::DriverError::TimeWentBackwards { .. })
    ));
    Ok(())
}

#[test]
fn a_bump_moves_the_true_mount_by_the_configured_amount() -> TestResult {
    let text = "name = \"b\"\nseed = 5\nduration_s = 3.0\n[bump]\ntime_s = 1.5\nrot_deg = 2.5\ntrans_mm = 7.0\n[panoramic]\nperiod_s = 0\n[camera]\nscale = 0.05\n";
    let s = Scenario::parse(text, "b")?;
    let mut w = SimWorld::new(&SimConfig::of_scenario(&s)?)?;
    w.step_until(RobotTime::from_millis(1_400))?;
    let before = w.true_mount();
    let out = w.step_until(RobotTime::from_millis(1_600))?;
    let after = w.true_mount();
    let angle_deg = (before.rotation.inverse() * after.rotation)
        .angle()
        .to_degrees();
    let shift_mm = (after.translation.vector - before.translation.vector).norm() * 1e3;
    assert!((angle_deg - 2.5).abs() < 1e-9, "{angle_deg}");
    assert!((shift_mm - 7.0).abs() < 1e-9, "{shift_mm}");
    // The truth topic reports it at the bump time.
    let mount = out
        .iter()
        .find(|o| {
            o.topic == topics::SIM_CAMERA_MOUNT && o.log_time == RobotTime::from_millis(1_500)
        })
        .and_then(|o| o.msg.get::<msgs::geometry_msgs::TransformStamped>())
        .ok_or("no /sim/camera_mount at the bump")?;
    assert!((mount.transform.translation.x - after.translation.x).abs() < 1e-12);
    // Seeded sizes follow the design distribution.
    let seeded = Scenario::parse(
        "name = \"b\"\nseed = 6\nduration_s = 10.0\n[bump]\n[panoramic]\nperiod_s = 0\n",
        "b",
    )?;
    let b = SimWorld::new(&SimConfig::of_scenario(&seeded)?)?
        .bump()
        .copied()
        .ok_or("no bump")?;
    assert!((1.0..=3.0).contains(&b.rot_deg) && (3.0..=10.0).contains(&b.trans_mm));
    Ok(())
}

#[test]
fn capture_is_stamped_at_exposure_published_a_second_later_and_refuses_while_busy() -> TestResult {
    let text = "name = \"c\"\nseed = 2\nduration_s = 5.0\n[camera]\nscale = 0.1\ndepth_encoding = \"16UC1\"\n[panoramic]\nperiod_s = 0\n";
    let s = Scenario::parse(text, "c")?;
    let mut w = SimWorld::new(&SimConfig::of_scenario(&s)?)?;
    w.step_until(RobotTime::from_millis(1_000))?;
    w.command(
        RobotTime::from_millis(1_000),
        topics::CAMERA_TRIGGER,
        &msgs::std_msgs::Empty.into(),
    )?;
    let busy = w.command(
        RobotTime::from_millis(1_000),
        topics::CAMERA_TRIGGER,
        &msgs::std_msgs::Empty.into(),
    );
    assert!(matches!(busy, Err(msgs::DriverError::Busy { .. })));
    let early = w.step_until(RobotTime::from_millis(1_990))?;
    assert!(early.iter().all(|o| o.topic != topics::CAMERA_COLOR_IMAGE));
    let out = w.step_until(RobotTime::from_millis(2_000))?;
    let images: Vec<_> = out
        .iter()
        .filter(|o| o.producer == "camera_driver")
        .collect();
    assert_eq!(images.len(), 3);
    assert_eq!(
        out.iter()
            .filter(|o| o.topic == topics::SIM_CAMERA_INFO && o.producer == "sim")
            .count(),
        1,
        "the true intrinsics go with the capture"
    );
    let exposure = RobotTime::from_millis(1_010).to_ros()?;
    for o in &images {
        assert_eq!(o.log_time, RobotTime::from_millis(2_000));
        assert_eq!(o.msg.stamp(), Some(exposure));
    }
    let depth = out
        .iter()
        .find(|o| o.topic == topics::CAMERA_DEPTH_IMAGE)
        .and_then(|o| o.msg.get::<Image>())
        .ok_or("no depth")?;
    assert_eq!(
        (
            depth.encoding.as_str(),
            depth.width,
            depth.height,
            depth.step
        ),
        ("16UC1", 128, 102, 256)
    );
    let info = out
        .iter()
        .find(|o| o.topic == topics::CAMERA_COLOR_INFO)
        .and_then(|o| o.msg.get::<CameraInfo>())
        .ok_or("no info")?;
    assert_eq!(info.distortion_model, "plumb_bob");
    let truth = out
        .iter()
        .find(|o| o.topic == topics::SIM_CAMERA_INFO)
        .and_then(|o| o.msg.get::<CameraInfo>())
        .ok_or("no /sim/camera_info")?;
    // The truth is the renderer's camera; the published info is a calibration of it: off,
    // but within 4 sigma of the calibration error (fx 0.3%, principal point 2 px at full
    // resolution = 0.2 px here).
    assert!((truth.k[0] - 174.5).abs() < 1e-9);
    assert_eq!(truth.header, info.header);
    assert_ne!(info.k, truth.k);
    assert!(((info.k[0] - truth.k[0]) / truth.k[0]).abs() < 4.0 * 0.00305);
    assert!((info.k[2] - truth.k[2]).abs() < 4.0 * 0.2);
    assert_ne!(info.d, truth.d);
    // Free again.
    w.command(
        RobotTime::from_millis(2_000),
        topics::CAMERA_TRIGGER,
        &msgs::std_msgs::Empty.into(),
    )?;
    let bad = w.command(
        RobotTime::from_millis(2_000),
        topics::CAMERA_TRIGGER,
        &msgs::std_msgs::Float64::default().into(),
    );
    assert!(matches!(
        bad,
        Err(msgs::DriverError::UnroutableCommand { .. })
    ));
    Ok(())
}

#[test]
fn calib18_views_see_the_cabinet_at_working_distance_with_the_arm_settled() -> TestResult {
    let mut s = Scenario::find("calib-18")?;
    for set in [
        "robot.perturbation=false",
        "robot.encoder_noise=false",
        "camera.scale=0.1",
    ] {
        s.set_from_arg(set)?;
    }
    // Nominal camera poses from the committed joint goals.
    let world = SimWorld::new(&SimConfig::of_scenario(&s)?)?;
    let model = world.model().clone();
    let c = world.config();
    let mount = mount_from_config(c.camera.mount_xyz_m, c.camera.mount_rpy_deg);
    let lift = s
        .commands
        .iter()
        .find(|c| c.kind == CommandKind::Lift)
        .and_then(|c| c.values.first().copied())
        .ok_or("no lift")?;
    let k = wrist_camera();
    let goals: Vec<[f64; 6]> = s
        .commands
        .iter()
        .filter(|c| c.kind == CommandKind::Joints)
        .filter_map(|c| <[f64; 6]>::try_from(c.values.as_slice()).ok())
        .collect();
    assert_eq!(goals.len(), 18);
    assert_eq!(
        s.commands
            .iter()
            .filter(|c| c.kind == CommandKind::Capture)
            .count(),
        18
    );
    let mut rotations = Vec::new();
    for (i, q) in goals.iter().enumerate() {
        let cam = world.layout().world_from_robot_spot * model.base_from_tool0(lift, q) * mount;
        let mut seen = 0;
        for (u, v) in [(0.5, 0.5), (0.3, 0.3), (0.7, 0.3), (0.3, 0.7), (0.7, 0.7)] {
            let z = raycast_depth(world.scene(), &cam, &k, u * 1279.0, v * 1023.0)?;
            if z.is_some_and(|z| (0.3..=0.6).contains(&z)) {
                seen += 1;
            }
        }
        assert!(
            seen >= 4,
            "view {i}: only {seen}/5 probe rays hit structure at 0.3-0.6 m"
        );
        rotations.push(cam.rotation);
    }
    // Rotations of 15-40 deg between consecutive views, about well-spread axes.
    let mut scatter = nalgebra::Matrix3::<f64>::zeros();
    for w in rotations.windows(2) {
        let rel = w[0].inverse() * w[1];
        let deg = rel.angle().to_degrees();
        assert!((15.0..=40.0).contains(&deg), "{deg}");
        let axis = rel.axis().ok_or("no axis")?;
        scatter += axis.into_inner() * axis.into_inner().transpose();
    }
    let eig = scatter.symmetric_eigenvalues();
    assert!(
        eig.min() > 0.1 * eig.max(),
        "rotation axes are not spread: {eig:?}"
    );

    // Run it: every capture's exposure finds the arm on its goal, and the depth sees the
    // cabinet at 0.3-0.6 m.
    let end = RobotTime::ZERO + s.duration;
    let (_, out) = common::run(&s, end)?;
    let depths: Vec<&Image> = out
        .iter()
        .filter(|o| o.topic == topics::CAMERA_DEPTH_IMAGE)
        .filter_map(|o| o.msg.get::<Image>())
        .collect();
    assert_eq!(depths.len(), 18);
    for (i, d) in depths.iter().enumerate() {
        let stamp = d.header.stamp;
        let js = out
            .iter()
            .filter(|o| o.producer == "arm_driver")
            .filter_map(|o| o.msg.get::<JointState>())
            .rfind(|j| j.header.stamp <= stamp)
            .ok_or("no joint state")?;
        let goal = goals.get(i).ok_or("goal")?;
        for (q, g) in js.position.iter().zip(goal) {
            assert!(
                (q - g).abs() < 1e-9,
                "view {i}: arm not on its goal at exposure"
            );
        }
        let mut z: Vec<f32> = d
            .data
            .chunks_exact(4)
            .filter_map(|b| <[u8; 4]>::try_from(b).ok().map(f32::from_le_bytes))
            .filter(|z| z.is_finite())
            .collect();
        assert!(
            z.len() > d.data.len() / 4 / 2,
            "view {i}: fewer than half the pixels have depth"
        );
        z.sort_by(f32::total_cmp);
        let median = z.get(z.len() / 2).copied().unwrap_or(f32::NAN);
        assert!(
            (0.3..=0.6).contains(&median),
            "view {i}: median depth {median}"
        );
    }
    Ok(())
}

#[test]
fn truth_and_sensor_topics_carry_what_they_say() -> TestResult {
    let text = "name = \"t\"\nseed = 3\nduration_s = 3.0\nhour = 18.0\n[wind]\nmean_mps = 2.0\n[panoramic]\nperiod_s = 0\n[camera]\nscale=0.05\n";
    let s = Scenario::parse(text, "t")?;
    let (_, out) = common::run(&s, RobotTime::from_millis(3_000))?;
    let lux: Vec<f64> = out
        .iter()
        .filter(|o| o.topic == topics::SIM_ILLUMINANCE)
        .filter_map(|o| {
            o.msg
                .get::<msgs::sensor_msgs::Illuminance>()
                .map(|m| m.illuminance)
        })
        .collect();
    assert!(
        lux.first().is_some_and(|l| (l - 400.0).abs() < 1.0),
        "sunset is ~400 lx: {lux:?}"
    );
    let states = out
        .iter()
        .filter(|o| o.topic == topics::SIM_ROD_STATE)
        .filter_map(|o| o.msg.get::<msgs::std_msgs::String>());
    assert!(states.clone().count() >= 3 && states.into_iter().all(|m| m.data == "on_rack"));
    let per_producer = |p: &str| {
        out.iter()
            .filter(|o| o.producer == p && o.topic == topics::JOINT_STATES)
            .count()
    };
    assert_eq!(per_producer("arm_driver"), 301, "100 Hz over [0, 3] s");
    assert_eq!(per_producer("lift_driver"), 301);
    assert_eq!(per_producer("clamp_driver"), 301);
    assert_eq!(
        out.iter().filter(|o| o.producer == "base_driver").count(),
        151,
        "50 Hz"
    );
    assert!(
        out.iter().all(|o| !matches!(o.msg, Msg::Image(_))),
        "no camera output without a trigger"
    );
    Ok(())
}

/// A 5-minute operation: base drive, lift, 12 arm moves, clamp, 6 full-resolution captures,
/// panoramic at 1 Hz, wind and a bump. The <= 15 s wall budget is asserted in optimised
/// builds (the sim crate is opt-level 3 even in dev/test profiles; debug assertions on
/// `cargo test` make the check informative only there).
#[test]
fn a_five_minute_operation_runs_in_under_15_s() -> TestResult {
    let mut text = String::from(
        "name = \"op\"\nseed = 4\nduration_s = 300.0\nhour = 15.0\n[wind]\nmean_mps = 1.5\n[bump]\n[panoramic]\nperiod_s = 1.0\n\
         [[command]]\nt_s = 1.0\nkind = \"base\"\nvalues = [12.5, -1.5, 1.2]\n\
         [[command]]\nt_s = 20.0\nkind = \"lift\"\nvalues = [1.5]\n\
         [[command]]\nt_s = 150.0\nkind = \"clamp\"\nvalues = [1, 8.0]\n",
    );
    for i in 0..12 {
        let t = 40.0 + 20.0 * f64::from(i);
        let a = 0.3 * f64::from(i % 4) - 0.45;
        text.push_str(&format!(
            "[[command]]\nt_s = {t}\nkind = \"joints\"\nvalues = [{a}, 0.3, 1.6, 0.2, 1.4, {a}]\n"
        ));
        if i % 2 == 0 {
            text.push_str(&format!(
                "[[command]]\nt_s = {}\nkind = \"capture\"\n",
                t + 5.0
            ));
        }
    }
    let s = Scenario::parse(&text, "op")?;
    let wall = std::time::Instant::now();
    let (world, out) = common::run(&s, RobotTime::from_secs_f64(300.0)?)?;
    let secs = wall.elapsed().as_secs_f64();
    let images = out
        .iter()
        .filter(|o| o.topic == topics::CAMERA_COLOR_IMAGE)
        .count();
    let panoramic = out
        .iter()
        .filter(|o| o.topic == topics::PANORAMIC_IMAGE)
        .count();
    println!(
        "5-minute operation: {} messages, {images} wrist captures, {panoramic} panoramic images, {secs:.2} s wall",
        out.len()
    );
    assert_eq!(images, 6);
    assert_eq!(
        panoramic, 300,
        "1 Hz from t = 0; the last image of t = 300 s is logged 50 ms later"
    );
    assert!(world.robot_idle());
    if !cfg!(debug_assertions) {
        assert!(secs <= 15.0, "{secs} s wall");
    }
    Ok(())
}

#[test]
fn without_commands_nothing_moves_but_wind_sways_wire_and_platform() -> TestResult {
    let base = "name = \"w\"\nseed = 9\nduration_s = 20.0\n[panoramic]\nperiod_s = 0\n[robot]\nlift_m = 1.5\n";
    let calm = Scenario::parse(base, "calm")?;
    let windy = Scenario::parse(&format!("{base}[wind]\nmean_mps = 8.0\n"), "windy")?;
    let mut spans = Vec::new();
    for s in [&calm, &windy] {
        let mut w = SimWorld::new(&SimConfig::of_scenario(s)?)?;
        let (mut wire, mut cam) = (Vec::new(), Vec::new());
        for k in 1..=200u64 {
            w.step_until(RobotTime::from_millis(100 * k))?;
            wire.push(w.true_hanging_point().ok_or("no wire")?.translation.vector);
            cam.push(w.true_map_from_camera().translation.vector);
        }
        assert!(w.robot_idle());
        let span = |v: &[nalgebra::Vector3<f64>]| {
            v.iter().map(|p| (p - v[0]).norm()).fold(0.0_f64, f64::max)
        };
        spans.push((span(&wire), span(&cam)));
    }
    assert_eq!(
        spans[0],
        (0.0, 0.0),
        "calm air: the world never moves by itself"
    );
    let (wire_m, cam_m) = spans[1];
    assert!(
        wire_m > 0.01 && wire_m < 0.5,
        "wire sway at 8 m/s: {wire_m} m"
    );
    assert!(
        cam_m > 0.002 && cam_m < 0.15,
        "platform sway at 8 m/s: {cam_m} m"
    );
    Ok(())
}

/// `site.layout = "seeded"` builds the bay from the seed (the true wire is elsewhere than in
/// the fixed bay at the same seed); a value other than fixed or seeded is refused by name.
#[test]
fn a_seeded_site_moves_the_wire_and_the_layout_key_is_strict() -> TestResult {
    let wire_at =
        |layout: &str| -> Result<msgs::geometry_msgs::PoseStamped, Box<dyn std::error::Error>> {
            let text = format!(
                "name = \"s\"\nseed = 4\nduration_s = 1.0\n[panoramic]\nperiod_s = 0\n[camera]\nscale = 0.05\n[site]\nlayout = \"{layout}\"\n"
            );
            let s = Scenario::parse(&text, "s")?;
            let (_, out) = common::run(&s, RobotTime::from_millis(200))?;
            out.iter()
                .find(|o| o.topic == topics::SIM_WIRE_POSE)
                .and_then(|o| o.msg.get::<msgs::geometry_msgs::PoseStamped>())
                .cloned()
                .ok_or_else(|| "no /sim/wire_pose".into())
        };
    let (fixed, seeded) = (wire_at("fixed")?, wire_at("seeded")?);
    let (a, b) = (fixed.pose.position, seeded.pose.position);
    let moved_m = ((a.x - b.x).powi(2) + (a.y - b.y).powi(2) + (a.z - b.z).powi(2)).sqrt();
    assert!(moved_m > 0.01, "seeded wire {b:?} vs fixed {a:?}");
    let s = Scenario::parse(
        "name = \"s\"\nseed = 4\nduration_s = 1.0\n[site]\nlayout = \"random\"\n",
        "s",
    )?;
    let err = SimConfig::of_scenario(&s)
        .err()
        .ok_or("layout = random accepted")?;
    assert!(err.to_string().contains("site.layout"), "{err}");
    Ok(())
}
