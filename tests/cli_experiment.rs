//! `rodlog experiment`: the matchers smoke run (2 pairs per set at a quarter of the
//! resolution) writes a report, parseable results with every method's numbers and seeds,
//! match pictures and plots.

#[path = "support/cli.rs"]
mod cli;
use cli::rodlog;

#[test]
fn matchers_smoke_run_writes_report_results_and_pictures() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let out = tmp.path().join("matchers");
    let out_s = out.display().to_string();
    let run = rodlog(&[
        "experiment",
        "matchers",
        "--trials",
        "2",
        "--image-scale",
        "0.25",
        "--no-reference",
        "--out",
        &out_s,
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let report = std::fs::read_to_string(out.join("report.md")).expect("report.md");
    assert!(report.contains("| method |") && report.contains("orb-gms"));
    let results: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).expect("json"))
            .expect("results.json parses");
    assert_eq!(results["experiment"], "matchers");
    assert!(results["rodlog_version"].is_string());
    assert_eq!(results["parameters"]["pairs_per_set"], 2);
    let shecar = testkit::shared_data(
        "shecar/handposes.txt",
        "the matchers experiment's shecar set",
    )
    .is_some();
    let sets = if shecar { 3 } else { 1 };
    let seeds = results["seeds"].as_array().expect("seeds");
    assert!(seeds.len() >= 2 * (sets - 1) + 2, "seeds {seeds:?}");
    let summary = results["sections"]["summary"].as_array().expect("summary");
    let methods = results["parameters"]["methods"]
        .as_array()
        .expect("methods");
    assert_eq!(summary.len(), sets * methods.len());
    // On simulated pairs at this size ORB+GMS finds true matches, judged by depth and pose.
    let sim_gms = summary
        .iter()
        .find(|s| s["set"] == "sim" && s["method"] == "orb-gms")
        .expect("sim orb-gms");
    assert!(
        sim_gms["true_matches"]["median"].as_f64().unwrap_or(0.0) > 10.0,
        "{sim_gms}"
    );
    for name in ["true_rate", "true_matches", "true_rate_box", "time_box"] {
        let png = out.join("plots").join(format!("{name}.png"));
        let img = image::open(&png).unwrap_or_else(|e| panic!("{}: {e}", png.display()));
        assert!(img.width() > 100);
        let svg =
            std::fs::read_to_string(out.join("plots").join(format!("{name}.svg"))).expect("svg");
        assert!(svg.starts_with("<svg"));
    }
    let pic = out.join("images").join("sim_orb-gms.png");
    assert!(image::open(&pic).is_ok(), "{}", pic.display());
}

/// `--no-pictures` leaves the match pictures out (shecar's photos are GPL-3.0: a committed
/// report must not hold them) and changes no number; other experiments refuse the option.
#[test]
fn matchers_without_pictures_write_none_and_the_same_numbers() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let run = |extra: &[&str], name: &str| {
        let out = tmp.path().join(name);
        let out_s = out.display().to_string();
        let mut args = vec![
            "experiment",
            "matchers",
            "--trials",
            "1",
            "--image-scale",
            "0.25",
            "--no-reference",
            "--out",
            &out_s,
        ];
        args.extend_from_slice(extra);
        let r = rodlog(&args);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        out
    };
    let with = run(&[], "with");
    let without = run(&["--no-pictures"], "without");
    let pngs = |dir: &std::path::Path| {
        std::fs::read_dir(dir.join("images")).map_or(0, |d| d.flatten().count())
    };
    assert!(pngs(&with) > 0);
    assert_eq!(pngs(&without), 0);
    let report = std::fs::read_to_string(without.join("report.md")).expect("report.md");
    assert!(!report.contains("](images/"), "{report}");
    let summary = |dir: &std::path::Path| {
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("results.json")).expect("json"))
                .expect("parses");
        v["sections"]["summary"]
            .as_array()
            .expect("summary")
            .iter()
            .map(|s| {
                (
                    s["method"].clone(),
                    s["refused"].clone(),
                    s["true_matches"]["mean"].clone(),
                )
            })
            .collect::<Vec<_>>()
    };
    assert_eq!(summary(&with), summary(&without));
    let noise = rodlog(&[
        "experiment",
        "noise",
        "--no-pictures",
        "--out",
        "/nonexistent/x",
    ]);
    assert!(!noise.status.success());
    assert!(String::from_utf8_lossy(&noise.stderr).contains("--no-pictures is an option of"));
}
