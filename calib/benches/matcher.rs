//! Brute-force Hamming matching, 2000 x 2000 ORB descriptors of the bench frame and its
//! homography warp (see `benches/orb.rs`). `sequential` is the one-thread figure compared
//! with OpenCV's `BFMatcher(NORM_HAMMING)` at `cv2.setNumThreads(1)`; `parallel` uses the
//! global rayon pool.

use std::hint::black_box;
use std::path::Path;

use calib::features::command::{crop_resize, load_gray};
use calib::features::synth::{textured_image, warp_homography};
use calib::features::{GrayBuf, MatchParams, OrbParams, detect_and_describe, match_brute_force};
use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::Matrix3;

fn frames() -> (GrayBuf, GrayBuf) {
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
    let hb = Matrix3::new(0.95, -0.12, 60.0, 0.10, 0.97, -20.0, 2e-5, -1e-5, 1.0);
    let b = warp_homography(&a, &hb, 1280, 1024, 0).unwrap_or_else(|| a.clone());
    (a, b)
}

fn matcher(c: &mut Criterion) {
    let (a, b) = frames();
    let (Ok(fa), Ok(fb)) = (
        detect_and_describe(&a.view(), &OrbParams::default()),
        detect_and_describe(&b.view(), &OrbParams::default()),
    ) else {
        panic!("ORB failed on the bench frames");
    };
    let id = format!("{}x{}", fa.descriptors.len(), fb.descriptors.len());
    let seq = MatchParams {
        parallel: false,
        ..MatchParams::default()
    };
    c.bench_function(&format!("bf_hamming/sequential/{id}"), |bch| {
        bch.iter(|| match_brute_force(black_box(&fa.descriptors), black_box(&fb.descriptors), &seq))
    });
    let cc = MatchParams {
        parallel: false,
        cross_check: true,
        ..MatchParams::default()
    };
    c.bench_function(&format!("bf_hamming/sequential_cross_check/{id}"), |bch| {
        bch.iter(|| match_brute_force(black_box(&fa.descriptors), black_box(&fb.descriptors), &cc))
    });
    let par = MatchParams::default();
    c.bench_function(&format!("bf_hamming/parallel/{id}"), |bch| {
        bch.iter(|| match_brute_force(black_box(&fa.descriptors), black_box(&fb.descriptors), &par))
    });
}

criterion_group!(benches, matcher);
criterion_main!(benches);
