//! A scenario's timed commands, `[[command]]`, played by the `script` stage.
//!
//! ```toml
//! [[command]]
//! t_s = 1.0                   # when to publish it (s of robot time)
//! kind = "joints"             # joints | lift | base | clamp | capture
//! values = [0.0, 0.3, 1.2, 0.0, 1.57, 0.0]
//! duration_s = 3.0            # joints only: requested time_from_start (0 = as fast as allowed)
//! ```
//!
//! `values`: `joints` 6 angles (rad, J1..J6); `lift` height (m); `base` `x_m, y_m, yaw_rad`
//! in `map`; `clamp` `action` (0 open, 1 close, 2 stop) and optionally `max_torque_nm`;
//! `capture` none.

use crate::error::ScenarioError;

/// What a command does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CommandKind {
    /// An arm trajectory to 6 joint angles.
    Joints,
    /// A lift height.
    Lift,
    /// A base goal in `map`.
    Base,
    /// A clamp action.
    Clamp,
    /// A wrist-camera capture.
    Capture,
}

impl CommandKind {
    /// Every kind.
    pub const ALL: [Self; 5] = [
        Self::Joints,
        Self::Lift,
        Self::Base,
        Self::Clamp,
        Self::Capture,
    ];

    /// The name in scenario files.
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Joints => "joints",
            Self::Lift => "lift",
            Self::Base => "base",
            Self::Clamp => "clamp",
            Self::Capture => "capture",
        }
    }

    /// The kind of a name in scenario files.
    #[must_use]
    pub fn parse(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.as_str() == name)
    }

    /// How many values the kind takes: `(min, max)`.
    #[must_use]
    pub fn arity(self) -> (usize, usize) {
        match self {
            Self::Joints => (6, 6),
            Self::Lift => (1, 1),
            Self::Base => (3, 3),
            Self::Clamp => (1, 2),
            Self::Capture => (0, 0),
        }
    }
}

/// One timed command.
#[derive(Debug, Clone, PartialEq)]
pub struct Command {
    /// When to publish it (s of robot time).
    pub t_s: f64,
    /// What it does.
    pub kind: CommandKind,
    /// Its numbers (module docs).
    pub values: Vec<f64>,
    /// Requested duration (s), joints only; 0 = as fast as the limits allow.
    pub duration_s: f64,
}

const KEYS: [&str; 4] = ["t_s", "kind", "values", "duration_s"];

impl Command {
    /// Parses entry `index` of a `[[command]]` array; `origin` names the file in errors.
    ///
    /// # Errors
    /// [`ScenarioError::Field`] naming `command[index].FIELD`: unknown keys, a missing or
    /// negative `t_s`, an unknown kind, values that are not numbers or of the wrong count.
    pub fn parse(origin: &str, index: usize, v: &toml::Value) -> Result<Self, ScenarioError> {
        let field = |f: &str, reason: String| ScenarioError::Field {
            origin: origin.to_owned(),
            field: if f.is_empty() {
                format!("command[{index}]")
            } else {
                format!("command[{index}].{f}")
            },
            reason,
        };
        let toml::Value::Table(t) = v else {
            return Err(field("", "must be a table".to_owned()));
        };
        for k in t.keys() {
            if !KEYS.contains(&k.as_str()) {
                return Err(field(
                    k,
                    format!("unknown key (allowed: {})", KEYS.join(", ")),
                ));
            }
        }
        let number = |v: &toml::Value| match v {
            toml::Value::Float(f) if f.is_finite() => Some(*f),
            toml::Value::Integer(i) => Some(*i as f64),
            _ => None,
        };
        let t_s = t
            .get("t_s")
            .ok_or_else(|| field("t_s", "missing".to_owned()))
            .and_then(|v| number(v).ok_or_else(|| field("t_s", format!("{v} is not a number"))))?;
        if t_s < 0.0 {
            return Err(field("t_s", format!("{t_s} is negative")));
        }
        let names: Vec<&str> = CommandKind::ALL.iter().map(|k| k.as_str()).collect();
        let kind = match t.get("kind") {
            Some(toml::Value::String(s)) => CommandKind::parse(s)
                .ok_or_else(|| field("kind", format!("{s:?}: expected {}", names.join(", "))))?,
            Some(other) => return Err(field("kind", format!("{other} is not a string"))),
            None => return Err(field("kind", "missing".to_owned())),
        };
        let values = match t.get("values") {
            None => Vec::new(),
            Some(toml::Value::Array(a)) => a
                .iter()
                .map(number)
                .collect::<Option<Vec<f64>>>()
                .ok_or_else(|| field("values", "expected finite numbers".to_owned()))?,
            Some(other) => return Err(field("values", format!("expected an array, got {other}"))),
        };
        let (lo, hi) = kind.arity();
        if values.len() < lo || values.len() > hi {
            return Err(field(
                "values",
                format!(
                    "{} takes {lo}..={hi} values, got {}",
                    kind.as_str(),
                    values.len()
                ),
            ));
        }
        let duration_s = match t.get("duration_s") {
            None => 0.0,
            Some(v) => number(v)
                .filter(|d| (0.0..=3600.0).contains(d))
                .ok_or_else(|| {
                    field("duration_s", format!("{v}: expected a number in [0, 3600]"))
                })?,
        };
        Ok(Self {
            t_s,
            kind,
            values,
            duration_s,
        })
    }

    /// Parses a scenario table's `command` array (absent: no commands).
    ///
    /// # Errors
    /// Those of [`Command::parse`]; `command` that is not an array of tables.
    pub fn parse_all(origin: &str, table: &toml::Table) -> Result<Vec<Self>, ScenarioError> {
        match table.get("command") {
            None => Ok(Vec::new()),
            Some(toml::Value::Array(items)) => items
                .iter()
                .enumerate()
                .map(|(i, v)| Self::parse(origin, i, v))
                .collect(),
            Some(_) => Err(ScenarioError::Field {
                origin: origin.to_owned(),
                field: "command".to_owned(),
                reason: "must be an array of tables ([[command]])".to_owned(),
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Vec<Command>, ScenarioError> {
        let t: toml::Table = text
            .parse()
            .map_err(|e: toml::de::Error| ScenarioError::Toml {
                origin: "t".into(),
                reason: e.to_string(),
            })?;
        Command::parse_all("t", &t)
    }

    #[test]
    fn parses_every_kind() -> Result<(), ScenarioError> {
        let c = parse(
            "[[command]]\nt_s = 1\nkind = \"joints\"\nvalues = [0, 0.3, 1.2, 0, 1.57, 0]\nduration_s = 2\n\
             [[command]]\nt_s = 2.5\nkind = \"capture\"\n\
             [[command]]\nt_s = 3\nkind = \"clamp\"\nvalues = [1, 8.0]\n",
        )?;
        assert_eq!(c.len(), 3);
        assert_eq!(c[0].kind, CommandKind::Joints);
        assert_eq!(c[0].duration_s, 2.0);
        assert_eq!(c[1].kind, CommandKind::Capture);
        assert_eq!(c[2].values, vec![1.0, 8.0]);
        Ok(())
    }

    #[test]
    fn bad_entries_name_their_field() {
        let field_of = |text: &str| match parse(text) {
            Err(ScenarioError::Field { field, .. }) => field,
            other => format!("{other:?}"),
        };
        assert_eq!(
            field_of("[[command]]\nt_s = 1\nkind = \"grab\""),
            "command[0].kind"
        );
        assert_eq!(
            field_of("[[command]]\nt_s = 1\nkind = \"joints\"\nvalues = [0, 1]"),
            "command[0].values"
        );
        assert_eq!(
            field_of("[[command]]\nat_s = 1\nkind = \"lift\"\nvalues = [1]"),
            "command[0].at_s"
        );
        assert_eq!(
            field_of("[[command]]\nkind = \"capture\""),
            "command[0].t_s"
        );
    }
}
