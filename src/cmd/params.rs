//! `rodlog params SCENARIO [--set k=v]... [--all] [--json]`: every key the scenario's
//! pipeline and world read, with its default, unit, the scenario's value and what it does.
//! Keys of parts the scenario does not build (the task stage of a calibration scenario) are
//! listed with `--all`.

use std::fmt::Write as _;

/// Arguments of `rodlog params`.
#[derive(Debug, clap::Args)]
pub struct ParamsArgs {
    /// Scenario name (recordings/scenarios/NAME.toml), file, or recording (.mcap).
    pub scenario: String,
    /// Override a parameter first, `stage.key=value` (repeatable).
    #[arg(long = "set", value_name = "K=V")]
    pub set: Vec<String>,
    /// The crew's survey of the bay, a site file (`config/sites/*.toml`, ARCHITECTURE.md
    /// section 5): what the robot plans with instead of the built-in fixed bay.
    #[arg(long, value_name = "FILE")]
    pub site: Option<std::path::PathBuf>,
    /// Also list the keys of parts this scenario does not build.
    #[arg(long)]
    pub all: bool,
    /// Machine-readable output.
    #[arg(long)]
    pub json: bool,
}

/// Runs `rodlog params`.
pub fn run(args: &ParamsArgs) -> anyhow::Result<()> {
    let plan = super::record::plan(&args.scenario, None, None, &args.set, args.site.as_deref())?;
    let decls: Vec<&scenario::Decl> = plan
        .declarations()
        .iter()
        .filter(|d| args.all || d.active)
        .collect();
    if args.json {
        let rows: Vec<serde_json::Value> = decls
            .iter()
            .map(|d| {
                serde_json::json!({
                    "key": d.key,
                    "default": d.default,
                    "unit": d.unit,
                    "value": d.value,
                    "part": d.part,
                    "built": d.active,
                    "doc": d.doc,
                })
            })
            .collect();
        return super::print_stdout(&serde_json::to_string_pretty(&rows)?);
    }
    let key_w = decls.iter().map(|d| d.key.len()).max().unwrap_or(3).max(3);
    let def_w = decls
        .iter()
        .map(|d| d.default.len())
        .max()
        .unwrap_or(7)
        .clamp(7, 28);
    let mut text = format!(
        "scenario {} (seed {}, {} s): {} keys{}\n",
        plan.scenario().name,
        plan.scenario().seed,
        plan.scenario().duration.as_secs_f64(),
        decls.len(),
        if args.all {
            ""
        } else {
            " (--all adds those of parts not built)"
        }
    );
    let mut part = "";
    for d in decls {
        if d.part != part {
            part = &d.part;
            let built = if d.active { "" } else { " (not built)" };
            let _ = writeln!(text, "\n[{part}]{built}");
        }
        let value = d
            .value
            .as_deref()
            .map_or(String::new(), |v| format!("= {v}"));
        let _ = writeln!(
            text,
            "  {:<key_w$}  {:<def_w$}  {:<9}  {:<14}  {}",
            d.key, d.default, d.unit, value, d.doc
        );
    }
    super::print_stdout(text.trim_end())
}
