//! Errors of scenario files and parameters. Each names the key or field at fault and says
//! what would be valid.

use std::fmt;
use std::path::PathBuf;

/// Errors of a parameter: a value of the wrong type or range, a `--set` that is not
/// `key=value`, or keys that no part of the pipeline consumes.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ParamError {
    /// A `--set` argument is not `key=value`.
    #[error("--set {arg:?}: expected key=value with a dotted key such as task.standoff_m")]
    BadSet {
        /// The argument.
        arg: String,
    },
    /// A parameter has the wrong type or an invalid value.
    #[error("parameter {key} = {value}: {reason}")]
    Value {
        /// The key.
        key: String,
        /// Its value (TOML text).
        value: String,
        /// What was expected.
        reason: String,
    },
    /// Keys that no part of the pipeline or world consumes.
    #[error("{}", unused_text(.0))]
    Unused(Vec<KeyProblem>),
}

/// Why one key is not consumed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum KeyProblem {
    /// No part declares it (a typo, or a key this version does not have).
    Unknown {
        /// The key.
        key: String,
        /// The nearest valid key, if one is close.
        suggestion: Option<String>,
    },
    /// A part that is not built for this scenario declares it (e.g. `task.*` without a task).
    Inactive {
        /// The key.
        key: String,
        /// The part that reads it.
        part: String,
        /// Why that part is not built.
        reason: String,
    },
}

impl KeyProblem {
    /// The key.
    #[must_use]
    pub fn key(&self) -> &str {
        match self {
            Self::Unknown { key, .. } | Self::Inactive { key, .. } => key,
        }
    }
}

impl fmt::Display for KeyProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Unknown {
                key,
                suggestion: Some(s),
            } => write!(f, "unknown parameter {key:?}: did you mean {s:?}?"),
            Self::Unknown {
                key,
                suggestion: None,
            } => write!(
                f,
                "unknown parameter {key:?} (`rodlog params SCENARIO` lists the valid keys)"
            ),
            Self::Inactive { key, part, reason } => write!(
                f,
                "parameter {key:?} is read by the {part}, which this scenario does not run ({reason})"
            ),
        }
    }
}

fn unused_text(problems: &[KeyProblem]) -> String {
    match problems {
        [one] => one.to_string(),
        many => {
            let mut s = format!("{} parameters are not used:", many.len());
            for p in many {
                s.push_str("\n  ");
                s.push_str(&p.to_string());
            }
            s
        }
    }
}

/// Errors of scenario files.
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
    #[error("scenario {origin} is not valid TOML: {reason}")]
    Toml {
        /// The path (or what the text came from).
        origin: String,
        /// Parser message.
        reason: String,
    },
    /// A field is missing or has the wrong type.
    #[error("scenario {origin}: {field}: {reason}")]
    Field {
        /// The path (or what the text came from).
        origin: String,
        /// The field (`duration_s`, `command[3].values`, ...).
        field: String,
        /// What is wrong.
        reason: String,
    },
    /// No scenario of that name in the search path.
    #[error("no scenario {name:?}: tried {}", tried.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", "))]
    NotFound {
        /// The name given.
        name: String,
        /// Files tried.
        tried: Vec<PathBuf>,
    },
    /// A parameter error.
    #[error(transparent)]
    Param(#[from] ParamError),
}
