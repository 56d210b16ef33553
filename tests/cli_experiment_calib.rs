//! `rodlog experiment noise|motions|datasets` smoke runs: 2 trials at a low
//! resolution write report.md, results.json with every cell (attempts and refusals counted,
//! seeds recorded) and the box plots (PNG + SVG).

use std::path::Path;
use std::process::Command;

fn run_experiment(name: &str, out: &Path) -> serde_json::Value {
    let out_s = out.display().to_string();
    let run = Command::new(env!("CARGO_BIN_EXE_rodlog"))
        .args([
            "experiment",
            name,
            "--trials",
            "2",
            "--image-scale",
            "0.3",
            "--no-reference",
            "--out",
            &out_s,
        ])
        .output()
        .expect("run rodlog");
    assert!(
        run.status.success(),
        "{name}: {}",
        String::from_utf8_lossy(&run.stderr)
    );
    let report = std::fs::read_to_string(out.join("report.md")).expect("report.md");
    assert!(
        report.contains("ours-rgbd") && report.contains("zhi"),
        "{report}"
    );
    let results: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).expect("json"))
            .expect("results.json parses");
    assert_eq!(results["experiment"], name);
    assert_eq!(results["seeds"].as_array().map(Vec::len), Some(2));
    // Ours ran with the paper's keypoint distribution, and results.json says so.
    assert_eq!(results["parameters"]["orb_distribution"], "quadtree");
    results
}

/// Every cell ran both trials: successes + refusals = attempts = 2.
fn check_cells(cells: &serde_json::Value, expected: usize) {
    let cells = cells.as_array().expect("cells");
    assert_eq!(cells.len(), expected);
    for c in cells {
        assert_eq!(c["attempts"], 2, "{c}");
        let ok = c["samples"]["e_t_mm"].as_array().map_or(0, Vec::len);
        let refused = c["refused"].as_u64().unwrap_or(99) as usize;
        assert_eq!(ok + refused, 2, "{c}");
    }
}

#[test]
fn calibration_experiments_smoke_runs() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let noise = run_experiment("noise", &tmp.path().join("noise"));
    // 6 noise levels x 4 methods (ours-rgbd, ours-mono, ours-mono-unchecked, zhi).
    check_cells(&noise["sections"]["cells"], 24);
    for stem in ["noise_e_r", "noise_e_t"] {
        for ext in ["png", "svg"] {
            let p = tmp.path().join("noise/plots").join(format!("{stem}.{ext}"));
            assert!(p.is_file(), "{} missing", p.display());
        }
    }
    let motions = run_experiment("motions", &tmp.path().join("motions"));
    // 12..=18 motions x 4 methods.
    check_cells(&motions["sections"]["cells"], 28);
    assert!(
        tmp.path()
            .join("motions/plots/motions_median_e_t.png")
            .is_file()
    );
    let datasets = run_experiment("datasets", &tmp.path().join("datasets"));
    check_cells(&datasets["sections"]["simulator"], 4);
    assert!(datasets["sections"]["paper_improvement"].is_array());
}
