//! Perception on one synthetic 1280x1024 wrist capture (wire at 0.3-0.6 m, plane and boxes,
//! z² noise, grazing holes, outliers): ROI -> points -> normals -> RANSAC cylinder -> LM,
//! the colour confirmation of the fitted silhouette, and the full-frame depth -> point
//! conversion.

use std::hint::black_box;

use control::perception::colour::LumaImage;
use control::perception::point_cloud::wrist_nominal;
use control::perception::roi::{PixelRoi, extract_roi};
use control::perception::synthetic::{NoiseModel, WireScene, wrist_rays};
use control::perception::wire::{WireParams, detect_wire};
use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::Vector3;
use rng::SplitMix64;

fn perception(c: &mut Criterion) {
    let Ok(rays) = wrist_rays() else {
        panic!("nominal camera");
    };
    let cam = wrist_nominal();
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
    // A registered colour image: the wire dark on a lighter background, 4 DN of noise.
    let mut rng = SplitMix64::new(13);
    let wire_far_z = w.centre.z + w.radius_m;
    let luma = LumaImage {
        width: depth.width,
        height: depth.height,
        luma: depth
            .depth_m
            .iter()
            .map(|&z| {
                let base = if z.is_finite() && f64::from(z) < wire_far_z {
                    60.0
                } else {
                    150.0
                };
                (base + rng.uniform(-4.0, 4.0)) as f32
            })
            .collect(),
    };
    let Ok(observation) = detect_wire(&depth, &rays, cam.fx, &roi, &params) else {
        panic!("wire");
    };
    c.bench_function("colour_confirm/1280x1024", |b| {
        b.iter(|| black_box(observation.clone()).confirm_in_colour(black_box(&luma), &cam))
    });
    let full = PixelRoi::full(&cam, 0.0, f64::INFINITY);
    c.bench_function("depth_to_points/1280x1024", |b| {
        b.iter(|| extract_roi(black_box(&depth), &rays, &full, 1))
    });
}

criterion_group!(benches, perception);
criterion_main!(benches);
