//! TF frame names and joint names of ARCHITECTURE.md section 3 (URDF link names = frame names).

/// Fixed world frame.
pub const MAP: &str = "map";
/// Mobile base.
pub const BASE_LINK: &str = "base_link";
/// Top of the lift.
pub const LIFT_LINK: &str = "lift_link";
/// Arm base.
pub const ARM_BASE_LINK: &str = "arm_base_link";
/// Arm link 1.
pub const ARM_SHOULDER_LINK: &str = "arm_shoulder_link";
/// Arm link 2.
pub const ARM_UPPERARM_LINK: &str = "arm_upperarm_link";
/// Arm link 3.
pub const ARM_FOREARM_LINK: &str = "arm_forearm_link";
/// Arm link 4.
pub const ARM_WRIST1_LINK: &str = "arm_wrist1_link";
/// Arm link 5.
pub const ARM_WRIST2_LINK: &str = "arm_wrist2_link";
/// Arm link 6.
pub const ARM_WRIST3_LINK: &str = "arm_wrist3_link";
/// Flange.
pub const TOOL0: &str = "tool0";
/// Wrist camera, OpenCV optical axes (x right, y down, z forward).
pub const CAMERA_COLOR_OPTICAL_FRAME: &str = "camera_color_optical_frame";
/// Panoramic camera, OpenCV optical axes.
pub const PANORAMIC_OPTICAL_FRAME: &str = "panoramic_optical_frame";
/// The grounding rod.
pub const ROD_LINK: &str = "rod_link";

/// All frames, from the world down the kinematic chain.
pub const ALL_FRAMES: [&str; 14] = [
    MAP,
    BASE_LINK,
    LIFT_LINK,
    ARM_BASE_LINK,
    ARM_SHOULDER_LINK,
    ARM_UPPERARM_LINK,
    ARM_FOREARM_LINK,
    ARM_WRIST1_LINK,
    ARM_WRIST2_LINK,
    ARM_WRIST3_LINK,
    TOOL0,
    CAMERA_COLOR_OPTICAL_FRAME,
    PANORAMIC_OPTICAL_FRAME,
    ROD_LINK,
];

/// Lift (prismatic, m).
pub const LIFT_JOINT: &str = "lift_joint";
/// Arm joint 1 (rad).
pub const ARM_SHOULDER_JOINT: &str = "arm_shoulder_joint";
/// Arm joint 2 (rad).
pub const ARM_UPPERARM_JOINT: &str = "arm_upperarm_joint";
/// Arm joint 3 (rad).
pub const ARM_FOREARM_JOINT: &str = "arm_forearm_joint";
/// Arm joint 4 (rad).
pub const ARM_WRIST1_JOINT: &str = "arm_wrist1_joint";
/// Arm joint 5 (rad).
pub const ARM_WRIST2_JOINT: &str = "arm_wrist2_joint";
/// Arm joint 6 (rad).
pub const ARM_WRIST3_JOINT: &str = "arm_wrist3_joint";
/// Clamp lead-screw travel (m).
pub const CLAMP_JOINT: &str = "clamp_joint";

/// The six arm joints in DH order (J1..J6).
pub const ARM_JOINT_NAMES: [&str; 6] = [
    ARM_SHOULDER_JOINT,
    ARM_UPPERARM_JOINT,
    ARM_FOREARM_JOINT,
    ARM_WRIST1_JOINT,
    ARM_WRIST2_JOINT,
    ARM_WRIST3_JOINT,
];

/// Every joint in order: lift, the six arm joints, clamp.
pub const JOINT_NAMES: [&str; 8] = [
    LIFT_JOINT,
    ARM_SHOULDER_JOINT,
    ARM_UPPERARM_JOINT,
    ARM_FOREARM_JOINT,
    ARM_WRIST1_JOINT,
    ARM_WRIST2_JOINT,
    ARM_WRIST3_JOINT,
    CLAMP_JOINT,
];
