//! Motion: trajectories within limits (and a checker that catches violations), Cartesian
//! straight lines via IK with refusals, collision checks, A* on a grid, lift height.

use control::motion::MotionError;
use control::motion::base_planner::{OccupancyGrid, base_path_to_msg, plan_base_path};
use control::motion::cartesian::{CartesianParams, plan_line};
use control::motion::collision::{
    ArmCollisionModel, Capsule, CollisionWorld, OrientedBox, capsule_box, capsule_capsule,
};
use control::motion::lift::{LiftParams, choose_lift};
use control::motion::trajectory::{
    DEFAULT_DT_NS, LIMIT_SCALE, TrapezoidProfile, Violation, check_trajectory, limits_for_names,
    plan_joint_path, to_joint_trajectory, to_path, tool0_path,
};
use msgs::frames::ARM_JOINT_NAMES;
use msgs::std_msgs::Header;
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use proptest::prelude::*;
use robot::{ArmIk, RobotModel};

const Q_WORK: [f64; 6] = [0.2, 0.3, 1.8, 0.4, 1.3, 0.3];

fn arm_limits() -> [robot::JointLimit; 6] {
    robot::aubo_i10::aubo_i10_limits()
}

#[test]
fn trapezoid_reaches_the_end_within_limits() {
    for (d, v, a) in [(1.0, 0.5, 2.0), (0.01, 3.0, 5.0), (2.0, 1.0, 1.0)] {
        let p = TrapezoidProfile::new(d, v, a);
        let (s, sd, _) = p.sample(p.duration_s());
        assert!((s - d).abs() < 1e-12 && sd.abs() < 1e-12);
        let mut t = 0.0;
        while t < p.duration_s() {
            let (_, sd, sdd) = p.sample(t);
            assert!(sd <= v + 1e-12 && sdd.abs() <= a + 1e-12);
            t += 1e-3;
        }
        let slow = p.stretched_to(2.0 * p.duration_s());
        assert!((slow.duration_s() - 2.0 * p.duration_s()).abs() < 1e-12);
        assert!((slow.sample(slow.duration_s()).0 - d).abs() < 1e-12);
    }
}

#[test]
fn joint_path_passes_the_checker_and_uses_the_limits() {
    let waypoints = [
        [0.0, 0.0, 1.0, 0.0, 1.0, 0.0],
        [1.5, -0.5, 2.0, 1.0, -1.0, 2.5],
        [-1.0, 0.4, 0.5, -0.3, 0.2, -2.9],
    ];
    let traj = match plan_joint_path(&waypoints, &arm_limits(), DEFAULT_DT_NS) {
        Ok(t) => t,
        Err(e) => panic!("{e}"),
    };
    let msg = to_joint_trajectory(&traj, &ARM_JOINT_NAMES, Header::default());
    let limits = match limits_for_names(&RobotModel::nominal(), &msg.joint_names) {
        Ok(l) => l,
        Err(e) => panic!("{e}"),
    };
    let report = match check_trajectory(&msg, &limits) {
        Ok(r) => r,
        Err(e) => panic!("{e}"),
    };
    // Near time-optimal: some joint runs close to its speed or acceleration limit.
    assert!(
        report
            .peak_velocity_ratio
            .max(report.peak_acceleration_ratio)
            > 0.9 * LIMIT_SCALE
    );
    assert!(report.peak_velocity_ratio <= 1.0 && report.peak_acceleration_ratio <= 1.0);
    assert_eq!(
        msg.points.first().map(|p| p.positions.clone()),
        Some(waypoints[0].to_vec())
    );
    assert_eq!(
        msg.points.last().map(|p| p.positions.clone()),
        Some(waypoints[2].to_vec())
    );
    // The planned tool0 path for the viewer.
    let poses = tool0_path(&RobotModel::nominal(), 0.5, &traj, 10);
    assert_eq!(to_path(&poses, Header::default()).poses.len(), poses.len());
}

#[test]
fn checker_catches_speed_acceleration_position_and_time_violations() {
    let limits = arm_limits().to_vec();
    let waypoints = [[0.0; 6], [1.0, 0.5, 0.5, 0.5, 0.5, 0.5]];
    let traj = match plan_joint_path(&waypoints, &arm_limits(), DEFAULT_DT_NS) {
        Ok(t) => t,
        Err(e) => panic!("{e}"),
    };
    let msg = to_joint_trajectory(&traj, &ARM_JOINT_NAMES, Header::default());
    // Played 1.5x faster: accelerations x2.25 break the limit.
    let mut fast = msg.clone();
    for p in &mut fast.points {
        let ns = (u64::from(p.time_from_start.nanosec)
            + p.time_from_start.sec as u64 * 1_000_000_000)
            * 2
            / 3;
        p.time_from_start = control::motion::trajectory::duration_from_ns(ns);
        p.velocities.clear();
    }
    assert!(matches!(
        check_trajectory(&fast, &limits),
        Err(Violation::Acceleration { joint: 0, .. } | Violation::Velocity { joint: 0, .. })
    ));
    let mut out_of_range = msg.clone();
    if let Some(p) = out_of_range.points.get_mut(3) {
        p.positions[2] = 3.1;
    }
    assert!(matches!(
        check_trajectory(&out_of_range, &limits),
        Err(Violation::Position {
            point: 3,
            joint: 2,
            ..
        })
    ));
    let mut backwards = msg.clone();
    if let Some(p) = backwards.points.get_mut(5) {
        p.time_from_start = msgs::builtin_interfaces::Duration { sec: 0, nanosec: 1 };
    }
    assert!(matches!(
        check_trajectory(&backwards, &limits),
        Err(Violation::NonMonotonicTime { point: 5, .. })
    ));
    assert!(matches!(
        check_trajectory(&msg, &limits[..5]),
        Err(Violation::LimitsMismatch {
            names: 6,
            limits: 5
        })
    ));
    assert!(matches!(
        plan_joint_path(
            &[[0.0; 6], [0.0, 0.0, 3.1, 0.0, 0.0, 0.0]],
            &arm_limits(),
            DEFAULT_DT_NS
        ),
        Err(MotionError::OutsideLimits {
            waypoint: 1,
            joint: 3,
            ..
        })
    ));
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 48,
        rng_seed: proptest::test_runner::RngSeed::Fixed(0x5EED_0148),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]
    #[test]
    fn random_joint_paths_respect_limits(
        raw in proptest::collection::vec(proptest::array::uniform6(-3.0f64..3.0), 2..5)
    ) {
        let traj = plan_joint_path(&raw, &arm_limits(), DEFAULT_DT_NS);
        prop_assert!(traj.is_ok());
        if let Ok(traj) = traj {
            let msg = to_joint_trajectory(&traj, &ARM_JOINT_NAMES, Header::default());
            let checked = check_trajectory(&msg, &arm_limits());
            prop_assert!(checked.is_ok(), "{:?}", checked);
        }
    }
}

fn approach(q_start: &[f64; 6], distance_m: f64) -> (Isometry3<f64>, Isometry3<f64>) {
    let start = RobotModel::nominal().arm_base_from_tool0(q_start);
    let goal = start * Translation3::new(0.0, 0.0, distance_m);
    (start, goal)
}

#[test]
fn cartesian_line_is_straight_and_within_limits() {
    let ik = ArmIk::aubo_i10();
    let (start, goal) = approach(&Q_WORK, 0.15);
    let plan = match plan_line(&ik, &start, &goal, &Q_WORK, &CartesianParams::default()) {
        Ok(p) => p,
        Err(e) => panic!("{e}"),
    };
    eprintln!(
        "0.15 m approach: {} samples, {:.3} s, {} IK pre-samples",
        plan.trajectory.positions.len(),
        plan.trajectory.duration_s(),
        plan.steps
    );
    let dir = (goal.translation.vector - start.translation.vector).normalize();
    for q in &plan.trajectory.positions {
        let pose = ik.dh().forward(q);
        let rel = pose.translation.vector - start.translation.vector;
        let off_line = (rel - dir * rel.dot(&dir)).norm();
        assert!(off_line < 1e-9, "off the line by {off_line} m");
        assert!(pose.rotation.angle_to(&start.rotation) < 1e-9);
    }
    let last = plan.trajectory.last().map(|q| ik.dh().forward(&q));
    assert!(last.is_some_and(|p| (p.translation.vector - goal.translation.vector).norm() < 1e-9));
    let msg = to_joint_trajectory(&plan.trajectory, &ARM_JOINT_NAMES, Header::default());
    assert!(check_trajectory(&msg, &arm_limits()).is_ok());
    // Tool speed within 0.10 m/s (finite differences).
    let dt = DEFAULT_DT_NS as f64 * 1e-9;
    for w in plan.trajectory.positions.windows(2) {
        let v = (ik.dh().forward(&w[1]).translation.vector
            - ik.dh().forward(&w[0]).translation.vector)
            .norm()
            / dt;
        assert!(v <= 0.1 * 1.0001, "tool speed {v}");
    }
    // Retreat from the goal back to the start.
    let Some(q_goal) = plan.trajectory.last() else {
        panic!("empty")
    };
    assert!(plan_line(&ik, &goal, &start, &q_goal, &CartesianParams::default()).is_ok());
}

#[test]
fn cartesian_refuses_mismatched_start_and_singular_lines() {
    let ik = ArmIk::aubo_i10();
    let (start, goal) = approach(&Q_WORK, 0.1);
    let mut wrong = Q_WORK;
    wrong[0] += 0.05;
    assert!(matches!(
        plan_line(&ik, &start, &goal, &wrong, &CartesianParams::default()),
        Err(MotionError::StartMismatch { .. })
    ));
    // A line through the wrist singularity (q5 from +0.3 to -0.3 rad).
    let q_a = [0.2, 0.3, 1.8, 0.4, 0.3, 0.3];
    let mut q_b = q_a;
    q_b[4] = -0.3;
    let model = RobotModel::nominal();
    let (a, b) = (
        model.arm_base_from_tool0(&q_a),
        model.arm_base_from_tool0(&q_b),
    );
    let result = plan_line(&ik, &a, &b, &q_a, &CartesianParams::default());
    assert!(
        matches!(
            result,
            Err(MotionError::NearSingularity { .. } | MotionError::BranchJump { .. })
        ),
        "{result:?}"
    );
    // Out of reach.
    let far = start * Translation3::new(0.0, 0.0, 2.0);
    assert!(matches!(
        plan_line(&ik, &start, &far, &Q_WORK, &CartesianParams::default()),
        Err(MotionError::Ik { .. } | MotionError::NearSingularity { .. })
    ));
}

#[test]
fn segment_and_capsule_distances() {
    let cap = |a: [f64; 3], b: [f64; 3], r| Capsule {
        a: Point3::from(a),
        b: Point3::from(b),
        radius_m: r,
    };
    // Crossing skew segments 0.5 apart.
    let c = capsule_capsule(
        &cap([-1.0, 0.0, 0.0], [1.0, 0.0, 0.0], 0.1),
        &cap([0.0, -1.0, 0.5], [0.0, 1.0, 0.5], 0.1),
    );
    assert!((c - 0.3).abs() < 1e-12);
    // Parallel, offset, overlapping in extent.
    let c = capsule_capsule(
        &cap([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], 0.0),
        &cap([0.5, 0.2, 0.0], [2.0, 0.2, 0.0], 0.0),
    );
    assert!((c - 0.2).abs() < 1e-12);
    // End to end.
    let c = capsule_capsule(
        &cap([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], 0.0),
        &cap([2.0, 0.0, 0.0], [3.0, 0.0, 0.0], 0.0),
    );
    assert!((c - 1.0).abs() < 1e-12);
    let b = OrientedBox {
        frame_from_box: Isometry3::from_parts(
            Translation3::new(0.0, 0.0, 0.0),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.3),
        ),
        half_extents_m: Vector3::new(0.5, 0.5, 0.5),
    };
    let above = cap([-2.0, 0.1, 1.5], [2.0, -0.1, 1.5], 0.25);
    assert!((capsule_box(&above, &b) - 0.75).abs() < 1e-9);
    let through = cap([-2.0, 0.0, 0.0], [2.0, 0.0, 0.0], 0.0);
    assert!(capsule_box(&through, &b) <= 0.0);
}

#[test]
fn arm_collides_with_a_box_in_its_way_and_not_with_a_far_one() {
    let arm = ArmCollisionModel::nominal();
    let lift_m = 0.5;
    let capsules = arm.capsules(lift_m, &Q_WORK);
    let elbow = capsules[1].b;
    let block = |at: Point3<f64>| OrientedBox {
        frame_from_box: Isometry3::translation(at.x, at.y, at.z),
        half_extents_m: Vector3::new(0.05, 0.05, 0.05),
    };
    let mut world = CollisionWorld::default();
    world
        .boxes
        .push(("platform".into(), block(Point3::new(3.0, 3.0, 0.3))));
    world.capsules.push((
        "wire".into(),
        Capsule {
            a: Point3::new(-5.0, 3.0, 4.0),
            b: Point3::new(5.0, 3.0, 4.0),
            radius_m: 0.0134,
        },
    ));
    // The far obstacles are > 1 m away; the smallest clearance is now the wrist's own
    // (self-collision pairs), still above the margin.
    let clear = arm.check_samples(&world, lift_m, &[Q_WORK], 1);
    assert!(clear.as_ref().is_ok_and(|c| *c > arm.margin_m), "{clear:?}");
    let (_, link, obstacle) = arm.clearance(&world, lift_m, &Q_WORK);
    assert!(
        obstacle != "platform" && obstacle != "wire",
        "{link} vs {obstacle}"
    );
    world.boxes.push((
        "obstacle".into(),
        block(elbow + Vector3::new(0.0, 0.0, 0.1)),
    ));
    let hit = arm.check_samples(&world, lift_m, &[Q_WORK], 1);
    assert!(
        matches!(&hit, Err(MotionError::Collision { obstacle, .. }) if obstacle == "obstacle"),
        "{hit:?}"
    );
}

fn substation() -> OccupancyGrid {
    let mut grid = OccupancyGrid::free(200, 200, 0.1, (0.0, 0.0));
    // A wall at x = 10 m with a 2 m gate near y = 16 m, and a transformer block.
    grid.fill_rect(10.0, 0.0, 10.3, 15.0);
    grid.fill_rect(10.0, 17.0, 10.3, 20.0);
    grid.fill_rect(4.0, 4.0, 7.0, 8.0);
    grid
}

#[test]
fn astar_finds_a_collision_free_path_through_the_gate() {
    let grid = substation().inflated(0.6);
    let path = match plan_base_path(&grid, (2.0, 2.0), (18.0, 3.0)) {
        Ok(p) => p,
        Err(e) => panic!("{e}"),
    };
    // Every leg is free in the inflated grid (sampled every 2 cm).
    for w in path.waypoints_m.windows(2) {
        let n = ((w[1].0 - w[0].0).hypot(w[1].1 - w[0].1) / 0.02).ceil() as usize;
        for k in 0..=n {
            let s = k as f64 / n.max(1) as f64;
            let (x, y) = (
                w[0].0 + s * (w[1].0 - w[0].0),
                w[0].1 + s * (w[1].1 - w[0].1),
            );
            let (i, j) = grid.cell_of(x, y);
            assert!(!grid.occupied(i, j), "({x}, {y}) is occupied");
        }
    }
    // Through the gate: some waypoint leg crosses x = 10 near y in (15.6, 16.4).
    assert!(path.length_m() > 20.0 && path.length_m() <= path.grid_length_m + 1e-9);
    assert_eq!(
        base_path_to_msg(&path, Header::default()).poses.len(),
        path.waypoints_m.len()
    );
    // Optimal on a free grid: the octile distance.
    let free = OccupancyGrid::free(50, 50, 0.1, (0.0, 0.0));
    let p = match plan_base_path(&free, (0.05, 0.05), (3.05, 1.05)) {
        Ok(p) => p,
        Err(e) => panic!("{e}"),
    };
    let octile = 0.1 * (30.0 - 10.0 + 10.0 * std::f64::consts::SQRT_2);
    assert!((p.grid_length_m - octile).abs() < 1e-9);
    assert_eq!(p.waypoints_m.len(), 2);
}

#[test]
fn astar_refuses_blocked_ends_and_closed_maps() {
    let grid = substation().inflated(0.6);
    assert!(matches!(
        plan_base_path(&grid, (5.5, 6.0), (18.0, 3.0)),
        Err(MotionError::BlockedEndpoint { which: "start", .. })
    ));
    let mut closed = substation();
    closed.fill_rect(10.0, 15.0, 10.3, 17.0);
    assert!(matches!(
        plan_base_path(&closed.inflated(0.6), (2.0, 2.0), (18.0, 3.0)),
        Err(MotionError::NoPath { .. })
    ));
}

#[test]
fn lift_height_reaches_a_high_target_dexterously() {
    let model = RobotModel::nominal();
    let ik = ArmIk::aubo_i10();
    // Tool0 0.7 m in front of the base at 2.6 m height, pointing up (hook from below).
    let target = Isometry3::from_parts(
        Translation3::new(0.7, 0.1, 2.6),
        UnitQuaternion::from_euler_angles(std::f64::consts::PI, 0.0, 0.0),
    );
    let choice = match choose_lift(&model, &ik, &target, &Q_WORK, &LiftParams::default()) {
        Ok(c) => c,
        Err(e) => panic!("{e}"),
    };
    let reached = model.base_from_tool0(choice.lift_m, &choice.q_rad);
    assert!((reached.translation.vector - target.translation.vector).norm() < 1e-9);
    assert!(choice.score > 0.5, "{choice:?}");
    eprintln!(
        "lift {:.2} m, dexterity {:.3}, {} heights tried",
        choice.lift_m, choice.score, choice.tried
    );
    assert!((0.0..=2.0).contains(&choice.lift_m));
    let unreachable = Isometry3::translation(0.5, 0.0, 8.0);
    assert!(matches!(
        choose_lift(&model, &ik, &unreachable, &Q_WORK, &LiftParams::default()),
        Err(MotionError::NoLiftHeight { .. })
    ));
}

#[test]
fn approach_trajectory_is_checked_against_the_wire() {
    let ik = ArmIk::aubo_i10();
    let arm = ArmCollisionModel::nominal();
    let model = RobotModel::nominal();
    let lift_m = 1.0;
    let (start, goal) = approach(&Q_WORK, 0.15);
    let plan = match plan_line(&ik, &start, &goal, &Q_WORK, &CartesianParams::default()) {
        Ok(p) => p,
        Err(e) => panic!("{e}"),
    };
    // A wire across the approach, perpendicular to it, 0.15 m + tool + margin beyond the goal.
    let base_from_goal = model.base_from_arm_base(lift_m) * goal;
    let across = base_from_goal.rotation * Vector3::x();
    let wire_at = |beyond_m: f64| {
        let centre = base_from_goal * Point3::new(0.0, 0.0, arm.tool_length_m + beyond_m);
        Capsule {
            a: centre - across * 3.0,
            b: centre + across * 3.0,
            radius_m: 0.0134,
        }
    };
    let mut world = CollisionWorld::default();
    world.capsules.push(("wire".into(), wire_at(0.1)));
    let clearance = arm.check_samples(&world, lift_m, &plan.trajectory.positions, 5);
    assert!(
        clearance
            .as_ref()
            .is_ok_and(|c| (c - (0.1 - 0.0134 - arm.tool_radius_m)).abs() < 0.02),
        "{clearance:?}"
    );
    world.capsules[0].1 = wire_at(-0.03);
    assert!(matches!(
        arm.check_samples(&world, lift_m, &plan.trajectory.positions, 5),
        Err(MotionError::Collision { link: "tool", .. })
    ));
}
