//! Planning: a 0.15 m Cartesian approach (IK pre-sampling, timing, sampling) turned into a
//! `JointTrajectory` and checked; a joint-space plan to a tool0 goal (IK, trapezoids, collision
//! check of every second sample against the platform and itself) and the log checker on its
//! command; A* on a 200x200 substation grid (inflated).

use std::hint::black_box;

use control::motion::base_planner::{OccupancyGrid, plan_base_path};
use control::motion::cartesian::{CartesianParams, plan_line};
use control::motion::trajectory::{check_trajectory, to_joint_trajectory};
use criterion::{Criterion, criterion_group, criterion_main};
use msgs::frames::ARM_JOINT_NAMES;
use msgs::std_msgs::Header;
use nalgebra::Translation3;
use robot::{ArmIk, RobotModel};

fn planning(c: &mut Criterion) {
    let ik = ArmIk::aubo_i10();
    let q_start = [0.2, 0.3, 1.8, 0.4, 1.3, 0.3];
    let start = RobotModel::nominal().arm_base_from_tool0(&q_start);
    let goal = start * Translation3::new(0.0, 0.0, 0.15);
    let limits = robot::aubo_i10::aubo_i10_limits();
    let params = CartesianParams::default();
    c.bench_function("cartesian_approach_0.15m+trajectory+check", |b| {
        b.iter(|| {
            let Ok(plan) = plan_line(&ik, black_box(&start), black_box(&goal), &q_start, &params)
            else {
                panic!("plan");
            };
            let msg = to_joint_trajectory(&plan.trajectory, &ARM_JOINT_NAMES, Header::default());
            check_trajectory(&msg, &limits).is_ok()
        })
    });
    let arm = control::motion::collision::ArmCollisionModel::nominal();
    let world = control::motion::collision::CollisionWorld::robot_body(&arm.model, 1.0);
    let q_goal = [0.6, 0.2, 1.4, 0.3, 1.3, 0.4];
    let tool0_goal = arm.model.base_from_tool0(1.0, &q_goal);
    c.bench_function("plan_to_tool0+collision(self,platform)", |b| {
        b.iter(|| {
            control::motion::planner::plan_to_tool0(
                &arm,
                &ik,
                &world,
                1.0,
                black_box(&q_start),
                black_box(&tool0_goal),
                10_000_000,
            )
            .is_ok()
        })
    });
    let Ok(plan) = control::motion::planner::plan_to_tool0(
        &arm,
        &ik,
        &world,
        1.0,
        &q_start,
        &tool0_goal,
        10_000_000,
    ) else {
        panic!("plan");
    };
    let command: msgs::Msg =
        control::motion::planner::plan_trajectory_msg(&plan, Header::default()).into();
    c.bench_function("motion_checker/one_command", |b| {
        b.iter(|| {
            let mut checker = control::motion::checker::MotionChecker::new(
                control::motion::checker::CheckerParams::default(),
            );
            checker.feed(0, msgs::topics::ARM_JOINT_TRAJECTORY, black_box(&command));
            checker.finish().passed()
        })
    });
    let mut grid = OccupancyGrid::free(200, 200, 0.1, (0.0, 0.0));
    grid.fill_rect(10.0, 0.0, 10.3, 15.0);
    grid.fill_rect(10.0, 17.0, 10.3, 20.0);
    grid.fill_rect(4.0, 4.0, 7.0, 8.0);
    grid.fill_rect(13.0, 5.0, 16.0, 12.0);
    let inflated = grid.inflated(0.6);
    c.bench_function("astar/200x200", |b| {
        b.iter(|| plan_base_path(black_box(&inflated), (2.0, 2.0), (18.0, 3.0)))
    });
    c.bench_function("inflate/200x200/r0.6m", |b| {
        b.iter(|| black_box(&grid).inflated(0.6))
    });
}

criterion_group!(benches, planning);
criterion_main!(benches);
