//! Brute-force Hamming matching, 2000 x 2000 ORB descriptors of the bench frame and its
//! homography warp (see `benches/orb.rs`). `sequential` is the one-thread figure compared
//! with OpenCV's `BFMatcher(NORM_HAMMING)` at `cv2.setNumThreads(1)`; `parallel` uses the
//! global rayon pool.

use std::hint::black_box;

use calib::features::{MatchParams, OrbParams, detect_and_describe, match_brute_force};
use criterion::{Criterion, criterion_group, criterion_main};

#[path = "common/frames.rs"]
mod frames;
use frames::frames;

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
