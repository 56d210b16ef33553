//! The rod's physical tolerances through the whole true chain (base, lift, arm, rod, wire):
//! grasp from the rack, lift out, hook onto the wire, clamp, release. Poses come from the
//! nominal model and IK, the world runs with the perturbation, noise, drift and wind off so
//! the commanded poses are exact.

use msgs::drivers::World;
use msgs::frames::{ARM_JOINT_NAMES, MAP};
use msgs::geometry_msgs::{Point, Pose, PoseStamped, Quaternion};
use msgs::rodlog_msgs::ClampCommand;
use msgs::std_msgs::{Float64, Header};
use msgs::trajectory_msgs::{JointTrajectory, JointTrajectoryPoint};
use msgs::{RobotDuration, RobotTime, topics};
use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};
use robot::ArmIk;
use scenario::Scenario;
use sim::rod::{RodState, rod_from_hook, rod_from_tool0_grasp};
use sim::{SimConfig, SimWorld};

type TestResult = Result<(), Box<dyn std::error::Error>>;

struct Driver {
    world: SimWorld,
    now: RobotTime,
    q: [f64; 6],
    lift_m: f64,
    states: Vec<String>,
}

impl Driver {
    fn wait(&mut self, secs: f64) -> TestResult {
        let end = self.now + RobotDuration::from_secs_f64(secs)?;
        while self.now < end {
            self.now += RobotDuration::from_millis(10);
            for o in self.world.step_until(self.now)? {
                let state = (o.topic == topics::SIM_ROD_STATE)
                    .then(|| o.msg.get::<msgs::std_msgs::String>())
                    .flatten();
                if let Some(s) = state.filter(|s| self.states.last() != Some(&s.data)) {
                    self.states.push(s.data.clone());
                }
            }
        }
        Ok(())
    }

    fn base(&mut self, x: f64, y: f64, yaw: f64) -> TestResult {
        let q = UnitQuaternion::from_euler_angles(0.0, 0.0, yaw);
        let goal = PoseStamped {
            header: Header {
                frame_id: MAP.to_owned(),
                ..Default::default()
            },
            pose: Pose {
                position: Point { x, y, z: 0.0 },
                orientation: Quaternion {
                    x: q.i,
                    y: q.j,
                    z: q.k,
                    w: q.w,
                },
            },
        };
        self.world
            .command(self.now, topics::BASE_GOAL, &goal.into())?;
        while !self.world.robot_idle() {
            self.wait(0.5)?;
        }
        Ok(())
    }

    fn lift(&mut self, h: f64) -> TestResult {
        self.world
            .command(self.now, topics::LIFT_COMMAND, &Float64 { data: h }.into())?;
        self.lift_m = h;
        while !self.world.robot_idle() {
            self.wait(0.5)?;
        }
        Ok(())
    }

    /// Moves tool0 to `map_from_tool0` (nominal model + IK) and waits until the arm rests.
    fn tool(&mut self, map_from_tool0: &Isometry3<f64>) -> TestResult {
        let model = self.world.model().clone();
        let map_from_arm_base =
            self.world.base().map_from_base() * model.base_from_arm_base(self.lift_m);
        let sol =
            ArmIk::aubo_i10().nearest(&(map_from_arm_base.inverse() * map_from_tool0), &self.q)?;
        self.q = sol.q_rad;
        let traj = JointTrajectory {
            header: Header::default(),
            joint_names: ARM_JOINT_NAMES.iter().map(|s| (*s).to_owned()).collect(),
            points: vec![JointTrajectoryPoint {
                positions: sol.q_rad.to_vec(),
                ..Default::default()
            }],
        };
        self.world
            .command(self.now, topics::ARM_JOINT_TRAJECTORY, &traj.into())?;
        while !self.world.robot_idle() {
            self.wait(0.1)?;
        }
        self.wait(0.05)
    }

    fn clamp(&mut self, action: u8, secs: f64) -> TestResult {
        let c = ClampCommand {
            header: Header::default(),
            action,
            max_torque_nm: 8.0,
        };
        self.world
            .command(self.now, topics::CLAMP_COMMAND, &c.into())?;
        self.wait(secs)
    }
}

#[test]
fn grasp_from_the_rack_hook_onto_the_wire_clamp_and_release() -> TestResult {
    let text = "name = \"rod\"\nseed = 1\nduration_s = 300.0\n[panoramic]\nperiod_s = 0\n[camera]\nscale = 0.05\n\
                [robot]\nperturbation = false\nencoder_noise = false\nodometry_drift = false\n";
    let s = Scenario::parse(text, "rod")?;
    let world = SimWorld::new(&SimConfig::of_scenario(&s)?)?;
    let q0 = world.config().robot.home_rad;
    let mut d = Driver {
        world,
        now: RobotTime::ZERO,
        q: q0,
        lift_m: 0.0,
        states: Vec::new(),
    };
    d.wait(0.1)?;

    // Drive next to the rack, facing the rod's +x (the tool approaches the handle along it).
    let stored = d.world.rod().world_from_rod_stored;
    let x_rod = stored.rotation * Vector3::x();
    let (_, _, yaw) = stored.rotation.euler_angles();
    let spot = stored.translation.vector - x_rod * 0.65;
    d.base(spot.x, spot.y, yaw)?;
    d.q = [0.0, 0.3, 1.6, 0.0, 1.57, 0.0];

    // Pre-grasp 10 cm back along tool z, then the grasp pose: the passive coupling holds it.
    let grasp = stored * rod_from_tool0_grasp();
    d.tool(&(grasp * Isometry3::translation(0.0, 0.0, -0.10)))?;
    assert!(!d.world.rod().held, "10 cm away is not a grasp");
    d.tool(&grasp)?;
    assert!(d.world.rod().held);
    assert_eq!(d.world.rod().state, RodState::OnRack);
    // Lift it 0.4 m straight up (2 cm joint-space steps stay within the holder's 10 mm):
    // out of the rack.
    for k in 1..=20 {
        d.tool(&(Isometry3::translation(0.0, 0.0, 0.02 * f64::from(k)) * grasp))?;
        assert!(d.world.rod().held, "released while lifting at step {k}");
    }
    assert_eq!(d.world.rod().state, RodState::InGripper);

    // Under the wire: robot facing +y 0.6 m south of the conductor, lift up.
    let hp = d.world.true_hanging_point().ok_or("no wire")?;
    let wire = hp.translation.vector;
    d.base(wire.x, wire.y - 0.6, std::f64::consts::FRAC_PI_2)?;
    d.q = [-1.57, 0.0, 1.6, 0.0, 1.57, 0.0];
    d.lift(2.0)?;
    // Hook frame on the wire: y along -x (the wire), z up, x = +y (away from the robot).
    let hook_rot = Matrix3::from_columns(&[Vector3::y(), -Vector3::x(), Vector3::z()]);
    let hook_on_wire = |offset: Vector3<f64>| {
        Isometry3::from_parts(
            Translation3::from(wire + offset),
            UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(hook_rot)),
        )
    };
    let tool_for = |world_from_hook: Isometry3<f64>| {
        world_from_hook * rod_from_hook().inverse() * rod_from_tool0_grasp()
    };
    // 6 cm short along the approach (outside the +-10 mm window), then onto the wire.
    d.tool(&tool_for(hook_on_wire(Vector3::new(0.0, 0.06, 0.0))))?;
    assert_eq!(
        d.world.rod().state,
        RodState::InGripper,
        "6 cm off: not hooked"
    );
    d.tool(&tool_for(hook_on_wire(Vector3::new(0.0, 0.004, -0.008))))?;
    assert_eq!(
        d.world.rod().state,
        RodState::Hooked,
        "4 mm along, 8 mm across: captured"
    );

    // Close the clamp: ~9 s of lead-screw travel, then clamped.
    d.clamp(ClampCommand::CLOSE, 4.0)?;
    assert_eq!(
        d.world.rod().state,
        RodState::Hooked,
        "still closing after 4 s"
    );
    d.clamp(ClampCommand::CLOSE, 8.0)?;
    assert_eq!(d.world.rod().state, RodState::Clamped);
    // Retreat 5 cm: the rod stays clamped on the wire.
    let clamped_grasp = d.world.rod().world_from_grasp();
    d.tool(&(clamped_grasp * Isometry3::translation(0.0, 0.0, -0.05)))?;
    assert!(!d.world.rod().held);
    assert_eq!(d.world.rod().state, RodState::Clamped);
    assert_eq!(d.states, ["on_rack", "in_gripper", "hooked", "clamped"]);
    // The motor, decoupled, may run on; the rod's self-locking screw keeps the wire clamped.
    d.clamp(ClampCommand::OPEN, 12.0)?;
    assert_eq!(d.world.rod().state, RodState::Clamped);
    // Removal: re-grasp (couples at the contact travel), open: hooked; pull back: unhooked.
    d.tool(&clamped_grasp)?;
    assert!(d.world.rod().held);
    assert_eq!(
        d.world.clamp_travel_m().0,
        sim::clamp::WIRE_CONTACT_TRAVEL_M
    );
    assert_eq!(d.world.rod().state, RodState::Clamped);
    d.clamp(ClampCommand::OPEN, 12.0)?;
    assert_eq!(d.world.rod().state, RodState::Hooked);
    d.tool(&(clamped_grasp * Isometry3::translation(0.0, 0.0, -0.06)))?;
    assert_eq!(d.world.rod().state, RodState::InGripper);
    assert!(
        d.world.rod().held,
        "unhooked, the rod is still in the gripper"
    );
    Ok(())
}
