//! One RGB-D capture of the substation from a typical wrist pose (calibration cabinet at
//! ~0.45 m, noon, shadows and antialiasing on), at 1280x1024 and the 320x256 test preset,
//! plus the panoramic camera and the per-camera ray-table build.
//!
//! `cargo bench -p sim --bench render -- --warm-up-time 2 --measurement-time 10`

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::Vector3;
use sim::render::{
    LightConditions, RayTable, SensorParams, panoramic_camera, render_rgbd_with_rays,
    world_from_camera_looking_at, wrist_camera,
};
use sim::scene::SubstationBuilder;

fn bench(c: &mut Criterion) {
    let Ok((scene, layout)) = SubstationBuilder::new(1).build() else {
        return;
    };
    let Some(pose) = layout.cabinet_wrist_view() else {
        return;
    };
    let light = LightConditions::from_hour(12.0);
    let mut group = c.benchmark_group("render_rgbd");
    group.sample_size(10);
    for (name, k) in [
        ("wrist_1280x1024", Ok(wrist_camera())),
        ("wrist_320x256", wrist_camera().scaled(0.25)),
    ] {
        let Ok(k) = k else { continue };
        let Ok(rays) = RayTable::new(&k) else {
            continue;
        };
        let sensor = SensorParams::wrist();
        group.bench_function(name, |b| {
            b.iter(|| {
                black_box(render_rgbd_with_rays(
                    &scene,
                    &pose,
                    &rays,
                    &light,
                    &sensor,
                    black_box(7),
                ))
            });
        });
    }
    let pano = panoramic_camera();
    if let Ok(rays) = RayTable::new(&pano) {
        let spot = layout.world_from_robot_spot.translation.vector;
        let eye = nalgebra::Point3::new(spot.x, spot.y, 1.4);
        if let Some(pose) =
            world_from_camera_looking_at(&eye, &nalgebra::Point3::new(0.0, 0.0, 5.0), &Vector3::z())
        {
            let sensor = SensorParams::panoramic();
            group.bench_function("panoramic_640x360", |b| {
                b.iter(|| {
                    black_box(render_rgbd_with_rays(
                        &scene, &pose, &rays, &light, &sensor, 7,
                    ))
                });
            });
        }
    }
    group.bench_function("ray_table_1280x1024", |b| {
        b.iter(|| black_box(RayTable::new(&wrist_camera())));
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
