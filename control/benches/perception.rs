//! Perception on one synthetic 1280x1024 wrist capture (wire at 0.3-0.6 m, plane and boxes,
//! z² noise, grazing holes, outliers): ROI -> points -> normals -> RANSAC cylinder -> LM,
//! and the full-frame depth -> point conversion.

use std::hint::black_box;

use control::perception::point_cloud::PinholeCamera;
use control::perception::roi::{PixelRoi, extract_roi};
use control::perception::synthetic::{NoiseModel, WireScene, wrist_rays};
use control::perception::wire::{WireParams, detect_wire};
use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::Vector3;

fn perception(c: &mut Criterion) {
    let Ok(rays) = wrist_rays() else {
        panic!("nominal camera");
    };
    let cam = PinholeCamera::wrist_nominal();
    let scene = WireScene::random(11);
    let depth = scene.render(&rays, &NoiseModel::default(), 12);
    let w = scene.wire;
    let across = w.direction.cross(&Vector3::z()).normalize();
    let centre = w.centre + across * 0.01;
    let Ok(roi) = PixelRoi::around_segment(
        &cam,
        &(centre - w.direction * 0.3),
        &(centre + w.direction * 0.3),
        80.0,
        0.06,
    ) else {
        panic!("roi");
    };
    let params = WireParams::default();
    c.bench_function("wire_detect/1280x1024", |b| {
        b.iter(|| detect_wire(black_box(&depth), &rays, cam.fx, black_box(&roi), &params))
    });
    let full = PixelRoi::full(&cam, 0.0, f64::INFINITY);
    c.bench_function("depth_to_points/1280x1024", |b| {
        b.iter(|| extract_roi(black_box(&depth), &rays, &full, 1))
    });
}

criterion_group!(benches, perception);
criterion_main!(benches);
