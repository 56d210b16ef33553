//! GMS on the 2000 nearest-neighbour matches of the bench frame and its homography warp
//! (see `benches/orb.rs`), beside `cv2.xfeatures2d.matchGMS` in
//! `scripts/features/bench_opencv.py`.

use std::hint::black_box;

use calib::features::{
    GmsParams, MatchParams, OrbParams, detect_and_describe, gms_filter, match_brute_force,
};
use criterion::{Criterion, criterion_group, criterion_main};

#[path = "common/frames.rs"]
mod frames;
use frames::frames;

fn gms(c: &mut Criterion) {
    let (a, b) = frames();
    let (Ok(fa), Ok(fb)) = (
        detect_and_describe(&a.view(), &OrbParams::default()),
        detect_and_describe(&b.view(), &OrbParams::default()),
    ) else {
        panic!("ORB failed on the bench frames");
    };
    let matches = match_brute_force(&fa.descriptors, &fb.descriptors, &MatchParams::default());
    let size = (1280, 1024);
    for (name, params) in [
        ("plain", GmsParams::default()),
        (
            "rotation_scale",
            GmsParams {
                with_rotation: true,
                with_scale: true,
                ..GmsParams::default()
            },
        ),
    ] {
        c.bench_function(&format!("gms/{name}/{}_matches", matches.len()), |bch| {
            bch.iter(|| {
                gms_filter(
                    black_box(&fa.keypoints),
                    size,
                    black_box(&fb.keypoints),
                    size,
                    black_box(&matches),
                    &params,
                )
            })
        });
    }
}

criterion_group!(benches, gms);
criterion_main!(benches);
