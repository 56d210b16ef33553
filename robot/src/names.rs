//! Frame and joint names of ARCHITECTURE.md section 3 (TF frame names = URDF link names).
//!
//! The shared names are `msgs::frames`' constants, re-exported; this module adds the names only
//! the robot model needs (its fixed URDF joints, the arm links in chain order).

pub use msgs::frames::{
    ARM_BASE_LINK, ARM_FOREARM_JOINT, ARM_FOREARM_LINK, ARM_SHOULDER_JOINT, ARM_SHOULDER_LINK,
    ARM_UPPERARM_JOINT, ARM_UPPERARM_LINK, ARM_WRIST1_JOINT, ARM_WRIST1_LINK, ARM_WRIST2_JOINT,
    ARM_WRIST2_LINK, ARM_WRIST3_JOINT, ARM_WRIST3_LINK, BASE_LINK, CAMERA_COLOR_OPTICAL_FRAME,
    CLAMP_JOINT, LIFT_JOINT, LIFT_LINK, MAP, PANORAMIC_OPTICAL_FRAME, ROD_LINK, TOOL0,
};

/// The six arm joints in order (joint 1 first).
pub const ARM_JOINTS: [&str; 6] = msgs::frames::ARM_JOINT_NAMES;

/// Fixed joint `lift_link` -> `arm_base_link` (URDF only; rodlog's name).
pub const ARM_MOUNT_JOINT: &str = "arm_mount_joint";
/// Fixed joint `arm_wrist3_link` -> `tool0` (URDF only; rodlog's name).
pub const TOOL0_JOINT: &str = "tool0_joint";
/// Fixed joint `base_link` -> `panoramic_optical_frame` (URDF only; rodlog's name).
pub const PANORAMIC_JOINT: &str = "panoramic_joint";

/// The six arm link frames in order (the body of joint 1 first).
pub const ARM_LINKS: [&str; 6] = [
    ARM_SHOULDER_LINK,
    ARM_UPPERARM_LINK,
    ARM_FOREARM_LINK,
    ARM_WRIST1_LINK,
    ARM_WRIST2_LINK,
    ARM_WRIST3_LINK,
];
