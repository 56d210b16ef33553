//! The committed experiment results (`results/`) agree with themselves: every condition of
//! each `results.json` appears in its `report.md` with the same runs, successes, refusals,
//! failures and unsafe commands (the maintenance bins with the same verdict counts), and
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
        } else {
            // The maintenance experiment: | bin | runs | no check | drifted | consistent
            // | cannot tell | 4 views: cannot tell | looked again | ...
            let bins = sections["bins"]
                .as_array()
                .unwrap_or_else(|| panic!("{}: neither groups nor bins", dir.display()));
            assert!(!bins.is_empty(), "{}", dir.display());
            for b in bins {
                let row = row_of(&dir, &report, &[&b["bin"], &b["runs"]]);
                let not_checked: u64 = b["not_checked"].as_object().map_or(0, |m| {
                    m.values().filter_map(serde_json::Value::as_u64).sum()
                });
                assert_eq!(
                    row.get(3)
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
                        row.get(k).map(String::as_str),
                        Some(b[key].to_string().as_str()),
                        "{}: {key} of {row:?}",
                        dir.display()
                    );
                }
            }
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
