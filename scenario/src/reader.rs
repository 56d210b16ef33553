//! [`Reader`]: the one way a stage or world config reads its parameters.
//!
//! Each config has a `from_params(&mut Reader)` next to its `Default`. Through a
//! [`Section`] it *declares* each key it knows (default, unit, one line of doc) and reads the
//! value if the scenario sets one. The composition root runs every config's `from_params`
//! over one reader, grouped in *parts* (a stage, the world), some of which it will not build
//! (the `task` stage of a scenario without a task). [`Reader::finish`] then checks every key
//! the scenario sets:
//! - declared by a part that is built: fine;
//! - declared only by parts that are not built: an error that says which part reads it and
//!   why it is not built;
//! - declared by nobody: an error naming the key and the nearest declared key.
//!
//! So a typo is never a silent default, and [`Reader::declarations`] is the table `rodlog
//! params` prints.

use std::ops::RangeInclusive;

use msgs::{RobotDuration, RobotTime};

use crate::error::{KeyProblem, ParamError};
use crate::params::Params;

/// One declared key: what `rodlog params` lists.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Decl {
    /// Full dotted key.
    pub key: String,
    /// Default, as text (`"1.5"`, `"seeded"`, `"[0, 0, 0]"`).
    pub default: String,
    /// Unit (`m`, `ms`, `deg`, ...; empty for none).
    pub unit: &'static str,
    /// One line of doc.
    pub doc: &'static str,
    /// The part that declared it (`task stage`, `simulator`, ...).
    pub part: String,
    /// Whether that part is built for this scenario.
    pub active: bool,
    /// The value the scenario sets, as TOML text (None: the default applies).
    pub value: Option<String>,
}

#[derive(Debug, Clone)]
struct Part {
    name: String,
    inactive: Option<String>,
}

/// Reads parameters and records what was declared (module docs).
#[derive(Debug)]
pub struct Reader<'p> {
    params: &'p Params,
    parts: Vec<Part>,
    decls: Vec<Decl>,
}

impl<'p> Reader<'p> {
    /// A reader over `params`, with one active part named `parameters` until
    /// [`Reader::part`] starts another.
    #[must_use]
    pub fn new(params: &'p Params) -> Self {
        Self {
            params,
            parts: vec![Part {
                name: "parameters".to_owned(),
                inactive: None,
            }],
            decls: Vec::new(),
        }
    }

    /// Starts a part that is built for this scenario: the keys declared from now on belong
    /// to it.
    pub fn part(&mut self, name: &str) -> &mut Self {
        self.parts.push(Part {
            name: name.to_owned(),
            inactive: None,
        });
        self
    }

    /// Starts a part that is *not* built for this scenario, `reason` saying why (its config
    /// is still read, so its keys are known and typed).
    pub fn inactive_part(&mut self, name: &str, reason: &str) -> &mut Self {
        self.parts.push(Part {
            name: name.to_owned(),
            inactive: Some(reason.to_owned()),
        });
        self
    }

    /// A section of dotted keys under `prefix` (`""` for top-level keys).
    pub fn section<'r>(&'r mut self, prefix: &str) -> Section<'r, 'p> {
        Section {
            reader: self,
            prefix: prefix.to_owned(),
        }
    }

    /// The parameters read.
    #[must_use]
    pub fn params(&self) -> &'p Params {
        self.params
    }

    /// Every key declared so far, in declaration order.
    #[must_use]
    pub fn declarations(&self) -> &[Decl] {
        &self.decls
    }

    fn declare(&mut self, key: String, default: String, unit: &'static str, doc: &'static str) {
        let part = self.parts.last().cloned().unwrap_or(Part {
            name: "parameters".to_owned(),
            inactive: None,
        });
        let value = self.params.get(&key).map(ToString::to_string);
        self.decls.push(Decl {
            key,
            default,
            unit,
            doc,
            part: part.name,
            active: part.inactive.is_none(),
            value,
        });
    }

    /// The problems of every key the scenario sets that no built part consumes, in key order
    /// (empty when all are consumed).
    #[must_use]
    pub fn problems(&self) -> Vec<KeyProblem> {
        let mut problems = Vec::new();
        for key in self.params.keys() {
            let mut declared = self.decls.iter().filter(|d| d.key == key).peekable();
            if declared.peek().is_none() && self.is_empty_section(key) {
                continue;
            }
            if declared.peek().is_none() {
                problems.push(KeyProblem::Unknown {
                    key: key.to_owned(),
                    suggestion: self.nearest(key),
                });
                continue;
            }
            if declared.clone().any(|d| d.active) {
                continue;
            }
            if let Some(d) = declared.next() {
                let reason = self
                    .parts
                    .iter()
                    .find(|p| p.name == d.part)
                    .and_then(|p| p.inactive.clone())
                    .unwrap_or_default();
                problems.push(KeyProblem::Inactive {
                    key: key.to_owned(),
                    part: d.part.clone(),
                    reason,
                });
            }
        }
        problems
    }

    /// Every declaration, or an error listing each key no built part consumes.
    ///
    /// # Errors
    /// [`ParamError::Unused`].
    pub fn finish(self) -> Result<Vec<Decl>, ParamError> {
        let problems = self.problems();
        if problems.is_empty() {
            Ok(self.decls)
        } else {
            Err(ParamError::Unused(problems))
        }
    }

    /// True for an empty table (`[robot]` with no keys) over declared keys: it sets nothing.
    fn is_empty_section(&self, key: &str) -> bool {
        let dotted = format!("{key}.");
        matches!(self.params.get(key), Some(toml::Value::Table(t)) if t.is_empty())
            && self.decls.iter().any(|d| d.key.starts_with(&dotted))
    }

    /// The declared key nearest to `key` when it is close enough to be a typo.
    fn nearest(&self, key: &str) -> Option<String> {
        let limit = (key.len() / 3).max(2);
        self.decls
            .iter()
            .map(|d| (edit_distance(key, &d.key), &d.key))
            .filter(|(dist, _)| *dist <= limit)
            .min()
            .map(|(_, k)| k.clone())
    }
}

/// Levenshtein distance over bytes (keys are ASCII).
fn edit_distance(a: &str, b: &str) -> usize {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    let mut row = vec![0; b.len() + 1];
    for (i, ca) in a.iter().enumerate() {
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let substitute = prev[j] + usize::from(ca != cb);
            row[j + 1] = substitute.min(prev[j + 1] + 1).min(row[j] + 1);
        }
        std::mem::swap(&mut prev, &mut row);
    }
    prev[b.len()]
}

/// The keys under one prefix, read through a [`Reader`].
#[derive(Debug)]
pub struct Section<'r, 'p> {
    reader: &'r mut Reader<'p>,
    prefix: String,
}

fn bad(key: &str, value: &toml::Value, reason: impl Into<String>) -> ParamError {
    ParamError::Value {
        key: key.to_owned(),
        value: value.to_string(),
        reason: reason.into(),
    }
}

fn as_f64(v: &toml::Value) -> Option<f64> {
    match v {
        toml::Value::Float(f) if f.is_finite() => Some(*f),
        toml::Value::Integer(i) => Some(*i as f64),
        _ => None,
    }
}

fn array_text(values: &[f64]) -> String {
    let items: Vec<String> = values.iter().map(|v| format!("{v:?}")).collect();
    format!("[{}]", items.join(", "))
}

impl Section<'_, '_> {
    fn key(&self, name: &str) -> String {
        if self.prefix.is_empty() {
            name.to_owned()
        } else {
            format!("{}.{name}", self.prefix)
        }
    }

    fn take(
        &mut self,
        name: &str,
        default: String,
        unit: &'static str,
        doc: &'static str,
    ) -> (String, Option<toml::Value>) {
        let key = self.key(name);
        self.reader.declare(key.clone(), default, unit, doc);
        let value = self.reader.params.get(&key).cloned();
        (key, value)
    }

    /// Declares the section's own key (an empty table such as `[bump]`) and returns whether
    /// the scenario has the section at all (the empty table or any key under it).
    pub fn present(&mut self, doc: &'static str) -> bool {
        let prefix = self.prefix.clone();
        self.reader
            .declare(prefix.clone(), "absent".to_owned(), "", doc);
        let dotted = format!("{prefix}.");
        self.reader
            .params
            .keys()
            .any(|k| k == prefix || k.starts_with(&dotted))
    }

    /// A finite number (integers accepted).
    ///
    /// # Errors
    /// [`ParamError::Value`] for another type or a non-finite value.
    pub fn f64(
        &mut self,
        name: &str,
        default: f64,
        unit: &'static str,
        doc: &'static str,
    ) -> Result<f64, ParamError> {
        match self.take(name, format!("{default:?}"), unit, doc) {
            (_, None) => Ok(default),
            (key, Some(v)) => as_f64(&v).ok_or_else(|| bad(&key, &v, "expected a finite number")),
        }
    }

    /// A finite number in `range`.
    ///
    /// # Errors
    /// [`ParamError::Value`] for another type or a value outside the range.
    pub fn f64_in(
        &mut self,
        name: &str,
        default: f64,
        range: RangeInclusive<f64>,
        unit: &'static str,
        doc: &'static str,
    ) -> Result<f64, ParamError> {
        let v = self.f64(name, default, unit, doc)?;
        if range.contains(&v) {
            Ok(v)
        } else {
            Err(bad(
                &self.key(name),
                &toml::Value::Float(v),
                format!("must be in [{}, {}]", range.start(), range.end()),
            ))
        }
    }

    /// A finite number >= 0.
    ///
    /// # Errors
    /// [`ParamError::Value`] for another type or a negative value.
    pub fn non_negative(
        &mut self,
        name: &str,
        default: f64,
        unit: &'static str,
        doc: &'static str,
    ) -> Result<f64, ParamError> {
        let v = self.f64(name, default, unit, doc)?;
        if v >= 0.0 {
            Ok(v)
        } else {
            Err(bad(&self.key(name), &toml::Value::Float(v), "must be >= 0"))
        }
    }

    /// An optional finite number; `default_text` says what applies without one (`seeded`).
    ///
    /// # Errors
    /// [`ParamError::Value`] for another type.
    pub fn f64_opt(
        &mut self,
        name: &str,
        default_text: &str,
        unit: &'static str,
        doc: &'static str,
    ) -> Result<Option<f64>, ParamError> {
        match self.take(name, default_text.to_owned(), unit, doc) {
            (_, None) => Ok(None),
            (key, Some(v)) => as_f64(&v)
                .map(Some)
                .ok_or_else(|| bad(&key, &v, "expected a finite number")),
        }
    }

    /// A non-negative integer.
    ///
    /// # Errors
    /// [`ParamError::Value`] for another type or a negative value.
    pub fn u64(
        &mut self,
        name: &str,
        default: u64,
        unit: &'static str,
        doc: &'static str,
    ) -> Result<u64, ParamError> {
        match self.take(name, default.to_string(), unit, doc) {
            (_, None) => Ok(default),
            (key, Some(v)) => match v {
                toml::Value::Integer(i) => {
                    u64::try_from(i).map_err(|_| bad(&key, &v, "expected an integer >= 0"))
                }
                _ => Err(bad(&key, &v, "expected an integer >= 0")),
            },
        }
    }

    /// A count of at least `min`.
    ///
    /// # Errors
    /// [`ParamError::Value`] for another type or a count below `min`.
    pub fn count(
        &mut self,
        name: &str,
        default: usize,
        min: usize,
        doc: &'static str,
    ) -> Result<usize, ParamError> {
        let v = self.u64(name, default as u64, "", doc)?;
        match usize::try_from(v) {
            Ok(n) if n >= min => Ok(n),
            _ => Err(bad(
                &self.key(name),
                &toml::Value::Integer(i64::try_from(v).unwrap_or(i64::MAX)),
                format!("must be at least {min}"),
            )),
        }
    }

    /// A boolean.
    ///
    /// # Errors
    /// [`ParamError::Value`] for another type.
    pub fn bool(
        &mut self,
        name: &str,
        default: bool,
        doc: &'static str,
    ) -> Result<bool, ParamError> {
        match self.take(name, default.to_string(), "", doc) {
            (_, None) => Ok(default),
            (_, Some(toml::Value::Boolean(b))) => Ok(b),
            (key, Some(v)) => Err(bad(&key, &v, "expected true or false")),
        }
    }

    /// A string.
    ///
    /// # Errors
    /// [`ParamError::Value`] for another type.
    pub fn string(
        &mut self,
        name: &str,
        default: &str,
        doc: &'static str,
    ) -> Result<String, ParamError> {
        match self.take(name, format!("{default:?}"), "", doc) {
            (_, None) => Ok(default.to_owned()),
            (_, Some(toml::Value::String(s))) => Ok(s),
            (key, Some(v)) => Err(bad(&key, &v, "expected a string")),
        }
    }

    /// One of `choices` (a string).
    ///
    /// # Errors
    /// [`ParamError::Value`] for another type or a value not among the choices.
    pub fn choice(
        &mut self,
        name: &str,
        default: &str,
        choices: &[&str],
        doc: &'static str,
    ) -> Result<String, ParamError> {
        let v = self.string(name, default, doc)?;
        if choices.contains(&v.as_str()) {
            Ok(v)
        } else {
            Err(bad(
                &self.key(name),
                &toml::Value::String(v),
                format!("expected one of {}", choices.join(", ")),
            ))
        }
    }

    /// `N` finite numbers.
    ///
    /// # Errors
    /// [`ParamError::Value`] for another type or another length.
    pub fn f64s<const N: usize>(
        &mut self,
        name: &str,
        default: [f64; N],
        unit: &'static str,
        doc: &'static str,
    ) -> Result<[f64; N], ParamError> {
        match self.take(name, array_text(&default), unit, doc) {
            (_, None) => Ok(default),
            (key, Some(v)) => numbers::<N>(&key, &v),
        }
    }

    /// Optionally `N` finite numbers; `default_text` says what applies without them.
    ///
    /// # Errors
    /// [`ParamError::Value`] for another type or another length.
    pub fn f64s_opt<const N: usize>(
        &mut self,
        name: &str,
        default_text: &str,
        unit: &'static str,
        doc: &'static str,
    ) -> Result<Option<[f64; N]>, ParamError> {
        match self.take(name, default_text.to_owned(), unit, doc) {
            (_, None) => Ok(None),
            (key, Some(v)) => numbers::<N>(&key, &v).map(Some),
        }
    }

    /// A duration given in milliseconds.
    ///
    /// # Errors
    /// [`ParamError::Value`] for another type or a negative or huge value.
    pub fn millis(
        &mut self,
        name: &str,
        default: RobotDuration,
        doc: &'static str,
    ) -> Result<RobotDuration, ParamError> {
        let ms = self.f64(name, default.as_secs_f64() * 1e3, "ms", doc)?;
        RobotDuration::from_secs_f64(ms * 1e-3)
            .map_err(|e| bad(&self.key(name), &toml::Value::Float(ms), e.to_string()))
    }

    /// A duration given in seconds.
    ///
    /// # Errors
    /// [`ParamError::Value`] for another type or a negative or huge value.
    pub fn seconds(
        &mut self,
        name: &str,
        default: RobotDuration,
        doc: &'static str,
    ) -> Result<RobotDuration, ParamError> {
        let s = self.f64(name, default.as_secs_f64(), "s", doc)?;
        RobotDuration::from_secs_f64(s)
            .map_err(|e| bad(&self.key(name), &toml::Value::Float(s), e.to_string()))
    }

    /// A robot time given in seconds from the start.
    ///
    /// # Errors
    /// [`ParamError::Value`] for another type or a negative or huge value.
    pub fn time_s(
        &mut self,
        name: &str,
        default: RobotTime,
        doc: &'static str,
    ) -> Result<RobotTime, ParamError> {
        let s = self.f64(name, default.as_secs_f64(), "s", doc)?;
        RobotTime::from_secs_f64(s)
            .map_err(|e| bad(&self.key(name), &toml::Value::Float(s), e.to_string()))
    }
}

fn numbers<const N: usize>(key: &str, v: &toml::Value) -> Result<[f64; N], ParamError> {
    let toml::Value::Array(items) = v else {
        return Err(bad(key, v, format!("expected an array of {N} numbers")));
    };
    let values: Option<Vec<f64>> = items.iter().map(as_f64).collect();
    let values = values.ok_or_else(|| bad(key, v, "expected finite numbers"))?;
    <[f64; N]>::try_from(values.as_slice()).map_err(|_| {
        bad(
            key,
            v,
            format!("expected {N} numbers, got {}", values.len()),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(pairs: &[&str]) -> Result<Params, ParamError> {
        let mut p = Params::new();
        for s in pairs {
            p.set_from_arg(s)?;
        }
        Ok(p)
    }

    #[test]
    fn reads_values_and_defaults() -> Result<(), ParamError> {
        let p = params(&["task.standoff_m=0.5", "task.count=3", "task.mode=\"fast\""])?;
        let mut r = Reader::new(&p);
        r.part("task stage");
        let mut s = r.section("task");
        assert_eq!(s.f64("standoff_m", 0.4, "m", "standoff")?, 0.5);
        assert_eq!(s.count("count", 1, 1, "count")?, 3);
        assert_eq!(s.choice("mode", "slow", &["slow", "fast"], "mode")?, "fast");
        assert!(s.bool("flag", true, "flag")?);
        assert_eq!(
            s.millis("latency_ms", RobotDuration::from_millis(5), "latency")?,
            RobotDuration::from_millis(5)
        );
        let decls = r.finish()?;
        assert_eq!(decls.len(), 5);
        assert_eq!(decls[0].value.as_deref(), Some("0.5"));
        assert_eq!(decls[4].unit, "ms");
        Ok(())
    }

    #[test]
    fn a_typo_names_the_key_and_the_nearest_one() -> Result<(), ParamError> {
        let p = params(&["task.standof_m=0.5"])?;
        let mut r = Reader::new(&p);
        r.part("task stage");
        r.section("task").f64("standoff_m", 0.4, "m", "standoff")?;
        let err = r.finish().err();
        assert_eq!(
            err,
            Some(ParamError::Unused(vec![KeyProblem::Unknown {
                key: "task.standof_m".into(),
                suggestion: Some("task.standoff_m".into()),
            }]))
        );
        let text = err.map(|e| e.to_string()).unwrap_or_default();
        assert!(
            text.contains("task.standof_m") && text.contains("task.standoff_m"),
            "{text}"
        );
        Ok(())
    }

    #[test]
    fn far_keys_get_no_suggestion_and_inactive_parts_say_why() -> Result<(), ParamError> {
        let p = params(&["zzz.qqq=1", "task.standoff_m=1"])?;
        let mut r = Reader::new(&p);
        r.inactive_part("task stage", "task = \"none\"");
        r.section("task").f64("standoff_m", 0.4, "m", "standoff")?;
        let problems = r.problems();
        assert_eq!(problems.len(), 2);
        assert!(
            matches!(&problems[0], KeyProblem::Inactive { key, reason, .. }
            if key == "task.standoff_m" && reason.contains("none"))
        );
        assert!(matches!(
            &problems[1],
            KeyProblem::Unknown {
                suggestion: None,
                ..
            }
        ));
        Ok(())
    }

    #[test]
    fn wrong_types_and_ranges_are_errors() -> Result<(), ParamError> {
        let p = params(&[
            "a.x=\"word\"",
            "a.n=-1",
            "a.r=5.0",
            "a.v=[1, 2]",
            "a.c=\"x\"",
        ])?;
        let mut r = Reader::new(&p);
        let mut s = r.section("a");
        assert!(s.f64("x", 0.0, "", "").is_err());
        assert!(s.u64("n", 0, "", "").is_err());
        assert!(s.f64_in("r", 0.0, 0.0..=1.0, "", "").is_err());
        assert!(s.f64s::<3>("v", [0.0; 3], "", "").is_err());
        assert!(s.choice("c", "a", &["a", "b"], "").is_err());
        Ok(())
    }

    #[test]
    fn section_presence_counts_empty_tables_and_keys() -> Result<(), Box<dyn std::error::Error>> {
        let t: toml::Table = "[bump]\n[robot]\n[other]\n[wind]\nmean_mps = 1.0\n".parse()?;
        let p = Params::from_table(&t);
        let mut r = Reader::new(&p);
        assert!(r.section("bump").present("bump"));
        assert!(r.section("wind").present("wind"));
        assert!(!r.section("camera").present("camera"));
        r.section("wind").f64("mean_mps", 0.0, "m/s", "")?;
        r.section("robot").bool("perturbation", true, "")?;
        // An empty [robot] sets nothing; an empty table nobody reads from is unknown.
        let problems = r.problems();
        assert_eq!(problems.len(), 1);
        assert_eq!(problems[0].key(), "other");
        Ok(())
    }

    #[test]
    fn edit_distance_counts_edits() {
        assert_eq!(edit_distance("kitten", "sitting"), 3);
        assert_eq!(edit_distance("", "abc"), 3);
        assert_eq!(edit_distance("same", "same"), 0);
    }
}
