//! Scenarios and stage/world parameters.
//!
//! A scenario is a TOML file (`recordings/scenarios/NAME.toml`):
//!
//! ```toml
//! name = "arm_sweep"          # required
//! seed = 7                    # world seed (noise, gusts)
//! duration_s = 12.0           # robot time to run
//! description = "..."         # optional
//!
//! [parameters]                # flattened to dotted keys: "arm_exerciser.amplitude_rad"
//! arm_exerciser.amplitude_rad = 0.6
//! test_world.encoder_noise_rad = 1e-4
//!
//! [[command]]                 # timed commands, played by the `script` stage (control crate)
//! at_s = 1.0
//! topic = "/lift/command"
//! ```
//!
//! Every other top-level key or table (e.g. the simulator's `hour = 15.0`, `[wind]
//! mean_mps = 1.5`) is a parameter too (`hour`, `wind.mean_mps`); `[parameters]` wins on a
//! clash. Parameters are `stage_or_world.key = value`; `--set k=v` overrides one (the value is
//! parsed as a TOML value, a bare word is a string). The recording's `scenario` metadata
//! record holds the seed and every parameter (`param.<key>` = TOML value text), so replay
//! can rebuild the same pipeline and a closed-loop what-if can re-record (DESIGN.md s2).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use msgs::RobotDuration;

/// Prefix of parameter keys in the `scenario` metadata record.
pub const PARAM_PREFIX: &str = "param.";
/// Name of the scenario metadata record.
pub const SCENARIO_RECORD: &str = "scenario";
/// Top-level scenario keys that are not parameters.
pub const RESERVED_KEYS: [&str; 6] = [
    "name",
    "seed",
    "duration_s",
    "description",
    "parameters",
    "command",
];

/// Errors of scenario files and parameters.
#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    /// The file could not be read.
    #[error("cannot read scenario {path}: {source}")]
    Read {
        /// The path.
        path: PathBuf,
        /// OS error.
        source: std::io::Error,
    },
    /// The file is not valid TOML.
    #[error("scenario {path} is not valid TOML: {reason}")]
    Toml {
        /// The path (or `<string>`).
        path: String,
        /// Parser message.
        reason: String,
    },
    /// A field is missing or has the wrong type.
    #[error("scenario {path}: field {field}: {reason}")]
    Field {
        /// The path.
        path: String,
        /// The field.
        field: String,
        /// What is wrong.
        reason: String,
    },
    /// No scenario of that name in the search path.
    #[error("no scenario {name:?}: tried {tried:?}")]
    NotFound {
        /// The name given.
        name: String,
        /// Files tried.
        tried: Vec<PathBuf>,
    },
    /// A `--set` argument is not `key=value`.
    #[error("--set {arg:?}: expected key=value with a dotted key such as stage.param")]
    BadSet {
        /// The argument.
        arg: String,
    },
    /// A parameter has the wrong type or an invalid value.
    #[error("parameter {key} = {value}: {reason}")]
    BadParam {
        /// The key.
        key: String,
        /// Its value (TOML text).
        value: String,
        /// What was expected.
        reason: String,
    },
}

/// Stage and world parameters: dotted keys (`stage.key`) to TOML values, sorted.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Params {
    values: BTreeMap<String, toml::Value>,
}

fn flatten(prefix: &str, table: &toml::Table, out: &mut BTreeMap<String, toml::Value>) {
    for (key, value) in table {
        let full = if prefix.is_empty() {
            key.clone()
        } else {
            format!("{prefix}.{key}")
        };
        match value {
            toml::Value::Table(inner) => flatten(&full, inner, out),
            other => {
                out.insert(full, other.clone());
            }
        }
    }
}

/// Parses a TOML value from its text; a bare word that is not TOML becomes a string.
fn parse_value(text: &str) -> toml::Value {
    let text = text.trim();
    match format!("v = {text}").parse::<toml::Table>() {
        Ok(mut t) => t
            .remove("v")
            .unwrap_or_else(|| toml::Value::String(text.to_owned())),
        Err(_) => toml::Value::String(text.to_owned()),
    }
}

impl Params {
    /// No parameters.
    pub fn new() -> Self {
        Self::default()
    }

    /// Parameters from a TOML table, nested tables flattened to dotted keys.
    pub fn from_table(table: &toml::Table) -> Self {
        let mut values = BTreeMap::new();
        flatten("", table, &mut values);
        Self { values }
    }

    /// Reads a `--config` file: its `[parameters]` table if it has one (a scenario file),
    /// otherwise the whole file, flattened.
    ///
    /// # Errors
    /// [`ScenarioError::Read`], [`ScenarioError::Toml`].
    pub fn from_file(path: &Path) -> Result<Self, ScenarioError> {
        let text = std::fs::read_to_string(path).map_err(|source| ScenarioError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        let table: toml::Table =
            text.parse()
                .map_err(|e: toml::de::Error| ScenarioError::Toml {
                    path: path.display().to_string(),
                    reason: e.message().to_owned(),
                })?;
        Ok(match table.get("parameters") {
            Some(toml::Value::Table(p)) => Self::from_table(p),
            _ => Self::from_table(&table),
        })
    }

    /// Parameters stored in a `scenario` metadata record (`param.<key>` entries).
    pub fn from_metadata(entries: &BTreeMap<String, String>) -> Self {
        let values = entries
            .iter()
            .filter_map(|(k, v)| {
                k.strip_prefix(PARAM_PREFIX)
                    .map(|key| (key.to_owned(), parse_value(v)))
            })
            .collect();
        Self { values }
    }

    /// `(param.<key>, TOML value text)` pairs for a metadata record.
    pub fn to_metadata(&self) -> Vec<(String, String)> {
        self.values
            .iter()
            .map(|(k, v)| (format!("{PARAM_PREFIX}{k}"), v.to_string()))
            .collect()
    }

    /// Applies one `key=value` override (value parsed as TOML, else a string).
    ///
    /// # Errors
    /// [`ScenarioError::BadSet`] without `=` or with an empty key.
    pub fn set_from_arg(&mut self, arg: &str) -> Result<(), ScenarioError> {
        let Some((key, value)) = arg.split_once('=') else {
            return Err(ScenarioError::BadSet {
                arg: arg.to_owned(),
            });
        };
        let key = key.trim();
        if key.is_empty() {
            return Err(ScenarioError::BadSet {
                arg: arg.to_owned(),
            });
        }
        self.values.insert(key.to_owned(), parse_value(value));
        Ok(())
    }

    /// Sets `key` to `value`.
    pub fn set(&mut self, key: impl Into<String>, value: toml::Value) {
        self.values.insert(key.into(), value);
    }

    /// Overrides with every parameter of `other`.
    pub fn merge(&mut self, other: &Params) {
        for (k, v) in &other.values {
            self.values.insert(k.clone(), v.clone());
        }
    }

    /// The raw value of `key`.
    pub fn get(&self, key: &str) -> Option<&toml::Value> {
        self.values.get(key)
    }

    /// All parameters, sorted by key.
    pub fn iter(&self) -> impl Iterator<Item = (&str, &toml::Value)> {
        self.values.iter().map(|(k, v)| (k.as_str(), v))
    }

    /// Number of parameters.
    pub fn len(&self) -> usize {
        self.values.len()
    }

    /// True without parameters.
    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    fn bad(key: &str, value: &toml::Value, reason: &str) -> ScenarioError {
        ScenarioError::BadParam {
            key: key.to_owned(),
            value: value.to_string(),
            reason: reason.to_owned(),
        }
    }

    /// `key` as a finite float (integers accepted), or `default` when absent.
    ///
    /// # Errors
    /// [`ScenarioError::BadParam`] for other types or non-finite values.
    pub fn f64_or(&self, key: &str, default: f64) -> Result<f64, ScenarioError> {
        match self.values.get(key) {
            None => Ok(default),
            Some(toml::Value::Float(f)) if f.is_finite() => Ok(*f),
            Some(toml::Value::Integer(i)) => Ok(*i as f64),
            Some(v) => Err(Self::bad(key, v, "expected a finite number")),
        }
    }

    /// `key` as a non-negative integer, or `default` when absent.
    ///
    /// # Errors
    /// [`ScenarioError::BadParam`] for other types or negative values.
    pub fn u64_or(&self, key: &str, default: u64) -> Result<u64, ScenarioError> {
        match self.values.get(key) {
            None => Ok(default),
            Some(toml::Value::Integer(i)) => u64::try_from(*i)
                .map_err(|_| Self::bad(key, &toml::Value::Integer(*i), "expected >= 0")),
            Some(v) => Err(Self::bad(key, v, "expected a non-negative integer")),
        }
    }

    /// `key` as a boolean, or `default` when absent.
    ///
    /// # Errors
    /// [`ScenarioError::BadParam`] for other types.
    pub fn bool_or(&self, key: &str, default: bool) -> Result<bool, ScenarioError> {
        match self.values.get(key) {
            None => Ok(default),
            Some(toml::Value::Boolean(b)) => Ok(*b),
            Some(v) => Err(Self::bad(key, v, "expected true or false")),
        }
    }

    /// `key` as a string, or `default` when absent.
    ///
    /// # Errors
    /// [`ScenarioError::BadParam`] for other types.
    pub fn str_or(&self, key: &str, default: &str) -> Result<String, ScenarioError> {
        match self.values.get(key) {
            None => Ok(default.to_owned()),
            Some(toml::Value::String(s)) => Ok(s.clone()),
            Some(v) => Err(Self::bad(key, v, "expected a string")),
        }
    }

    /// Keys whose values differ between `self` and `other` (present in either), sorted.
    pub fn changed_keys(&self, other: &Params) -> Vec<String> {
        let mut keys: Vec<String> = Vec::new();
        for (k, v) in &self.values {
            if other.values.get(k) != Some(v) {
                keys.push(k.clone());
            }
        }
        for k in other.values.keys() {
            if !self.values.contains_key(k) {
                keys.push(k.clone());
            }
        }
        keys.sort();
        keys
    }
}

/// A scenario: what to run, for how long, with which seed and parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    /// Scenario name.
    pub name: String,
    /// World seed.
    pub seed: u64,
    /// Robot time to run.
    pub duration: RobotDuration,
    /// Free text.
    pub description: String,
    /// Stage and world parameters.
    pub params: Params,
    /// The `[[command]]` entries, verbatim (played by the `script` stage).
    pub commands: Vec<toml::Table>,
    /// The file's text (attached to the recording).
    pub source_text: String,
    /// The file it was read from, if any.
    pub source_path: Option<PathBuf>,
}

impl Scenario {
    /// Parses scenario TOML text; `origin` names it in errors.
    ///
    /// # Errors
    /// [`ScenarioError::Toml`], [`ScenarioError::Field`].
    pub fn parse(text: &str, origin: &str) -> Result<Self, ScenarioError> {
        let table: toml::Table =
            text.parse()
                .map_err(|e: toml::de::Error| ScenarioError::Toml {
                    path: origin.to_owned(),
                    reason: e.message().to_owned(),
                })?;
        let field = |f: &str, reason: &str| ScenarioError::Field {
            path: origin.to_owned(),
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
        let duration = RobotDuration::from_secs_f64(duration_s)
            .map_err(|e| field("duration_s", &e.to_string()))?;
        let description = match table.get("description") {
            None => String::new(),
            Some(toml::Value::String(s)) => s.clone(),
            Some(_) => return Err(field("description", "must be a string")),
        };
        // Every other top-level key or table (`hour`, `[wind]`, ...: the world's settings) is
        // a parameter too, so it is recorded and `--set` can change it; `[parameters]` wins.
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
        let commands = match table.get("command") {
            None => Vec::new(),
            Some(toml::Value::Array(items)) => items
                .iter()
                .enumerate()
                .map(|(i, v)| match v {
                    toml::Value::Table(t) => Ok(t.clone()),
                    _ => Err(field(&format!("command[{i}]"), "must be a table")),
                })
                .collect::<Result<_, _>>()?,
            Some(_) => return Err(field("command", "must be an array of tables ([[command]])")),
        };
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

    /// Finds `name_or_path`: an existing file, else `DIR/NAME.toml` for each search dir.
    ///
    /// # Errors
    /// [`ScenarioError::NotFound`] and those of [`Scenario::from_file`].
    pub fn find(name_or_path: &str, search_dirs: &[PathBuf]) -> Result<Self, ScenarioError> {
        let direct = PathBuf::from(name_or_path);
        if direct.is_file() {
            return Self::from_file(&direct);
        }
        let mut tried = vec![direct];
        for dir in search_dirs {
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

    /// The scenario a recording was made with, from its `scenario` metadata record and the
    /// attached scenario file (`source_text`, for the `[[command]]` list): the basis of a
    /// closed-loop what-if (`record` again, same seed, changed parameters).
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
            path: origin.to_owned(),
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
            Some(text) => Self::parse(text, origin)?.commands,
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
[parameters]
a.x = 0.5
a.n = 3
b = { flag = true, s = "hi" }
[[command]]
at_s = 1.0
"#;

    #[test]
    fn parses_and_flattens() -> Result<(), ScenarioError> {
        let s = Scenario::parse(TEXT, "t.toml")?;
        assert_eq!(s.seed, 3);
        assert_eq!(s.duration, RobotDuration::from_millis(2500));
        assert_eq!(s.params.f64_or("a.x", 0.0)?, 0.5);
        assert_eq!(s.params.u64_or("a.n", 0)?, 3);
        assert!(s.params.bool_or("b.flag", false)?);
        assert_eq!(s.params.str_or("b.s", "")?, "hi");
        assert_eq!(s.commands.len(), 1);
        assert_eq!(s.params.f64_or("hour", 0.0)?, 15.0);
        assert_eq!(s.params.f64_or("wind.mean_mps", 0.0)?, 1.5);
        assert!(s.params.get("name").is_none() && s.params.get("command.at_s").is_none());
        Ok(())
    }

    #[test]
    fn metadata_round_trip_and_set() -> Result<(), ScenarioError> {
        let s = Scenario::parse(TEXT, "t.toml")?;
        let back = Params::from_metadata(&s.metadata_entries());
        assert_eq!(back, s.params);
        let mut p = back.clone();
        p.set_from_arg("a.x=0.25")?;
        p.set_from_arg("c=word")?;
        assert_eq!(p.f64_or("a.x", 0.0)?, 0.25);
        assert_eq!(p.str_or("c", "")?, "word");
        assert_eq!(
            p.changed_keys(&back),
            vec!["a.x".to_owned(), "c".to_owned()]
        );
        assert!(p.set_from_arg("novalue").is_err());
        assert!(p.f64_or("b.s", 0.0).is_err());
        Ok(())
    }

    #[test]
    fn scenario_from_its_metadata() -> Result<(), ScenarioError> {
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
    fn missing_fields_are_errors() {
        assert!(Scenario::parse("seed = 1\nduration_s = 1.0", "x").is_err());
        assert!(Scenario::parse("name = \"n\"", "x").is_err());
        assert!(Scenario::parse("name = \"n\"\nduration_s = -1.0", "x").is_err());
    }
}
