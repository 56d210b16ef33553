//! The bench frame pair shared by the matcher and GMS benches: a 1280x1024 crop of shecar
//! image 00 (a seeded synthetic scene when the sample is absent) and its homography warp,
//! the same pair `benches/orb.rs` writes for `scripts/features/bench_opencv.py`.

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

/// Frame A and its warp B, both 1280x1024.
pub fn frames() -> (GrayBuf, GrayBuf) {
    let shecar = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/shecar/00.jpg");
    let a = match load_gray(&shecar) {
        Ok(full) => GrayBuf {
            data: crop_resize(&full, 1280, 1024).into_raw(),
            width: 1280,
            height: 1024,
        },
        Err(e) => {
            eprintln!("shecar frame unavailable ({e}); benchmarking a synthetic scene");
            textured_image(1280, 1024, 1)
        }
    };
    let b = warp_homography(&a, &warp(), 1280, 1024, 0).unwrap_or_else(|| a.clone());
    (a, b)
}
