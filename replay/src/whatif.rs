//! What-if: replay with other parameters, write the recorded inputs beside the new outputs,
//! and say what changed.
//!
//! A what-if is **open-loop**: the recorded sensor data did not see the
//! new commands, so every output after the first divergent *command* (a stage output on a
//! command topic, [`recorder::scheduler::COMMAND_TOPICS`]) only shows what the stages would
//! have said, not what the robot would have done. The output file carries a `whatif`
//! metadata record naming that log time and topic (`open_loop_from_ns`,
//! `first_divergent_command_topic`), how many outputs follow it, the changed parameters and
//! the per-channel counts; [`summary`] prints the same for people. A closed-loop what-if is
//! `rodlog record` again with the scenario and seed from the recording's metadata.

use std::fmt::Write as _;

use recorder::MetadataRecord;

use crate::replay::ReplayReport;

/// Name of the what-if metadata record.
pub const WHATIF_RECORD: &str = "whatif";

fn secs(ns: u64) -> String {
    format!("{}.{:09}", ns / 1_000_000_000, ns % 1_000_000_000)
}

/// The `whatif` metadata record of an output file.
pub fn metadata(
    report: &ReplayReport,
    source: &str,
    changed_parameters: &[String],
) -> MetadataRecord {
    let c = &report.comparison;
    let mut m = MetadataRecord::new(WHATIF_RECORD)
        .with("source", source)
        .with("changed_parameters", changed_parameters.join(","))
        .with("window_start_ns", report.window_ns.0)
        .with("window_end_ns", report.window_ns.1)
        .with("compared", c.compared())
        .with("identical", c.identical());
    match c.first_divergent_command() {
        Some(d) => {
            m.insert("open_loop", "true");
            m.insert("open_loop_from_ns", d.log_time_ns);
            m.insert("first_divergent_command_topic", &d.topic);
            m.insert("first_divergent_command_producer", &d.producer);
            m.insert("open_loop_outputs", report.outputs_after(d.log_time_ns));
        }
        None => m.insert("open_loop", "false"),
    }
    if let Some(d) = c.first_divergence() {
        m.insert("first_divergence", d.to_string());
    }
    for ch in &c.channels {
        m.insert(
            format!("channel {} {}", ch.topic, ch.producer),
            format!(
                "recorded={} regenerated={} identical={} changed={}",
                ch.recorded,
                ch.regenerated,
                ch.identical,
                ch.changed()
            ),
        );
    }
    m
}

/// A human-readable summary of a replay (check or what-if).
pub fn summary(report: &ReplayReport, changed_parameters: &[String]) -> String {
    let c = &report.comparison;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "replayed {} inputs ({} latched before start, {} undecodable) in [{} s, {} s]",
        report.inputs_fed,
        report.latched_fed,
        report.undecodable_inputs,
        secs(report.window_ns.0),
        secs(report.window_ns.1)
    );
    if let Some(t) = &report.truncated {
        let _ = writeln!(s, "recording was not finished: {t}");
    }
    if !changed_parameters.is_empty() {
        let _ = writeln!(s, "changed parameters: {}", changed_parameters.join(", "));
    }
    let _ = writeln!(
        s,
        "compared {} outputs: {} identical, {} channels",
        c.compared(),
        c.identical(),
        c.channels.len()
    );
    for ch in &c.channels {
        let _ = writeln!(
            s,
            "  {:<28} {:<22} recorded {:>6}  regenerated {:>6}  identical {:>6}  changed {:>6}",
            ch.topic,
            ch.producer,
            ch.recorded,
            ch.regenerated,
            ch.identical,
            ch.changed()
        );
    }
    for ((topic, producer), n) in &report.orphan_outputs {
        let _ = writeln!(
            s,
            "  {topic:<28} {producer:<22} recorded {n:>6}  NOT CHECKED: this pipeline has no stage {producer}"
        );
    }
    match c.first_divergence() {
        Some(d) => {
            let _ = writeln!(s, "first divergence: {d}");
        }
        None => {
            let _ = writeln!(s, "no divergence");
        }
    }
    if let Some(d) = c.first_divergent_command() {
        let _ = writeln!(
            s,
            "open-loop from {} s: first divergent command on {} ({}); the {} outputs after it are open-loop (recorded sensors did not see the new commands)",
            secs(d.log_time_ns),
            d.topic,
            d.producer,
            report.outputs_after(d.log_time_ns)
        );
    }
    s
}
