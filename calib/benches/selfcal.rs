//! Self-calibration end to end (`calib::selfcal::self_calibrate`): synthetic RGB-D views of a
//! textured plane with boxes through the wrist camera (1280x1024, f = 1745 px), 18 views
//! (153 pairs), with ours, the paper's method and paper+ba side by side (the budget is < 1 s
//! wall on the 2-core machine). Also the per-stage parts (ORB on all views, matching + GMS
//! over all pairs).

use std::hint::black_box;

use calib::selfcal::pairs::{candidate_pairs, extract_features, match_pair};
use calib::selfcal::{SelfCalMethod, SelfCalParams};
use criterion::{Criterion, criterion_group, criterion_main};
use rayon::prelude::*;

#[path = "../tests/selfcal_support/mod.rs"]
mod selfcal_support;

fn bench(c: &mut Criterion) {
    let x = selfcal_support::true_x();
    let poses = selfcal_support::camera_poses(18);
    let (views, cam) =
        selfcal_support::views_with_camera(&poses, &x, true, selfcal_support::wrist_camera());
    let params = SelfCalParams::default();
    let mut g = c.benchmark_group("selfcal");
    g.sample_size(10);
    for method in [
        SelfCalMethod::Ours,
        SelfCalMethod::Paper,
        SelfCalMethod::PaperBa,
    ] {
        let p = SelfCalParams::for_method(&cam, method);
        g.bench_function(format!("{method}_rgbd_18views_1280x1024"), |b| {
            b.iter(|| calib::selfcal::self_calibrate(black_box(&views), &cam, &p))
        });
    }
    g.bench_function("orb_18views_1280x1024", |b| {
        b.iter(|| extract_features(black_box(&views), &params))
    });
    if let Ok(features) = extract_features(&views, &params) {
        let (cands, _) = candidate_pairs(&views, params.min_pair_rotation_deg);
        g.bench_function("match_gms_153pairs_2000kp", |b| {
            b.iter(|| {
                cands
                    .par_iter()
                    .map(|&p| match_pair(&features, (1280, 1024), p, &params).coords.len())
                    .collect::<Vec<_>>()
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
