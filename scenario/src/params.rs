//! [`Params`]: a scenario's stage and world parameters as dotted keys (`wind.mean_mps`,
//! `task.standoff_m`) to TOML values, sorted.
//!
//! A scenario file's tables flatten to dotted keys (`[wind] mean_mps = 1.5` is
//! `wind.mean_mps`); an empty table stays a key of its own (`[bump]` with no keys is `bump =
//! {}`), because its presence means something (a bump with seeded values). `--set k=v` parses
//! `v` as a TOML value, a bare word becoming a string. A recording's `scenario` metadata
//! record holds each parameter as `param.<key>` = TOML value text ([`Params::to_metadata`]).
//!
//! Params only hold values; the configs read them through a [`crate::Reader`], which is what
//! makes an unconsumed key an error.

use std::collections::BTreeMap;

use crate::error::ParamError;
use crate::file::PARAM_PREFIX;

/// Stage and world parameters: dotted keys to TOML values, sorted.
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
            toml::Value::Table(inner) if !inner.is_empty() => flatten(&full, inner, out),
            other => {
                out.insert(full, other.clone());
            }
        }
    }
}

/// Parses a TOML value from its text; a bare word that is not TOML becomes a string.
#[must_use]
pub fn parse_value(text: &str) -> toml::Value {
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
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Parameters from a TOML table, nested tables flattened to dotted keys.
    #[must_use]
    pub fn from_table(table: &toml::Table) -> Self {
        let mut values = BTreeMap::new();
        flatten("", table, &mut values);
        Self { values }
    }

    /// Parameters stored in a `scenario` metadata record (`param.<key>` entries).
    #[must_use]
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
    #[must_use]
    pub fn to_metadata(&self) -> Vec<(String, String)> {
        self.values
            .iter()
            .map(|(k, v)| (format!("{PARAM_PREFIX}{k}"), v.to_string()))
            .collect()
    }

    /// Applies one `key=value` override (value parsed as TOML, else a string).
    ///
    /// # Errors
    /// [`ParamError::BadSet`] without `=` or with an empty key.
    pub fn set_from_arg(&mut self, arg: &str) -> Result<(), ParamError> {
        let (key, value) = split_set(arg)?;
        self.values.insert(key.to_owned(), parse_value(value));
        Ok(())
    }

    /// Sets `key` to `value`.
    pub fn set(&mut self, key: impl Into<String>, value: toml::Value) {
        self.values.insert(key.into(), value);
    }

    /// Removes `key`, returning its value.
    pub fn remove(&mut self, key: &str) -> Option<toml::Value> {
        self.values.remove(key)
    }

    /// Overrides with every parameter of `other`.
    pub fn merge(&mut self, other: &Params) {
        for (k, v) in &other.values {
            self.values.insert(k.clone(), v.clone());
        }
    }

    /// The raw value of `key`.
    #[must_use]
    pub fn get(&self, key: &str) -> Option<&toml::Value> {
        self.values.get(key)
    }

    /// True when `key` is set.
    #[must_use]
    pub fn contains(&self, key: &str) -> bool {
        self.values.contains_key(key)
    }

    /// All parameters, sorted by key.
    pub fn iter(&self) -> impl Iterator<Item = (&str, &toml::Value)> {
        self.values.iter().map(|(k, v)| (k.as_str(), v))
    }

    /// All keys, sorted.
    pub fn keys(&self) -> impl Iterator<Item = &str> {
        self.values.keys().map(String::as_str)
    }

    /// Number of parameters.
    #[must_use]
    pub fn len(&self) -> usize {
        self.values.len()
    }

    /// True without parameters.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    /// Keys whose values differ between `self` and `other` (present in either), sorted.
    #[must_use]
    pub fn changed_keys(&self, other: &Params) -> Vec<String> {
        let mut keys: Vec<String> = self
            .values
            .iter()
            .filter(|(k, v)| other.values.get(*k) != Some(*v))
            .map(|(k, _)| k.clone())
            .collect();
        keys.extend(
            other
                .values
                .keys()
                .filter(|k| !self.values.contains_key(*k))
                .cloned(),
        );
        keys.sort();
        keys
    }
}

/// Splits a `--set` argument into its trimmed key and its value text.
///
/// # Errors
/// [`ParamError::BadSet`] without `=` or with an empty key.
pub fn split_set(arg: &str) -> Result<(&str, &str), ParamError> {
    let bad = || ParamError::BadSet {
        arg: arg.to_owned(),
    };
    let (key, value) = arg.split_once('=').ok_or_else(bad)?;
    let key = key.trim();
    if key.is_empty() {
        return Err(bad());
    }
    Ok((key, value))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flattens_and_keeps_empty_tables() -> Result<(), Box<dyn std::error::Error>> {
        let t: toml::Table = "hour = 15.0\n[wind]\nmean_mps = 1.5\n[bump]\n".parse()?;
        let p = Params::from_table(&t);
        assert_eq!(p.get("wind.mean_mps"), Some(&toml::Value::Float(1.5)));
        assert_eq!(p.get("bump"), Some(&toml::Value::Table(toml::Table::new())));
        let back = Params::from_metadata(&p.to_metadata().into_iter().collect());
        assert_eq!(back, p);
        Ok(())
    }

    #[test]
    fn set_parses_toml_or_a_bare_word() -> Result<(), ParamError> {
        let mut p = Params::new();
        p.set_from_arg("a.x=0.25")?;
        p.set_from_arg("c=word")?;
        p.set_from_arg("v=[1, 2]")?;
        assert_eq!(p.get("a.x"), Some(&toml::Value::Float(0.25)));
        assert_eq!(p.get("c"), Some(&toml::Value::String("word".into())));
        assert!(matches!(p.get("v"), Some(toml::Value::Array(a)) if a.len() == 2));
        assert!(p.set_from_arg("novalue").is_err());
        assert!(p.set_from_arg(" =1").is_err());
        assert_eq!(
            p.changed_keys(&Params::new()),
            vec!["a.x".to_owned(), "c".to_owned(), "v".to_owned()]
        );
        Ok(())
    }
}
