//! One closed-form IK call (all solutions) of the AUBO i10, for a generic reachable pose.

use criterion::{Criterion, criterion_group, criterion_main};
use robot::{AUBO_I10_DH, ArmIk};
use std::hint::black_box;

fn bench_ik(c: &mut Criterion) {
    let ik = ArmIk::aubo_i10();
    // A pose whose 8 analytic solutions are all inside the joint limits.
    let q = [0.2, 0.3, 1.0, -0.4, 1.0, 0.5];
    let pose = AUBO_I10_DH.forward(&q);
    c.bench_function("ik/aubo_i10/all_solutions/8", |b| {
        b.iter(|| ik.solve(black_box(&pose), None))
    });
    c.bench_function("ik/aubo_i10/nearest", |b| {
        b.iter(|| ik.nearest(black_box(&pose), black_box(&q)))
    });
    c.bench_function("fk/aubo_i10/flange", |b| {
        b.iter(|| AUBO_I10_DH.forward(black_box(&q)))
    });
}

criterion_group!(benches, bench_ik);
criterion_main!(benches);
