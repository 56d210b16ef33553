//! The bench frame pair shared by the matcher and GMS benches: a 1280x1024 crop of shecar
//! image 00 (a seeded synthetic scene when the sample is absent) and its homography warp,
//! the same pair `benches/orb.rs` writes for `scripts/features/bench_opencv.py`. Also
//! included by tests that want the same real frame.
#![allow(dead_code)] // each includer uses part of it

use std::path::Path;

use calib::features::GrayBuf;
use calib::features::command::{crop_resize, gray_from_encoded};
use calib::features::synth::{textured_image, warp_homography};
use nalgebra::Matrix3;

/// The homography `b_from_a` from frame A to frame B.
pub fn warp() -> Matrix3<f64> {
    Matrix3::new(0.95, -0.12, 60.0, 0.10, 0.97, -20.0, 2e-5, -1e-5, 1.0)
}

/// An image file as grey (calib decodes; the file is read here).
fn load_gray(path: &Path) -> Result<image::GrayImage, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    gray_from_encoded(&bytes).map_err(|e| format!("{}: {e}", path.display()))
}

/// A `width x height` centre crop of shecar image 00, or the seeded synthetic scene `seed`
/// (with a notice) when the shared data is absent.
pub fn shecar_or_synthetic(width: u32, height: u32, seed: u64) -> GrayBuf {
    let shecar = testkit::shared_data_dir().join("shecar/00.jpg");
    match load_gray(&shecar) {
        Ok(full) => GrayBuf {
            data: crop_resize(&full, width, height).into_raw(),
            width: width as usize,
            height: height as usize,
        },
        Err(e) => {
            eprintln!("shecar frame unavailable ({e}); using a synthetic scene");
            textured_image(width as usize, height as usize, seed)
        }
    }
}

/// Frame A and its warp B, both 1280x1024.
pub fn frames() -> (GrayBuf, GrayBuf) {
    let a = shecar_or_synthetic(1280, 1024, 1);
    let b = warp_homography(&a, &warp(), 1280, 1024, 0).unwrap_or_else(|| a.clone());
    (a, b)
}
