//! `rodlog calib ...`: calibration tools (ARCHITECTURE.md section 4).
//!
//! `calib match` runs the calibration front end on two images: the tool a user reaches for
//! when a calibration looks wrong.
//!
//! `calib carry` reads the camera edge a run ended with (the self-calibration it accepted,
//! the drift check reference taken with it) and writes it as the next run's
//! `calibration.mount_*` and `calibration.reference_*` parameters ([`calib::selfcal::carry`]).
//!
//! `calib handeye` solves AX=XB from two TUM pose files: hand = `base_from_tool0`, eye =
//! `world_from_camera`, paired by equal timestamp. The result is always
//! **tool0_from_camera** (maps camera coordinates to tool0 coordinates).

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use calib::handeye::{HandEyeOptions, HandEyeSolution, Method, calibration_json, solve_tum};
use clap::{Args, Subcommand};

/// The camera frame a hand-eye result names as its child (ARCHITECTURE.md section 3).
const CAMERA_FRAME: &str = msgs::frames::CAMERA_COLOR_OPTICAL_FRAME;

/// `rodlog calib` subcommands.
#[derive(Debug, Subcommand)]
pub enum CalibCommand {
    /// Hand-eye calibration (AX=XB) from hand and eye pose files (TUM format).
    Handeye(HandeyeArgs),
    /// Match two images the way calibration does (ORB + quadtree, BF Hamming, GMS), or with
    /// a baseline (--method).
    Match(MatchArgs),
    /// Hand-eye calibration from a recording of a chessboard (corners, PnP, AX=XB).
    Board(BoardArgs),
    /// Hand-eye SELF-calibration from a recording's natural scene features (no board):
    /// RGB-D when depth is recorded, monocular otherwise.
    #[command(name = "self")]
    SelfCal(SelfArgs),
    /// The self-calibration a run accepted and its drift check reference, as the next run's
    /// parameters (`calibration.mount_*`, `calibration.reference_*`): the robot then starts
    /// from them instead of the nominal mount.
    Carry(CarryArgs),
}

/// Arguments of `rodlog calib carry`.
#[derive(Debug, Args)]
pub struct CarryArgs {
    /// Recording of a run whose calibration stage accepted a self-calibration
    /// (`/calibration/hand_eye`, and the camera edge on `/tf`) or took a drift check reference
    /// (`/calibration/check_reference`).
    pub rec: PathBuf,
    /// Write the parameters to this file (TOML lines for a scenario's `[parameters]`) instead
    /// of stdout.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Arguments of `rodlog calib self`.
#[derive(Debug, Args)]
pub struct SelfArgs {
    /// Recording with wrist images (and depth), camera info and the arm's /tf.
    pub rec: PathBuf,
    /// Method: ours (the paper's pipeline with our additions, the default), paper (the
    /// paper's method as written: Umeyama pair motions, Kronecker/SVD, LM on eq. 15 over the
    /// tracked features; needs depth), paper+ba (eq. 15 over X and the world points jointly)
    /// or zhi (the SIFT + SfM + SVD baseline, colour only).
    #[arg(long, default_value = "ours")]
    pub method: String,
    /// Print one JSON object (ARCHITECTURE.md section 4, plus per-pair reports) on stdout.
    #[arg(long)]
    pub json: bool,
    /// Also write the result as YAML (parent tool0, child camera, direction named).
    #[arg(long)]
    pub yaml: Option<PathBuf>,
    /// Also write OUT.mcap: the recording's messages plus the calibration stage's outputs
    /// (`/calibration/hand_eye`, `/calibration/matches`, the camera edge on `/tf`, `/rosout`),
    /// like `rodlog replay --out` with the calibration stage. Nothing is written on error.
    #[arg(long, value_name = "OUT.mcap")]
    pub out: Option<PathBuf>,
    /// Ignore recorded depth: the monocular path even when depth is present.
    #[arg(long)]
    pub mono: bool,
    /// Switch a step of the method on (repeatable): rigid-ransac, depth-weighted-motion,
    /// image-motion, pose-refinement, pair-rejection, angle-prior, guided-round,
    /// epipolar-refinement, consistency, eq15 (see `rodlog experiment ablation`).
    #[arg(long = "with", value_name = "STEP")]
    pub with_steps: Vec<String>,
    /// Switch a step of the method off (repeatable; names as for --with).
    #[arg(long = "without", value_name = "STEP")]
    pub without_steps: Vec<String>,
    /// How eq. 15's world points follow X (methods with eq. 15): fixed-from-start
    /// (triangulated once at the Kronecker X and held; the default), alternated (held during
    /// each LM, re-triangulated between them, to the fixed point) or retriangulated (at
    /// every X the LM evaluates).
    #[arg(long, value_enum, default_value_t = WorldPointsArg::FixedFromStart)]
    pub eq15_world_points: WorldPointsArg,
    /// ORB keypoint selection: quadtree (the paper's) or retain-best (the strongest corners;
    /// far more robust on noisy images, see `rodlog experiment noise --orb-distribution`).
    /// Default: the method's own (`SelfCalMethod::keypoint_distribution`: ours retain-best,
    /// the paper's the quadtree).
    #[arg(long, value_enum)]
    pub distribution: Option<Distribution>,
}

/// `--eq15-world-points` of `calib self` ([`calib::selfcal::eq15::WorldPoints`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum WorldPointsArg {
    /// Triangulated and held during each LM, re-triangulated between them.
    Alternated,
    /// Re-triangulated at every X the LM evaluates.
    Retriangulated,
    /// Triangulated once at the initial X.
    FixedFromStart,
}

/// Arguments of `rodlog calib board`.
#[derive(Debug, Args)]
pub struct BoardArgs {
    /// Recording with wrist images, camera info and the arm's /tf.
    pub rec: PathBuf,
    /// Inner corners, COLSxROWS (e.g. 6x8).
    #[arg(long)]
    pub board: String,
    /// Square size, metres.
    #[arg(long)]
    pub square: f64,
    /// Hand-eye solver (as for `calib handeye`).
    #[arg(long, default_value = "ours")]
    pub method: String,
    /// Print one JSON object (ARCHITECTURE.md section 4) on stdout.
    #[arg(long)]
    pub json: bool,
}

/// `--distribution` of `rodlog calib match` and `calib self`, `--orb-distribution` of the
/// calibration experiments ([`calib::features::KeypointDistribution`]).
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "kebab-case")]
pub enum Distribution {
    /// ORB-SLAM's quadtree (the paper's front end).
    Quadtree,
    /// The strongest corners, as OpenCV's ORB.
    RetainBest,
}

impl From<Distribution> for calib::features::KeypointDistribution {
    fn from(d: Distribution) -> Self {
        match d {
            Distribution::Quadtree => Self::Quadtree,
            Distribution::RetainBest => Self::RetainBest,
        }
    }
}

/// Arguments of `rodlog calib match`.
#[derive(Debug, Args)]
pub struct MatchArgs {
    /// First image (PNG or JPEG).
    pub image_a: PathBuf,
    /// Second image.
    pub image_b: PathBuf,
    /// orb-gms (default: the paper's front end), orb-bf (cross-checked, no filter), sift
    /// (Lowe's SIFT, L2 ratio test 0.8, no filter) or akaze (AKAZE, Hamming ratio test 0.8,
    /// fundamental-matrix RANSAC; all keypoints, --features does not apply).
    #[arg(long, default_value = "orb-gms")]
    pub method: String,
    /// Features per image (ORB's target; SIFT keeps at most this many strongest).
    #[arg(long, default_value_t = 2000)]
    pub features: usize,
    /// How ORB keeps its features on each pyramid level (ORB methods only): quadtree (the
    /// paper's, even coverage of the textured image) or retain-best (OpenCV's: the strongest
    /// corners, denser, so GMS finds more support but coverage is patchier).
    #[arg(long, value_enum, default_value_t = Distribution::Quadtree)]
    pub distribution: Distribution,
    /// Print the match JSON (ARCHITECTURE.md section 4) on stdout.
    #[arg(long)]
    pub json: bool,
    /// Write a side-by-side picture of the matches (kept green, rejected red).
    #[arg(short = 'o', long = "out")]
    pub picture: Option<PathBuf>,
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
    /// Print one JSON object (ARCHITECTURE.md section 4) on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Runs a `calib` subcommand.
pub fn run(command: &CalibCommand) -> Result<()> {
    match command {
        CalibCommand::Handeye(args) => handeye(args),
        CalibCommand::Match(args) => match_images(args),
        CalibCommand::Board(args) => board(args),
        CalibCommand::SelfCal(args) => self_calibration(args),
        CalibCommand::Carry(args) => carry(args),
    }
}

/// `calib carry`: the camera edge a recording ended with, its accepted self-calibration and
/// its drift check reference ([`calib::selfcal::CarryFinder`]) as parameters.
fn carry(args: &CarryArgs) -> Result<()> {
    let finder = read_carry(&args.rec)?;
    let results = finder.results();
    let Some(carried) = finder.finish() else {
        bail!(
            "{}: nothing to carry: no accepted self-calibration ({results} results on /calibration/hand_eye, none became the camera edge on /tf) and no drift check reference taken with the final camera edge on /calibration/check_reference; the run kept the camera edge it started with",
            args.rec.display()
        );
    };
    let mut what = Vec::new();
    match &carried.accepted {
        Some(a) => {
            let h = &a.message;
            what.push(format!(
                "the self-calibration accepted at {:.3} s ({}, {}, {} views; sigma {:.4} deg / {:.3} mm over the three axes)",
                a.log_time_ns as f64 * 1e-9,
                h.method,
                h.mode,
                h.views,
                h.sigma_rot_deg,
                h.sigma_trans_mm
            ));
        }
        None => {
            what.push("the camera edge the run kept (no calibration accepted in it)".to_owned())
        }
    }
    if let Some(r) = &carried.reference {
        let (rot_deg, trans_m) = calib::handeye::pose_error(&r.tool0_from_camera, &carried.edge);
        what.push(format!(
            "the drift check reference taken at {:.3} s ({rot_deg:.3} deg / {:.2} mm from the edge: what the check poses see of the arm's and camera_info's error)",
            r.log_time_ns as f64 * 1e-9,
            trans_m * 1e3
        ));
    }
    let text = format!(
        "# rodlog calib carry {}: {}.\n\
         # Under the next run's [parameters], or each line as --set KEY=VALUE.\n{}",
        args.rec.display(),
        what.join("; "),
        carried.parameters_toml()
    );
    match &args.out {
        Some(path) => {
            std::fs::write(path, &text).with_context(|| format!("cannot write {}", path.display()))
        }
        None => super::print_stdout(text.trim_end()),
    }
}

/// Reads what a recording leaves for the next run.
///
/// # Errors
/// An unreadable recording or an undecodable message, naming the file, topic and time.
pub(crate) fn read_carry(rec: &std::path::Path) -> Result<calib::selfcal::CarryFinder> {
    use calib::selfcal::CarryFinder;
    use replay::{McapReader, ReadFilter};

    let mut reader =
        McapReader::open(rec).with_context(|| format!("cannot read {}", rec.display()))?;
    let mut finder = CarryFinder::new();
    for m in reader.messages(&ReadFilter::all().with_topics(CarryFinder::TOPICS)) {
        let m = m.with_context(|| format!("reading {}", rec.display()))?;
        let msg = m
            .decode()
            .with_context(|| format!("{}: {} at {} ns", rec.display(), m.topic(), m.log_time_ns))?;
        finder.feed(m.log_time_ns, m.topic(), &msg);
    }
    Ok(finder)
}

fn handeye(args: &HandeyeArgs) -> Result<()> {
    let method = parse_method(&args.method)?;
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
        super::print_stdout(&serde_json::to_string(&value)?)?;
    } else {
        super::print_stdout(&human_text(&solution, method.name()))?;
    }
    Ok(())
}

fn parse_method(name: &str) -> Result<Method> {
    name.parse().map_err(|_| {
        anyhow::anyhow!(
            "unknown hand-eye method '{name}': use one of ours, kronecker, tsai, park, horaud, andreff, daniilidis"
        )
    })
}

fn board(args: &BoardArgs) -> Result<()> {
    use calib::board::{BoardOptions, BoardSpec, calibrate_board_views};
    let method = parse_method(&args.method)?;
    let spec = BoardSpec::from_arg(&args.board, args.square)?;
    let (views, camera) = super::recording_views::read_views(&args.rec)?;
    let images: Vec<image::GrayImage> = views.iter().map(|v| v.gray.clone()).collect();
    let board_views = calibrate_board_views(&images, &camera, &spec, &BoardOptions::default())
        .context("board calibration refused")?;
    let hand: Vec<_> = views.iter().map(|v| v.base_from_tool0).collect();
    let eye: Vec<_> = board_views.iter().map(|b| b.world_from_camera).collect();
    let opts = HandEyeOptions {
        method,
        ..HandEyeOptions::default()
    };
    let solution =
        calib::handeye::solve(&hand, &eye, &opts).context("hand-eye calibration refused")?;
    if args.json {
        let value = calibration_json(&solution, method.name(), "poses", CAMERA_FRAME);
        super::print_stdout(&serde_json::to_string(&value)?)?;
    } else {
        let rms: Vec<f64> = board_views.iter().map(|b| b.rms_px).collect();
        let worst = rms.iter().copied().fold(0.0_f64, f64::max);
        super::print_stdout(&format!(
            "board {}x{} ({:.1} mm squares) found in {} of {} images, reprojection RMS <= {worst:.3} px",
            spec.cols,
            spec.rows,
            args.square * 1e3,
            board_views.len(),
            views.len()
        ))?;
        super::print_stdout(&human_text(&solution, method.name()))?;
    }
    Ok(())
}

fn self_calibration(args: &SelfArgs) -> Result<()> {
    use calib::selfcal::{
        SelfCalParams, calibration_yaml, result_json, self_calibrate, views_from_messages,
    };
    if args.method == "zhi" {
        return self_calibration_zhi(args);
    }
    let method: calib::selfcal::SelfCalMethod = args.method.parse().map_err(|_| {
        anyhow::anyhow!(
            "calib self --method {}: use ours, paper, paper+ba or zhi",
            args.method
        )
    })?;
    let mut messages = super::recording_views::read_calibration_messages(&args.rec)?;
    if args.mono {
        messages.retain(|(topic, _)| topic != msgs::topics::CAMERA_DEPTH_IMAGE);
    }
    let (views, camera) = views_from_messages(&messages)
        .with_context(|| format!("cannot build calibration views from {}", args.rec.display()))?;
    let mut params = SelfCalParams::for_method(&camera, method);
    if let Some(d) = args.distribution {
        params.orb.distribution = d.into();
    }
    params.eq15.world_points = match args.eq15_world_points {
        WorldPointsArg::Alternated => calib::selfcal::eq15::WorldPoints::Alternated,
        WorldPointsArg::Retriangulated => calib::selfcal::eq15::WorldPoints::Retriangulated,
        WorldPointsArg::FixedFromStart => calib::selfcal::eq15::WorldPoints::FixedFromStart,
    };
    for (names, on) in [(&args.with_steps, true), (&args.without_steps, false)] {
        for name in names {
            params
                .steps
                .set(name, on)
                .map_err(|e| anyhow::anyhow!("calib self --with/--without: {e}"))?;
        }
    }
    if args.out.is_some() && !(args.with_steps.is_empty() && args.without_steps.is_empty()) {
        bail!(
            "calib self --out replays the calibration stage, which runs the method's own steps: drop --with/--without"
        );
    }
    let result = self_calibrate(&views, &camera, &params).context("self-calibration refused")?;
    let written = match &args.out {
        Some(out) => Some((
            out,
            write_calibrated_recording(&args.rec, out, views.len(), method, args)?,
        )),
        None => None,
    };
    if let Some(path) = &args.yaml {
        std::fs::write(path, calibration_yaml(&result, &args.method, CAMERA_FRAME))
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    if args.json {
        super::print_stdout(&serde_json::to_string(&result_json(
            &result,
            &args.method,
            CAMERA_FRAME,
        ))?)?;
    } else {
        super::print_stdout(&format!(
            "self-calibration ({}): {} views, {} of {} pairs used",
            result.mode.name(),
            views.len(),
            result.used_pairs(),
            result.pairs.len()
        ))?;
        super::print_stdout(&human_text(&result.solution, method.name()))?;
        if let Some(e) = &result.eq15 {
            super::print_stdout(&format!(
                "eq. 15 ({} world points): {} points, {} views, {} observations, {} iterations, cost {:.4e} -> {:.4e} m^2 (RMS {:.3} mm)",
                e.world_points.name(),
                e.points,
                e.views,
                e.observations,
                e.iterations,
                e.initial_cost,
                e.final_cost,
                e.rms_m * 1e3
            ))?;
        }
        if let Some((out, n)) = written {
            super::print_stdout(&format!(
                "wrote {n} messages (inputs + calibration stage outputs) to {}",
                out.display()
            ))?;
        }
    }
    Ok(())
}

/// `calib self --out`: the recording replayed through the calibration stage alone (every
/// recorded channel is an input except the stage's own, which are regenerated), calibrating
/// once after `captures` captures, into a temporary file beside `out` renamed over it only
/// when complete (never a half-written `out`).
fn write_calibrated_recording(
    rec: &std::path::Path,
    out: &std::path::Path,
    captures: usize,
    method: calib::selfcal::SelfCalMethod,
    args: &SelfArgs,
) -> Result<u64> {
    use calib::selfcal::{CalibrationStage, CalibrationStageConfig};
    use recorder::{McapSink, McapStreamSink, MetadataRecord, Sink, SinkFanout, SinkOptions};
    use replay::{McapReader, ReplayOptions, whatif};

    let name = out
        .file_name()
        .with_context(|| format!("--out {}: not a file name", out.display()))?;
    let tmp = out.with_file_name(format!(".{}.partial", name.to_string_lossy()));
    let write = || -> Result<u64> {
        let mut reader =
            McapReader::open(rec).with_context(|| format!("cannot read {}", rec.display()))?;
        let config = CalibrationStageConfig {
            captures_to_solve: captures,
            ignore_depth: args.mono,
            method,
            orb_distribution: args.distribution.map(Into::into),
            ..CalibrationStageConfig::default()
        };
        let stages: Vec<Box<dyn msgs::Stage + Send>> =
            vec![Box::new(CalibrationStage::new(config))];
        let mcap = McapSink::create(&tmp, &SinkOptions::default())?;
        let sink: Box<dyn Sink> = Box::new(McapStreamSink::new(mcap));
        let mut fanout = SinkFanout::new(vec![sink]);
        for m in reader.metadata().to_vec() {
            if m.name == whatif::WHATIF_RECORD || m.name == SELF_CAL_RECORD {
                continue;
            }
            let mut record = MetadataRecord::new(m.name.clone());
            record.entries = m.entries.clone();
            fanout.write_metadata(&record)?;
        }
        for a in reader.attachments().to_vec() {
            let data = reader.read_attachment(&a)?;
            fanout.attach(&a.name, &a.media_type, a.log_time_ns, &data)?;
        }
        let report = replay::replay(
            &mut reader,
            stages,
            &ReplayOptions::default(),
            Some(&mut fanout),
        )
        .with_context(|| format!("replaying {} through the calibration stage", rec.display()))?;
        fanout.write_metadata(
            &MetadataRecord::new(SELF_CAL_RECORD)
                .with("source", rec.display().to_string())
                .with("captures", captures.to_string())
                .with("mode", if args.mono { "mono" } else { "auto" })
                .with(
                    "orb_distribution",
                    args.distribution
                        .map_or(method.keypoint_distribution(), Into::into)
                        .name(),
                ),
        )?;
        fanout.finish()?;
        Ok(report.written)
    };
    match write() {
        Ok(written) => {
            std::fs::rename(&tmp, out)
                .with_context(|| format!("cannot move {} to {}", tmp.display(), out.display()))?;
            Ok(written)
        }
        Err(e) => {
            let _ignored = std::fs::remove_file(&tmp);
            Err(e.context(format!("--out {}: nothing written", out.display())))
        }
    }
}

/// Metadata record `calib self --out` adds: source recording, captures, mode.
const SELF_CAL_RECORD: &str = "calib_self";

/// `calib self --method zhi`: the ZHI baseline (SIFT, SfM, scale-free SVD; colour only).
fn self_calibration_zhi(args: &SelfArgs) -> Result<()> {
    use calib::selfcal::views_from_messages;
    use calib::zhi::{ZhiParams, calibrate_zhi};
    if args.yaml.is_some() {
        bail!("calib self --method zhi: --yaml is only written by `ours`");
    }
    let messages = super::recording_views::read_calibration_messages(&args.rec)?;
    let (views, camera) = views_from_messages(&messages)
        .with_context(|| format!("cannot build calibration views from {}", args.rec.display()))?;
    let params = ZhiParams::for_camera(&camera);
    let result = calibrate_zhi(&views, &camera, &params).context("ZHI calibration refused")?;
    if args.json {
        let mut value = calibration_json(&result.solution, "zhi", "mono", CAMERA_FRAME);
        if let Some(obj) = value.as_object_mut() {
            obj.insert("registered_views".into(), result.registered().into());
            obj.insert("points".into(), result.points.into());
            obj.insert(
                "reprojection_rms_px".into(),
                result.reprojection_rms_px.into(),
            );
        }
        super::print_stdout(&serde_json::to_string(&value)?)?;
    } else {
        super::print_stdout(&format!(
            "ZHI (sfm, colour only): {} of {} views registered, {} points, reprojection RMS {:.3} px",
            result.registered(),
            views.len(),
            result.points,
            result.reprojection_rms_px
        ))?;
        super::print_stdout(&human_text(&result.solution, "zhi (kronecker)"))?;
    }
    Ok(())
}

fn match_images(args: &MatchArgs) -> Result<()> {
    use calib::features::command::{
        PairMatching, match_json, match_pair, match_picture, match_summary,
    };
    if args.features == 0 {
        bail!("--features must be at least 1");
    }
    let how = PairMatching {
        // The error names the method and lists the available ones.
        method: args.method.parse()?,
        n_features: args.features,
        distribution: args.distribution.into(),
    };
    let a = read_gray(&args.image_a)?;
    let b = read_gray(&args.image_b)?;
    let result = match_pair(&a, &b, &how)?;
    if let Some(out) = &args.picture {
        match_picture(&a, &b, &result)
            .save(out)
            .with_context(|| format!("cannot write the match picture {}", out.display()))?;
    }
    if args.json {
        super::print_stdout(&match_json(&result))?;
    } else {
        super::print_stdout(&match_summary(&result))?;
        if let Some(p) = &args.picture {
            super::print_stdout(&format!("picture: {}", p.display()))?;
        }
    }
    Ok(())
}

/// An image file (PNG, JPEG) as 8-bit grey.
fn read_gray(path: &std::path::Path) -> Result<image::GrayImage> {
    let bytes =
        std::fs::read(path).with_context(|| format!("cannot read image {}", path.display()))?;
    calib::features::command::gray_from_encoded(&bytes)
        .with_context(|| format!("cannot read image {}", path.display()))
}

/// The human-readable result (the JSON's figures, with units and the direction spelled out).
fn human_text(s: &HandEyeSolution, method: &str) -> String {
    use std::fmt::Write as _;
    let mut out = String::new();
    let t = s.tool0_from_camera.translation.vector;
    let q = s.tool0_from_camera.rotation;
    let (roll, pitch, yaw) = q.euler_angles();
    let _ = writeln!(
        out,
        "tool0_from_camera  (parent tool0, child {CAMERA_FRAME}; maps camera points into tool0)"
    );
    let _ = writeln!(out, "  method            {method}");
    let _ = writeln!(
        out,
        "  translation_m     [{:.6}, {:.6}, {:.6}]",
        t.x, t.y, t.z
    );
    let _ = writeln!(
        out,
        "  quaternion_xyzw   [{:.9}, {:.9}, {:.9}, {:.9}]",
        q.i, q.j, q.k, q.w
    );
    let _ = writeln!(
        out,
        "  rpy_deg           [{:.4}, {:.4}, {:.4}]",
        roll.to_degrees(),
        pitch.to_degrees(),
        yaw.to_degrees()
    );
    let _ = writeln!(out, "  views / pairs     {} / {}", s.views, s.pairs);
    if !s.rejected_pairs.is_empty() {
        let _ = writeln!(
            out,
            "  rejected pairs    {} (hand/eye rotation angles disagree)",
            s.rejected_pairs.len()
        );
    }
    let _ = writeln!(
        out,
        "  residual (median) {:.4} deg, {:.3} mm",
        s.residual_rot_deg, s.residual_trans_mm
    );
    let _ = writeln!(
        out,
        "  sigma (1-sigma)   {:.4} deg, {:.3} mm",
        s.sigma_rot_deg, s.sigma_trans_mm
    );
    let _ = writeln!(out, "  condition         {:.3}", s.condition);
    if (s.scale - 1.0).abs() > 0.0 {
        let _ = writeln!(out, "  scale             {:.6} m per eye unit", s.scale);
    }
    out.trim_end().to_owned()
}
