//! `report.md` and `results.json` of an experiment (ARCHITECTURE.md section 7).
//!
//! - [`Table`]: a markdown table builder (header, rows of cells, per-column alignment).
//! - [`Report`]: the markdown document: title, paragraphs, tables, images, written last.
//! - [`Results`]: the machine-readable twin: experiment name, rodlog version, seeds,
//!   parameters, and named sections holding every number the tables show (serde values).
//!
//! Floats: `results.json` is written by serde_json with its `float_roundtrip` feature
//! (workspace Cargo.toml), whose shortest representation parses back to the same bits; NaN
//! and infinities have no JSON form and are written as `null` (the report shows them as
//! `-`). Tables print numbers with [`fmt_num`], a fixed number of decimals chosen by the
//! caller; the exact values are in `results.json`.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use serde::Serialize;
use serde_json::Value;

/// The rodlog version written in every `results.json` (the crate version, independent of
/// git state).
pub const RODLOG_VERSION: &str = env!("CARGO_PKG_VERSION");

/// Column alignment of a [`Table`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Align {
    /// Text columns.
    Left,
    /// Number columns.
    Right,
}

/// A markdown table under construction.
///
/// ```ignore
/// let mut t = Table::new(&["method", "matches", "true rate"]);
/// t.row(vec!["orb-gms".into(), "812".into(), fmt_num(0.93, 3)]);
/// report.table(&t);
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Table {
    header: Vec<String>,
    align: Vec<Align>,
    rows: Vec<Vec<String>>,
}

impl Table {
    /// A table with these column headers; the first column is left-aligned, the others
    /// right-aligned (numbers), change with [`Table::align`].
    pub fn new(header: &[&str]) -> Self {
        let align = (0..header.len())
            .map(|i| if i == 0 { Align::Left } else { Align::Right })
            .collect();
        Self {
            header: header.iter().map(|s| (*s).to_owned()).collect(),
            align,
            rows: Vec::new(),
        }
    }

    /// Sets the alignment of column `col` (ignored past the last column).
    pub fn align(mut self, col: usize, a: Align) -> Self {
        if let Some(x) = self.align.get_mut(col) {
            *x = a;
        }
        self
    }

    /// Appends a row; short rows are padded with empty cells, long ones truncated to the
    /// header. `|` inside a cell is escaped.
    pub fn row(&mut self, mut cells: Vec<String>) {
        cells.resize(self.header.len(), String::new());
        self.rows.push(cells);
    }

    /// The markdown text (one line per row, ending with a newline).
    pub fn to_markdown(&self) -> String {
        let esc = |s: &str| s.replace('|', "\\|");
        let mut out = String::new();
        let line = |cells: &mut dyn Iterator<Item = String>| {
            let mut l = String::from("|");
            for c in cells {
                let _ = write!(l, " {c} |");
            }
            l.push('\n');
            l
        };
        out.push_str(&line(&mut self.header.iter().map(|h| esc(h))));
        out.push_str(&line(&mut self.align.iter().map(|a| match a {
            Align::Left => ":--".to_owned(),
            Align::Right => "--:".to_owned(),
        })));
        for r in &self.rows {
            out.push_str(&line(&mut r.iter().map(|c| esc(c))));
        }
        out
    }
}

/// `x` with `decimals` decimals, `-` for NaN or infinity.
pub fn fmt_num(x: f64, decimals: usize) -> String {
    if x.is_finite() {
        format!("{x:.decimals$}")
    } else {
        "-".to_owned()
    }
}

/// `x` as a percentage with `decimals` decimals (`0.934` -> `93.4%`), `-` when not finite.
pub fn fmt_pct(x: f64, decimals: usize) -> String {
    if x.is_finite() {
        format!("{:.decimals$}%", 100.0 * x)
    } else {
        "-".to_owned()
    }
}

/// One figure of the paper beside rodlog's on the same protocol (an experiment's
/// "Beside the paper" table, and the summary `scripts/reproduce_paper.sh` writes at the top
/// of the whole report).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Comparison {
    /// What is compared, with the paper's table or figure.
    pub what: String,
    /// The paper's figure.
    pub paper: String,
    /// rodlog's, with its interval where it has one.
    pub rodlog: String,
    /// rodlog is behind the paper here.
    pub behind: bool,
}

impl Comparison {
    /// A comparison (fields as named).
    pub fn new(what: &str, paper: &str, rodlog: String, behind: bool) -> Self {
        Self {
            what: what.to_owned(),
            paper: paper.to_owned(),
            rodlog,
            behind,
        }
    }
}

/// The markdown report under construction; [`Report::write`] saves it as `report.md`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Report {
    text: String,
}

impl Report {
    /// A report titled `# title`.
    pub fn new(title: &str) -> Self {
        Self {
            text: format!("# {title}\n\n"),
        }
    }

    /// A `## heading`.
    pub fn heading(&mut self, heading: &str) {
        let _ = write!(self.text, "## {heading}\n\n");
    }

    /// A paragraph of markdown text.
    pub fn paragraph(&mut self, text: &str) {
        let _ = write!(self.text, "{}\n\n", text.trim_end());
    }

    /// A table.
    pub fn table(&mut self, table: &Table) {
        self.text.push_str(&table.to_markdown());
        self.text.push('\n');
    }

    /// The "Beside the paper" section: one row per [`Comparison`], `behind` where rodlog is.
    pub fn comparisons(&mut self, comparisons: &[Comparison]) {
        if comparisons.is_empty() {
            return;
        }
        self.heading("Beside the paper");
        let mut t = Table::new(&["", "paper", "rodlog", "rodlog is"]);
        for c in comparisons {
            t.row(vec![
                c.what.clone(),
                c.paper.clone(),
                c.rodlog.clone(),
                if c.behind { "behind" } else { "level or ahead" }.to_owned(),
            ]);
        }
        self.table(&t);
    }

    /// An image, by a path relative to the report (e.g. `"plots/true_rate.png"`).
    pub fn image(&mut self, alt: &str, relative_path: &str) {
        let _ = write!(self.text, "![{alt}]({relative_path})\n\n");
    }

    /// Writes `dir/report.md`, returning its path.
    ///
    /// # Errors
    /// File system errors.
    pub fn write(&self, dir: &Path) -> Result<PathBuf> {
        let path = dir.join("report.md");
        std::fs::write(&path, &self.text).with_context(|| format!("writing {}", path.display()))?;
        Ok(path)
    }
}

/// The content of `results.json` (module docs): fixed header fields, then `sections`,
/// which an experiment fills with whatever serialisable structs hold its table numbers.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Results {
    /// Experiment name (`matchers`, `noise`, ...).
    pub experiment: String,
    /// [`RODLOG_VERSION`].
    pub rodlog_version: String,
    /// The `--seed` the run started from.
    pub seed: u64,
    /// Every seed actually used, per trial, so any single trial can be rerun.
    pub seeds: Vec<u64>,
    /// Parameters of the run (trials, image scale, method settings...), sorted by name.
    pub parameters: BTreeMap<String, Value>,
    /// Named sections with the numbers of the tables, sorted by name.
    pub sections: BTreeMap<String, Value>,
}

impl Results {
    /// Empty results for `experiment` run from `seed`.
    pub fn new(experiment: &str, seed: u64) -> Self {
        Self {
            experiment: experiment.to_owned(),
            rodlog_version: RODLOG_VERSION.to_owned(),
            seed,
            seeds: Vec::new(),
            parameters: BTreeMap::new(),
            sections: BTreeMap::new(),
        }
    }

    /// Records a parameter.
    ///
    /// # Errors
    /// When `value` cannot be represented as JSON (e.g. a map with non-string keys).
    pub fn parameter(&mut self, name: &str, value: impl Serialize) -> Result<()> {
        let v = serde_json::to_value(value).with_context(|| format!("parameter {name}"))?;
        self.parameters.insert(name.to_owned(), v);
        Ok(())
    }

    /// Stores a section (replacing one of the same name).
    ///
    /// # Errors
    /// When `value` cannot be represented as JSON.
    pub fn section(&mut self, name: &str, value: impl Serialize) -> Result<()> {
        let v = serde_json::to_value(value).with_context(|| format!("section {name}"))?;
        self.sections.insert(name.to_owned(), v);
        Ok(())
    }

    /// Writes `dir/results.json` (pretty-printed, trailing newline), returning its path.
    ///
    /// # Errors
    /// Serialisation or file system errors.
    pub fn write(&self, dir: &Path) -> Result<PathBuf> {
        let path = dir.join("results.json");
        let mut text = serde_json::to_string_pretty(self).context("serialising results")?;
        text.push('\n');
        std::fs::write(&path, text).with_context(|| format!("writing {}", path.display()))?;
        Ok(path)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_markdown_escapes_and_pads() {
        let mut t = Table::new(&["method", "n"]);
        t.row(vec!["a|b".into(), "3".into()]);
        t.row(vec!["c".into()]);
        assert_eq!(
            t.to_markdown(),
            "| method | n |\n| :-- | --: |\n| a\\|b | 3 |\n| c |  |\n"
        );
        assert_eq!(fmt_num(f64::NAN, 2), "-");
        assert_eq!(fmt_pct(0.9345, 1), "93.5%");
    }

    #[test]
    fn results_round_trip_floats_exactly_and_null_nan() {
        let dir = tempfile::tempdir().expect("tempdir");
        let mut r = Results::new("matchers", 7);
        r.seeds = vec![7, 8];
        let x = 0.1f64 + 0.2;
        r.section("s", [x, f64::NAN, 1e-300]).expect("section");
        let path = r.write(dir.path()).expect("write");
        let v: Value =
            serde_json::from_str(&std::fs::read_to_string(path).expect("read")).expect("parse");
        assert_eq!(v["rodlog_version"], RODLOG_VERSION);
        assert_eq!(
            v["sections"]["s"][0].as_f64().map(f64::to_bits),
            Some(x.to_bits())
        );
        assert!(v["sections"]["s"][1].is_null());
        assert_eq!(v["sections"]["s"][2].as_f64(), Some(1e-300));
    }
}
