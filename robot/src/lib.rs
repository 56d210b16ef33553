//! AUBO i10 + lift + mobile base model: kinematics, inverse kinematics, URDF, TF buffer, the `robot_state` stage.
