//! Relative pose timings on 1000 noisy matches with 30% outliers (ARCHITECTURE.md section 6, the wrist camera:
//! 0.5 px keypoints, 0.1 mm depth noise at 0.5 m growing with z^2): rigid 3D-3D RANSAC with
//! the anisotropic refinement, essential 5-point RANSAC with the Sampson refinement, and the
//! 5-point minimal solver alone.

use std::hint::black_box;

use calib::relpose::essential::essential_five_point;
use calib::relpose::{
    EssentialParams, RigidRansacParams, estimate_essential_ransac, estimate_rigid_ransac,
};
use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use nalgebra::Point2;

#[path = "../tests/relpose_support.rs"]
mod support;

use support::{SceneSpec, generate, true_a_from_b};

fn relpose(c: &mut Criterion) {
    let n = 1000;
    let s = generate(&SceneSpec::noisy(n, 0.3, 42), &true_a_from_b());
    let mut group = c.benchmark_group("relpose");
    group
        .sample_size(20)
        .warm_up_time(std::time::Duration::from_millis(500))
        .measurement_time(std::time::Duration::from_secs(3));
    let rigid = RigidRansacParams::default();
    group.bench_with_input(
        BenchmarkId::new("rigid_ransac_outliers30", n),
        &s,
        |b, s| {
            b.iter(|| {
                estimate_rigid_ransac(black_box(&s.p_in_a), black_box(&s.p_in_b), &rigid, 1)
                    .map(|e| e.inlier_count)
            });
        },
    );
    let essential = EssentialParams::default();
    group.bench_with_input(
        BenchmarkId::new("essential_ransac_outliers30", n),
        &s,
        |b, s| {
            b.iter(|| {
                estimate_essential_ransac(black_box(&s.x_a), black_box(&s.x_b), &essential, 1)
                    .map(|e| e.inlier_count)
            });
        },
    );
    let xa: [Point2<f64>; 5] =
        std::array::from_fn(|i| s.x_a.get(i).copied().unwrap_or(Point2::origin()));
    let xb: [Point2<f64>; 5] =
        std::array::from_fn(|i| s.x_b.get(i).copied().unwrap_or(Point2::origin()));
    group.bench_function("five_point_minimal", |b| {
        b.iter(|| essential_five_point(black_box(&xa), black_box(&xb)).map(|v| v.len()));
    });
    group.finish();
}

criterion_group!(benches, relpose);
criterion_main!(benches);
