//! Hand-eye self-calibration: ORB features, matching, GMS, relative pose, AX=XB solvers, refinement.

pub mod board;
pub mod features;
pub mod handeye;
pub mod relpose;
pub mod selfcal;
pub mod zhi;
