//! Motion: time-parameterised joint trajectories within the speed and acceleration limits,
//! their checker, straight-line Cartesian approach/retreat through the closed-form IK,
//! collision checks of the arm against platform, rod and wire, base path planning on a
//! substation map, and the lift height for a target.
//!
//! | module | holds |
//! |---|---|
//! | [`trajectory`] | synchronised trapezoidal segments, sampling, `JointTrajectory`/`Path` output, `check_trajectory` |
//! | [`cartesian`] | straight-line tool0 motion via IK with branch continuity and singularity refusal |
//! | [`collision`] | capsules, boxes, segment distances; the arm as capsules; configuration and trajectory checks |
//! | [`base_planner`] | occupancy grid, footprint inflation, 8-connected A* |
//! | [`lift`] | lift height that puts the target in the arm's dexterous workspace |
//! | [`planner`] | IK to a tool0 goal, checked plan, its `/arm/joint_trajectory` and `/arm/planned_path` |
//! | [`roadmap`] | RRT-Connect in joint space with shortcuts: a path around obstacles where the fixed detours fail |
//! | [`checker`] | the log checker: every commanded and executed arm motion within limits and collision-free |
//!
//! # Conventions
//! Joint vectors are `[f64; 6]` in radians (J1..J6); times are integer nanoseconds
//! (`dt_ns`); transforms are `a_from_b` isometries; SI units everywhere.

pub mod base_planner;
pub mod cartesian;
pub mod checker;
pub mod collision;
pub mod lift;
pub mod planner;
pub mod roadmap;
pub mod trajectory;

/// Why a motion could not be planned.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MotionError {
    /// A waypoint or pose is non-finite.
    #[error("non-finite input: {what} (index {index})")]
    NonFinite {
        /// Which input.
        what: &'static str,
        /// Its index.
        index: usize,
    },
    /// A waypoint is outside the joint limits.
    #[error("waypoint {waypoint}: joint {joint} at {value:.4} outside [{min:.4}, {max:.4}]")]
    OutsideLimits {
        /// Waypoint index.
        waypoint: usize,
        /// Joint index (1-based).
        joint: usize,
        /// Its value.
        value: f64,
        /// Lower limit.
        min: f64,
        /// Upper limit.
        max: f64,
    },
    /// The sampling period is zero.
    #[error("sampling period {dt_ns} ns must be positive")]
    BadPeriod {
        /// The period.
        dt_ns: u64,
    },
    /// No IK solution along a Cartesian path.
    #[error("Cartesian step {step} of {steps}: {source}")]
    Ik {
        /// Step index.
        step: usize,
        /// Steps in the path.
        steps: usize,
        /// The IK failure.
        source: robot::IkError,
    },
    /// The start configuration does not reach the start pose.
    #[error("start configuration is {distance_m:.6} m / {angle_rad:.6} rad from the start pose")]
    StartMismatch {
        /// Position mismatch.
        distance_m: f64,
        /// Orientation mismatch.
        angle_rad: f64,
    },
    /// Consecutive IK solutions jumped (branch change).
    #[error(
        "Cartesian step {step}: joint {joint} jumps {jump_rad:.4} rad (> {max_rad:.4}) or branch changed"
    )]
    BranchJump {
        /// Step index.
        step: usize,
        /// Joint index (1-based).
        joint: usize,
        /// The jump.
        jump_rad: f64,
        /// Allowed per step.
        max_rad: f64,
    },
    /// The path passes too close to a singularity.
    #[error(
        "Cartesian step {step}: near singularity (|sin q5| {wrist_sin:.4}, |sin beta| {elbow_sin:.4}, shoulder {shoulder_m:.4} m)"
    )]
    NearSingularity {
        /// Step index.
        step: usize,
        /// `|sin q5|`.
        wrist_sin: f64,
        /// `|sin β|` (elbow).
        elbow_sin: f64,
        /// Wrist-centre distance from the plane of axes 1-2 (m).
        shoulder_m: f64,
    },
    /// A configuration collides.
    #[error("collision at sample {sample}: {link} vs {obstacle}, clearance {clearance_m:.4} m")]
    Collision {
        /// Sample index.
        sample: usize,
        /// Link name.
        link: &'static str,
        /// Obstacle name.
        obstacle: String,
        /// Signed clearance (negative = penetration) (m).
        clearance_m: f64,
    },
    /// Start or goal cell is blocked or outside the grid.
    #[error("{which} ({x_m:.3}, {y_m:.3}) m is outside the map or blocked")]
    BlockedEndpoint {
        /// `start` or `goal`.
        which: &'static str,
        /// x (m).
        x_m: f64,
        /// y (m).
        y_m: f64,
    },
    /// A* exhausted the free space.
    #[error("no path: {expanded} cells expanded")]
    NoPath {
        /// Cells expanded.
        expanded: usize,
    },
    /// The grid's dimensions and data disagree.
    #[error("grid {width}x{height} needs {expected} cells, got {got}")]
    BadGrid {
        /// Width (cells).
        width: usize,
        /// Height (cells).
        height: usize,
        /// `width * height`.
        expected: usize,
        /// Cells given.
        got: usize,
    },
    /// No lift height reaches the target.
    #[error("no lift height in [{min_m:.3}, {max_m:.3}] m reaches the target ({tried} tried)")]
    NoLiftHeight {
        /// Lowest lift.
        min_m: f64,
        /// Highest lift.
        max_m: f64,
        /// Heights tried.
        tried: usize,
    },
}
