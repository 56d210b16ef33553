//! Renders the substation from a few wrist poses and the panoramic camera, at noon, sunset
//! (400 lx) and dusk (~10 lx), and writes PNGs (colour and colourised depth).
//!
//! `cargo run -p sim --example render_views -- [OUT_DIR] [SCALE]` (default
//! `target/render_views`, scale 1.0 = 1280x1024).

// Wall-clock timings and hashed sets of a test, bench or example: not a stage, so the
// crate's determinism lints do not apply here.
#![allow(clippy::disallowed_methods, clippy::disallowed_types)]

use std::path::PathBuf;
use std::time::Instant;

use nalgebra::{Isometry3, Point3, Vector3};
use sim::render::{
    LightConditions, RayTable, RgbdFrame, SensorParams, panoramic_camera, render_rgbd_with_rays,
    world_from_camera_looking_at, wrist_camera,
};
use sim::scene::SubstationBuilder;

fn save_rgb(f: &RgbdFrame, path: &PathBuf) -> Result<(), Box<dyn std::error::Error>> {
    image::save_buffer(
        path,
        &f.rgb,
        f.width,
        f.height,
        image::ExtendedColorType::Rgb8,
    )?;
    Ok(())
}

/// Depth colourised with a blue (near) -> red (far) ramp over [z0, z1]; holes black.
fn save_depth(
    f: &RgbdFrame,
    z0: f32,
    z1: f32,
    path: &PathBuf,
) -> Result<(), Box<dyn std::error::Error>> {
    let mut out = Vec::with_capacity(f.depth_m.len() * 3);
    for &z in &f.depth_m {
        if z.is_finite() {
            let t = ((z - z0) / (z1 - z0)).clamp(0.0, 1.0);
            let r = (255.0 * (1.5 - (4.0 * t - 3.0).abs()).clamp(0.0, 1.0)) as u8;
            let g = (255.0 * (1.5 - (4.0 * t - 2.0).abs()).clamp(0.0, 1.0)) as u8;
            let b = (255.0 * (1.5 - (4.0 * t - 1.0).abs()).clamp(0.0, 1.0)) as u8;
            out.extend_from_slice(&[r, g, b]);
        } else {
            out.extend_from_slice(&[0, 0, 0]);
        }
    }
    image::save_buffer(
        path,
        &out,
        f.width,
        f.height,
        image::ExtendedColorType::Rgb8,
    )?;
    Ok(())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let out = PathBuf::from(
        args.get(1)
            .cloned()
            .unwrap_or_else(|| "target/render_views".into()),
    );
    let scale: f64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1.0);
    std::fs::create_dir_all(&out)?;
    let (scene, layout) = SubstationBuilder::new(1).build()?;
    println!("static primitives: {}", scene.static_primitive_count());
    let wrist = wrist_camera().scaled(scale)?;
    let pano = panoramic_camera();
    let wrist_rays = RayTable::new(&wrist)?;
    let pano_rays = RayTable::new(&pano)?;
    let up = Vector3::z();

    let c = layout.calibration_target_center;
    let nrm = layout.calibration_target_normal;
    let wire = layout.target_conductor().ok_or("no conductor")?;
    let wire_mid = wire.point_at(wire.span_m() * 0.5);
    let rod = layout.world_from_rod_stored;
    let rod_mid = rod * Point3::new(0.0, 0.0, 0.9);
    let spot = layout.world_from_robot_spot.translation.vector;

    let mut views: Vec<(&str, Isometry3<f64>, bool)> = Vec::new();
    let look = |eye: Point3<f64>, target: Point3<f64>| {
        world_from_camera_looking_at(&eye, &target, &up).ok_or("bad view")
    };
    views.push((
        "wrist_cabinet",
        look(
            c + nrm * 0.45 + Vector3::new(0.0, 0.08, 0.12),
            c + Vector3::new(0.0, 0.0, 0.25),
        )?,
        false,
    ));
    views.push((
        "wrist_cabinet_low",
        look(
            c + nrm * 0.35 + Vector3::new(0.0, -0.2, -0.35),
            c + Vector3::new(0.0, 0.05, -0.5),
        )?,
        false,
    ));
    views.push((
        "wrist_junction",
        look(
            c + nrm * 0.5 + Vector3::new(0.25, -0.8, 0.1),
            c + Vector3::new(0.3, -0.95, 0.1),
        )?,
        false,
    ));
    views.push((
        "wrist_labels",
        look(
            c + nrm * 0.4 + Vector3::new(0.0, -0.05, 0.45),
            c + Vector3::new(0.0, -0.15, 0.42),
        )?,
        false,
    ));
    views.push((
        "wrist_wire",
        look(wire_mid + Vector3::new(0.0, -0.25, -0.38), wire_mid)?,
        false,
    ));
    views.push((
        "wrist_rod",
        look(
            rod_mid + Vector3::new(0.35, 0.3, 0.15),
            rod_mid + Vector3::new(0.0, 0.0, 0.1),
        )?,
        false,
    ));
    let pano_eye = Point3::new(spot.x, spot.y, 1.4);
    views.push((
        "pano_wire",
        look(pano_eye, wire_mid + Vector3::new(-4.0, 0.0, 0.0))?,
        true,
    ));
    views.push((
        "pano_gantry",
        look(
            Point3::new(spot.x - 3.0, spot.y - 6.0, 1.6),
            Point3::new(0.0, 0.0, 5.0),
        )?,
        true,
    ));

    let hour_10_lux = 18.0 + 12.0 / std::f64::consts::PI * (4.52_f64 / 62.0).asin();
    let lights = [
        ("noon", LightConditions::from_hour(12.0)),
        ("sunset400lx", LightConditions::from_hour(18.0)),
        ("dusk10lx", LightConditions::from_hour(hour_10_lux)),
    ];
    for (name, pose, is_pano) in &views {
        for (lname, light) in &lights {
            let (rays, sensor) = if *is_pano {
                (&pano_rays, SensorParams::panoramic())
            } else {
                (&wrist_rays, SensorParams::wrist())
            };
            let t0 = Instant::now();
            let f = render_rgbd_with_rays(&scene, pose, rays, light, &sensor, 7);
            let ms = t0.elapsed().as_secs_f64() * 1e3;
            let valid =
                f.depth_m.iter().filter(|z| z.is_finite()).count() as f64 / f.depth_m.len() as f64;
            let mean = f.rgb.iter().map(|&b| f64::from(b)).sum::<f64>() / f.rgb.len() as f64;
            println!(
                "{name:18} {lname:12} {:5.1} ms  exposure {:8.3} ms gain {:5.2}  mean {mean:5.1}  depth valid {:4.1}%  aa {}",
                ms,
                f.exposure.exposure_s * 1e3,
                f.exposure.gain,
                100.0 * valid,
                f.antialiased_pixels
            );
            save_rgb(&f, &out.join(format!("{name}_{lname}.png")))?;
            if !is_pano && *lname != "dusk10lx" {
                save_depth(
                    &f,
                    0.25,
                    0.8,
                    &out.join(format!("{name}_{lname}_depth.png")),
                )?;
            }
        }
    }
    Ok(())
}
