//! Where scenarios come from: a name, a file, or a recording (its `scenario` record and
//! attached file), and the key migrations that keep old recordings replayable.
//!
//! # Key migrations
//! A recording stores every parameter it was made with. When a later version renames or
//! retires a key, [`MIGRATIONS`] says what became of it, and [`migrate`] applies that to the
//! parameters *read from a recording* (never to a user's `--set` or scenario file, where an
//! unknown key is an error). A recorded key that is neither known nor in the table is not an
//! error either: replay runs without it and reports it as a divergence (the run cannot be
//! reproduced as recorded).

use std::path::Path;

use replay::McapReader;
use scenario::{Params, SCENARIO_ATTACHMENT, SCENARIO_RECORD, Scenario};

use crate::error::ComposeError;

/// What became of a key that a recording may hold.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Migration {
    /// The key is now called this (same meaning, same unit).
    Renamed(&'static str),
    /// The key was removed; its value no longer has an effect. The text says why.
    Retired(&'static str),
}

/// Every key migration, oldest first.
pub const MIGRATIONS: &[(&str, Migration)] = &[
    (
        "perceive.prior_x_m",
        Migration::Retired("the perceive stage takes the wire prior from the site map"),
    ),
    (
        "perceive.prior_y_m",
        Migration::Retired("the perceive stage takes the wire prior from the site map"),
    ),
    (
        "perceive.prior_z_m",
        Migration::Retired("the perceive stage takes the wire prior from the site map"),
    ),
];

/// One migration applied to recorded parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct Migrated {
    /// The recorded key.
    pub key: String,
    /// What was done.
    pub migration: Migration,
    /// The recorded value (TOML text).
    pub value: String,
}

impl std::fmt::Display for Migrated {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.migration {
            Migration::Renamed(new) => {
                write!(f, "recorded {} = {} is now {new}", self.key, self.value)
            }
            Migration::Retired(why) => {
                write!(
                    f,
                    "recorded {} = {} is retired: {why}",
                    self.key, self.value
                )
            }
        }
    }
}

/// Applies [`MIGRATIONS`] to parameters read from a recording.
pub fn migrate(params: &mut Params) -> Vec<Migrated> {
    let mut done = Vec::new();
    for (old, migration) in MIGRATIONS {
        let Some(value) = params.remove(old) else {
            continue;
        };
        if let Migration::Renamed(new) = migration
            && !params.contains(new)
        {
            params.set(*new, value.clone());
        }
        done.push(Migrated {
            key: (*old).to_owned(),
            migration: *migration,
            value: value.to_string(),
        });
    }
    done
}

/// The scenario of a recording (its `scenario` metadata record and attached scenario file),
/// with [`MIGRATIONS`] applied to its parameters.
///
/// # Errors
/// An unreadable file, a recording without a `scenario` record, a malformed record or
/// attachment.
pub fn scenario_of_recording(path: &Path) -> Result<(Scenario, Vec<Migrated>), ComposeError> {
    let read = |source| ComposeError::Read {
        path: path.to_path_buf(),
        source: Box::new(source),
    };
    let mut reader = McapReader::open(path).map_err(read)?;
    let Some(meta) = reader.metadata_named(SCENARIO_RECORD).cloned() else {
        return Err(ComposeError::NoScenario {
            path: path.to_path_buf(),
        });
    };
    let attachment = reader
        .attachments()
        .iter()
        .find(|a| a.name == SCENARIO_ATTACHMENT)
        .cloned();
    let text = match attachment {
        Some(a) => Some(
            String::from_utf8(reader.read_attachment(&a).map_err(read)?).map_err(|_| {
                ComposeError::AttachmentText {
                    path: path.to_path_buf(),
                }
            })?,
        ),
        None => None,
    };
    let mut scenario =
        Scenario::from_metadata(&meta.entries, text.as_deref(), &path.display().to_string())?;
    let migrated = migrate(&mut scenario.params);
    Ok((scenario, migrated))
}

/// A scenario by name (`recordings/scenarios/NAME.toml`), by file, or from a recording
/// (`.mcap`: its scenario, seed and parameters, for a closed-loop what-if).
///
/// # Errors
/// Those of [`Scenario::find`] and [`scenario_of_recording`].
pub fn load_scenario(name_or_path: &str) -> Result<(Scenario, Vec<Migrated>), ComposeError> {
    let path = Path::new(name_or_path);
    if path.extension().is_some_and(|e| e == "mcap") && path.is_file() {
        scenario_of_recording(path)
    } else {
        Ok((Scenario::find(name_or_path)?, Vec::new()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn retired_and_renamed_keys_leave_the_recorded_params() -> Result<(), scenario::ParamError> {
        let mut p = Params::new();
        p.set_from_arg("perceive.prior_y_m=0.05")?;
        p.set_from_arg("perceive.standoff_m=0.45")?;
        let done = migrate(&mut p);
        assert_eq!(done.len(), 1);
        assert!(done[0].to_string().contains("retired"), "{}", done[0]);
        assert!(!p.contains("perceive.prior_y_m") && p.contains("perceive.standoff_m"));
        Ok(())
    }

    #[test]
    fn no_key_is_both_migrated_and_current() {
        for (old, m) in MIGRATIONS {
            if let Migration::Renamed(new) = m {
                assert_ne!(old, new);
            }
        }
    }
}
