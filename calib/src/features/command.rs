//! `rodlog calib match` without the files (ARCHITECTURE.md section 4): decode two encoded
//! images (PNG, JPEG: bytes the caller read; colour is converted to grey with OpenCV's BT.601
//! weights), match them ([`match_images`]), draw the match picture, and render the match JSON.
//! The binary reads and writes the files; nothing here does I/O.

use image::{GrayImage, RgbImage};
use serde::Serialize;

use super::draw::draw_matches;
use super::gray::rgb_to_gray;
use super::{
    FeatureError, GrayView, KeypointDistribution, MatchImagesParams, MatchMethod, MatchResult,
    match_images,
};

/// How `rodlog calib match` matches a pair.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairMatching {
    /// `--method` (default `orb-gms`).
    pub method: MatchMethod,
    /// `--features` (default 2000): ORB's target count, SIFT's cap on the strongest.
    pub n_features: usize,
    /// `--distribution` (default the quadtree): how ORB keeps its features per level.
    pub distribution: KeypointDistribution,
}

impl Default for PairMatching {
    /// `orb-gms`, 2000 features, the quadtree.
    fn default() -> Self {
        Self {
            method: MatchMethod::OrbGms,
            n_features: 2000,
            distribution: KeypointDistribution::Quadtree,
        }
    }
}

/// Decodes an encoded image (any format the `image` crate decodes here: PNG, JPEG) to 8-bit
/// grey.
///
/// # Errors
/// [`FeatureError::ImageDecode`] with the decoder's message.
pub fn gray_from_encoded(bytes: &[u8]) -> Result<GrayImage, FeatureError> {
    let img = image::load_from_memory(bytes).map_err(|e| FeatureError::ImageDecode {
        message: e.to_string(),
    })?;
    Ok(match img {
        image::DynamicImage::ImageLuma8(g) => g,
        other => rgb_to_gray(&other.to_rgb8()),
    })
}

/// Matches image `a` against image `b` as `rodlog calib match` does. Print [`match_json`]
/// (for `--json`) or [`match_summary`] of the result.
///
/// # Errors
/// [`FeatureError::InvalidParam`] (e.g. `n_features` = 0), [`FeatureError::ImageTooSmall`].
pub fn match_pair(
    a: &GrayImage,
    b: &GrayImage,
    how: &PairMatching,
) -> Result<MatchResult, FeatureError> {
    if how.n_features == 0 {
        return Err(FeatureError::InvalidParam {
            name: "n_features",
            value: 0.0,
        });
    }
    let (va, vb) = (GrayView::from_image(a), GrayView::from_image(b));
    let mut params = MatchImagesParams::for_method(how.method);
    params.orb.n_features = how.n_features;
    params.orb.distribution = how.distribution;
    params.sift.n_features = how.n_features;
    match_images(&va, &vb, how.method, &params)
}

/// The match picture of a pair: both images side by side, the kept matches in green and the
/// rejected ones in red.
#[must_use]
pub fn match_picture(a: &GrayImage, b: &GrayImage, result: &MatchResult) -> RgbImage {
    draw_matches(
        &GrayView::from_image(a),
        &GrayView::from_image(b),
        &result.features_a.keypoints,
        &result.features_b.keypoints,
        &result.matches,
        &result.inliers,
    )
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
