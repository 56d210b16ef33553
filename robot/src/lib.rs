//! AUBO i10 + lift + mobile base model: kinematics, inverse kinematics, URDF, TF buffer, the
//! wrist camera's model, the `robot_state` stage.
//!
//! Everything that knows the robot's geometry lives here (ARCHITECTURE.md section 1), shared by the
//! simulator, calibration and control. Pure maths in [`dh`], [`ik`], [`kinematics`], [`se3`],
//! [`tf_buffer`]; the message-facing parts are [`conversions`], [`urdf`] (text) and the
//! [`robot_state`] stage.
//!
//! | module | holds |
//! |---|---|
//! | [`dh`] | standard DH rows, chain FK, link frames |
//! | [`aubo_i10`] | the AUBO i10 table and limits (ARCHITECTURE.md section 6) |
//! | [`ik`] | closed-form IK, all 8 solutions, limits, nearest choice, singularities |
//! | [`kinematics`] | base (planar) + lift (prismatic) + arm: every frame, mount numbers |
//! | [`names`] | frame and joint names (ARCHITECTURE.md section 3) |
//! | [`camera`] | the camera model (pinhole + plumb_bob, from and to `CameraInfo`) every crate uses |
//! | [`camera_mount`] | the wrist camera's nominal mount `tool0_from_camera` |
//! | [`grounding_rod`] | the rod (the robot's tool): dimensions, grasp, hook window, clamp travel |
//! | [`urdf`] | the generated URDF |
//! | [`tf_buffer`] | TF tree with interpolation |
//! | [`robot_state`] | the `/joint_states` -> `/tf` stage |
//!
//! ```
//! use robot::{ArmIk, RobotModel};
//! let model = RobotModel::nominal();
//! let q_rad = [0.4, -0.6, 1.2, 0.3, 0.9, -0.5];
//! let base_from_tool0 = model.base_from_tool0(0.5, &q_rad); // lift at 0.5 m
//! let arm_base_from_tool0 = model.arm_base_from_base(0.5) * base_from_tool0;
//! let ik = ArmIk::aubo_i10();
//! let solutions = ik.solve(&arm_base_from_tool0, Some(&q_rad))?; // up to 8, nearest first
//! let best = &solutions.within_limits[0];
//! assert!((0..6).all(|i| (best.q_rad[i] - q_rad[i]).abs() < 1e-9));
//! # Ok::<(), robot::IkError>(())
//! ```
//!
//! # Conventions
//!
//! - Transforms are `nalgebra::Isometry3<f64>` named `a_from_b`: `a_from_b * p_in_b = p_in_a`
//!   (e.g. `arm_base_from_tool0`, `base_from_lift`). Composition chains read right to left:
//!   `a_from_c = a_from_b * b_from_c`. A TF edge `parent -> child` carries `parent_from_child`.
//! - SI units and radians everywhere (`_m`, `_rad`, `_rad_s`, `_ns` suffixes); degrees only in
//!   error messages and docs. Times are integer nanoseconds of the robot clock (`stamp_ns: u64`).
//! - Quaternions are `UnitQuaternion` (Hamilton, `w + xi + yj + zk`); on the wire they are
//!   written `(x, y, z, w)` as in ROS.
//! - Frames follow REP-103 (x forward, y left, z up) except the optical frames, which use the
//!   OpenCV axes (x right, y down, z forward). Frame and joint names are those of ARCHITECTURE.md section 3
//!   ([`names`]).
//! - The arm's kinematics is the standard DH table of ARCHITECTURE.md section 6 ([`aubo_i10`], [`dh`]);
//!   `arm_base_link` is DH frame 0 and `tool0` is DH frame 6 (the flange).

pub mod aubo_i10;
pub mod camera;
pub mod camera_mount;
pub mod conversions;
pub mod dh;
pub mod grounding_rod;
pub mod ik;
pub mod kinematics;
pub mod limits;
pub mod names;
pub mod robot_state;
pub mod se3;
pub mod tf_buffer;
pub mod urdf;

pub use aubo_i10::AUBO_I10_DH;
pub use camera::{CameraError, CameraModel};
pub use dh::{DhRow, DhTable};
pub use ik::{ArmIk, IkError, IkSettings, IkSolution, IkSolutions};
pub use kinematics::{FrameEdge, JointKind, RobotModel};
pub use limits::JointLimit;
pub use robot_state::{RobotStateConfig, RobotStateStage, robot_description_msg};
pub use tf_buffer::{TfBuffer, TfError};
pub use urdf::robot_urdf;
