//! `rodlog info REC [--json]`: what a recording holds, like `mcap info`.
//!
//! Channel frequency = messages / (end - start) of the whole recording (as `mcap info`
//! computes it), so a topic published only in part of the run shows its mean rate over the
//! run. Times are robot-clock nanoseconds (ARCHITECTURE.md section 2), printed as seconds.
//!
//! A live recording (`record --ros2`) also shows its per-topic input counters (the
//! `live_inputs` metadata record: received, lost on the way, dropped when the runtime fell
//! behind, late, undecodable) and its command path (the `motion` record: command writers,
//! commands sent and withheld, the watchdog's worst gap).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::Context as _;
use replay::{IndexSource, McapReader};
use serde_json::{Value, json};

/// Arguments of `rodlog info`.
#[derive(Debug, clap::Args)]
pub struct InfoArgs {
    /// The recording (MCAP).
    pub rec: PathBuf,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    pub json: bool,
}

/// Runs `rodlog info`.
pub fn run(args: &InfoArgs) -> anyhow::Result<()> {
    let mut reader = McapReader::open(&args.rec)
        .with_context(|| format!("cannot read {}", args.rec.display()))?;
    let report = InfoReport::collect(&args.rec, &mut reader);
    if args.json {
        super::print_stdout(&report.to_json().to_string())?;
    } else {
        super::print_stdout(report.to_human().trim_end_matches('\n'))?;
    }
    Ok(())
}

/// One channel's line.
#[derive(Debug, Clone, PartialEq)]
struct ChannelLine {
    id: u16,
    topic: String,
    type_name: String,
    schema_encoding: String,
    message_encoding: String,
    producer: Option<String>,
    count: u64,
    frequency_hz: Option<f64>,
}

/// Chunks of one compression.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
struct CompressionLine {
    chunks: u64,
    compressed_bytes: u64,
    uncompressed_bytes: u64,
}

/// Everything `info` shows, gathered once and rendered as text or JSON.
#[derive(Debug, Clone)]
struct InfoReport {
    file: String,
    file_bytes: u64,
    profile: String,
    library: String,
    index: IndexSource,
    summary_problem: Option<String>,
    messages: u64,
    time_range_ns: Option<(u64, u64)>,
    chunks: u64,
    compression: BTreeMap<String, CompressionLine>,
    channels: Vec<ChannelLine>,
    metadata: Vec<(String, BTreeMap<String, String>)>,
    attachments: Vec<(String, String, u64, u64)>,
    recovery: Option<replay::Recovery>,
}

const NS_PER_S: f64 = 1e9;

fn seconds(ns: u64) -> String {
    format!("{}.{:09}", ns / 1_000_000_000, ns % 1_000_000_000)
}

fn human_bytes(n: u64) -> String {
    const UNITS: [&str; 5] = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut v = n as f64;
    let mut unit = 0;
    while v >= 1024.0 && unit + 1 < UNITS.len() {
        v /= 1024.0;
        unit += 1;
    }
    if unit == 0 {
        format!("{n} B")
    } else {
        format!("{v:.2} {}", UNITS.get(unit).copied().unwrap_or("B"))
    }
}

impl InfoReport {
    fn collect(path: &Path, reader: &mut McapReader) -> Self {
        let duration_s = reader
            .time_range_ns()
            .map(|(a, b)| b.saturating_sub(a) as f64 / NS_PER_S)
            .filter(|d| *d > 0.0);
        let counts = reader.channel_message_counts();
        let channels = reader
            .channels()
            .values()
            .map(|c| {
                let count = counts.get(&c.id).copied().unwrap_or(0);
                ChannelLine {
                    id: c.id,
                    topic: c.topic.clone(),
                    type_name: c.schema_name().to_owned(),
                    schema_encoding: c.schema_encoding().to_owned(),
                    message_encoding: c.message_encoding.clone(),
                    producer: c.producer().map(str::to_owned),
                    count,
                    frequency_hz: duration_s.map(|d| count as f64 / d),
                }
            })
            .collect();
        let mut compression: BTreeMap<String, CompressionLine> = BTreeMap::new();
        for c in reader.chunks() {
            let name = if c.compression.is_empty() {
                "none".to_owned()
            } else {
                c.compression.clone()
            };
            let line = compression.entry(name).or_default();
            line.chunks += 1;
            line.compressed_bytes += c.compressed_bytes;
            line.uncompressed_bytes += c.uncompressed_bytes;
        }
        Self {
            file: path.display().to_string(),
            file_bytes: reader.file_bytes(),
            profile: reader.header().profile.clone(),
            library: reader.header().library.clone(),
            index: reader.index_source(),
            summary_problem: reader.summary_problem().map(str::to_owned),
            messages: reader.message_count(),
            time_range_ns: reader.time_range_ns(),
            chunks: reader.chunks().len() as u64,
            compression,
            channels,
            metadata: reader
                .metadata()
                .iter()
                .map(|m| (m.name.clone(), m.entries.clone()))
                .collect(),
            attachments: reader
                .attachments()
                .iter()
                .map(|a| {
                    (
                        a.name.clone(),
                        a.media_type.clone(),
                        a.data_bytes,
                        a.log_time_ns,
                    )
                })
                .collect(),
            recovery: reader.recovery().cloned(),
        }
    }

    fn to_human(&self) -> String {
        use std::fmt::Write as _;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "file:        {} ({})",
            self.file,
            human_bytes(self.file_bytes)
        );
        let _ = writeln!(s, "library:     {}", self.library);
        let _ = writeln!(s, "profile:     {}", self.profile);
        let _ = writeln!(s, "messages:    {}", self.messages);
        if let Some((a, b)) = self.time_range_ns {
            let _ = writeln!(s, "duration:    {} s", seconds(b.saturating_sub(a)));
            let _ = writeln!(s, "start:       {} s (robot clock)", seconds(a));
            let _ = writeln!(s, "end:         {} s (robot clock)", seconds(b));
        }
        let _ = writeln!(s, "chunks:      {}", self.chunks);
        if !self.compression.is_empty() {
            let _ = writeln!(s, "compression:");
            for (name, c) in &self.compression {
                let ratio = if c.uncompressed_bytes > 0 {
                    100.0 * c.compressed_bytes as f64 / c.uncompressed_bytes as f64
                } else {
                    100.0
                };
                let _ = writeln!(
                    s,
                    "\t{name}: [{} chunks] [{} / {} ({ratio:.1}%)]",
                    c.chunks,
                    human_bytes(c.uncompressed_bytes),
                    human_bytes(c.compressed_bytes)
                );
            }
        }
        let _ = writeln!(s, "channels:    {}", self.channels.len());
        let width = self
            .channels
            .iter()
            .map(|c| c.topic.len())
            .max()
            .unwrap_or(0);
        let id_width = self
            .channels
            .iter()
            .map(|c| c.id.to_string().len())
            .max()
            .unwrap_or(1);
        for c in &self.channels {
            let hz = c
                .frequency_hz
                .map_or_else(String::new, |f| format!(" ({f:.2} Hz)"));
            let producer = c
                .producer
                .as_deref()
                .map_or_else(String::new, |p| format!(" producer={p}"));
            let _ = writeln!(
                s,
                "\t({:>id_width$}) {:width$} {:>7} msgs{hz} : {} [{}/{}]{producer}",
                c.id, c.topic, c.count, c.type_name, c.schema_encoding, c.message_encoding
            );
        }
        let names = |v: Vec<&str>| {
            if v.is_empty() {
                String::new()
            } else {
                format!(" ({})", v.join(", "))
            }
        };
        let _ = writeln!(
            s,
            "metadata:    {}{}",
            self.metadata.len(),
            names(self.metadata.iter().map(|m| m.0.as_str()).collect())
        );
        // A live run's per-topic input counters (received, lost, dropped, late, undecodable),
        // and its command path (writers, commands sent and withheld, the watchdog).
        for (record, title) in [
            (recorder::live::INPUTS_RECORD, "live inputs:"),
            (compose::ros2::motion::MOTION_RECORD, "motion:"),
        ] {
            if let Some((_, entries)) = self.metadata.iter().find(|m| m.0 == record) {
                let _ = writeln!(s, "{title}");
                let width = entries.keys().map(String::len).max().unwrap_or(0);
                for (key, value) in entries {
                    let _ = writeln!(s, "\t{key:width$} {value}");
                }
            }
        }
        let _ = writeln!(
            s,
            "attachments: {}{}",
            self.attachments.len(),
            names(self.attachments.iter().map(|a| a.0.as_str()).collect())
        );
        let index = match self.index {
            IndexSource::Summary => "summary",
            IndexSource::Scan => "linear scan (no usable summary)",
        };
        let _ = writeln!(s, "index:       {index}");
        if let Some(p) = &self.summary_problem {
            let _ = writeln!(s, "summary:     unusable: {p}");
        }
        match &self.recovery {
            None => {
                let _ = writeln!(s, "recovered:   no (file intact)");
            }
            Some(r) => {
                let _ = writeln!(s, "recovered:   yes");
                if let Some(t) = &r.truncation {
                    let _ = writeln!(
                        s,
                        "\tlost {} bytes after offset {}: {}",
                        t.lost_bytes, t.valid_until, t.reason
                    );
                }
                for c in &r.skipped_chunks {
                    let _ = writeln!(
                        s,
                        "\tskipped damaged chunk at offset {} ({} bytes): {}",
                        c.offset, c.record_bytes, c.detail
                    );
                }
            }
        }
        s
    }

    fn to_json(&self) -> Value {
        let channels: Vec<Value> = self
            .channels
            .iter()
            .map(|c| {
                json!({
                    "id": c.id,
                    "topic": c.topic,
                    "type": c.type_name,
                    "schema_encoding": c.schema_encoding,
                    "message_encoding": c.message_encoding,
                    "producer": c.producer,
                    "count": c.count,
                    "frequency_hz": c.frequency_hz,
                })
            })
            .collect();
        let compression: serde_json::Map<String, Value> = self
            .compression
            .iter()
            .map(|(k, c)| {
                (
                    k.clone(),
                    json!({
                        "chunks": c.chunks,
                        "compressed_bytes": c.compressed_bytes,
                        "uncompressed_bytes": c.uncompressed_bytes,
                    }),
                )
            })
            .collect();
        let recovery = self.recovery.as_ref().map(|r| {
            json!({
                "valid_until": r.truncation.as_ref().map(|t| t.valid_until),
                "lost_bytes": r.truncation.as_ref().map_or(0, |t| t.lost_bytes),
                "reason": r.truncation.as_ref().map(|t| t.reason.to_string()),
                "skipped_chunks": r.skipped_chunks.iter().map(|c| json!({
                    "offset": c.offset, "bytes": c.record_bytes, "reason": c.detail,
                })).collect::<Vec<_>>(),
            })
        });
        json!({
            "file": self.file,
            "file_bytes": self.file_bytes,
            "profile": self.profile,
            "library": self.library,
            "index": match self.index { IndexSource::Summary => "summary", IndexSource::Scan => "scan" },
            "summary_problem": self.summary_problem,
            "messages": self.messages,
            "start_ns": self.time_range_ns.map(|t| t.0),
            "end_ns": self.time_range_ns.map(|t| t.1),
            "duration_s": self.time_range_ns.map(|(a, b)| b.saturating_sub(a) as f64 / NS_PER_S),
            "chunks": self.chunks,
            "compressed_bytes": self.compression.values().map(|c| c.compressed_bytes).sum::<u64>(),
            "uncompressed_bytes": self.compression.values().map(|c| c.uncompressed_bytes).sum::<u64>(),
            "compression": compression,
            "channels": channels,
            "metadata": self.metadata.iter().map(|(n, e)| json!({"name": n, "entries": e})).collect::<Vec<_>>(),
            "attachments": self.attachments.iter().map(|(n, m, b, t)| json!({
                "name": n, "media_type": m, "bytes": b, "log_time_ns": t,
            })).collect::<Vec<_>>(),
            "recovered": self.recovery.is_some(),
            "recovery": recovery,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seconds_keep_all_nanoseconds() {
        assert_eq!(seconds(1_500_000_001), "1.500000001");
        assert_eq!(seconds(0), "0.000000000");
    }

    #[test]
    fn bytes_are_scaled() {
        assert_eq!(human_bytes(10), "10 B");
        assert_eq!(human_bytes(2048), "2.00 KiB");
        assert_eq!(human_bytes(3 * 1024 * 1024), "3.00 MiB");
    }
}
