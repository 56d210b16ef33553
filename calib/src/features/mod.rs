//! The pose-acquisition front end of the paper (ARCHITECTURE.md section 6): ORB features kept
//! evenly by the ORB-SLAM quadtree, brute-force Hamming matching, and grid-based motion
//! statistics (GMS) that reject wrong matches without RANSAC.
//!
//! - [`orb`]: pyramid, FAST-9 ([`fast`]) with Harris ranking and the 20 -> 7 per-cell
//!   fallback, [`quadtree`] distribution, intensity-centroid orientation, steered rBRIEF
//!   with the learned test pattern of [`brief_pattern`].
//! - [`matcher`]: brute-force Hamming (popcount), cross-check and ratio options.
//! - [`gms`]: GMS inlier mask (3x3 neighbourhoods, threshold 6 sqrt(mean features), shifted
//!   grids, optional rotation and scale).
//! - [`sift`]: the SIFT baseline (DoG scale space, orientation, 128-d descriptor) and its
//!   brute-force L2 ratio-test matcher.
//! - [`draw`]: match pictures. [`command`]: what `rodlog calib match` runs.
//! - [`match_images`]: one entry point for every [`MatchMethod`]; its [`MatchResult`] holds
//!   method-neutral [`Keypoint`]s and the method's [`Descriptors`] (binary or float).
//!
//! # Conventions
//! Pixel coordinates of the full-size image, x right, y down, origin at the centre of the
//! top-left pixel; angles in radians in image axes.
//!
//! Everything here is a pure function of its inputs except [`match_images`], which also
//! measures the wall time of its phases for the user-facing report (the algorithms
//! themselves never read a clock).

pub mod akaze;
pub mod brief_pattern;
pub mod command;
pub mod draw;
pub mod fast;
pub mod gms;
pub mod gray;
pub mod matcher;
pub mod orb;
pub mod quadtree;
pub mod sift;
pub mod synth;

use std::time::Instant;

pub use gms::{GmsParams, gms_filter};
pub use gray::{GrayBuf, GrayView};
pub use matcher::{Match, MatchParams, match_brute_force};
pub use orb::{KeypointDistribution, OrbExtractor, OrbParams};
pub use sift::{SiftFeatures, SiftKeypoint, SiftMatchParams, SiftParams};

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
    #[error("unknown or unavailable matching method {name:?} (available: {available})")]
    UnsupportedMethod {
        /// The requested name.
        name: String,
        /// The names [`MatchMethod::ALL`] accepts, comma separated.
        available: String,
    },
    /// Encoded image bytes could not be decoded.
    #[error("cannot decode the image: {message}")]
    ImageDecode {
        /// The decoder's message.
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
    /// SIFT (Lowe 2004), brute-force L2 with Lowe's ratio test 0.8; every match is kept.
    Sift,
    /// AKAZE (Alcantarilla et al. 2013), brute-force Hamming with the ratio test 0.8, then a
    /// fundamental-matrix RANSAC (1 px Sampson) keeps the epipolar-consistent matches.
    Akaze,
}

impl MatchMethod {
    /// Every method, in the order of the CLI help.
    pub const ALL: &'static [MatchMethod] = &[
        MatchMethod::OrbGms,
        MatchMethod::OrbBf,
        MatchMethod::Sift,
        MatchMethod::Akaze,
    ];

    /// The CLI name (`orb-gms`, `orb-bf`, `sift`, `akaze`).
    pub fn name(self) -> &'static str {
        match self {
            MatchMethod::OrbGms => "orb-gms",
            MatchMethod::OrbBf => "orb-bf",
            MatchMethod::Sift => "sift",
            MatchMethod::Akaze => "akaze",
        }
    }

    /// The names of [`MatchMethod::ALL`], comma separated.
    pub fn available() -> String {
        Self::ALL
            .iter()
            .map(|m| m.name())
            .collect::<Vec<_>>()
            .join(", ")
    }
}

impl std::str::FromStr for MatchMethod {
    type Err = FeatureError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .iter()
            .copied()
            .find(|m| m.name() == s)
            .ok_or_else(|| FeatureError::UnsupportedMethod {
                name: s.to_owned(),
                available: Self::available(),
            })
    }
}

/// Parameters of [`match_images`].
#[derive(Clone, Debug, PartialEq)]
pub struct MatchImagesParams {
    /// ORB parameters for both images (ORB methods).
    pub orb: OrbParams,
    /// Brute-force Hamming options of the ORB methods ([`MatchImagesParams::for_method`]
    /// sets the method's defaults); `parallel` also decides whether the two images are
    /// processed concurrently, for every method.
    pub matching: MatchParams,
    /// GMS options (used by [`MatchMethod::OrbGms`]).
    pub gms: GmsParams,
    /// SIFT parameters for both images ([`MatchMethod::Sift`]).
    pub sift: SiftParams,
    /// L2 ratio-test options ([`MatchMethod::Sift`]).
    pub sift_matching: SiftMatchParams,
    /// AKAZE, Hamming ratio test and fundamental RANSAC ([`MatchMethod::Akaze`]).
    pub akaze: akaze::AkazeRansacParams,
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
            sift: SiftParams::default(),
            sift_matching: SiftMatchParams::default(),
            akaze: akaze::AkazeRansacParams::default(),
        }
    }
}

/// Wall time of the phases of [`match_images`], milliseconds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MatchTimings {
    /// Detection and description of both images (run concurrently when
    /// `matching.parallel`).
    pub detect_ms: f64,
    /// Brute-force matching.
    pub match_ms: f64,
    /// The filter (GMS; 0 for methods without one).
    pub filter_ms: f64,
}

/// Descriptors of one image, in the representation of the method that made them.
#[derive(Clone, Debug, PartialEq)]
pub enum Descriptors {
    /// 256-bit rBRIEF (ORB methods).
    Binary(Vec<Descriptor>),
    /// 128-d SIFT descriptors (integers `0..=255` in `f32`).
    Sift(Vec<sift::SiftDescriptor>),
    /// 486-bit M-LDB (AKAZE).
    Mldb(Vec<akaze::MldbDescriptor>),
}

impl Default for Descriptors {
    fn default() -> Self {
        Descriptors::Binary(Vec::new())
    }
}

impl Descriptors {
    /// Number of descriptors.
    pub fn len(&self) -> usize {
        match self {
            Descriptors::Binary(d) => d.len(),
            Descriptors::Sift(d) => d.len(),
            Descriptors::Mldb(d) => d.len(),
        }
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The binary descriptors, if these are.
    pub fn binary(&self) -> Option<&[Descriptor]> {
        match self {
            Descriptors::Binary(d) => Some(d),
            _ => None,
        }
    }

    /// The SIFT descriptors, if these are.
    pub fn sift(&self) -> Option<&[sift::SiftDescriptor]> {
        match self {
            Descriptors::Sift(d) => Some(d),
            _ => None,
        }
    }
}

/// Keypoints and descriptors of one image in [`MatchResult`], whatever the method:
/// `keypoints[i]` <-> descriptor `i`. Method-specific keypoint fields are mapped onto
/// [`Keypoint`] (SIFT: `level` = octave + 1, so 0 is the doubled image; see
/// [`SiftKeypoint::to_keypoint`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ImageFeatures {
    /// Keypoints in full-size pixels.
    pub keypoints: Vec<Keypoint>,
    /// Their descriptors.
    pub descriptors: Descriptors,
}

impl From<Features> for ImageFeatures {
    fn from(f: Features) -> Self {
        Self {
            keypoints: f.keypoints,
            descriptors: Descriptors::Binary(f.descriptors),
        }
    }
}

impl From<akaze::AkazeFeatures> for ImageFeatures {
    fn from(f: akaze::AkazeFeatures) -> Self {
        Self {
            keypoints: f.keypoints,
            descriptors: Descriptors::Mldb(f.descriptors),
        }
    }
}

impl From<SiftFeatures> for ImageFeatures {
    fn from(f: SiftFeatures) -> Self {
        Self {
            keypoints: f.keypoints.iter().map(SiftKeypoint::to_keypoint).collect(),
            descriptors: Descriptors::Sift(f.descriptors),
        }
    }
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
    pub features_a: ImageFeatures,
    /// Features of B.
    pub features_b: ImageFeatures,
    /// All brute-force matches (query in A, train in B); `distance` is in the method's
    /// unit (Hamming bits for ORB, squared L2 for SIFT).
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
/// Those of the method's detector ([`OrbExtractor::new`],
/// [`OrbExtractor::detect_and_describe`], [`sift::detect_and_describe`]).
// The timings are the one impure output, for the `calib match` tool and the matcher
// experiment; no stage calls this (stages go through `selfcal`).
#[allow(clippy::disallowed_methods)]
pub fn match_images(
    a: &GrayView<'_>,
    b: &GrayView<'_>,
    method: MatchMethod,
    params: &MatchImagesParams,
) -> Result<MatchResult, FeatureError> {
    let t0 = Instant::now();
    let run = |img: &GrayView<'_>| -> Result<ImageFeatures, FeatureError> {
        match method {
            MatchMethod::OrbGms | MatchMethod::OrbBf => {
                detect_and_describe(img, &params.orb).map(ImageFeatures::from)
            }
            MatchMethod::Sift => {
                sift::detect_and_describe(img, &params.sift).map(ImageFeatures::from)
            }
            MatchMethod::Akaze => {
                akaze::detect_and_describe_akaze(img, &params.akaze.akaze).map(ImageFeatures::from)
            }
        }
    };
    let (fa, fb) = if params.matching.parallel {
        rayon::join(|| run(a), || run(b))
    } else {
        (run(a), run(b))
    };
    let (fa, fb) = (fa?, fb?);
    let t1 = Instant::now();
    let matches = match (&fa.descriptors, &fb.descriptors) {
        (Descriptors::Binary(da), Descriptors::Binary(db)) => {
            match_brute_force(da, db, &params.matching)
        }
        (Descriptors::Sift(da), Descriptors::Sift(db)) => {
            sift::match_l2_ratio(da, db, &params.sift_matching)
        }
        (Descriptors::Mldb(da), Descriptors::Mldb(db)) => {
            akaze::match_mldb(da, db, &params.akaze.matching)
        }
        // Both images always go through the same method, so kinds never differ.
        _ => Vec::new(),
    };
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
        MatchMethod::OrbBf | MatchMethod::Sift => vec![true; matches.len()],
        MatchMethod::Akaze => {
            akaze::verify_fundamental(
                &fa.keypoints,
                &fb.keypoints,
                &matches,
                &params.akaze.fundamental,
                params.akaze.seed,
            )
            .0
        }
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
