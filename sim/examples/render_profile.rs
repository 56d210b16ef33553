//! Renders the `render` benchmark's wrist capture (calibration cabinet at ~0.45 m, noon,
//! shadows and antialiasing on, 1280x1024) a few times and prints the CPU-independent
//! facts of the output: FNV-1a digests of the colour bytes and depth bits, the number of
//! antialiased pixels, and the wall time per capture. For instruction counts:
//!
//! `RAYON_NUM_THREADS=1 valgrind --tool=callgrind target/release/examples/render_profile 1`
//!
//! `cargo run --release -p sim --example render_profile -- [CAPTURES] [HOUR] [SCALE]`
//! (defaults 5, 12.0, 1.0).

// Wall-clock timings and hashed sets of a test, bench or example: not a stage, so the
// crate's determinism lints do not apply here.
#![allow(clippy::disallowed_methods, clippy::disallowed_types)]

use std::time::Instant;

use sim::render::{LightConditions, RayTable, SensorParams, render_rgbd_with_rays, wrist_camera};
use sim::scene::SubstationBuilder;

/// CPU time of this process (user + system, seconds) from `/proc/self/stat` (Linux; `None`
/// elsewhere): unlike wall time it does not grow when other processes share the cores.
fn cpu_time_s() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
    let rest = stat.rsplit_once(')')?.1;
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    // USER_HZ is 100 on every Linux ABI rodlog runs on.
    Some(ticks / 100.0)
}

/// FNV-1a, 64 bits: a stable digest to compare outputs between builds.
fn fnv1a(bytes: impl IntoIterator<Item = u8>) -> u64 {
    bytes.into_iter().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let captures: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(5);
    let hour: f64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(12.0);
    let scale: f64 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(1.0);
    let (scene, layout) = SubstationBuilder::new(1).build()?;
    let pose = layout.cabinet_wrist_view().ok_or("bad view")?;
    let rays = RayTable::new(&wrist_camera().scaled(scale)?)?;
    let light = LightConditions::from_hour(hour);
    let sensor = SensorParams::wrist();
    let cpu0 = cpu_time_s();
    let wall0 = Instant::now();
    for i in 0..captures {
        let t0 = Instant::now();
        let f = render_rgbd_with_rays(&scene, &pose, &rays, &light, &sensor, 7);
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        println!(
            "capture {i}: {ms:7.1} ms  rgb {:016x}  depth {:016x}  aa {}  exposure {:.6} ms",
            fnv1a(f.rgb.iter().copied()),
            fnv1a(f.depth_m.iter().flat_map(|z| z.to_bits().to_le_bytes())),
            f.antialiased_pixels,
            f.exposure.exposure_s * 1e3,
        );
    }
    if let (Some(a), Some(b)) = (cpu0, cpu_time_s()) {
        let n = captures.max(1) as f64;
        println!(
            "mean per capture: wall {:.1} ms, CPU {:.1} ms (all threads)",
            wall0.elapsed().as_secs_f64() * 1e3 / n,
            (b - a) * 1e3 / n
        );
    }
    Ok(())
}
