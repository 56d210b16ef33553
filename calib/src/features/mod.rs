//! The pose-acquisition front end of the paper (DESIGN.md section 6): ORB features kept
//! evenly by the ORB-SLAM quadtree, brute-force Hamming matching, and grid-based motion
//! statistics (GMS) that reject wrong matches without RANSAC.
//!
//! - [`orb`]: pyramid, FAST-9 ([`fast`]) with Harris ranking and the 20 -> 7 per-cell
//!   fallback, [`quadtree`] distribution, intensity-centroid orientation, steered rBRIEF
//!   with the learned test pattern of [`brief_pattern`].
//! - [`matcher`]: brute-force Hamming (popcount), cross-check and ratio options.
//! - [`gms`]: GMS inlier mask (3x3 neighbourhoods, threshold 6 sqrt(mean features), shifted
//!   grids, optional rotation and scale).
//! - [`draw`]: match pictures. [`command`]: what `rodlog calib match` runs.
//!
//! # Conventions
//! Pixel coordinates of the full-size image, x right, y down, origin at the centre of the
//! top-left pixel; angles in radians in image axes.
//!
//! Everything here is a pure function of its inputs except [`match_images`], which also
//! measures the wall time of its phases for the user-facing report (the algorithms
//! themselves never read a clock).

pub mod brief_pattern;
pub mod command;
pub mod draw;
pub mod fast;
pub mod gms;
pub mod gray;
pub mod matcher;
pub mod orb;
pub mod quadtree;
pub mod synth;

use std::path::PathBuf;
use std::time::Instant;

pub use gms::{GmsParams, gms_filter};
pub use gray::{GrayBuf, GrayView};
pub use matcher::{Match, MatchParams, match_brute_force};
pub use orb::{OrbExtractor, OrbParams};

/// Errors of the feature front end.
#[derive(Debug, thiserror::Error)]
pub enum FeatureError {
    /// The pixel buffer ends before the last pixel.
    #[error("image buffer holds {len} bytes, the view needs {needed}")]
    BufferTooShort {
        /// Bytes given.
        len: usize,
        /// Bytes needed.
        needed: usize,
    },
    /// Row stride smaller than the width.
    #[error("row stride {stride} is smaller than the width {width}")]
    BadStride {
        /// Width in pixels.
        width: usize,
        /// Stride in bytes.
        stride: usize,
    },
    /// No room for a keypoint inside the border.
    #[error("image {width}x{height} is too small for ORB: both sides must be >= {min} pixels")]
    ImageTooSmall {
        /// Width in pixels.
        width: usize,
        /// Height in pixels.
        height: usize,
        /// Smallest usable side (2 * edge threshold + 1).
        min: usize,
    },
    /// A parameter outside its valid range.
    #[error("invalid parameter {name} = {value}")]
    InvalidParam {
        /// Field name.
        name: &'static str,
        /// The rejected value.
        value: f64,
    },
    /// A matching method this build does not provide.
    #[error("unknown or unavailable matching method {name:?} (available: orb-gms, orb-bf)")]
    UnsupportedMethod {
        /// The requested name.
        name: String,
    },
    /// An image file could not be read or decoded.
    #[error("cannot read image {path}: {message}")]
    ImageRead {
        /// The file.
        path: PathBuf,
        /// The decoder's message.
        message: String,
    },
    /// An image file could not be written.
    #[error("cannot write image {path}: {message}")]
    ImageWrite {
        /// The file.
        path: PathBuf,
        /// The encoder's message.
        message: String,
    },
}

/// An ORB keypoint.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Keypoint {
    /// Column in full-resolution pixels (`x_level * scale^level`).
    pub x: f32,
    /// Row in full-resolution pixels.
    pub y: f32,
    /// Pyramid level it was found in (0 = full resolution).
    pub level: u8,
    /// Intensity-centroid orientation, radians in `(-pi, pi]`, image axes (x right, y down).
    pub angle_rad: f32,
    /// Harris response (higher is stronger).
    pub response: f32,
    /// Diameter of the described patch in full-resolution pixels (`patch_size * scale^level`).
    pub size: f32,
}

/// A 256-bit binary descriptor; bit `i` is bit `i % 64` of word `i / 64` (the byte order of
/// OpenCV's 32-byte descriptors read as little-endian words).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub struct Descriptor(pub [u64; 4]);

/// Keypoints and their descriptors (`keypoints[i]` <-> `descriptors[i]`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Features {
    /// Keypoints, grouped by pyramid level, finest first.
    pub keypoints: Vec<Keypoint>,
    /// One descriptor per keypoint.
    pub descriptors: Vec<Descriptor>,
}

/// ORB detection and description of `img` with fresh buffers (use an [`OrbExtractor`] to
/// reuse them across images).
///
/// # Errors
/// [`FeatureError::InvalidParam`] for bad parameters, [`FeatureError::ImageTooSmall`].
pub fn detect_and_describe(
    img: &GrayView<'_>,
    params: &OrbParams,
) -> Result<Features, FeatureError> {
    let mut ex = OrbExtractor::new(params.clone())?;
    let mut f = Features::default();
    ex.detect_and_describe(img, &mut f)?;
    Ok(f)
}

/// A matching pipeline of `rodlog calib match`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MatchMethod {
    /// ORB + quadtree, brute-force Hamming (nearest neighbour), GMS (the paper's method).
    OrbGms,
    /// ORB + quadtree, brute-force Hamming with cross-check; every match is kept.
    OrbBf,
}

impl MatchMethod {
    /// The CLI name (`orb-gms`, `orb-bf`).
    pub fn name(self) -> &'static str {
        match self {
            MatchMethod::OrbGms => "orb-gms",
            MatchMethod::OrbBf => "orb-bf",
        }
    }
}

impl std::str::FromStr for MatchMethod {
    type Err = FeatureError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "orb-gms" => Ok(MatchMethod::OrbGms),
            "orb-bf" => Ok(MatchMethod::OrbBf),
            other => Err(FeatureError::UnsupportedMethod {
                name: other.to_owned(),
            }),
        }
    }
}

/// Parameters of [`match_images`].
#[derive(Clone, Debug, PartialEq)]
pub struct MatchImagesParams {
    /// ORB parameters for both images.
    pub orb: OrbParams,
    /// Brute-force options ([`MatchImagesParams::for_method`] sets the method's defaults).
    pub matching: MatchParams,
    /// GMS options (used by [`MatchMethod::OrbGms`]).
    pub gms: GmsParams,
}

impl MatchImagesParams {
    /// Defaults for `method`: default ORB and GMS; nearest-neighbour matching for
    /// `OrbGms` (GMS wants every nearest neighbour), cross-checked for `OrbBf`.
    pub fn for_method(method: MatchMethod) -> Self {
        let matching = MatchParams {
            cross_check: method == MatchMethod::OrbBf,
            ..MatchParams::default()
        };
        Self {
            orb: OrbParams::default(),
            matching,
            gms: GmsParams::default(),
        }
    }
}

/// Wall time of the phases of [`match_images`], milliseconds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MatchTimings {
    /// ORB on both images (run concurrently when `matching.parallel`).
    pub detect_ms: f64,
    /// Brute-force matching.
    pub match_ms: f64,
    /// GMS (0 for `OrbBf`).
    pub filter_ms: f64,
}

/// Result of [`match_images`].
#[derive(Clone, Debug, PartialEq)]
pub struct MatchResult {
    /// The method run.
    pub method: MatchMethod,
    /// `(width, height)` of image A.
    pub size_a: (usize, usize),
    /// `(width, height)` of image B.
    pub size_b: (usize, usize),
    /// Features of A.
    pub features_a: Features,
    /// Features of B.
    pub features_b: Features,
    /// All brute-force matches (query in A, train in B).
    pub matches: Vec<Match>,
    /// `inliers[i]`: `matches[i]` survived the filter.
    pub inliers: Vec<bool>,
    /// Phase timings (not part of the algorithm's result; see [`match_images`]).
    pub timings: MatchTimings,
}

impl MatchResult {
    /// The accepted matches.
    pub fn inlier_matches(&self) -> impl Iterator<Item = &Match> + '_ {
        self.matches
            .iter()
            .zip(self.inliers.iter())
            .filter(|(_, k)| **k)
            .map(|(m, _)| m)
    }

    /// Accepted matches as `[xa, ya, xb, yb]` in full-size pixels.
    pub fn inlier_coordinates(&self) -> Vec<[f32; 4]> {
        self.inlier_matches()
            .filter_map(|m| {
                let a = self.features_a.keypoints.get(m.query as usize)?;
                let b = self.features_b.keypoints.get(m.train as usize)?;
                Some([a.x, a.y, b.x, b.y])
            })
            .collect()
    }
}

/// Detects, matches and filters features of two images with `method`.
///
/// The only impure part is the [`MatchTimings`] it reports (wall-clock `Instant`s around the
/// phases, for the `rodlog calib match` report and the matcher experiment); keypoints,
/// matches and the mask are deterministic and independent of the rayon thread count.
///
/// # Errors
/// Those of [`OrbExtractor::new`] and [`OrbExtractor::detect_and_describe`].
pub fn match_images(
    a: &GrayView<'_>,
    b: &GrayView<'_>,
    method: MatchMethod,
    params: &MatchImagesParams,
) -> Result<MatchResult, FeatureError> {
    let t0 = Instant::now();
    let run = |img: &GrayView<'_>| detect_and_describe(img, &params.orb);
    let (fa, fb) = if params.matching.parallel {
        rayon::join(|| run(a), || run(b))
    } else {
        (run(a), run(b))
    };
    let (fa, fb) = (fa?, fb?);
    let t1 = Instant::now();
    let matches = match_brute_force(&fa.descriptors, &fb.descriptors, &params.matching);
    let t2 = Instant::now();
    let size_a = (a.width(), a.height());
    let size_b = (b.width(), b.height());
    let inliers = match method {
        MatchMethod::OrbGms => gms_filter(
            &fa.keypoints,
            size_a,
            &fb.keypoints,
            size_b,
            &matches,
            &params.gms,
        ),
        MatchMethod::OrbBf => vec![true; matches.len()],
    };
    let t3 = Instant::now();
    let ms = |d: std::time::Duration| d.as_secs_f64() * 1e3;
    Ok(MatchResult {
        method,
        size_a,
        size_b,
        features_a: fa,
        features_b: fb,
        matches,
        inliers,
        timings: MatchTimings {
            detect_ms: ms(t1 - t0),
            match_ms: ms(t2 - t1),
            filter_ms: ms(t3 - t2),
        },
    })
}
