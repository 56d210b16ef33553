//! Hand-eye solver timings: `ours` (Kronecker + LM) and the Kronecker/SVD form alone on
//! 18 poses (153 pairs), noisy synthetic data.

use std::hint::black_box;

use calib::handeye::{HandEyeOptions, Method, solve};
use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

fn data(n: usize) -> (Vec<Isometry3<f64>>, Vec<Isometry3<f64>>) {
    let mut rng = rng::SplitMix64::new(7);
    let x = Isometry3::from_parts(
        Translation3::new(0.05, 0.02, -0.08),
        UnitQuaternion::from_scaled_axis(
            Vector3::new(1.0, -2.0, 0.5).normalize() * std::f64::consts::FRAC_PI_6,
        ),
    );
    let base_from_world =
        Isometry3::from_parts(Translation3::new(1.0, 0.2, 0.3), UnitQuaternion::identity());
    let mut hand = Vec::new();
    let mut eye = Vec::new();
    for _ in 0..n {
        let axis = Vector3::new(
            rng.uniform(-1., 1.),
            rng.uniform(-1., 1.),
            rng.uniform(-1., 1.),
        );
        let h = Isometry3::from_parts(
            Translation3::new(
                rng.uniform(0.3, 0.8),
                rng.uniform(-0.3, 0.3),
                rng.uniform(0.2, 0.6),
            ),
            UnitQuaternion::from_scaled_axis(axis.normalize() * rng.uniform(0.2, 0.8)),
        );
        let world_from_cam = base_from_world.inverse() * h * x;
        let noise = Isometry3::from_parts(
            Translation3::new(
                1e-3 * rng.normal(),
                1e-3 * rng.normal(),
                1e-3 * rng.normal(),
            ),
            UnitQuaternion::from_scaled_axis(Vector3::new(
                1e-3 * rng.normal(),
                1e-3 * rng.normal(),
                1e-3 * rng.normal(),
            )),
        );
        hand.push(h);
        eye.push(world_from_cam * noise);
    }
    (hand, eye)
}

fn bench(c: &mut Criterion) {
    let (hand, eye) = data(18);
    let mut group = c.benchmark_group("handeye");
    for method in [Method::Ours, Method::Kronecker] {
        let opts = HandEyeOptions::with_method(method);
        group.bench_with_input(
            BenchmarkId::new(method.name(), "18poses_153pairs"),
            &opts,
            |b, opts| b.iter(|| solve(black_box(&hand), black_box(&eye), opts)),
        );
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
