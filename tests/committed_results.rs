//! The committed experiment results (`results/`) agree with themselves: every condition of
//! each `results.json` appears in its `report.md` with the same runs, successes, refusals,
//! failures and unsafe commands, and every plot the report shows is committed beside it.
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
        let groups = json["sections"]["groups"]
            .as_array()
            .unwrap_or_else(|| panic!("{}: no groups", dir.display()));
        assert!(!groups.is_empty(), "{}", dir.display());
        for g in groups {
            let cells = [
                g["condition"].as_str().expect("condition").to_owned(),
                g["runs"].to_string(),
                g["success"].to_string(),
            ];
            let row = format!("| {} |", cells.join(" | "));
            let line = report
                .lines()
                .find(|l| l.starts_with(&row))
                .unwrap_or_else(|| panic!("{}: no row {row}", dir.display()));
            let tail: Vec<&str> = line.split('|').map(str::trim).collect();
            // | condition | runs | success | rate | interval | refused | failed | unsafe | ...
            for (k, key) in [(6, "refused"), (7, "failed"), (8, "unsafe_commands")] {
                assert_eq!(
                    tail.get(k).copied(),
                    Some(g[key].to_string().as_str()),
                    "{}: {key} of {line}",
                    dir.display()
                );
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
