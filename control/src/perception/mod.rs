//! Perception: wrist depth capture -> point cloud -> ROI -> wire axis (RANSAC cylinder of
//! known radius, refined) -> hanging point and approach normal; the rod's handle likewise;
//! a confidence score from measured fit quality (never from the illuminance reading).
//!
//! | module | holds |
//! |---|---|
//! | [`point_cloud`] | pinhole + plumb_bob camera, per-pixel ray table, depth image -> points, normals, `PointCloud2` |
//! | [`roi`] | pixel ROI from a prior, ROI extraction, the wrist camera's look pose |
//! | [`cylinder`] | RANSAC cylinder of known radius (2 points + normals) and LM refinement |
//! | [`wire`] | hanging point on the axis, approach normal, capture fusion, `PoseStamped` |
//! | [`sway`] | the wire's swing across the captures: its centre and the band it swings in |
//! | [`handle`] | the rod handle (a bar of known radius and length): pose |
//! | [`rack`] | the empty rack's pose from its post (a survey's few cm to a millimetre) |
//! | [`panoramic`] | the panoramic wire-region finder: plane of the wire, corrected map prior, wrist look pose |
//! | [`colour`] | colour confirmation of a depth fit: silhouette contrast in the registered colour image |
//! | [`confidence`] | quality metrics -> score in [0, 1], refusal threshold |
//! | [`synthetic`] | seeded synthetic depth captures (cylinder, plane, boxes, noise, holes) for tests and benches |
//!
//! Geometric ROI fitting replaces the paper's LA-Net segmentation (ARCHITECTURE.md section 6): the wire is
//! whatever a cylinder of the conductor's known radius explains best inside the ROI.
//!
//! # Conventions
//! Points are `nalgebra::Point3<f64>` in metres; the camera frame is
//! `camera_color_optical_frame` (OpenCV axes: x right, y down, z forward); transforms are
//! `a_from_b` (`base_from_camera * p_in_camera = p_in_base`). Depth images hold the z
//! coordinate (not the range) of each pixel, 0 or NaN for holes.

pub mod colour;
pub mod confidence;
pub mod cylinder;
pub mod handle;
pub mod panoramic;
pub mod point_cloud;
pub mod rack;
pub mod roi;
pub mod sway;
pub mod synthetic;
pub mod wire;

/// Conductor radius of the wire (m): 26.8 mm diameter (ARCHITECTURE.md section 6).
pub const WIRE_RADIUS_M: f64 = 0.0134;

/// Why perception produced no estimate (it refuses rather than guesses).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PerceptionError {
    /// The camera model is unusable (bad `CameraInfo`, or a distortion without an inverse).
    #[error("camera model: {0}")]
    Camera(#[from] robot::camera::CameraError),
    /// A depth or colour image does not match the camera or has an unsupported layout.
    #[error(
        "{image} image: {reason} (encoding {encoding}, {width}x{height}, step {step}, {bytes} bytes)"
    )]
    BadImage {
        /// Which image: `"depth"` or `"colour"`.
        image: &'static str,
        /// What is wrong.
        reason: &'static str,
        /// Its encoding.
        encoding: String,
        /// Width (px).
        width: u32,
        /// Height (px).
        height: u32,
        /// Row stride (bytes).
        step: u32,
        /// Data length (bytes).
        bytes: usize,
    },
    /// Too few valid points to fit.
    #[error("too few points: {got} valid, need at least {needed}")]
    TooFewPoints {
        /// Valid points available.
        got: usize,
        /// Minimum required.
        needed: usize,
    },
    /// RANSAC found no hypothesis with enough inliers.
    #[error("no cylinder: best hypothesis has {inliers} inliers of {points}, need {needed}")]
    NoCylinder {
        /// Inliers of the best hypothesis.
        inliers: usize,
        /// Points tried.
        points: usize,
        /// Minimum inliers required.
        needed: usize,
    },
    /// The fitted handle's visible length disagrees with the model.
    #[error("handle length {measured_m:.4} m, model {model_m:.4} m (tolerance {tolerance_m:.4} m)")]
    HandleLength {
        /// Measured inlier extent along the axis.
        measured_m: f64,
        /// Model length.
        model_m: f64,
        /// Allowed difference.
        tolerance_m: f64,
    },
    /// The view cuts the handle at both ends: its centre cannot be placed.
    #[error(
        "the view cuts the handle at both ends ({measured_m:.4} m of {model_m:.4} m seen): look from farther away"
    )]
    HandleCut {
        /// Seen extent along the axis.
        measured_m: f64,
        /// Model length.
        model_m: f64,
    },
    /// The estimate's confidence is below the acceptance threshold.
    #[error("refused: confidence {score:.3} < {threshold:.3} (limited by {limiting})")]
    LowConfidence {
        /// Score in [0, 1].
        score: f64,
        /// Acceptance threshold.
        threshold: f64,
        /// The factor that limited the score.
        limiting: &'static str,
    },
    /// No capture was given.
    #[error("no captures given")]
    NoCaptures,
    /// The wire prior does not project into the panoramic image.
    #[error(
        "panoramic: wire prior not in view ({samples_in_view} samples in the image, need {needed})"
    )]
    PanoramicNotInView {
        /// Prior samples inside the image.
        samples_in_view: usize,
        /// Minimum required.
        needed: usize,
    },
    /// No thin dark line along the prior in the panoramic image.
    #[error(
        "panoramic: no wire line ({inliers} inliers of {samples_in_view} samples in view, need {needed})"
    )]
    PanoramicNoWire {
        /// Inliers of the best line.
        inliers: usize,
        /// Prior samples inside the image.
        samples_in_view: usize,
        /// Minimum inliers required.
        needed: usize,
    },
    /// A geometric input is degenerate (non-finite or zero-length).
    #[error("degenerate input: {what}")]
    Degenerate {
        /// Which input.
        what: &'static str,
    },
}

impl PerceptionError {
    /// [`PerceptionError::BadImage`] for `message`, the `image` (`"depth"` or `"colour"`).
    #[must_use]
    pub fn bad_image(
        image: &'static str,
        message: &msgs::sensor_msgs::Image,
        reason: &'static str,
    ) -> Self {
        Self::BadImage {
            image,
            reason,
            encoding: message.encoding.clone(),
            width: message.width,
            height: message.height,
            step: message.step,
            bytes: message.data.len(),
        }
    }
}
