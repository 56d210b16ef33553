//! `rodlog calib ...`: calibration tools (DESIGN.md section 4).
//!
//! `calib handeye` solves AX=XB from two TUM pose files: hand = `base_from_tool0`, eye =
//! `world_from_camera`, paired by equal timestamp. The result is always
//! **tool0_from_camera** (maps camera coordinates to tool0 coordinates).

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use calib::handeye::{HandEyeOptions, HandEyeSolution, Method, calibration_json, solve_tum};
use clap::{Args, Subcommand};

/// The camera frame a hand-eye result names as its child (DESIGN.md section 3).
const CAMERA_FRAME: &str = msgs::frames::CAMERA_COLOR_OPTICAL_FRAME;

/// `rodlog calib` subcommands.
#[derive(Debug, Subcommand)]
pub enum CalibCommand {
    /// Hand-eye calibration (AX=XB) from hand and eye pose files (TUM format).
    Handeye(HandeyeArgs),
}

/// Arguments of `rodlog calib handeye`.
#[derive(Debug, Args)]
pub struct HandeyeArgs {
    /// Hand poses (TUM: `timestamp tx ty tz qx qy qz qw`), base_from_tool0.
    #[arg(long)]
    pub hand: PathBuf,
    /// Eye poses (TUM), world_from_camera (world: a board or an SfM frame).
    #[arg(long)]
    pub eye: PathBuf,
    /// Solver: ours (default), kronecker, tsai, park, horaud, andreff, daniilidis.
    #[arg(long, default_value = "ours")]
    pub method: String,
    /// The eye translations are metric only up to one unknown scale: estimate it.
    #[arg(long)]
    pub scale_free: bool,
    /// Print one JSON object (DESIGN.md section 4) on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Runs a `calib` subcommand.
pub fn run(command: &CalibCommand) -> Result<()> {
    match command {
        CalibCommand::Handeye(args) => handeye(args),
    }
}

fn handeye(args: &HandeyeArgs) -> Result<()> {
    let method: Method = match args.method.parse() {
        Ok(m) => m,
        Err(_) => bail!(
            "unknown hand-eye method '{}': use one of ours, kronecker, tsai, park, horaud, andreff, daniilidis",
            args.method
        ),
    };
    let hand = std::fs::read_to_string(&args.hand)
        .with_context(|| format!("cannot read hand poses {}", args.hand.display()))?;
    let eye = std::fs::read_to_string(&args.eye)
        .with_context(|| format!("cannot read eye poses {}", args.eye.display()))?;
    let opts = HandEyeOptions {
        method,
        scale_free: args.scale_free,
        ..HandEyeOptions::default()
    };
    let solution = solve_tum(&hand, &eye, &opts).context("hand-eye calibration refused")?;
    if args.json {
        let value = calibration_json(&solution, method.name(), "poses", CAMERA_FRAME);
        println!("{}", serde_json::to_string(&value)?);
    } else {
        print_human(&solution, method);
    }
    Ok(())
}

fn print_human(s: &HandEyeSolution, method: Method) {
    let t = s.tool0_from_camera.translation.vector;
    let q = s.tool0_from_camera.rotation;
    let (roll, pitch, yaw) = q.euler_angles();
    println!(
        "tool0_from_camera  (parent tool0, child {CAMERA_FRAME}; maps camera points into tool0)"
    );
    println!("  method            {}", method.name());
    println!("  translation_m     [{:.6}, {:.6}, {:.6}]", t.x, t.y, t.z);
    println!(
        "  quaternion_xyzw   [{:.9}, {:.9}, {:.9}, {:.9}]",
        q.i, q.j, q.k, q.w
    );
    println!(
        "  rpy_deg           [{:.4}, {:.4}, {:.4}]",
        roll.to_degrees(),
        pitch.to_degrees(),
        yaw.to_degrees()
    );
    println!("  views / pairs     {} / {}", s.views, s.pairs);
    if !s.rejected_pairs.is_empty() {
        println!(
            "  rejected pairs    {} (hand/eye rotation angles disagree)",
            s.rejected_pairs.len()
        );
    }
    println!(
        "  residual (median) {:.4} deg, {:.3} mm",
        s.residual_rot_deg, s.residual_trans_mm
    );
    println!(
        "  sigma (1-sigma)   {:.4} deg, {:.3} mm",
        s.sigma_rot_deg, s.sigma_trans_mm
    );
    println!("  condition         {:.3}", s.condition);
    if (s.scale - 1.0).abs() > 0.0 {
        println!("  scale             {:.6} m per eye unit", s.scale);
    }
}
