//! [`Scenario`]: one run, as a TOML file (`recordings/scenarios/NAME.toml`).
//!
//! ```toml
//! name = "hang"               # required
//! seed = 21                   # every random process of the world derives from it
//! duration_s = 300.0          # robot time to run (required)
//! description = "..."         # optional
//! hour = 11.0                 # every other top-level key or table is a parameter:
//! task = "hang"               #   `hour`, `task`, `wind.mean_mps`, `camera.scale`, ...
//! [wind]
//! mean_mps = 1.0
//! [parameters]                # also parameters (dotted keys); they win on a clash
//! task.standoff_m = 0.45
//! [[command]]                 # timed commands for the `script` stage (crate::command)
//! t_s = 0.5
//! kind = "lift"
//! values = [0.4]
//! ```
//!
//! The file says nothing about which keys exist: the configs declare them through a
//! [`crate::Reader`], and the composition root rejects any key nobody consumes. `rodlog
//! params NAME` lists them.
//!
//! A recording carries its scenario twice: the `scenario` metadata record
//! ([`Scenario::metadata_entries`]: name, seed, duration and every parameter as
//! `param.<key>`) and the file itself as the attachment [`SCENARIO_ATTACHMENT`] (for the
//! command list). [`Scenario::from_metadata`] rebuilds the scenario from both, which is what
//! replay and a closed-loop what-if start from.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use msgs::RobotDuration;

use crate::command::Command;
use crate::error::{ParamError, ScenarioError};
use crate::params::{Params, parse_value, split_set};

/// Prefix of parameter keys in the `scenario` metadata record.
pub const PARAM_PREFIX: &str = "param.";
/// Name of the scenario metadata record.
pub const SCENARIO_RECORD: &str = "scenario";
/// Name of the scenario file's attachment in a recording.
pub const SCENARIO_ATTACHMENT: &str = "scenario.toml";
/// Top-level keys of a scenario file that are not parameters.
pub const RESERVED_KEYS: [&str; 6] = [
    "name",
    "seed",
    "duration_s",
    "description",
    "parameters",
    "command",
];
/// Longest run a scenario may ask for (s): one day of robot time.
pub const MAX_DURATION_S: f64 = 86_400.0;

/// The parameters' section a site file fills (`survey.*`).
pub const SURVEY_KEY: &str = "survey";

/// A scenario: what to run, for how long, with which seed, parameters and commands.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    /// Scenario name.
    pub name: String,
    /// Seed of every random process of the world.
    pub seed: u64,
    /// Robot time to run.
    pub duration: RobotDuration,
    /// Free text.
    pub description: String,
    /// Stage and world parameters.
    pub params: Params,
    /// The `[[command]]` entries, in file order.
    pub commands: Vec<Command>,
    /// The file's text (attached to recordings).
    pub source_text: String,
    /// The file it was read from, if any.
    pub source_path: Option<PathBuf>,
}

fn toml_table(text: &str, origin: &str) -> Result<toml::Table, ScenarioError> {
    text.parse()
        .map_err(|e: toml::de::Error| ScenarioError::Toml {
            origin: origin.to_owned(),
            reason: e.message().to_owned(),
        })
}

impl Scenario {
    /// Parses scenario TOML text; `origin` names it in errors.
    ///
    /// # Errors
    /// [`ScenarioError::Toml`], [`ScenarioError::Field`] (missing name or duration, bad
    /// seed, malformed commands).
    pub fn parse(text: &str, origin: &str) -> Result<Self, ScenarioError> {
        let table = toml_table(text, origin)?;
        let field = |f: &str, reason: &str| ScenarioError::Field {
            origin: origin.to_owned(),
            field: f.to_owned(),
            reason: reason.to_owned(),
        };
        let name = match table.get("name") {
            Some(toml::Value::String(s)) if !s.is_empty() => s.clone(),
            Some(_) => return Err(field("name", "must be a non-empty string")),
            None => return Err(field("name", "missing")),
        };
        let seed = match table.get("seed") {
            None => 0,
            Some(toml::Value::Integer(i)) => {
                u64::try_from(*i).map_err(|_| field("seed", "must be >= 0"))?
            }
            Some(_) => return Err(field("seed", "must be an integer")),
        };
        let duration_s = match table.get("duration_s") {
            Some(toml::Value::Float(f)) => *f,
            Some(toml::Value::Integer(i)) => *i as f64,
            Some(_) => return Err(field("duration_s", "must be a number")),
            None => return Err(field("duration_s", "missing")),
        };
        let duration =
            duration_from_secs(duration_s).map_err(|reason| field("duration_s", &reason))?;
        let description = match table.get("description") {
            None => String::new(),
            Some(toml::Value::String(s)) => s.clone(),
            Some(_) => return Err(field("description", "must be a string")),
        };
        let mut others = table.clone();
        for reserved in RESERVED_KEYS {
            others.remove(reserved);
        }
        let mut params = Params::from_table(&others);
        match table.get("parameters") {
            None => {}
            Some(toml::Value::Table(t)) => params.merge(&Params::from_table(t)),
            Some(_) => return Err(field("parameters", "must be a table")),
        }
        if params
            .keys()
            .any(|k| k == SURVEY_KEY || k.starts_with(&format!("{SURVEY_KEY}.")))
        {
            return Err(field(
                SURVEY_KEY,
                "a scenario carries no site priors: the survey comes from a site file (--site FILE)",
            ));
        }
        let commands = Command::parse_all(origin, &table)?;
        Ok(Self {
            name,
            seed,
            duration,
            description,
            params,
            commands,
            source_text: text.to_owned(),
            source_path: None,
        })
    }

    /// Reads a scenario file.
    ///
    /// # Errors
    /// [`ScenarioError::Read`] and those of [`Scenario::parse`].
    pub fn from_file(path: &Path) -> Result<Self, ScenarioError> {
        let text = std::fs::read_to_string(path).map_err(|source| ScenarioError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        let mut s = Self::parse(&text, &path.display().to_string())?;
        s.source_path = Some(path.to_path_buf());
        Ok(s)
    }

    /// The folders searched for scenario names: `recordings/scenarios` under the current
    /// folder, then the repository's (where this crate was built from).
    #[must_use]
    pub fn search_dirs() -> Vec<PathBuf> {
        vec![
            PathBuf::from("recordings/scenarios"),
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../recordings/scenarios"),
        ]
    }

    /// Finds `name_or_path`: an existing file, else `NAME.toml` in [`Scenario::search_dirs`].
    ///
    /// # Errors
    /// [`ScenarioError::NotFound`] and those of [`Scenario::from_file`].
    pub fn find(name_or_path: &str) -> Result<Self, ScenarioError> {
        let direct = PathBuf::from(name_or_path);
        if direct.is_file() {
            return Self::from_file(&direct);
        }
        let mut tried = vec![direct];
        for dir in Self::search_dirs() {
            let candidate = dir.join(format!("{name_or_path}.toml"));
            if candidate.is_file() {
                return Self::from_file(&candidate);
            }
            tried.push(candidate);
        }
        Err(ScenarioError::NotFound {
            name: name_or_path.to_owned(),
            tried,
        })
    }

    /// Applies a site file (`--site FILE`): its `[survey.*]` tables become the `survey.*`
    /// parameters (replacing any), which the task and perception configs read; the recording
    /// keeps them with the other parameters, so a replay plans with the same survey.
    ///
    /// # Errors
    /// [`ScenarioError::Read`], [`ScenarioError::Toml`], and [`ScenarioError::Field`] for a
    /// file with anything but `[survey]` tables.
    pub fn apply_site_file(&mut self, path: &Path) -> Result<(), ScenarioError> {
        let text = std::fs::read_to_string(path).map_err(|source| ScenarioError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        self.apply_site_text(&text, &path.display().to_string())
    }

    /// [`Scenario::apply_site_file`] of a site file's text (`origin` names it in errors).
    ///
    /// # Errors
    /// As [`Scenario::apply_site_file`], but for reading.
    pub fn apply_site_text(&mut self, text: &str, origin: &str) -> Result<(), ScenarioError> {
        let origin = origin.to_owned();
        let table = toml_table(text, &origin)?;
        match (
            table.get(SURVEY_KEY),
            table.keys().find(|k| *k != SURVEY_KEY),
        ) {
            (_, Some(other)) => Err(ScenarioError::Field {
                origin,
                field: other.clone(),
                reason: "a site file holds [survey.*] tables only".to_owned(),
            }),
            (Some(toml::Value::Table(_)), None) => {
                let old: Vec<String> = self
                    .params
                    .keys()
                    .filter(|k| k.starts_with(&format!("{SURVEY_KEY}.")))
                    .map(str::to_owned)
                    .collect();
                for k in old {
                    self.params.remove(&k);
                }
                self.params.merge(&Params::from_table(&table));
                Ok(())
            }
            _ => Err(ScenarioError::Field {
                origin,
                field: SURVEY_KEY.to_owned(),
                reason: "missing: a site file is [survey.*] tables".to_owned(),
            }),
        }
    }

    /// Applies one `--set key=value`: `seed` and `duration_s` set the scenario's own fields,
    /// every other key a parameter (checked later, when the configs read them).
    ///
    /// # Errors
    /// [`ParamError::BadSet`], and [`ParamError::Value`] for a bad seed or duration.
    pub fn set_from_arg(&mut self, arg: &str) -> Result<(), ParamError> {
        let (key, text) = split_set(arg)?;
        let value = parse_value(text);
        let bad = |reason: &str| ParamError::Value {
            key: key.to_owned(),
            value: value.to_string(),
            reason: reason.to_owned(),
        };
        match key {
            "seed" => {
                self.seed = value
                    .as_integer()
                    .and_then(|i| u64::try_from(i).ok())
                    .ok_or_else(|| bad("expected an integer >= 0"))?;
            }
            "duration_s" => {
                let s = value
                    .as_float()
                    .or_else(|| value.as_integer().map(|i| i as f64))
                    .ok_or_else(|| bad("expected a number of seconds"))?;
                self.duration = duration_from_secs(s).map_err(|r| bad(&r))?;
            }
            "name" | "description" | "parameters" | "command" => {
                return Err(bad("not a parameter: edit the scenario file"));
            }
            _ => self.params.set(key, value),
        }
        Ok(())
    }

    /// The scenario a recording was made with, from its `scenario` metadata record and the
    /// attached scenario file (`source_text`, for the `[[command]]` list): the basis of
    /// replay and of a closed-loop what-if.
    ///
    /// # Errors
    /// [`ScenarioError::Field`] for a missing or invalid name, seed or duration, and the
    /// errors of [`Scenario::parse`] for the attached text.
    pub fn from_metadata(
        entries: &BTreeMap<String, String>,
        source_text: Option<&str>,
        origin: &str,
    ) -> Result<Self, ScenarioError> {
        let field = |f: &str, reason: &str| ScenarioError::Field {
            origin: origin.to_owned(),
            field: f.to_owned(),
            reason: reason.to_owned(),
        };
        let get = |k: &str| {
            entries
                .get(k)
                .ok_or_else(|| field(k, "missing in the scenario record"))
        };
        let name = get("name")?.clone();
        let seed = get("seed")?
            .parse::<u64>()
            .map_err(|e| field("seed", &e.to_string()))?;
        let duration_ns = get("duration_ns")?
            .parse::<u64>()
            .map_err(|e| field("duration_ns", &e.to_string()))?;
        let commands = match source_text {
            Some(text) => Command::parse_all(origin, &toml_table(text, origin)?)?,
            None => Vec::new(),
        };
        Ok(Self {
            name,
            seed,
            duration: RobotDuration::from_nanos(duration_ns),
            description: entries.get("description").cloned().unwrap_or_default(),
            params: Params::from_metadata(entries),
            commands,
            source_text: source_text.unwrap_or_default().to_owned(),
            source_path: None,
        })
    }

    /// The `scenario` metadata record: name, seed, duration, description, command count and
    /// every parameter.
    #[must_use]
    pub fn metadata_entries(&self) -> BTreeMap<String, String> {
        let mut m = BTreeMap::new();
        m.insert("name".to_owned(), self.name.clone());
        m.insert("seed".to_owned(), self.seed.to_string());
        m.insert(
            "duration_ns".to_owned(),
            self.duration.as_nanos().to_string(),
        );
        m.insert(
            "duration_s".to_owned(),
            self.duration.as_secs_f64().to_string(),
        );
        m.insert("description".to_owned(), self.description.clone());
        m.insert("commands".to_owned(), self.commands.len().to_string());
        for (k, v) in self.params.to_metadata() {
            m.insert(k, v);
        }
        m
    }
}

fn duration_from_secs(s: f64) -> Result<RobotDuration, String> {
    if !(0.0..=MAX_DURATION_S).contains(&s) {
        return Err(format!("{s} is outside [0, {MAX_DURATION_S}]"));
    }
    RobotDuration::from_secs_f64(s).map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = r#"
name = "t"
seed = 3
duration_s = 2.5
hour = 15.0
[wind]
mean_mps = 1.5
[bump]
[parameters]
a.x = 0.5
b = { flag = true, s = "hi" }
[[command]]
t_s = 1.0
kind = "capture"
"#;

    #[test]
    fn parses_and_flattens() -> Result<(), ScenarioError> {
        let s = Scenario::parse(TEXT, "t.toml")?;
        assert_eq!(s.seed, 3);
        assert_eq!(s.duration, RobotDuration::from_millis(2500));
        assert_eq!(s.commands.len(), 1);
        for key in ["hour", "wind.mean_mps", "bump", "a.x", "b.flag", "b.s"] {
            assert!(s.params.contains(key), "{key}");
        }
        assert!(!s.params.contains("name") && !s.params.contains("command"));
        Ok(())
    }

    #[test]
    fn metadata_round_trip() -> Result<(), ScenarioError> {
        let s = Scenario::parse(TEXT, "t.toml")?;
        let back = Scenario::from_metadata(&s.metadata_entries(), Some(TEXT), "rec.mcap")?;
        assert_eq!(back.name, s.name);
        assert_eq!(back.seed, s.seed);
        assert_eq!(back.duration, s.duration);
        assert_eq!(back.params, s.params);
        assert_eq!(back.commands, s.commands);
        assert!(Scenario::from_metadata(&BTreeMap::new(), None, "x").is_err());
        Ok(())
    }

    #[test]
    fn set_reaches_seed_duration_and_params() -> Result<(), ParamError> {
        let mut s = Scenario::parse(TEXT, "t.toml")
            .map_err(|e| ParamError::BadSet { arg: e.to_string() })?;
        s.set_from_arg("seed=9")?;
        s.set_from_arg("duration_s=4")?;
        s.set_from_arg("wind.mean_mps=2.5")?;
        assert_eq!(s.seed, 9);
        assert_eq!(s.duration, RobotDuration::from_secs(4));
        assert_eq!(
            s.params.get("wind.mean_mps"),
            Some(&toml::Value::Float(2.5))
        );
        assert!(s.set_from_arg("seed=-1").is_err());
        assert!(s.set_from_arg("name=x").is_err());
        Ok(())
    }

    #[test]
    fn missing_fields_are_errors() {
        assert!(Scenario::parse("seed = 1\nduration_s = 1.0", "x").is_err());
        assert!(Scenario::parse("name = \"n\"", "x").is_err());
        assert!(Scenario::parse("name = \"n\"\nduration_s = -1.0", "x").is_err());
        assert!(Scenario::find("no-such-scenario").is_err());
    }

    #[test]
    fn every_committed_scenario_parses() -> Result<(), ScenarioError> {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../recordings/scenarios");
        let mut n = 0;
        for entry in std::fs::read_dir(&dir).map_err(|source| ScenarioError::Read {
            path: dir.clone(),
            source,
        })? {
            let path = entry
                .map_err(|source| ScenarioError::Read {
                    path: dir.clone(),
                    source,
                })?
                .path();
            if path.extension().is_some_and(|e| e == "toml") {
                Scenario::from_file(&path)?;
                n += 1;
            }
        }
        assert!(n >= 5, "only {n} scenarios in {}", dir.display());
        Ok(())
    }
}
