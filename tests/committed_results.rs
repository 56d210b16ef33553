//! The committed experiment results (`results/`) agree with themselves: every condition of
//! each `results.json` appears in its `report.md` with the same runs, successes, refusals,
//! failures and unsafe commands (the maintenance bins with the same verdict counts; the
//! calibration experiments' cells, the ablation's variants and the matchers' rows with the
//! same answers and refusals), every comparison with the paper as results.json has it, and
//! every plot the report shows is committed beside it.
//! The numbers were made by the command in `results/README.md`; a report edited by hand, or
//! regenerated without its results.json, fails here.

use std::path::{Path, PathBuf};

fn committed() -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("results");
    let mut dirs = Vec::new();
    let mut stack = vec![root];
    while let Some(dir) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.file_name().is_some_and(|n| n == "results.json") {
                dirs.push(dir.clone());
            }
        }
    }
    dirs.sort();
    dirs
}

#[test]
fn committed_reports_say_what_their_results_say() {
    let dirs = committed();
    assert!(
        dirs.len() >= 2,
        "results/ holds the seeded-site task and light tables: {dirs:?}"
    );
    for dir in dirs {
        let json: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(dir.join("results.json")).expect("results.json"),
        )
        .expect("results.json parses");
        let report = std::fs::read_to_string(dir.join("report.md")).expect("report.md");
        let sections = &json["sections"];
        if let Some(groups) = sections["groups"].as_array() {
            // The task experiments: | condition | runs | success | rate | interval | refused
            // | failed | unsafe | ...
            assert!(!groups.is_empty(), "{}", dir.display());
            for g in groups {
                let row = row_of(&dir, &report, &[&g["condition"], &g["runs"], &g["success"]]);
                for (k, key) in [(6, "refused"), (7, "failed"), (8, "unsafe_commands")] {
                    assert_eq!(
                        row.get(k).map(String::as_str),
                        Some(g[key].to_string().as_str()),
                        "{}: {key} of {row:?}",
                        dir.display()
                    );
                }
            }
        } else if let Some(cells) = sections["cells"]
            .as_array()
            .or(sections["simulator"].as_array())
        {
            // The calibration experiments (noise, motions, datasets): | condition | method
            // | ... | refused/attempts |.
            assert!(!cells.is_empty(), "{}", dir.display());
            for c in cells {
                let row = row_of(&dir, &report, &[&c["condition"], &c["method"]]);
                assert_eq!(
                    row.iter().rev().nth(1).map(String::as_str),
                    Some(format!("{}/{}", c["refused"], c["attempts"]).as_str()),
                    "{}: refusals of {row:?}",
                    dir.display()
                );
            }
            // The noise experiment beside the OpenCV depth-PnP peer: | noise | ours answered
            // | peer answered | both answered | ... | ours ahead |.
            let peer = sections["opencv_peer"]
                .as_array()
                .map_or(&[][..], Vec::as_slice);
            if peer.iter().any(|l| l["peer_runs"].as_u64() > Some(0)) {
                let section = report
                    .split("\n## ")
                    .find(|part| part.starts_with("Beside the OpenCV depth-PnP peer"))
                    .unwrap_or_else(|| panic!("{}: no peer section", dir.display()));
                for l in peer {
                    let runs = l["peer_runs"].as_u64().unwrap_or(0);
                    let answered = format!("{}/{runs}", l["ours_answered"]);
                    let row = row_of(&dir, section, &[&l["condition"], &answered.into()]);
                    let peer_answered = runs - l["peer_refused"].as_u64().unwrap_or(0);
                    assert_eq!(
                        (
                            row.get(3).map(String::as_str),
                            row.get(4).map(String::as_str)
                        ),
                        (
                            Some(format!("{peer_answered}/{runs}").as_str()),
                            Some(l["trials"].to_string().as_str())
                        ),
                        "{}: peer row {row:?}",
                        dir.display()
                    );
                    // | ours-rgbd deg | ours-rgbd mm | peer solver | peer deg | peer mm |,
                    // formatted as the report formats them ("-" where there is no median).
                    let num = |key: &str, decimals: usize| {
                        l[key]
                            .as_f64()
                            .map_or_else(|| "-".to_owned(), |v| format!("{v:.decimals$}"))
                    };
                    let medians = [
                        num("ours_deg", 3),
                        num("ours_mm", 2),
                        l["peer_solver"].as_str().unwrap_or("").to_owned(),
                        num("peer_deg", 3),
                        num("peer_mm", 2),
                    ];
                    assert_eq!(
                        row.get(5..10),
                        Some(&medians[..]),
                        "{}: peer medians of {row:?}",
                        dir.display()
                    );
                }
            }
        } else if let Some(variants) = sections["variants"].as_array() {
            // The ablation: | variant | change | answered/trials | ...
            assert!(!variants.is_empty(), "{}", dir.display());
            for v in variants {
                let row = row_of(&dir, &report, &[&v["variant"], &v["change"]]);
                assert_eq!(
                    row.get(3).map(String::as_str),
                    Some(format!("{}/{}", v["answered"], v["trials"]).as_str()),
                    "{}: answers of {row:?}",
                    dir.display()
                );
            }
        } else if let Some(summary) = sections["summary"].as_array() {
            // The matchers, a table per set: | method | refused/pairs | ...
            assert!(!summary.is_empty(), "{}", dir.display());
            for m in summary {
                let set = m["set"].as_str().unwrap_or("");
                let heading = format!("## {set} pairs");
                let section = report
                    .split("\n## ")
                    .find(|part| format!("## {part}").starts_with(&heading))
                    .unwrap_or_else(|| panic!("{}: no section {heading}", dir.display()));
                let row = row_of(&dir, section, &[&m["method"]]);
                assert_eq!(
                    row.get(2).map(String::as_str),
                    Some(format!("{}/{}", m["refused"], m["pairs"]).as_str()),
                    "{}: {set} refusals of {row:?}",
                    dir.display()
                );
            }
        } else {
            // The maintenance experiment: | bin | runs | against a reference | no check
            // | drifted | consistent | cannot tell | 4 views: cannot tell | looked again | ...
            // (tables made before the reference check have no "against a reference")
            let bins = sections["bins"].as_array().unwrap_or_else(|| {
                panic!(
                    "{}: none of groups, cells, variants, summary or bins",
                    dir.display()
                )
            });
            assert!(!bins.is_empty(), "{}", dir.display());
            for b in bins {
                let row = row_of(&dir, &report, &[&b["bin"], &b["runs"]]);
                let not_checked: u64 = b["not_checked"].as_object().map_or(0, |m| {
                    m.values().filter_map(serde_json::Value::as_u64).sum()
                });
                let with_reference = usize::from(!b["from_reference"].is_null());
                if with_reference == 1 {
                    assert_eq!(
                        row.get(3).map(String::as_str),
                        Some(b["from_reference"].to_string().as_str()),
                        "{}: from_reference of {row:?}",
                        dir.display()
                    );
                }
                assert_eq!(
                    row.get(3 + with_reference)
                        .and_then(|c| c.split(' ').next())
                        .map(str::to_owned),
                    Some(not_checked.to_string()),
                    "{}: not_checked of {row:?}",
                    dir.display()
                );
                for (k, key) in [
                    (4, "drifted"),
                    (5, "consistent"),
                    (6, "cannot_tell"),
                    (7, "first_cannot_tell"),
                    (8, "extended"),
                ] {
                    assert_eq!(
                        row.get(k + with_reference).map(String::as_str),
                        Some(b[key].to_string().as_str()),
                        "{}: {key} of {row:?}",
                        dir.display()
                    );
                }
            }
        }
        // Every comparison with the paper is in the report as results.json has it.
        for c in sections["comparisons"].as_array().into_iter().flatten() {
            let text = |k: &str| c[k].as_str().unwrap_or_default().to_owned();
            let row = format!(
                "| {} | {} | {} |",
                text("what"),
                text("paper"),
                text("rodlog")
            );
            assert!(report.contains(&row), "{}: no row {row}", dir.display());
        }
        for image in report
            .split("](")
            .skip(1)
            .filter_map(|s| s.split(')').next())
            .filter(|s| s.ends_with(".png"))
        {
            assert!(
                dir.join(image).is_file(),
                "{}: {image} is shown but not committed",
                dir.display()
            );
        }
    }
}

/// The cells of the report's table row that starts with `first` (strings unquoted), from
/// the leading `|` on (cell 0 is empty).
fn row_of(dir: &Path, report: &str, first: &[&serde_json::Value]) -> Vec<String> {
    let cells: Vec<String> = first
        .iter()
        .map(|v| v.as_str().map_or_else(|| v.to_string(), str::to_owned))
        .collect();
    let start = format!("| {} |", cells.join(" | "));
    let line = report
        .lines()
        .find(|l| l.starts_with(&start))
        .unwrap_or_else(|| panic!("{}: no row {start}", dir.display()));
    line.split('|').map(|c| c.trim().to_owned()).collect()
}
