//! Summary statistics and refusal counting for experiment reports (ARCHITECTURE.md section 7).
//!
//! Quantiles use linear interpolation between order statistics, position `p (n - 1)` in the
//! ascending sample (Hyndman & Fan 1996, definition 7; numpy's default `percentile`, so a
//! reader can check any number with one line of Python). Samples are sorted with
//! `f64::total_cmp` and summed in sorted order, so a [`Summary`] depends only on the multiset
//! of samples, never on the order trials finished in or on the thread count.
//!
//! Refusals (a method that declines to answer, e.g. too few matches) are not samples: they
//! are counted per condition and method in a [`RefusalCounter`] and shown in the report
//! beside the statistics of the answers, never silently dropped.

use std::collections::BTreeMap;

use serde::Serialize;

/// Median, quartiles, mean, p95 and range of a sample set.
///
/// Non-finite samples (NaN, infinities) are not averaged; they are counted in `non_finite`
/// so a report can show them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Summary {
    /// Number of finite samples the statistics are over.
    pub n: usize,
    /// Samples left out because they were NaN or infinite.
    pub non_finite: usize,
    /// Arithmetic mean (NaN when `n == 0`; NaN is written as JSON `null`).
    pub mean: f64,
    /// Median (50th percentile).
    pub median: f64,
    /// First quartile (25th percentile).
    pub q1: f64,
    /// Third quartile (75th percentile).
    pub q3: f64,
    /// 95th percentile.
    pub p95: f64,
    /// Smallest sample.
    pub min: f64,
    /// Largest sample.
    pub max: f64,
}

/// The Wilson score interval of a success rate at 95% (Wilson 1927; Brown, Cai & DasGupta
/// 2001 recommend it over the normal approximation for small `n` and rates near 0 or 1):
///
/// ```text
/// p = k / n,  z = 1.96
/// centre = (p + z^2 / 2n) / (1 + z^2 / n)
/// half   = z sqrt(p (1 - p) / n + z^2 / 4n^2) / (1 + z^2 / n)
/// ```
///
/// `(centre - half, centre + half)`; `(NaN, NaN)` when `n == 0`.
#[must_use]
pub fn wilson_95(successes: usize, n: usize) -> (f64, f64) {
    if n == 0 {
        return (f64::NAN, f64::NAN);
    }
    const Z: f64 = 1.959_963_984_540_054;
    let (k, n) = (successes.min(n) as f64, n as f64);
    let p = k / n;
    let z2 = Z * Z;
    let denominator = 1.0 + z2 / n;
    let centre = (p + z2 / (2.0 * n)) / denominator;
    let half = Z * (p * (1.0 - p) / n + z2 / (4.0 * n * n)).sqrt() / denominator;
    ((centre - half).max(0.0), (centre + half).min(1.0))
}

/// Quantile `p` in `[0, 1]` of the ascending `sorted` slice (module docs); NaN when empty.
pub fn quantile_sorted(sorted: &[f64], p: f64) -> f64 {
    let Some(&last) = sorted.last() else {
        return f64::NAN;
    };
    let pos = p.clamp(0.0, 1.0) * (sorted.len() - 1) as f64;
    let lo = pos.floor() as usize;
    let frac = pos - lo as f64;
    let a = sorted.get(lo).copied().unwrap_or(last);
    let b = sorted.get(lo + 1).copied().unwrap_or(last);
    a + (b - a) * frac
}

impl Summary {
    /// The statistics of `samples` (any order). With no finite sample every statistic is NaN
    /// and `n == 0`.
    pub fn of(samples: &[f64]) -> Self {
        let mut v: Vec<f64> = samples.iter().copied().filter(|x| x.is_finite()).collect();
        let non_finite = samples.len() - v.len();
        v.sort_by(f64::total_cmp);
        let n = v.len();
        let mean = if n == 0 {
            f64::NAN
        } else {
            v.iter().sum::<f64>() / n as f64
        };
        Self {
            n,
            non_finite,
            mean,
            median: quantile_sorted(&v, 0.5),
            q1: quantile_sorted(&v, 0.25),
            q3: quantile_sorted(&v, 0.75),
            p95: quantile_sorted(&v, 0.95),
            min: v.first().copied().unwrap_or(f64::NAN),
            max: v.last().copied().unwrap_or(f64::NAN),
        }
    }
}

/// Attempts and refusals of one (condition, method) cell.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct RefusalCell {
    /// Trials attempted.
    pub attempts: usize,
    /// Trials the method refused (no answer).
    pub refused: usize,
    /// Refusals by reason (the error's short text), sorted by reason.
    pub reasons: BTreeMap<String, usize>,
}

impl RefusalCell {
    /// `"refused/attempts"`, e.g. `"3/100"`, for report tables.
    pub fn fraction(&self) -> String {
        format!("{}/{}", self.refused, self.attempts)
    }
}

/// Per-condition, per-method counter of refusals (module docs). Keys are kept sorted, so
/// iteration and the JSON it serialises to are deterministic.
///
/// ```ignore
/// let mut r = RefusalCounter::default();
/// r.attempt("sigma=0.1", "zhi");
/// r.refuse("sigma=0.1", "zhi", "too few matches");
/// r.attempt("sigma=0.1", "ours");
/// assert_eq!(r.cell("sigma=0.1", "zhi").refused, 1);
/// ```
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct RefusalCounter {
    /// `cells[condition][method]`.
    pub cells: BTreeMap<String, BTreeMap<String, RefusalCell>>,
}

impl RefusalCounter {
    fn cell_mut(&mut self, condition: &str, method: &str) -> &mut RefusalCell {
        self.cells
            .entry(condition.to_owned())
            .or_default()
            .entry(method.to_owned())
            .or_default()
    }

    /// Counts one attempt of `method` under `condition`.
    pub fn attempt(&mut self, condition: &str, method: &str) {
        self.cell_mut(condition, method).attempts += 1;
    }

    /// Counts one refusal (call [`RefusalCounter::attempt`] for the same trial too).
    pub fn refuse(&mut self, condition: &str, method: &str, reason: &str) {
        let cell = self.cell_mut(condition, method);
        cell.refused += 1;
        *cell.reasons.entry(reason.to_owned()).or_default() += 1;
    }

    /// Records one trial's outcome: an attempt, and a refusal when `outcome` is an error
    /// (its `Display` text is the reason). Returns the value on success.
    pub fn record<T, E: std::fmt::Display>(
        &mut self,
        condition: &str,
        method: &str,
        outcome: Result<T, E>,
    ) -> Option<T> {
        self.attempt(condition, method);
        match outcome {
            Ok(v) => Some(v),
            Err(e) => {
                self.refuse(condition, method, &e.to_string());
                None
            }
        }
    }

    /// The cell of `(condition, method)` (empty when never touched).
    pub fn cell(&self, condition: &str, method: &str) -> RefusalCell {
        self.cells
            .get(condition)
            .and_then(|m| m.get(method))
            .cloned()
            .unwrap_or_default()
    }

    /// Total refusals over every cell.
    pub fn total_refused(&self) -> usize {
        self.cells
            .values()
            .flat_map(|m| m.values())
            .map(|c| c.refused)
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wilson_interval_matches_an_independent_evaluation() {
        // The formula evaluated independently (Python, z = 1.959964), rounded to 4 places.
        let (lo, hi) = wilson_95(98, 100);
        assert!(
            (lo - 0.9300).abs() < 1e-4 && (hi - 0.9945).abs() < 1e-4,
            "{lo} {hi}"
        );
        let (lo, hi) = wilson_95(0, 20);
        assert!(lo == 0.0 && (hi - 0.1611).abs() < 1e-4, "{lo} {hi}");
        let (lo, hi) = wilson_95(6, 10);
        assert!(
            (lo - 0.3127).abs() < 1e-4 && (hi - 0.8318).abs() < 1e-4,
            "{lo} {hi}"
        );
        assert!(wilson_95(0, 0).0.is_nan());
    }

    #[test]
    fn summary_matches_numpy_and_ignores_order() {
        // numpy: percentile([1,2,3,4,10], [25,50,75,95]) = [2, 3, 4, 8.8]
        let a = Summary::of(&[10.0, 1.0, 3.0, f64::NAN, 2.0, 4.0]);
        assert_eq!((a.n, a.non_finite), (5, 1));
        assert_eq!((a.q1, a.median, a.q3), (2.0, 3.0, 4.0));
        assert!((a.p95 - 8.8).abs() < 1e-12);
        assert_eq!((a.mean, a.min, a.max), (4.0, 1.0, 10.0));
        let b = Summary::of(&[4.0, 2.0, 10.0, 3.0, 1.0]);
        assert_eq!(a.median.to_bits(), b.median.to_bits());
        assert_eq!(a.mean.to_bits(), b.mean.to_bits());
        let e = Summary::of(&[]);
        assert_eq!(e.n, 0);
        assert!(e.median.is_nan() && e.mean.is_nan());
    }

    #[test]
    fn refusals_are_counted_per_cell_and_reason() {
        let mut r = RefusalCounter::default();
        assert_eq!(r.record::<i32, &str>("c1", "zhi", Err("few matches")), None);
        assert_eq!(r.record::<i32, &str>("c1", "zhi", Ok(3)), Some(3));
        r.attempt("c1", "ours");
        let c = r.cell("c1", "zhi");
        assert_eq!(
            (c.attempts, c.refused, c.fraction()),
            (2, 1, "1/2".to_owned())
        );
        assert_eq!(c.reasons.get("few matches"), Some(&1));
        assert_eq!(r.cell("c1", "ours").refused, 0);
        assert_eq!(r.total_refused(), 1);
    }
}
