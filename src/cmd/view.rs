//! `rodlog view REC.mcap [-o REC.rrd | --spawn | --connect URL] [--until S]`: a recording in
//! Rerun, through the viz crate's sink (entities, timelines and blueprint: see `viz::sink`).
//!
//! Also [`VizSink`], the same sink as a recorder [`Sink`] for `rodlog record --viz`.
//!
//! For a recording of the simulator's world (`robot_info` `world = sim`) the site is drawn as
//! the robot knows it: the task's site map (rod rack, cabinet, cable tray, the other
//! conductors) and the grounding rod's dimensions ([`site_for_world`]); the 3D eye starts on
//! the robot's first pose and the wire prior ([`framing`]).
//!
//! The Rerun recording id is deterministic: a hash of the recording's metadata records and
//! summary (message count, time range) for `view`, of the scenario's metadata records for
//! `record --viz` ([`viz::convert::recording_id`]). The .rrd bytes themselves are not stable
//! (Rerun's row ids are random by design); only the MCAP is under the determinism contract.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context as _, bail};
use control::tasks::site::{CONDUCTOR_RADIUS_M, SiteMap};
use msgs::Msg;
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use recorder::{MetadataRecord, Sink, SinkError, SinkMessage};
use replay::{McapReader, ReadFilter};
use robot::grounding_rod as rod;
use viz::blueprint::Framing;
use viz::convert::Pose;
use viz::site::{Body, Site};
use viz::urdf::Shape;
use viz::{Target, Viz, VizError, VizStats};

/// Name of the URDF attachment `rodlog record` writes.
pub const URDF_ATTACHMENT: &str = "robot.urdf";

/// At most this many drawing errors are printed (all are counted).
const PRINTED_ERRORS: usize = 5;

/// Arguments of `rodlog view`.
#[derive(Debug, clap::Args)]
#[command(group(clap::ArgGroup::new("target").required(true).args(["out", "spawn", "connect"])))]
pub struct ViewArgs {
    /// The recording (MCAP).
    pub rec: PathBuf,
    /// Write a Rerun recording (.rrd) instead of showing it.
    #[arg(short = 'o', long = "out", value_name = "REC.rrd")]
    pub out: Option<PathBuf>,
    /// Start a viewer (`rerun` on PATH, else the reference venv's) and stream to it.
    #[arg(long)]
    pub spawn: bool,
    /// Stream to a running viewer or server: `rerun+http://HOST:PORT/proxy`.
    #[arg(long, value_name = "URL")]
    pub connect: Option<String>,
    /// The gRPC port of the viewer `--spawn` starts (or reuses when one listens there).
    #[arg(long, value_name = "PORT", default_value_t = 9876, requires = "spawn")]
    pub port: u16,
    /// Draw only the first S seconds of robot time (from the first message): the viewer, which
    /// follows the newest data, then opens on that moment (screenshots of a moment).
    #[arg(long, value_name = "S")]
    pub until: Option<f64>,
}

/// The `world` entry of a recording's `robot_info` metadata record.
fn world_of<'a>(
    records: impl IntoIterator<Item = (&'a str, &'a BTreeMap<String, String>)>,
) -> Option<String> {
    records
        .into_iter()
        .find(|(name, _)| *name == "robot_info")
        .and_then(|(_, entries)| entries.get("world").cloned())
}

fn pose_of(iso: &Isometry3<f64>) -> Pose {
    let t = iso.translation.vector;
    let q = iso.rotation.coords;
    Pose {
        t: [t.x, t.y, t.z],
        q: [q.x, q.y, q.z, q.w],
    }
}

fn rgba(r: f64, g: f64, b: f64) -> [u8; 4] {
    let q = |v: f64| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
    [q(r), q(g), q(b), 255]
}

/// The grounding rod's parts in the rod frame (`robot::grounding_rod`'s dimensions; the
/// parts the simulator renders).
fn rod_parts() -> Vec<Body> {
    let rubber = rgba(0.1, 0.1, 0.11);
    let tube = rgba(0.85, 0.4, 0.05);
    let steel = rgba(0.6, 0.6, 0.62);
    let head = rgba(0.7, 0.68, 0.62);
    let bronze = rgba(0.65, 0.42, 0.18);
    let warning = rgba(0.85, 0.7, 0.05);
    let cyl = |name: &str, z0: f64, z1: f64, r: f64, rgba: [u8; 4]| Body {
        name: name.to_owned(),
        pose: Pose {
            t: [0.0, 0.0, 0.5 * (z0 + z1)],
            q: [0.0, 0.0, 0.0, 1.0],
        },
        shape: Shape::Cylinder {
            radius_m: r as f32,
            length_m: (z1 - z0) as f32,
        },
        rgba,
    };
    let bx = |name: &str, c: [f64; 3], h: [f64; 3], rgba: [u8; 4]| Body {
        name: name.to_owned(),
        pose: Pose {
            t: c,
            q: [0.0, 0.0, 0.0, 1.0],
        },
        shape: Shape::Box {
            half_m: h.map(|v| v as f32),
        },
        rgba,
    };
    let (handle, support, drive) = (rod::HANDLE_LENGTH_M, rod::SUPPORT_TOP_M, rod::DRIVE_TOP_M);
    vec![
        cyl("handle", 0.0, handle, rod::HANDLE_RADIUS_M, rubber),
        cyl("guard", handle, handle + 0.03, 0.026, warning),
        cyl(
            "support_tube",
            handle + 0.03,
            support,
            rod::SUPPORT_RADIUS_M,
            tube,
        ),
        cyl("collar", support - 0.04, support, 0.024, head),
        cyl("drive_rod", support, drive, rod::DRIVE_RADIUS_M, steel),
        bx("clamp_head", [0.0, 0.0, 1.82], [0.035, 0.025, 0.04], head),
        bx(
            "clamp_jaw",
            [0.01, 0.0, 1.895],
            [0.03, 0.022, 0.012],
            bronze,
        ),
        bx("hook_back", [-0.032, 0.0, 1.93], [0.008, 0.02, 0.07], head),
        bx("hook_top", [0.0, 0.0, 2.0], [0.04, 0.02, 0.008], head),
        bx("hook_lip", [0.036, 0.0, 1.985], [0.006, 0.02, 0.02], head),
        bx(
            "contact_pad",
            [0.0, 0.0, 1.988],
            [0.022, 0.018, 0.004],
            bronze,
        ),
    ]
}

/// The site of a recording of `world`: the simulator's default bay as the task's site map
/// knows it (`sim`), nothing for other worlds (the test world has no site).
pub fn site_for_world(world: &str) -> Option<Site> {
    if world != "sim" {
        return None;
    }
    let map = SiteMap::default_bay();
    let mut fixed: Vec<Body> = map
        .obstacles
        .iter()
        .map(|(name, b)| {
            // The rack's boxes are its parts; the others are keep-out volumes around the
            // real cabinets (a few cm of margin): translucent, so the captured surfaces
            // inside them show.
            let colour = if name.starts_with("rack") {
                rgba(0.62, 0.48, 0.08)
            } else if name.starts_with("cable") {
                [140, 145, 150, 90]
            } else {
                [105, 115, 110, 110]
            };
            let h = b.half_extents_m;
            Body {
                name: name.clone(),
                pose: pose_of(&b.frame_from_box),
                shape: Shape::Box {
                    half_m: [h.x as f32, h.y as f32, h.z as f32],
                },
                rgba: colour,
            }
        })
        .collect();
    // The ground the planner keeps out of (its top at z = 0, a hair below the grid), opaque:
    // what is below it (the lift's mast when the lift is low, in its well) is hidden.
    let spot = map.work_spot;
    fixed.push(Body {
        name: "ground".to_owned(),
        pose: Pose {
            t: [spot.x_m, spot.y_m, -0.011],
            q: [0.0, 0.0, 0.0, 1.0],
        },
        shape: Shape::Box {
            half_m: [15.0, 15.0, 0.01],
        },
        rgba: [58, 62, 56, 255],
    });
    for (k, (a, b)) in map.other_conductors.iter().enumerate() {
        let d = b - a;
        let rotation = UnitQuaternion::rotation_between(&Vector3::z(), &d)
            .unwrap_or_else(UnitQuaternion::identity);
        let centre = a + 0.5 * d;
        fixed.push(Body {
            name: format!("conductor_{k}"),
            pose: pose_of(&Isometry3::from_parts(
                Translation3::from(centre.coords),
                rotation,
            )),
            shape: Shape::Cylinder {
                radius_m: CONDUCTOR_RADIUS_M as f32,
                length_m: d.norm() as f32,
            },
            rgba: rgba(0.35, 0.37, 0.42),
        });
    }
    Some(Site {
        fixed,
        rod_parts: rod_parts(),
        map_from_stored_rod: Some(pose_of(&map.map_from_stored_rod())),
        tool0_from_rod: pose_of(&rod::rod_from_tool0_grasp().inverse()),
        rod_from_handle: pose_of(&Isometry3::translation(
            rod::HANDLE_CENTER_IN_ROD_M[0],
            rod::HANDLE_CENTER_IN_ROD_M[1],
            rod::HANDLE_CENTER_IN_ROD_M[2],
        )),
        wire_radius_m: CONDUCTOR_RADIUS_M as f32,
    })
}

/// Where the 3D eye starts: on the robot's first pose (`map -> base_link`; when unknown, the
/// map origin, or in the simulator's bay the working spot) and, in the bay, the wire prior, the
/// rack and the calibration cabinet, seen from behind the robot's left.
pub fn framing(world: Option<&str>, robot_start: Option<[f64; 3]>) -> Option<Framing> {
    let sim = world == Some("sim");
    let mut points = Vec::new();
    if let Some(s) = robot_start.or((!sim).then_some([0.0; 3])) {
        points.extend([s, [s[0], s[1], s[2] + 2.0]]);
    }
    if sim {
        let map = SiteMap::default_bay();
        let w = map.wire.point;
        points.push([w.x, w.y, w.z]);
        let spot = map.work_spot;
        points.push([spot.x_m, spot.y_m, 0.0]);
        let rack = map.map_from_rack.translation.vector;
        points.push([rack.x, rack.y, rack.z]);
        let face = map.calibration_target;
        points.push([face.x, face.y, face.z]);
    }
    Framing::around(&points, [-0.6, -1.0])
}

/// The first `map -> base_link` translation on `/tf` (the robot's start).
fn robot_start(reader: &mut McapReader) -> Option<[f64; 3]> {
    let filter = ReadFilter::all().with_topics([msgs::topics::TF.to_owned()]);
    for item in reader.messages(&filter) {
        let Ok(m) = item else { continue };
        let Ok(Msg::TfMessage(tf)) = m.decode() else {
            continue;
        };
        if let Some(ts) = tf.transforms.iter().find(|ts| {
            ts.header.frame_id.trim_start_matches('/') == msgs::frames::MAP
                && ts.child_frame_id.trim_start_matches('/') == msgs::frames::BASE_LINK
        }) {
            let v = ts.transform.translation;
            return Some([v.x, v.y, v.z]);
        }
    }
    None
}

/// The `rerun` executable for `--spawn`: `None` when one is on `PATH` (the SDK finds it),
/// else the reference venv's (`RODLOG_REF_VENV` or `.venv-ref` here or in the source tree).
fn rerun_executable() -> Option<PathBuf> {
    let on_path = std::env::var_os("PATH")
        .is_some_and(|paths| std::env::split_paths(&paths).any(|dir| dir.join("rerun").is_file()));
    if on_path {
        return None;
    }
    let mut venvs: Vec<PathBuf> = std::env::var_os("RODLOG_REF_VENV")
        .map(PathBuf::from)
        .into_iter()
        .collect();
    venvs.push(PathBuf::from(".venv-ref"));
    venvs.push(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(".venv-ref"));
    venvs
        .into_iter()
        .map(|v| v.join("bin/rerun"))
        .find(|p| p.is_file())
}

/// The target of the arguments.
fn target(args: &ViewArgs) -> anyhow::Result<Target> {
    Ok(match (&args.out, args.spawn, &args.connect) {
        (Some(out), false, None) => Target::Rrd(out.clone()),
        (None, true, None) => Target::Spawn {
            exe: rerun_executable(),
            port: args.port,
        },
        (None, false, Some(url)) => Target::Connect(url.clone()),
        _ => bail!("give exactly one of -o REC.rrd, --spawn, --connect URL"),
    })
}

/// The recording id of a recording: its metadata records and summary.
fn recording_id_of(reader: &McapReader) -> String {
    let mut parts: Vec<String> = Vec::new();
    for m in reader.metadata() {
        parts.push(m.name.clone());
        for (k, v) in &m.entries {
            parts.push(format!("{k}={v}"));
        }
    }
    parts.push(format!("messages={}", reader.message_count()));
    if let Some((start, end)) = reader.time_range_ns() {
        parts.push(format!("span={start}..{end}"));
    }
    let refs: Vec<&str> = parts.iter().map(String::as_str).collect();
    viz::convert::recording_id(&refs)
}

/// Runs `rodlog view`.
pub fn run(args: &ViewArgs) -> anyhow::Result<()> {
    let target = target(args)?;
    let wall = Instant::now();
    let mut reader = McapReader::open(&args.rec)
        .with_context(|| format!("cannot read {}", args.rec.display()))?;
    let id = recording_id_of(&reader);
    let name = args.rec.file_stem().map_or_else(
        || "recording".to_owned(),
        |s| s.to_string_lossy().into_owned(),
    );
    let records: Vec<(String, BTreeMap<String, String>)> = reader
        .metadata()
        .iter()
        .map(|m| (m.name.clone(), m.entries.clone()))
        .collect();
    let world = world_of(records.iter().map(|(n, e)| (n.as_str(), e)));
    let start = robot_start(&mut reader);
    let framing = framing(world.as_deref(), start);
    let stream =
        viz::stream(&target, &id, &name, framing.as_ref()).context("starting the Rerun stream")?;
    let mut sink = Viz::new(stream)?;
    sink.log_metadata(&records)?;
    if let Some(site) = world.as_deref().and_then(site_for_world) {
        sink.log_site(&site)?;
    }
    if let Some(w) = reader
        .metadata()
        .iter()
        .find(|m| m.name == replay::whatif::WHATIF_RECORD)
    {
        let get = |k: &str| w.entries.get(k).map_or("", String::as_str);
        let open_loop_from_ns = (get("open_loop") == "true")
            .then(|| get("open_loop_from_ns").parse::<u64>().ok())
            .flatten();
        sink.log_whatif(
            get("source"),
            get("changed_parameters"),
            open_loop_from_ns,
            get("first_divergent_command_topic"),
        )?;
    }
    let urdf = reader
        .attachments()
        .iter()
        .find(|a| a.name == URDF_ATTACHMENT)
        .cloned();
    if let Some(a) = urdf {
        let bytes = reader.read_attachment(&a)?;
        sink.log_urdf(&String::from_utf8_lossy(&bytes))?;
    }
    let mut errors = Errors::default();
    let mut span: Option<(u64, u64)> = None;
    let mut filter = ReadFilter::all();
    if let Some(s) = args.until {
        if !(s.is_finite() && s >= 0.0) {
            bail!("--until {s}: give seconds >= 0");
        }
        let first = reader.time_range_ns().map_or(0, |(a, _)| a);
        filter = filter.with_time_range(None, Some(first.saturating_add((s * 1e9) as u64 + 1)));
    }
    for item in reader.messages(&filter) {
        let m = match item {
            Ok(m) => m,
            Err(e) => {
                errors.note(&anyhow::Error::new(e).context("reading the recording"));
                continue;
            }
        };
        span = Some(span.map_or((m.log_time_ns, m.log_time_ns), |(a, b)| {
            (a.min(m.log_time_ns), b.max(m.log_time_ns))
        }));
        if let Err(e) = sink.log_cdr(m.topic(), m.schema_name(), m.log_time_ns, &m.data) {
            if matches!(e, VizError::Rerun(_) | VizError::Flush(_)) {
                return Err(e).context("logging to Rerun");
            }
            errors.note(&anyhow::Error::new(e));
        }
    }
    let stats = sink.finish().context("finishing the Rerun stream")?;
    let robot_s = span.map_or(0.0, |(a, b)| (b - a) as f64 * 1e-9);
    let wall_s = wall.elapsed().as_secs_f64();
    let where_to = match &target {
        Target::Rrd(p) => p.display().to_string(),
        Target::Spawn { port, .. } => format!("a spawned viewer (port {port})"),
        Target::Connect(url) => url.clone(),
    };
    let mut text = format!(
        "{} -> {where_to}: {} messages drawn on {} topics, {} skipped, {} failed; {} depth captures as points, {} recalibrations; {robot_s:.1} s of robot time in {wall_s:.2} s ({:.1}x real time)",
        args.rec.display(),
        stats.total_logged(),
        stats.logged.len(),
        stats.skipped.values().sum::<u64>(),
        stats.failed.values().sum::<u64>(),
        stats.captures,
        stats.recalibrations,
        if wall_s > 0.0 { robot_s / wall_s } else { 0.0 },
    );
    text.push_str(&summary_lines(&stats));
    super::print_stdout(&text)?;
    errors.report();
    Ok(())
}

/// Per-topic counts, one line per topic.
fn summary_lines(stats: &VizStats) -> String {
    let mut topics: BTreeMap<&str, [u64; 3]> = BTreeMap::new();
    for (i, map) in [&stats.logged, &stats.skipped, &stats.failed]
        .into_iter()
        .enumerate()
    {
        for (topic, n) in map {
            topics.entry(topic.as_str()).or_default()[i] += n;
        }
    }
    let mut out = String::new();
    for (topic, [logged, skipped, failed]) in topics {
        out.push_str(&format!(
            "\n  {topic:<28} drawn {logged:>7}  skipped {skipped:>5}  failed {failed:>5}"
        ));
    }
    out
}

/// Drawing errors: counted, the first few printed on stderr.
#[derive(Debug, Default)]
struct Errors {
    count: usize,
    first: Vec<String>,
}

impl Errors {
    fn note(&mut self, e: &anyhow::Error) {
        self.count += 1;
        if self.first.len() < PRINTED_ERRORS {
            self.first.push(format!("{e:#}"));
        }
    }

    fn report(&self) {
        for e in &self.first {
            eprintln!("rodlog: warning: not drawn: {e}");
        }
        if self.count > self.first.len() {
            eprintln!(
                "rodlog: warning: {} more messages not drawn",
                self.count - self.first.len()
            );
        }
    }
}

/// The viz sink as a recorder [`Sink`] (`rodlog record --viz`): every message the MCAP
/// writer gets is drawn too. A message that cannot be drawn is counted and the recording goes
/// on; a Rerun stream failure stops the recording like an MCAP failure does.
pub struct VizSink {
    viz: Viz,
    metadata: Vec<(String, BTreeMap<String, String>)>,
    errors: Errors,
}

impl std::fmt::Debug for VizSink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("VizSink")
            .field("viz", &self.viz)
            .finish_non_exhaustive()
    }
}

impl VizSink {
    /// A sink writing `rrd`, its recording id derived from the recording's `metadata`.
    ///
    /// # Errors
    /// The .rrd file cannot be created.
    pub fn create(rrd: &Path, metadata: &[MetadataRecord]) -> anyhow::Result<Self> {
        let mut parts: Vec<String> = Vec::new();
        for m in metadata {
            parts.push(m.name.clone());
            parts.extend(m.entries.iter().map(|(k, v)| format!("{k}={v}")));
        }
        let refs: Vec<&str> = parts.iter().map(String::as_str).collect();
        let name = rrd.file_stem().map_or_else(
            || "recording".to_owned(),
            |s| s.to_string_lossy().into_owned(),
        );
        let world = world_of(metadata.iter().map(|m| (m.name.as_str(), &m.entries)));
        let stream = viz::stream(
            &Target::Rrd(rrd.to_path_buf()),
            &viz::convert::recording_id(&refs),
            &name,
            framing(world.as_deref(), None).as_ref(),
        )
        .with_context(|| format!("cannot create {}", rrd.display()))?;
        let mut viz = Viz::new(stream)?;
        if let Some(site) = world.as_deref().and_then(site_for_world) {
            viz.log_site(&site)?;
        }
        Ok(Self {
            viz,
            metadata: Vec::new(),
            errors: Errors::default(),
        })
    }
}

fn sink_error(e: &VizError, log_time_ns: u64) -> SinkError {
    SinkError::Other {
        sink: "rerun".to_owned(),
        log_time_ns,
        reason: e.to_string(),
    }
}

impl Sink for VizSink {
    fn write(&mut self, msg: &SinkMessage<'_>) -> Result<(), SinkError> {
        let ch = msg.channel;
        match self
            .viz
            .log_cdr(&ch.topic, &ch.type_name, msg.log_time_ns, msg.cdr)
        {
            Ok(()) => Ok(()),
            Err(e @ (VizError::Rerun(_) | VizError::Flush(_))) => {
                Err(sink_error(&e, msg.log_time_ns))
            }
            Err(e) => {
                self.errors.note(&anyhow::Error::new(e));
                Ok(())
            }
        }
    }

    fn write_metadata(&mut self, record: &MetadataRecord) -> Result<(), SinkError> {
        self.metadata
            .push((record.name.clone(), record.entries.clone()));
        self.viz
            .log_metadata(&self.metadata)
            .map_err(|e| sink_error(&e, 0))
    }

    fn attach(
        &mut self,
        name: &str,
        _media_type: &str,
        log_time_ns: u64,
        data: &[u8],
    ) -> Result<(), SinkError> {
        if name == URDF_ATTACHMENT {
            self.viz
                .log_urdf(&String::from_utf8_lossy(data))
                .map_err(|e| sink_error(&e, log_time_ns))?;
        }
        Ok(())
    }

    /// Does not force the Rerun stream out: the recorder flushes every second of robot time,
    /// and a forced flush ends every entity's chunk there (the demo became 8 000 small chunks
    /// that the viewer ingests slowly). The stream writes on its own batching
    /// ([`viz::BATCHER`]: every 10 s of wall time or 64 MiB) and at [`Sink::finish`].
    fn flush(&mut self) -> Result<(), SinkError> {
        Ok(())
    }

    fn finish(self: Box<Self>) -> Result<(), SinkError> {
        let Self { viz, errors, .. } = *self;
        errors.report();
        viz.finish().map(|_| ()).map_err(|e| sink_error(&e, 0))
    }
}
