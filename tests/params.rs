//! Strict parameters end to end, through the built binary: a mistyped key is an error naming
//! it on `record` and on a replay what-if; `rodlog params` lists the keys; an old recording
//! with a retired key still replays; a recorded key this version does not know is replayed
//! without and reported as a divergence; outputs of a stage the pipeline lacks fail
//! `replay --check`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use recorder::{McapSink, MetadataRecord, RawRecord, SinkOptions};
use replay::{McapReader, ReadFilter};

type TestResult = Result<(), Box<dyn std::error::Error>>;

fn rodlog(args: &[&str]) -> Result<Output, std::io::Error> {
    Command::new(env!("CARGO_BIN_EXE_rodlog"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(args)
        .output()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn arm_sweep() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("recordings/arm_sweep.mcap")
}

/// A copy of `src` with its `scenario` record's entries edited by `edit` and, when `extra`
/// is given, one more `/rosout` message from that producer: a recording as an older (or
/// another) version of rodlog would have written it.
fn rewrite(
    src: &Path,
    dst: &Path,
    edit: impl Fn(&mut BTreeMap<String, String>),
    extra: Option<&str>,
) -> TestResult {
    let mut reader = McapReader::open(src)?;
    let mut sink = McapSink::create(dst, &SinkOptions::default())?;
    for m in reader.metadata().to_vec() {
        let mut rec = MetadataRecord::new(m.name.clone());
        rec.entries = m.entries.clone();
        if m.name == scenario::SCENARIO_RECORD {
            edit(&mut rec.entries);
        }
        // The extra producer was one of the recording's stages.
        if let (Some(producer), "pipeline") = (extra, m.name.as_str())
            && let Some(stages) = rec.entries.get_mut("stages")
        {
            stages.push(',');
            stages.push_str(producer);
        }
        sink.write_metadata(&rec)?;
    }
    for a in reader.attachments().to_vec() {
        let data = reader.read_attachment(&a)?;
        sink.attach(&a.name, &a.media_type, a.log_time_ns, &data)?;
    }
    let mut extra_rosout: Option<(Vec<u8>, String, String)> = None;
    for (i, m) in reader.read_all(&ReadFilter::all())?.into_iter().enumerate() {
        let schema = m
            .channel
            .schema
            .as_ref()
            .map(|s| String::from_utf8_lossy(&s.data).into_owned())
            .unwrap_or_default();
        let qos = m
            .channel
            .metadata
            .get("offered_qos_profiles")
            .cloned()
            .unwrap_or_default();
        if m.topic() == "/rosout" && extra_rosout.is_none() {
            extra_rosout = Some((m.data.clone(), schema.clone(), qos.clone()));
        }
        sink.write_raw(&RawRecord {
            topic: m.topic(),
            producer: m.producer().unwrap_or_default(),
            type_name: m.channel.schema_name(),
            schema_text: &schema,
            qos_yaml: &qos,
            log_time_ns: m.log_time_ns,
            publish_time_ns: m.publish_time_ns,
            sequence: u32::try_from(i)?,
            cdr: &m.data,
        })?;
    }
    if let (Some(producer), Some((cdr, schema, qos))) = (extra, extra_rosout) {
        sink.write_raw(&RawRecord {
            topic: "/rosout",
            producer,
            type_name: "rcl_interfaces/msg/Log",
            schema_text: &schema,
            qos_yaml: &qos,
            log_time_ns: 1_000_000_000,
            publish_time_ns: 1_000_000_000,
            sequence: 0,
            cdr: &cdr,
        })?;
    }
    sink.finish()?;
    Ok(())
}

#[test]
fn a_mistyped_key_is_an_error_naming_it_on_record_and_on_a_what_if() -> TestResult {
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("x.mcap");
    let out_s = out.to_str().ok_or("path")?;
    let r = rodlog(&[
        "record",
        "--scenario",
        "arm_sweep",
        "--set",
        "arm_exerciser.amplitude_radd=0.5",
        "--out",
        out_s,
    ])?;
    assert_eq!(r.status.code(), Some(1));
    let err = stderr(&r);
    assert!(
        err.contains("\"arm_exerciser.amplitude_radd\"")
            && err.contains("did you mean \"arm_exerciser.amplitude_rad\""),
        "{err}"
    );
    assert!(!out.exists(), "nothing is recorded with a typo");

    let w = dir.path().join("w.mcap");
    let r = rodlog(&[
        "replay",
        arm_sweep().to_str().ok_or("path")?,
        "--set",
        "joint_limit_monitor.nonexistent=3",
        "--out",
        w.to_str().ok_or("path")?,
    ])?;
    assert_eq!(r.status.code(), Some(1));
    assert!(
        stderr(&r).contains("joint_limit_monitor.nonexistent"),
        "{}",
        stderr(&r)
    );

    // A key of a part the scenario does not build says which part and why.
    let r = rodlog(&[
        "record",
        "--scenario",
        "arm_sweep",
        "--set",
        "camera.scale=0.5",
        "--out",
        out_s,
    ])?;
    let err = stderr(&r);
    assert!(
        err.contains("simulator") && err.contains("world = \"test_world\""),
        "{err}"
    );
    Ok(())
}

#[test]
fn params_lists_every_key_with_default_unit_and_value() -> TestResult {
    let r = rodlog(&["params", "hang", "--json"])?;
    assert!(r.status.success(), "{}", stderr(&r));
    let rows: serde_json::Value = serde_json::from_slice(&r.stdout)?;
    let rows = rows.as_array().ok_or("array")?;
    let find = |key: &str| rows.iter().find(|r| r["key"] == key);
    let standoff = find("task.standoff_m").ok_or("task.standoff_m")?;
    assert_eq!(standoff["unit"], "m");
    assert_eq!(standoff["default"], "0.45");
    assert_eq!(find("hour").ok_or("hour")?["value"], "11.0");
    assert!(
        find("test_world.lift_m").is_none(),
        "parts not built are listed only with --all"
    );
    let r = rodlog(&["params", "hang", "--all"])?;
    assert!(String::from_utf8(r.stdout)?.contains("test_world.lift_m"));
    Ok(())
}

#[test]
fn an_old_recording_with_a_retired_key_still_replays() -> TestResult {
    let dir = tempfile::tempdir()?;
    let old = dir.path().join("old.mcap");
    rewrite(
        &arm_sweep(),
        &old,
        |e| {
            e.insert("param.perceive.prior_y_m".into(), "0.05".into());
        },
        None,
    )?;
    let r = rodlog(&["replay", old.to_str().ok_or("path")?, "--check"])?;
    let (out, err) = (String::from_utf8_lossy(&r.stdout).into_owned(), stderr(&r));
    assert!(r.status.success(), "{err}");
    assert!(
        err.contains("perceive.prior_y_m = 0.05 is retired"),
        "{err}"
    );
    assert!(out.contains("check passed"), "{out}");
    Ok(())
}

#[test]
fn an_unknown_recorded_key_is_replayed_without_and_reported() -> TestResult {
    let dir = tempfile::tempdir()?;
    let other = dir.path().join("other.mcap");
    rewrite(
        &arm_sweep(),
        &other,
        |e| {
            e.insert("param.arm_exerciser.jitter_rad".into(), "0.1".into());
        },
        None,
    )?;
    let path = other.to_str().ok_or("path")?;
    // The replay runs to the end and compares, then the check fails naming the key.
    let r = rodlog(&["replay", path, "--check"])?;
    assert_eq!(r.status.code(), Some(1));
    let (out, err) = (String::from_utf8_lossy(&r.stdout).into_owned(), stderr(&r));
    assert!(out.contains("no divergence"), "{out}");
    assert!(err.contains("arm_exerciser.jitter_rad"), "{err}");
    // A what-if still writes its file.
    let w = dir.path().join("w.mcap");
    let r = rodlog(&["replay", path, "--out", w.to_str().ok_or("path")?])?;
    assert!(r.status.success(), "{}", stderr(&r));
    assert!(w.is_file());
    Ok(())
}

#[test]
fn outputs_of_a_stage_the_pipeline_lacks_fail_the_check() -> TestResult {
    let dir = tempfile::tempdir()?;
    let file = dir.path().join("extra.mcap");
    rewrite(&arm_sweep(), &file, |_| {}, Some("retired_stage"))?;
    let r = rodlog(&["replay", file.to_str().ok_or("path")?, "--check"])?;
    assert_eq!(r.status.code(), Some(1));
    let (out, err) = (String::from_utf8_lossy(&r.stdout).into_owned(), stderr(&r));
    assert!(
        out.contains("NOT CHECKED: this pipeline has no stage retired_stage"),
        "{out}"
    );
    assert!(err.contains("/rosout from retired_stage (1)"), "{err}");
    Ok(())
}

/// `--site FILE` gives the task and perception the crew's survey as `survey.*` keys: listed
/// by `rodlog params`, kept in the recording (a replay plans with it), strict (a site file
/// with a typo or another table is refused by name), and a scenario file cannot carry one.
#[test]
fn a_site_file_is_the_surveys_only_way_in() -> TestResult {
    let fixed = Path::new(env!("CARGO_MANIFEST_DIR")).join("config/sites/fixed_bay.toml");
    let fixed_s = fixed.display().to_string();
    let out = rodlog(&["params", "hang", "--site", &fixed_s])?;
    assert!(out.status.success(), "{}", stderr(&out));
    let listing = String::from_utf8_lossy(&out.stdout);
    assert!(
        listing.contains("survey.cabinet.facing_deg") && listing.contains("= 180.0"),
        "{listing}"
    );

    let dir = tempfile::tempdir()?;
    let text = std::fs::read_to_string(&fixed)?;
    let typo = dir.path().join("typo.toml");
    std::fs::write(&typo, text.replace("yaw_deg = 90.0", "yaw_dg = 90.0"))?;
    let out = rodlog(&["params", "hang", "--site", &typo.display().to_string()])?;
    assert!(!out.status.success());
    assert!(
        stderr(&out).contains("survey.work_spot.yaw_d"),
        "{}",
        stderr(&out)
    );
    let other = dir.path().join("other.toml");
    std::fs::write(&other, format!("{text}\n[task]\nstandoff_m = 0.5\n"))?;
    let out = rodlog(&["params", "hang", "--site", &other.display().to_string()])?;
    assert!(
        !out.status.success() && stderr(&out).contains("[survey.*] tables only"),
        "{}",
        stderr(&out)
    );
    let scenario = dir.path().join("with_survey.toml");
    std::fs::write(
        &scenario,
        "name = \"s\"\nduration_s = 1.0\n[survey.wire]\npoint_m = [12.0, 0.0, 3.7]\n",
    )?;
    let out = rodlog(&["params", &scenario.display().to_string()])?;
    assert!(
        !out.status.success() && stderr(&out).contains("no site priors"),
        "{}",
        stderr(&out)
    );

    // Recorded with the survey, replayed from the recording alone.
    // (A scenario without the task and perception refuses the survey as unused keys.)
    let rec = dir.path().join("hang.mcap");
    let rec_s = rec.display().to_string();
    let out = rodlog(&[
        "record",
        "--scenario",
        "arm_sweep",
        "--site",
        &fixed_s,
        "--out",
        &rec_s,
    ])?;
    assert!(
        !out.status.success() && stderr(&out).contains("survey.wire.point_m"),
        "{}",
        stderr(&out)
    );
    let out = rodlog(&[
        "record",
        "--scenario",
        "hang",
        "--duration",
        "4",
        "--set",
        "camera.scale=0.1",
        "--site",
        &fixed_s,
        "--out",
        &rec_s,
    ])?;
    assert!(out.status.success(), "{}", stderr(&out));
    let reader = McapReader::open(&rec)?;
    let scenario_record = reader
        .metadata()
        .iter()
        .find(|m| m.name == "scenario")
        .cloned()
        .ok_or("no scenario record")?;
    assert!(
        scenario_record
            .entries
            .get("param.survey.rack.yaw_deg")
            .is_some_and(|v| v.starts_with("200.556")),
        "{:?}",
        scenario_record.entries
    );
    drop(reader);
    let out = rodlog(&["replay", &rec_s, "--check"])?;
    assert!(out.status.success(), "{}", stderr(&out));
    Ok(())
}
