//! Everything `rodlog calib match A B [--method ..] [--features N] [--distribution ..] [--json] [-o pic.png]`
//! does (ARCHITECTURE.md section 4), so the CLI only parses flags and prints: load two image
//! files (any format the `image` crate decodes here: PNG, JPEG; colour is converted to gray
//! with OpenCV's BT.601 weights), run [`match_images`], write the match picture, and render
//! the match JSON. This is the thin I/O shell around the pure front end.

use std::path::{Path, PathBuf};

use serde::Serialize;

use super::draw::draw_matches;
use super::gray::rgb_to_gray;
use super::{
    FeatureError, GrayView, KeypointDistribution, MatchImagesParams, MatchMethod, MatchResult,
    match_images,
};

/// The inputs of `rodlog calib match`.
#[derive(Clone, Debug, PartialEq)]
pub struct MatchCommand {
    /// Image A.
    pub image_a: PathBuf,
    /// Image B.
    pub image_b: PathBuf,
    /// `--method` (default `orb-gms`).
    pub method: MatchMethod,
    /// `--features` (default 2000): ORB's target count, SIFT's cap on the strongest.
    pub n_features: usize,
    /// `-o`: where to write the match picture (PNG or JPEG by extension).
    pub picture: Option<PathBuf>,
    /// `--distribution` (default the quadtree): how ORB keeps its features per level.
    pub distribution: KeypointDistribution,
}

impl MatchCommand {
    /// Defaults for two images: `orb-gms`, 2000 features, no picture.
    pub fn new(image_a: impl Into<PathBuf>, image_b: impl Into<PathBuf>) -> Self {
        Self {
            image_a: image_a.into(),
            image_b: image_b.into(),
            method: MatchMethod::OrbGms,
            n_features: 2000,
            picture: None,
            distribution: KeypointDistribution::Quadtree,
        }
    }
}

/// Reads an image file as 8-bit gray.
///
/// # Errors
/// [`FeatureError::ImageRead`] with the decoder's message.
pub fn load_gray(path: &Path) -> Result<image::GrayImage, FeatureError> {
    let img = image::open(path).map_err(|e| FeatureError::ImageRead {
        path: path.to_owned(),
        message: e.to_string(),
    })?;
    Ok(match img {
        image::DynamicImage::ImageLuma8(g) => g,
        other => rgb_to_gray(&other.to_rgb8()),
    })
}

/// Runs `rodlog calib match`: loads both images, matches them, writes the picture when
/// asked. Print [`match_json`] (for `--json`) or [`match_summary`] of the result.
///
/// # Errors
/// [`FeatureError::ImageRead`], [`FeatureError::ImageWrite`], [`FeatureError::InvalidParam`]
/// (e.g. `n_features` = 0), [`FeatureError::ImageTooSmall`].
pub fn run_match_command(cmd: &MatchCommand) -> Result<MatchResult, FeatureError> {
    if cmd.n_features == 0 {
        return Err(FeatureError::InvalidParam {
            name: "n_features",
            value: 0.0,
        });
    }
    let a = load_gray(&cmd.image_a)?;
    let b = load_gray(&cmd.image_b)?;
    let (va, vb) = (GrayView::from_image(&a), GrayView::from_image(&b));
    let mut params = MatchImagesParams::for_method(cmd.method);
    params.orb.n_features = cmd.n_features;
    params.orb.distribution = cmd.distribution;
    params.sift.n_features = cmd.n_features;
    let result = match_images(&va, &vb, cmd.method, &params)?;
    if let Some(out) = &cmd.picture {
        let pic = draw_matches(
            &va,
            &vb,
            &result.features_a.keypoints,
            &result.features_b.keypoints,
            &result.matches,
            &result.inliers,
        );
        pic.save(out).map_err(|e| FeatureError::ImageWrite {
            path: out.clone(),
            message: e.to_string(),
        })?;
    }
    Ok(result)
}

/// Centre crop of `img` to the aspect ratio of `width x height`, then a triangle-filter
/// resize to exactly that size (how the benchmarks make a 1280x1024 frame from a
/// 3264x1836 shecar photo).
pub fn crop_resize(img: &image::GrayImage, width: u32, height: u32) -> image::GrayImage {
    let (w, h) = img.dimensions();
    let target = f64::from(width) / f64::from(height.max(1));
    let (cw, ch) = if f64::from(w) / f64::from(h.max(1)) > target {
        (((f64::from(h) * target).round() as u32).min(w), h)
    } else {
        (w, ((f64::from(w) / target).round() as u32).min(h))
    };
    let crop = image::imageops::crop_imm(img, (w - cw) / 2, (h - ch) / 2, cw, ch).to_image();
    image::imageops::resize(&crop, width, height, image::imageops::FilterType::Triangle)
}

#[derive(Serialize)]
struct TimeJson {
    detect: f64,
    #[serde(rename = "match")]
    matching: f64,
    filter: f64,
}

#[derive(Serialize)]
struct MatchJson<'a> {
    method: &'a str,
    keypoints_a: usize,
    keypoints_b: usize,
    matches: Vec<[f32; 4]>,
    time_ms: TimeJson,
}

/// The match JSON of ARCHITECTURE.md section 4, one line:
/// `{"method":..,"keypoints_a":n,"keypoints_b":n,"matches":[[xa,ya,xb,yb],..],
/// "time_ms":{"detect":..,"match":..,"filter":..}}` with the accepted matches in full-size
/// pixels; floats are printed shortest round-trip exact (f32 coordinates, f64 times).
pub fn match_json(result: &MatchResult) -> String {
    let j = MatchJson {
        method: result.method.name(),
        keypoints_a: result.features_a.keypoints.len(),
        keypoints_b: result.features_b.keypoints.len(),
        matches: result.inlier_coordinates(),
        time_ms: TimeJson {
            detect: result.timings.detect_ms,
            matching: result.timings.match_ms,
            filter: result.timings.filter_ms,
        },
    };
    // Serialising plain structs of numbers and strings cannot fail.
    serde_json::to_string(&j).unwrap_or_default()
}

/// A one-paragraph human summary for the CLI without `--json`.
pub fn match_summary(result: &MatchResult) -> String {
    let kept = result.inliers.iter().filter(|&&k| k).count();
    format!(
        "{}: {} keypoints in A, {} in B, {} matches, {} kept; detect {:.1} ms, match {:.1} ms, filter {:.2} ms",
        result.method.name(),
        result.features_a.keypoints.len(),
        result.features_b.keypoints.len(),
        result.matches.len(),
        kept,
        result.timings.detect_ms,
        result.timings.match_ms,
        result.timings.filter_ms,
    )
}
