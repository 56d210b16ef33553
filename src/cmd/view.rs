//! `rodlog view REC.mcap [-o REC.rrd | --spawn | --connect URL]`: a recording in Rerun, through
//! the viz crate's sink (entities, timelines and blueprint: see `viz::sink`).
//!
//! Also [`VizSink`], the same sink as a recorder [`Sink`] for `rodlog record --viz`.
//!
//! The Rerun recording id is deterministic: a hash of the recording's metadata records and
//! summary (message count, time range) for `view`, of the scenario's metadata records for
//! `record --viz` ([`viz::convert::recording_id`]). The .rrd bytes themselves are not stable
//! (Rerun's row ids are random by design); only the MCAP is under the determinism contract.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context as _, bail};
use recorder::{MetadataRecord, Sink, SinkError, SinkMessage};
use replay::{McapReader, ReadFilter};
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
        (None, true, None) => Target::Spawn(rerun_executable()),
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
    let stream = viz::stream(&target, &id, &name).context("starting the Rerun stream")?;
    let mut sink = Viz::new(stream)?;
    let records: Vec<(String, BTreeMap<String, String>)> = reader
        .metadata()
        .iter()
        .map(|m| (m.name.clone(), m.entries.clone()))
        .collect();
    sink.log_metadata(&records)?;
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
    for item in reader.messages(&ReadFilter::all()) {
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
        Target::Spawn(_) => "a spawned viewer".to_owned(),
        Target::Connect(url) => url.clone(),
    };
    let mut text = format!(
        "{} -> {where_to}: {} messages drawn on {} topics, {} skipped, {} failed; {robot_s:.1} s of robot time in {wall_s:.2} s ({:.1}x real time)",
        args.rec.display(),
        stats.total_logged(),
        stats.logged.len(),
        stats.skipped.values().sum::<u64>(),
        stats.failed.values().sum::<u64>(),
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
        let stream = viz::stream(
            &Target::Rrd(rrd.to_path_buf()),
            &viz::convert::recording_id(&refs),
            &name,
        )
        .with_context(|| format!("cannot create {}", rrd.display()))?;
        Ok(Self {
            viz: Viz::new(stream)?,
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

    fn flush(&mut self) -> Result<(), SinkError> {
        self.viz.flush().map_err(|e| sink_error(&e, 0))
    }

    fn finish(self: Box<Self>) -> Result<(), SinkError> {
        let Self { viz, errors, .. } = *self;
        errors.report();
        viz.finish().map(|_| ()).map_err(|e| sink_error(&e, 0))
    }
}
