//! ORB on a 1280x1024 frame with 2000 features (sequential, one thread).
//!
//! The frame is shecar `00.jpg` (centre-cropped to 5:4, resized), or a synthetic textured
//! scene when `../shared/data/shecar` is absent. The frame and a homography warp of it are
//! written to `target/features-bench/{a,b}.png` so `scripts/features/bench_opencv.py` times
//! OpenCV on the very same pixels. `RODLOG_SIMD=baseline` (or `avx2`) caps the vector level
//! of the kernels ([`simd`]) for an A/B of the same build.

use std::hint::black_box;
use std::path::Path;

use calib::features::{Features, GrayBuf, OrbExtractor, OrbParams};
use criterion::{Criterion, criterion_group, criterion_main};

#[path = "common/frames.rs"]
mod frames;

/// The bench frame pair of the other benches, also saved as PNGs for the OpenCV script.
pub fn bench_pair() -> (GrayBuf, GrayBuf) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let (a, b) = frames::frames();
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
