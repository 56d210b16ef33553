//! ORB on a 1280x1024 frame with 2000 features (sequential, one thread).
//!
//! The frame is shecar `00.jpg` (centre-cropped to 5:4, resized), or a synthetic textured
//! scene when `../shared/data/shecar` is absent. The frame and a homography warp of it are
//! written to `target/features-bench/{a,b}.png` so `scripts/features/bench_opencv.py` times
//! OpenCV on the very same pixels. `RODLOG_SIMD=baseline` (or `avx2`) caps the vector level
//! of the kernels ([`simd`]) for an A/B of the same build.

use std::hint::black_box;
use std::path::Path;

use calib::features::command::{crop_resize, gray_from_encoded};
use calib::features::synth::{textured_image, warp_homography};
use calib::features::{Features, GrayBuf, OrbExtractor, OrbParams};
use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::Matrix3;

/// An image file as grey (calib decodes; the file is read here).
fn load_gray(path: &Path) -> Result<image::GrayImage, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    gray_from_encoded(&bytes).map_err(|e| format!("{}: {e}", path.display()))
}

/// The bench frame A and its warp B (also saved as PNGs for the OpenCV script).
pub fn bench_pair() -> (GrayBuf, GrayBuf) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let shecar = root.join("../shared/data/shecar/00.jpg");
    let a = match load_gray(&shecar) {
        Ok(full) => {
            let img = crop_resize(&full, 1280, 1024);
            GrayBuf {
                data: img.into_raw(),
                width: 1280,
                height: 1024,
            }
        }
        Err(e) => {
            eprintln!("shecar frame unavailable ({e}); benchmarking a synthetic scene");
            textured_image(1280, 1024, 1)
        }
    };
    let hb = Matrix3::new(0.95, -0.12, 60.0, 0.10, 0.97, -20.0, 2e-5, -1e-5, 1.0);
    let b = warp_homography(&a, &hb, 1280, 1024, 0).unwrap_or_else(|| a.clone());
    let dir = root.join("target/features-bench");
    if std::fs::create_dir_all(&dir).is_ok() {
        for (img, name) in [(&a, "a.png"), (&b, "b.png")] {
            if let Some(g) = image::GrayImage::from_raw(1280, 1024, img.data.clone()) {
                let _ = g.save(dir.join(name));
            }
        }
    }
    (a, b)
}

fn orb(c: &mut Criterion) {
    let (a, _) = bench_pair();
    let mut ex = match OrbExtractor::new(OrbParams::default()) {
        Ok(ex) => ex,
        Err(e) => panic!("default ORB parameters rejected: {e}"),
    };
    let mut f = Features::default();
    c.bench_function("orb/detect_and_describe/1280x1024/2000", |bch| {
        bch.iter(|| {
            let _ = ex.detect_and_describe(black_box(&a.view()), &mut f);
            black_box(f.keypoints.len())
        })
    });
}

criterion_group!(benches, orb);
criterion_main!(benches);
