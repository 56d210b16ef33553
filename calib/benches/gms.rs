//! GMS on the 2000 nearest-neighbour matches of the bench frame and its homography warp
//! (see `benches/orb.rs`), beside `cv2.xfeatures2d.matchGMS` in
//! `scripts/features/bench_opencv.py`.

use std::hint::black_box;
use std::path::Path;

use calib::features::command::{crop_resize, load_gray};
use calib::features::synth::{textured_image, warp_homography};
use calib::features::{
    GmsParams, GrayBuf, MatchParams, OrbParams, detect_and_describe, gms_filter, match_brute_force,
};
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
