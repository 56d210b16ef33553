//! Hand-eye calibration of the wrist camera: from a board, from poses, and by itself from
//! natural scene features (the paper's method, ARCHITECTURE.md section 6).
//!
//! | module | holds |
//! |---|---|
//! | [`features`] | ORB with the quadtree distribution, Hamming matching, GMS; AKAZE and SIFT baselines; match drawings |
//! | [`relpose`] | a pair's relative camera motion: essential matrix (five-point), fundamental matrix, RGB-D 3D-3D |
//! | [`handeye`] | `B X = X A` solvers over poses: the Kronecker/SVD form (eqs. 10-13) and the classic methods, with uncertainty |
//! | [`selfcal`] | self-calibration over views: pairs, motions, the solve, eq. 15 over feature tracks, the drift check, the calibration stage |
//! | [`board`] | chessboard corners, sub-pixel refinement and planar PnP, for board-based calibration |
//! | [`quantiles`] | the normal, chi-square, F and Hotelling T^2 quantiles of the statistical decisions |
//! | [`zhi`] | the ZHI baseline of the paper's comparisons (SIFT, structure from motion, SVD) |

pub mod board;
pub mod features;
pub mod handeye;
pub mod quantiles;
pub mod relpose;
pub mod selfcal;
pub mod zhi;
