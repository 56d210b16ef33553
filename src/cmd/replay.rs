//! `rodlog replay REC [--check] [--config F] [--set k=v]... [--out OUT] [--start S] [--end S]
//! [--topics T,..]`: feed a recording's inputs through the current pipeline again.
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
use recorder::scenario::{PARAM_PREFIX, Params, SCENARIO_RECORD};
use recorder::{McapSink, McapStreamSink, MetadataRecord, Sink, SinkFanout, SinkOptions};
use replay::{McapReader, ReplayOptions, whatif};

use super::record::pipeline;

/// Arguments of `rodlog replay`.
#[derive(Debug, clap::Args)]
pub struct ReplayArgs {
    /// The recording (MCAP).
    pub rec: PathBuf,
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

/// Runs `rodlog replay`.
pub fn run(args: &ReplayArgs) -> anyhow::Result<()> {
    let mut reader = McapReader::open(&args.rec)
        .with_context(|| format!("cannot read {}", args.rec.display()))?;
    let recorded_scenario = reader.metadata_named(SCENARIO_RECORD).cloned();
    let recorded_params = recorded_scenario
        .as_ref()
        .map(|m| Params::from_metadata(&m.entries))
        .unwrap_or_default();
    let mut params = recorded_params.clone();
    if let Some(path) = &args.config {
        params.merge(&Params::from_file(path)?);
    }
    for s in &args.set {
        params.set_from_arg(s)?;
    }
    let changed = params.changed_keys(&recorded_params);
    let changed_text: Vec<String> = changed
        .iter()
        .map(|k| match params.get(k) {
            Some(v) => format!("{k}={v}"),
            None => format!("{k} (removed)"),
        })
        .collect();
    // The scenario's command list (for the `script` stage) comes from the attached file.
    let commands = super::record::scenario_of_recording(&args.rec)
        .map(|s| s.commands)
        .unwrap_or_default();
    let stages = pipeline(&params, &commands)?;
    let options = ReplayOptions {
        start_s: args.start,
        end_s: args.end,
        topics: (!args.topics.is_empty())
            .then(|| args.topics.iter().cloned().collect::<BTreeSet<_>>()),
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
            return Err(e).context(format!("replaying {}", args.rec.display()));
        }
    };
    if let Some(mut f) = fanout {
        let source = args.rec.display().to_string();
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
                args.rec.display(),
                report.output_channels.len(),
                report.regenerated
            );
        }
        if let Some(d) = report.comparison.first_divergence() {
            bail!("replay --check: {compared} outputs compared; first divergence: {d}");
        }
        super::print_stdout(&format!(
            "check passed: {compared} outputs compared, all identical"
        ))?;
    }
    Ok(())
}
