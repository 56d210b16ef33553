//! The whole robot's forward kinematics: mobile base (planar pose in `map`), lift (prismatic
//! along z), AUBO i10 arm (DH), and the fixed frames.
//!
//! Tree of frames (ARCHITECTURE.md section 3; `*` = moving joint, published on `/tf`; others fixed, on
//! `/tf_static`):
//!
//! ```text
//! map -*-> base_link              planar pose (x, y, yaw): the base driver's odometry
//! base_link -*-> lift_link        lift_joint: base_from_lift = BASE_FROM_LIFT_ZERO Tz(lift_m)
//! lift_link ---> arm_base_link    LIFT_FROM_ARM_BASE (mount plate)
//! arm_base_link -*-> arm_shoulder_link -*-> ... -*-> arm_wrist3_link     joints 1..6
//! arm_wrist3_link ---> tool0      Tz(d6): tool0 = DH frame 6, the flange
//! base_link ---> panoramic_optical_frame     BASE_FROM_PANORAMIC_OPTICAL
//! tool0 -*-> camera_color_optical_frame      NOT here: the calibration stage publishes it
//! ```
//!
//! Arm link frames are the URDF-style frames of [`crate::dh`]: link `i` sits on joint `i`'s axis
//! (its z) and turns with the joint: `arm_base_from_link_1 = Rz(q1 + offset1)`,
//! `link_i_from_link_{i+1} = Tz(d_i) Tx(a_i) Rx(alpha_i) Rz(q_{i+1} + offset_{i+1})`.
//!
//! Chosen mount numbers (documented here; the simulator and the URDF use the same constants):
//! - `base_link` is on the ground below the base's centre of rotation (REP-105), x forward.
//! - The lift column stands on the base centre; `lift_link` (its top plate) is 0.60 m above the
//!   ground when fully lowered (`lift_m = 0`) and rises along z by `lift_m` in `[0, 2.0]` m at
//!   up to 0.10 m/s and 0.20 m/s^2 (a scissor/column lift carrying ~60 kg).
//! - `arm_base_link` is 0.03 m above `lift_link` (mounting plate), axes aligned with the base.
//! - `panoramic_optical_frame` is on a mast at (0.35, 0, 0.90) m in `base_link`, looking forward
//!   and pitched 45 deg up (towards the wires: a conductor 2.8 m above the mast and 1 m ahead
//!   is ~70 deg up, inside its view), OpenCV optical axes.
//! - `rod_link` is not part of the robot: the rod is a free body (on the rack, in the gripper, on
//!   the wire), published by whoever knows its pose; it is not in the URDF.

use crate::aubo_i10::{AUBO_I10_DH, aubo_i10_limits};
use crate::dh::DhTable;
use crate::ik::{ArmIk, IkGeometryError, IkSettings};
use crate::limits::JointLimit;
use crate::names;
use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};

/// Height of `lift_link` above `base_link` with the lift fully lowered (m).
pub const LIFT_ZERO_HEIGHT_M: f64 = 0.60;
/// Lift travel (m): `lift_m` in `[0, LIFT_TRAVEL_M]`.
pub const LIFT_TRAVEL_M: f64 = 2.0;
/// Lift maximum speed (m/s), chosen.
pub const LIFT_SPEED_MAX_M_S: f64 = 0.10;
/// Lift maximum acceleration (m/s^2), chosen.
pub const LIFT_ACCEL_MAX_M_S2: f64 = 0.20;
/// Height of `arm_base_link` above `lift_link` (m): the mounting plate.
pub const ARM_MOUNT_HEIGHT_M: f64 = 0.03;
/// Position of the panoramic camera in `base_link` (m).
pub const PANORAMIC_POSITION_M: [f64; 3] = [0.35, 0.0, 0.90];
/// Upward pitch of the panoramic camera's optical axis (rad): 45 deg.
pub const PANORAMIC_PITCH_UP_RAD: f64 = std::f64::consts::FRAC_PI_4;

/// One parent -> child edge of the frame tree with its current transform.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameEdge {
    /// Parent frame name.
    pub parent: &'static str,
    /// Child frame name.
    pub child: &'static str,
    /// `parent_from_child`.
    pub parent_from_child: Isometry3<f64>,
}

/// Which physical joint an edge belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JointKind {
    /// The prismatic lift.
    Lift,
    /// Arm joint `0..6` (index 0 = joint 1).
    Arm(usize),
}

impl JointKind {
    /// The joint for a ARCHITECTURE.md section 3 joint name, `None` for names without a frame (e.g.
    /// `clamp_joint`) or unknown ones.
    #[must_use]
    pub fn from_name(name: &str) -> Option<Self> {
        if name == names::LIFT_JOINT {
            return Some(Self::Lift);
        }
        names::ARM_JOINTS
            .iter()
            .position(|j| *j == name)
            .map(Self::Arm)
    }
}

/// The nominal robot: AUBO i10 on a lift on a mobile base.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotModel {
    /// The arm's DH table.
    pub dh: DhTable,
    /// Arm joint limits (index 0 = joint 1).
    pub arm_limits: [JointLimit; 6],
    /// Lift joint limits (m).
    pub lift_limit: JointLimit,
    /// `base_from_lift` at `lift_m = 0`.
    pub base_from_lift_zero: Isometry3<f64>,
    /// `lift_from_arm_base` (fixed).
    pub lift_from_arm_base: Isometry3<f64>,
    /// `base_from_panoramic_optical` (fixed).
    pub base_from_panoramic_optical: Isometry3<f64>,
}

impl Default for RobotModel {
    fn default() -> Self {
        Self::nominal()
    }
}

impl RobotModel {
    /// The nominal model: ARCHITECTURE.md section 6 DH table and limits, mount numbers of the module docs.
    #[must_use]
    pub fn nominal() -> Self {
        Self {
            dh: AUBO_I10_DH,
            arm_limits: aubo_i10_limits(),
            lift_limit: JointLimit {
                position_min: 0.0,
                position_max: LIFT_TRAVEL_M,
                velocity_max: LIFT_SPEED_MAX_M_S,
                acceleration_max: LIFT_ACCEL_MAX_M_S2,
            },
            base_from_lift_zero: Isometry3::translation(0.0, 0.0, LIFT_ZERO_HEIGHT_M),
            lift_from_arm_base: Isometry3::translation(0.0, 0.0, ARM_MOUNT_HEIGHT_M),
            base_from_panoramic_optical: optical_looking_along(
                Vector3::from(PANORAMIC_POSITION_M),
                PANORAMIC_PITCH_UP_RAD,
            ),
        }
    }

    /// The closed-form IK solver for this model's arm (its DH table and limits).
    ///
    /// # Errors
    /// [`IkGeometryError`] when the DH table lacks the structure the closed form needs.
    pub fn arm_ik(&self, settings: IkSettings) -> Result<ArmIk, IkGeometryError> {
        ArmIk::new(self.dh, self.arm_limits, settings)
    }

    /// `arm_base_from_base = base_from_arm_base(lift_m)^-1`: turns a `base_link` target into
    /// the arm-base pose the IK solves for.
    #[must_use]
    pub fn arm_base_from_base(&self, lift_m: f64) -> Isometry3<f64> {
        self.base_from_arm_base(lift_m).inverse()
    }

    /// `base_from_lift = base_from_lift_zero Tz(lift_m)`.
    #[must_use]
    pub fn base_from_lift(&self, lift_m: f64) -> Isometry3<f64> {
        self.base_from_lift_zero * Translation3::new(0.0, 0.0, lift_m)
    }

    /// `base_from_arm_base = base_from_lift(lift_m) lift_from_arm_base`.
    #[must_use]
    pub fn base_from_arm_base(&self, lift_m: f64) -> Isometry3<f64> {
        self.base_from_lift(lift_m) * self.lift_from_arm_base
    }

    /// Flange pose in the arm base: `arm_base_from_tool0 = T_1 ... T_6` (DH).
    #[must_use]
    pub fn arm_base_from_tool0(&self, q_rad: &[f64; 6]) -> Isometry3<f64> {
        self.dh.forward(q_rad)
    }

    /// `base_from_tool0 = base_from_arm_base(lift_m) arm_base_from_tool0(q)`.
    #[must_use]
    pub fn base_from_tool0(&self, lift_m: f64, q_rad: &[f64; 6]) -> Isometry3<f64> {
        self.base_from_arm_base(lift_m) * self.arm_base_from_tool0(q_rad)
    }

    /// `map_from_tool0 = map_from_base base_from_tool0` (see [`crate::se3::planar_pose`]).
    #[must_use]
    pub fn map_from_tool0(
        &self,
        map_from_base: &Isometry3<f64>,
        lift_m: f64,
        q_rad: &[f64; 6],
    ) -> Isometry3<f64> {
        map_from_base * self.base_from_tool0(lift_m, q_rad)
    }

    /// The arm link frames in the arm base: element `i` is `arm_base_from_link`, links in
    /// [`names::ARM_LINKS`] order, followed by `arm_base_from_tool0` as element 6.
    #[must_use]
    pub fn arm_base_from_links(&self, q_rad: &[f64; 6]) -> [Isometry3<f64>; 7] {
        let links = self.dh.link_frames(q_rad);
        let mut out = [Isometry3::identity(); 7];
        out[..6].copy_from_slice(&links);
        out[6] = links[5] * self.wrist3_from_tool0();
        out
    }

    /// `arm_wrist3_link_from_tool0 = Tz(d6) Tx(a6) Rx(alpha6)` (fixed).
    #[must_use]
    pub fn wrist3_from_tool0(&self) -> Isometry3<f64> {
        self.dh.rows[5].fixed_part()
    }

    /// The moving edge of one joint at `position` (rad or m): `parent_from_child`.
    ///
    /// Arm joint `i` (0-based): parent = the previous link (or `arm_base_link`),
    /// `parent_from_child = fixed_part(i-1) Rz(q_i + offset_i)`.
    #[must_use]
    pub fn joint_edge(&self, joint: JointKind, position: f64) -> Option<FrameEdge> {
        match joint {
            JointKind::Lift => Some(FrameEdge {
                parent: names::BASE_LINK,
                child: names::LIFT_LINK,
                parent_from_child: self.base_from_lift(position),
            }),
            JointKind::Arm(i) => {
                let row = self.dh.rows.get(i)?;
                let child = *names::ARM_LINKS.get(i)?;
                let (parent, fixed) = match i.checked_sub(1) {
                    None => (names::ARM_BASE_LINK, Isometry3::identity()),
                    Some(prev) => (
                        *names::ARM_LINKS.get(prev)?,
                        self.dh.rows.get(prev)?.fixed_part(),
                    ),
                };
                Some(FrameEdge {
                    parent,
                    child,
                    parent_from_child: fixed * row.joint_rotation(position),
                })
            }
        }
    }

    /// The origin of the URDF joint for `joint` (its pose at position 0, the axis being z):
    /// for the lift `base_from_lift_zero`, for arm joint `i` `fixed_part(i-1) Rz(offset_i)`.
    #[must_use]
    pub fn joint_origin(&self, joint: JointKind) -> Option<Isometry3<f64>> {
        self.joint_edge(joint, 0.0).map(|e| e.parent_from_child)
    }

    /// All moving edges for a full configuration, lift first then joints 1..6.
    #[must_use]
    pub fn moving_edges(&self, lift_m: f64, q_rad: &[f64; 6]) -> Vec<FrameEdge> {
        std::iter::once((JointKind::Lift, lift_m))
            .chain(
                q_rad
                    .iter()
                    .enumerate()
                    .map(|(i, &q)| (JointKind::Arm(i), q)),
            )
            .filter_map(|(j, p)| self.joint_edge(j, p))
            .collect()
    }

    /// The fixed edges (for `/tf_static`): arm mount, flange, panoramic camera. Never the
    /// camera edge `tool0 -> camera_color_optical_frame` (ARCHITECTURE.md section 3).
    #[must_use]
    pub fn fixed_edges(&self) -> Vec<FrameEdge> {
        vec![
            FrameEdge {
                parent: names::LIFT_LINK,
                child: names::ARM_BASE_LINK,
                parent_from_child: self.lift_from_arm_base,
            },
            FrameEdge {
                parent: names::ARM_WRIST3_LINK,
                child: names::TOOL0,
                parent_from_child: self.wrist3_from_tool0(),
            },
            FrameEdge {
                parent: names::BASE_LINK,
                child: names::PANORAMIC_OPTICAL_FRAME,
                parent_from_child: self.base_from_panoramic_optical,
            },
        ]
    }
}

/// An optical frame (x right, y down, z forward) at `position_m`, looking along the parent's x
/// pitched up by `pitch_up_rad` about the parent's y axis.
fn optical_looking_along(position_m: Vector3<f64>, pitch_up_rad: f64) -> Isometry3<f64> {
    let (s, c) = pitch_up_rad.sin_cos();
    let z_opt = Vector3::new(c, 0.0, s);
    let x_opt = Vector3::new(0.0, -1.0, 0.0);
    let y_opt = z_opt.cross(&x_opt);
    let rotation = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x_opt, y_opt, z_opt]));
    Isometry3::from_parts(
        Translation3::from(position_m),
        UnitQuaternion::from_rotation_matrix(&rotation),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn chain_of_edges_equals_direct_fk() {
        let model = RobotModel::nominal();
        let q = [0.3, -1.2, 0.7, 2.0, -0.4, 1.1];
        let lift_m = 0.8;
        let mut base_from_frame = model.base_from_lift(lift_m) * model.lift_from_arm_base;
        let links = model.arm_base_from_links(&q);
        let arm_base = model.base_from_arm_base(lift_m);
        for (i, &qi) in q.iter().enumerate() {
            let edge = model.joint_edge(JointKind::Arm(i), qi).expect("arm joint");
            base_from_frame *= edge.parent_from_child;
            assert_eq!(edge.child, names::ARM_LINKS[i]);
            assert_relative_eq!(
                base_from_frame.to_homogeneous(),
                (arm_base * links[i]).to_homogeneous(),
                epsilon = 1e-12
            );
        }
        base_from_frame *= model.wrist3_from_tool0();
        assert_relative_eq!(
            base_from_frame.to_homogeneous(),
            model.base_from_tool0(lift_m, &q).to_homogeneous(),
            epsilon = 1e-12
        );
    }

    #[test]
    fn zero_pose_in_the_base() {
        let model = RobotModel::nominal();
        let p = model.base_from_tool0(0.5, &[0.0; 6]).translation.vector;
        let z = LIFT_ZERO_HEIGHT_M + 0.5 + ARM_MOUNT_HEIGHT_M + 1.5132;
        assert_relative_eq!(p, Vector3::new(0.0, -0.2953, z), epsilon = 1e-12);
        let map_from_base = crate::se3::planar_pose(1.0, 2.0, std::f64::consts::FRAC_PI_2);
        let pm = model
            .map_from_tool0(&map_from_base, 0.5, &[0.0; 6])
            .translation
            .vector;
        assert_relative_eq!(pm, Vector3::new(1.2953, 2.0, z), epsilon = 1e-12);
    }

    #[test]
    fn ik_through_the_lift() {
        let model = RobotModel::nominal();
        let ik = model.arm_ik(IkSettings::default()).expect("AUBO table");
        let q = [0.4, -0.6, 1.2, 0.3, 0.9, -0.5];
        let lift_m = 1.3;
        let base_from_tool0 = model.base_from_tool0(lift_m, &q);
        let target = model.arm_base_from_base(lift_m) * base_from_tool0;
        let best = ik.nearest(&target, &q).expect("reachable");
        assert!((0..6).all(|i| (best.q_rad[i] - q[i]).abs() < 1e-9));
    }

    #[test]
    fn panoramic_frame_is_optical_and_looks_up() {
        let model = RobotModel::nominal();
        let r = model.base_from_panoramic_optical.rotation;
        assert_relative_eq!((r * Vector3::x()), -Vector3::y(), epsilon = 1e-12);
        let forward = r * Vector3::z();
        let pitch = forward.z.atan2(forward.x);
        assert_relative_eq!(pitch, PANORAMIC_PITCH_UP_RAD, epsilon = 1e-12);
        assert!(forward.y.abs() < 1e-12, "looks straight ahead");
        assert!(
            (r * Vector3::y()).z < 0.0,
            "image down points towards the ground"
        );
    }

    #[test]
    fn joint_names_map_to_edges() {
        assert_eq!(JointKind::from_name("lift_joint"), Some(JointKind::Lift));
        assert_eq!(
            JointKind::from_name("arm_wrist3_joint"),
            Some(JointKind::Arm(5))
        );
        assert_eq!(JointKind::from_name("clamp_joint"), None);
        assert_eq!(JointKind::from_name("foo"), None);
        let model = RobotModel::nominal();
        assert!(
            model
                .fixed_edges()
                .iter()
                .all(|e| e.child != names::CAMERA_COLOR_OPTICAL_FRAME)
        );
    }
}
