//! Runs a scenario through the simulated world alone (commands played in 10 ms steps as the
//! `script` stage would) and prints message counts per topic and the wall time.
//!
//! `cargo run --release -p sim --example run_scenario -- NAME|FILE [key=value ...] [--png DIR]`
//! (`--png`: writes every wrist colour image as `DIR/wrist_NN.png`).

// Wall-clock timings and hashed sets of a test, bench or example: not a stage, so the
// crate's determinism lints do not apply here.
#![allow(clippy::disallowed_methods, clippy::disallowed_types)]

#[path = "../tests/common/mod.rs"]
mod common;

use std::collections::BTreeMap;

use msgs::RobotTime;
use scenario::Scenario;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let png_dir = args
        .iter()
        .position(|a| a == "--png")
        .and_then(|i| args.get(i + 1))
        .cloned();
    let name = args
        .first()
        .cloned()
        .unwrap_or_else(|| "calib-18".to_owned());
    let mut s = Scenario::find(&name)?;
    for set in args.iter().skip(1).filter(|a| a.contains('=')) {
        s.set_from_arg(set)?;
    }
    let wall = std::time::Instant::now();
    let (_, out) = common::run(&s, RobotTime::ZERO + s.duration)?;
    let secs = wall.elapsed().as_secs_f64();
    let mut per_topic: BTreeMap<(&str, &str), usize> = BTreeMap::new();
    for o in &out {
        *per_topic
            .entry((o.producer.as_str(), o.topic.as_str()))
            .or_default() += 1;
    }
    for ((p, t), n) in per_topic {
        println!("{n:>8}  {p:<18} {t}");
    }
    if let Some(dir) = png_dir {
        std::fs::create_dir_all(&dir)?;
        let images = out
            .iter()
            .filter(|o| o.topic == msgs::topics::CAMERA_COLOR_IMAGE);
        for (i, img) in images
            .filter_map(|o| o.msg.get::<msgs::sensor_msgs::Image>())
            .enumerate()
        {
            let path = std::path::Path::new(&dir).join(format!("wrist_{i:02}.png"));
            image::save_buffer(
                &path,
                &img.data,
                img.width,
                img.height,
                image::ExtendedColorType::Rgb8,
            )?;
        }
    }
    println!(
        "{}: {} messages over {} s of robot time in {secs:.2} s wall",
        s.name,
        out.len(),
        s.duration.as_secs_f64()
    );
    Ok(())
}
