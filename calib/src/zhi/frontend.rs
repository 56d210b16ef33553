//! ZHI's feature front end: keypoints with descriptors per view, Lowe's ratio test
//! (`d1 < 0.8 d2`, Lowe 2004 sec. 7.1) between every pair of views.
//!
//! The paper's baseline uses SIFT ([`Detector::Sift`]); [`Detector::OrbBf`] (ORB with the
//! quadtree, Hamming distances, the same ratio test) is kept for comparison and for images
//! where SIFT is too slow.

use rayon::prelude::*;

use super::{ZhiError, ZhiParams};
use crate::features::sift::{self, SiftDescriptor, SiftMatchParams, SiftParams};
use crate::features::{
    Descriptor, GrayView, MatchParams, OrbExtractor, OrbParams, match_brute_force,
};
use crate::selfcal::CalibView;

/// Which detector/descriptor the front end uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Detector {
    /// SIFT (Lowe 2004), L2 distances: the baseline as its paper describes it.
    Sift,
    /// ORB (quadtree), Hamming distances.
    OrbBf,
}

impl Detector {
    /// Short name for reports (`sift`, `orb-bf`).
    pub fn name(self) -> &'static str {
        match self {
            Detector::Sift => "sift",
            Detector::OrbBf => "orb-bf",
        }
    }
}

/// Descriptors of one view.
#[derive(Debug, Clone, PartialEq)]
pub enum Descriptors {
    /// 256-bit binary (ORB).
    Binary(Vec<Descriptor>),
    /// 128-d float (SIFT).
    Float(Vec<SiftDescriptor>),
}

/// Keypoints (full-resolution pixels) and descriptors of one view.
#[derive(Debug, Clone, PartialEq)]
pub struct ViewFeatures {
    /// Keypoint positions `[x, y]`, pixels.
    pub points_px: Vec<[f32; 2]>,
    /// Their descriptors (same order).
    pub descriptors: Descriptors,
}

/// Features of every view (rayon, collected in view order).
///
/// # Errors
/// [`ZhiError::Features`] for invalid detector parameters.
pub fn detect_all(views: &[CalibView], params: &ZhiParams) -> Result<Vec<ViewFeatures>, ZhiError> {
    views.par_iter().map(|v| detect(&v.gray, params)).collect()
}

fn detect(gray: &image::GrayImage, params: &ZhiParams) -> Result<ViewFeatures, ZhiError> {
    match params.detector {
        Detector::OrbBf => {
            let orb = OrbParams {
                n_features: params.n_features,
                ..OrbParams::default()
            };
            let mut ex =
                OrbExtractor::new(orb.clone()).map_err(|e| ZhiError::Features(e.to_string()))?;
            let mut f = crate::features::Features::default();
            ex.detect_and_describe(&GrayView::from_image(gray), &mut f)
                .map_err(|e| ZhiError::Features(e.to_string()))?;
            let points_px = f
                .keypoints
                .iter()
                .map(|k| {
                    let (x, y) = orb.full_res_position(k, gray.width(), gray.height());
                    [x, y]
                })
                .collect();
            Ok(ViewFeatures {
                points_px,
                descriptors: Descriptors::Binary(f.descriptors),
            })
        }
        Detector::Sift => {
            let sp = SiftParams {
                n_features: params.n_features,
                // Views already run in parallel.
                parallel: false,
                ..SiftParams::default()
            };
            let f = sift::detect_and_describe(&GrayView::from_image(gray), &sp)
                .map_err(|e| ZhiError::Features(e.to_string()))?;
            let points_px = f.keypoints.iter().map(|k| [k.x, k.y]).collect();
            Ok(ViewFeatures {
                points_px,
                descriptors: Descriptors::Float(f.descriptors),
            })
        }
    }
}

/// Ratio-test matches `(index in a, index in b)` from `a` to `b`, ordered by index in `a`.
pub fn ratio_matches(a: &ViewFeatures, b: &ViewFeatures, ratio: f32) -> Vec<(usize, usize)> {
    match (&a.descriptors, &b.descriptors) {
        (Descriptors::Binary(da), Descriptors::Binary(db)) => {
            let mp = MatchParams {
                ratio: Some(ratio),
                parallel: false,
                ..MatchParams::default()
            };
            match_brute_force(da, db, &mp)
                .iter()
                .map(|m| (m.query as usize, m.train as usize))
                .collect()
        }
        (Descriptors::Float(da), Descriptors::Float(db)) => {
            let mp = SiftMatchParams {
                ratio: Some(ratio),
                cross_check: false,
                parallel: false,
            };
            sift::match_l2_ratio(da, db, &mp)
                .iter()
                .map(|m| (m.query as usize, m.train as usize))
                .collect()
        }
        _ => Vec::new(),
    }
}
