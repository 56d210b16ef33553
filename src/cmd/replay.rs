//! `rodlog replay REC... [--check] [--shard K/N] [--config F] [--set k=v]... [--out OUT]
//! [--start S] [--end S] [--topics T,..]`: feed a recording's inputs through the current
//! pipeline again.
//!
//! Several recordings (files, or folders of `.mcap` files) are replayed one after the other,
//! in path order; `--shard K/N` takes hand K of the recordings dealt to N shards as an
//! experiment's items are (`Shard::items_of`; a fleet's recordings checked on many machines). With several, a failure of one is reported
//! and the others still run; the exit status fails when any failed.
//!
//! Parameters: the recording's `scenario` metadata, then `--config`, then `--set`.
//! `--check` compares the regenerated outputs with the recorded ones byte for byte, prints how
//! many it compared and the first divergence (topic, log_time, field), and fails on a
//! divergence or when there is nothing to compare. `--out` writes a what-if file: recorded
//! inputs + regenerated outputs, the effective parameters in its `scenario` record, and a
//! `whatif` record naming where it becomes open-loop.

use std::collections::BTreeSet;
use std::path::PathBuf;

use anyhow::{Context as _, bail};
use recorder::{McapSink, McapStreamSink, MetadataRecord, Sink, SinkFanout, SinkOptions};
use replay::{McapReader, ReplayOptions, whatif};
use scenario::{PARAM_PREFIX, SCENARIO_RECORD};

/// Arguments of `rodlog replay`.
#[derive(Debug, clap::Args)]
pub struct ReplayArgs {
    /// The recordings (MCAP files, or folders of them).
    #[arg(required = true, value_name = "REC")]
    pub recs: Vec<PathBuf>,
    /// Replay only shard K of N (0-based) of the recordings (dealt as an experiment's items).
    #[arg(long, value_name = "K/N")]
    pub shard: Option<String>,
    /// Compare regenerated outputs with the recorded ones; exit 1 on divergence or when
    /// there is nothing to compare.
    #[arg(long)]
    pub check: bool,
    /// Parameter file (TOML; a scenario's `[parameters]` or a flat table).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Override a parameter, `stage.key=value` (repeatable).
    #[arg(long = "set", value_name = "K=V")]
    pub set: Vec<String>,
    /// Write recorded inputs + regenerated outputs here (what-if).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Start, seconds from the start of the recording.
    #[arg(long)]
    pub start: Option<f64>,
    /// End, seconds from the start of the recording (inclusive).
    #[arg(long)]
    pub end: Option<f64>,
    /// Only these topics are compared and written (comma-separated).
    #[arg(long, value_delimiter = ',')]
    pub topics: Vec<String>,
}

/// The parameters of a `--config` file: its `[parameters]` table if it has one (a scenario
/// file), otherwise the whole file, flattened.
fn parameter_file(path: &std::path::Path) -> anyhow::Result<scenario::Params> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let table: toml::Table = text
        .parse()
        .with_context(|| format!("{} is not valid TOML", path.display()))?;
    Ok(match table.get("parameters") {
        Some(toml::Value::Table(p)) => scenario::Params::from_table(p),
        _ => scenario::Params::from_table(&table),
    })
}

/// The recordings named by `paths`: files as given, folders expanded to their `.mcap` files;
/// sorted, without duplicates.
fn recordings(paths: &[PathBuf]) -> anyhow::Result<Vec<PathBuf>> {
    let mut out = BTreeSet::new();
    for p in paths {
        if p.is_dir() {
            for entry in
                std::fs::read_dir(p).with_context(|| format!("cannot list {}", p.display()))?
            {
                let path = entry?.path();
                if path.extension().is_some_and(|e| e == "mcap") {
                    out.insert(path);
                }
            }
        } else {
            out.insert(p.clone());
        }
    }
    Ok(out.into_iter().collect())
}

/// Runs `rodlog replay`.
pub fn run(args: &ReplayArgs) -> anyhow::Result<()> {
    let mut recs = recordings(&args.recs)?;
    if let Some(s) = &args.shard {
        let shard = crate::experiment::shard::Shard::parse(s)?;
        let mine = shard.items_of(recs.len());
        recs = mine
            .into_iter()
            .filter_map(|i| recs.get(i).cloned())
            .collect();
    }
    match recs.as_slice() {
        [] => bail!("no recordings to replay (an empty folder, or an empty shard)"),
        [one] if args.recs.len() == 1 && args.recs[0] == *one => replay_one(one, args),
        [one] => {
            super::print_stdout(&format!("== {}", one.display()))?;
            replay_one(one, args)
        }
        many => {
            if args.out.is_some() {
                bail!("--out writes one what-if file: give one recording");
            }
            let mut failed = Vec::new();
            for rec in many {
                super::print_stdout(&format!("== {}", rec.display()))?;
                if let Err(e) = replay_one(rec, args) {
                    eprintln!("rodlog: error: {}: {e:#}", rec.display());
                    failed.push(rec.display().to_string());
                }
            }
            if !failed.is_empty() {
                bail!(
                    "{} of {} recordings failed: {}",
                    failed.len(),
                    many.len(),
                    failed.join(", ")
                );
            }
            super::print_stdout(&format!("all {} recordings passed", many.len()))
        }
    }
}

/// Replays one recording (module docs).
fn replay_one(rec: &std::path::Path, args: &ReplayArgs) -> anyhow::Result<()> {
    let config = args
        .config
        .as_ref()
        .map(|path| parameter_file(path))
        .transpose()?;
    let setup = compose::ReplaySetup::new(rec, config.as_ref(), &args.set)?;
    for m in &setup.migrated {
        eprintln!("rodlog: note: {m}");
    }
    let unknown: Vec<String> = setup
        .unknown_recorded()
        .iter()
        .map(ToString::to_string)
        .collect();
    for u in &unknown {
        eprintln!("rodlog: warning: recorded {u}; replaying without it");
    }
    let changed_text = setup.changed_parameters();
    let params = &setup.plan.scenario().params;
    let stages = setup.plan.pipeline()?;
    let mut reader =
        McapReader::open(rec).with_context(|| format!("cannot read {}", rec.display()))?;
    let options = ReplayOptions {
        start_s: args.start,
        end_s: args.end,
        topics: (!args.topics.is_empty())
            .then(|| args.topics.iter().cloned().collect::<BTreeSet<_>>()),
        recorded_stages: Some(setup.recorded_stages.clone()),
    };

    let mut fanout = match &args.out {
        Some(out) => {
            let mcap = McapSink::create(out, &SinkOptions::default())?;
            let sink: Box<dyn Sink> = Box::new(McapStreamSink::new(mcap));
            let mut fanout = SinkFanout::new(vec![sink]);
            // The source's records, with the effective parameters in `scenario`.
            for m in reader.metadata().to_vec() {
                if m.name == whatif::WHATIF_RECORD {
                    continue;
                }
                let mut rec = MetadataRecord::new(m.name.clone());
                rec.entries = m.entries.clone();
                if m.name == SCENARIO_RECORD {
                    rec.entries.retain(|k, _| !k.starts_with(PARAM_PREFIX));
                    for (k, v) in params.to_metadata() {
                        rec.entries.insert(k, v);
                    }
                }
                fanout.write_metadata(&rec)?;
            }
            for a in reader.attachments().to_vec() {
                let data = reader.read_attachment(&a)?;
                fanout.attach(&a.name, &a.media_type, a.log_time_ns, &data)?;
            }
            Some(fanout)
        }
        None => None,
    };
    let result = replay::replay(&mut reader, stages, &options, fanout.as_mut());
    let report = match result {
        Ok(r) => r,
        Err(e) => {
            if let Some(f) = fanout {
                let _finished = f.finish();
            }
            return Err(e).context(format!("replaying {}", rec.display()));
        }
    };
    if let Some(mut f) = fanout {
        let source = rec.display().to_string();
        f.write_metadata(&whatif::metadata(&report, &source, &changed_text))?;
        f.finish()?;
    }
    super::print_stdout(whatif::summary(&report, &changed_text).trim_end_matches('\n'))?;
    if let Some(out) = &args.out {
        super::print_stdout(&format!(
            "wrote {} messages to {}",
            report.written,
            out.display()
        ))?;
    }
    if args.check {
        let compared = report.comparison.compared();
        if compared == 0 {
            bail!(
                "replay --check: nothing to compare in {} (output channels of this pipeline found: {}; regenerated outputs: {})",
                rec.display(),
                report.output_channels.len(),
                report.regenerated
            );
        }
        if let Some(d) = report.comparison.first_divergence() {
            bail!("replay --check: {compared} outputs compared; first divergence: {d}");
        }
        if !report.orphan_outputs.is_empty() {
            let names: Vec<String> = report
                .orphan_outputs
                .iter()
                .map(|((topic, producer), n)| format!("{topic} from {producer} ({n})"))
                .collect();
            bail!(
                "replay --check: the recording holds outputs of stages this pipeline does not have, so they cannot be checked: {}",
                names.join(", ")
            );
        }
        if !unknown.is_empty() {
            bail!(
                "replay --check: {compared} outputs identical, but the recording was made with parameters this version does not know: {}",
                unknown.join("; ")
            );
        }
        super::print_stdout(&format!(
            "check passed: {compared} outputs compared, all identical"
        ))?;
    }
    Ok(())
}
