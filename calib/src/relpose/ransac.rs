//! Generic, seeded, deterministic RANSAC with MSAC scoring and an adaptive iteration count.
//!
//! Fischler & Bolles (1981) hypothesise-and-verify; hypotheses are scored with the truncated
//! quadratic of MSAC (Torr & Zisserman 2000, MLESAC paper, sec. 3), `sum_i min(r_i^2, T^2)`, which ranks
//! equal-count hypotheses by their fit. After each improvement the number of iterations is
//! lowered to (Hartley & Zisserman 2004, eq. 4.18)
//!
//! ```text
//! N = log(1 - p) / log(1 - w^s)
//! ```
//!
//! with `p` the confidence, `w` the inlier fraction of the best hypothesis and `s` the sample
//! size, clamped to `[min_iterations, max_iterations]`.
//!
//! Samples come from [`SplitMix64`] (Steele, Lea & Flood 2014), a counter-based generator:
//! the k-th draw is `mix(seed + k * 0x9E3779B97F4A7C15)`, independent of threads and clocks.

/// The seeded generator RANSAC samples with (rodlog's one SplitMix64).
pub use rng::SplitMix64;

/// Stopping rule of [`ransac`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RansacConfig {
    /// Confidence `p` of having drawn one all-inlier sample; default 0.999.
    pub confidence: f64,
    /// Iterations always run (robustness to a lucky early sample); default 50.
    pub min_iterations: usize,
    /// Hard cap on iterations; default 5000.
    pub max_iterations: usize,
}

impl Default for RansacConfig {
    fn default() -> Self {
        Self {
            confidence: 0.999,
            min_iterations: 50,
            max_iterations: 5000,
        }
    }
}

/// Outcome of [`ransac`]: the best hypothesis and how it was found.
#[derive(Debug, Clone, PartialEq)]
pub struct RansacOutcome<M> {
    /// Best model (lowest MSAC cost); `None` when no sample gave a model.
    pub model: Option<M>,
    /// Inlier flags of the best model (`r^2 <= T^2`).
    pub inliers: Vec<bool>,
    /// Number of inliers of the best model.
    pub inlier_count: usize,
    /// MSAC cost of the best model.
    pub cost: f64,
    /// Iterations (samples drawn) run.
    pub iterations: usize,
}

/// Adaptive iteration bound `log(1 - p) / log(1 - w^s)` (module equation), clamped.
pub fn required_iterations(
    config: &RansacConfig,
    inlier_fraction: f64,
    sample_size: usize,
) -> usize {
    let max = config.max_iterations.max(config.min_iterations);
    if inlier_fraction.is_nan() || inlier_fraction <= 0.0 {
        return max;
    }
    let ws = inlier_fraction.min(1.0).powi(sample_size as i32);
    if ws >= 1.0 {
        return config.min_iterations;
    }
    let p = config.confidence.clamp(0.0, 1.0 - 1e-12);
    let n = (1.0 - p).ln() / (1.0 - ws).ln();
    if !n.is_finite() {
        return max;
    }
    (n.ceil() as usize).clamp(config.min_iterations, max)
}

/// Runs RANSAC/MSAC over `n` data with minimal samples of `sample_size`.
///
/// `fit(sample, models)` appends the models of one minimal sample (none if degenerate, several
/// for multi-solution solvers); `residual_sq(model, i)` is the squared residual of datum `i`;
/// `threshold_sq` is `T^2`. Deterministic for a given `seed`.
pub fn ransac<M: Clone>(
    n: usize,
    sample_size: usize,
    threshold_sq: f64,
    config: &RansacConfig,
    seed: u64,
    fit: impl FnMut(&[usize], &mut Vec<M>),
    residual_sq: impl Fn(&M, usize) -> f64,
) -> RansacOutcome<M> {
    ransac_lo(
        n,
        sample_size,
        threshold_sq,
        config,
        seed,
        fit,
        residual_sq,
        |_, _, _| {},
    )
}

/// Largest number of local-optimisation refits after one improvement of [`ransac_lo`].
pub const LOCAL_OPTIMISATION_ROUNDS: usize = 4;

/// [`ransac`] with local optimisation (LO-RANSAC: Chum, Matas & Kittler, "Locally optimized
/// RANSAC", DAGM 2003; the iterated least squares variant of sec. 3): every time a minimal
/// sample gives a new best hypothesis, `refit(model, inliers, models)` fits models to all of its
/// inliers (a non-minimal estimator such as the 8-point algorithm or a Sampson refinement),
/// and a refit that lowers the MSAC cost becomes the best hypothesis, up to
/// [`LOCAL_OPTIMISATION_ROUNDS`] times in a row.
///
/// Why: a minimal sample from points with pixel noise is itself noisy, the more so with a
/// narrow field of view and a near-planar scene, so its model gathers only part of the true
/// inliers; the adaptive stopping rule then believes the inlier fraction is low *and* stops
/// with that partial model. Refitting on the inliers recovers the full support (and a truer
/// inlier fraction for the stopping rule) at the cost of a few non-minimal fits per
/// improvement (there are `O(log N)` improvements).
#[allow(clippy::too_many_arguments)]
pub fn ransac_lo<M: Clone>(
    n: usize,
    sample_size: usize,
    threshold_sq: f64,
    config: &RansacConfig,
    seed: u64,
    mut fit: impl FnMut(&[usize], &mut Vec<M>),
    residual_sq: impl Fn(&M, usize) -> f64,
    mut refit: impl FnMut(&M, &[bool], &mut Vec<M>),
) -> RansacOutcome<M> {
    let mut rng = SplitMix64::new(seed);
    let mut sample = vec![0usize; sample_size];
    let mut models = Vec::new();
    let mut refits = Vec::new();
    let mut best = RansacOutcome {
        model: None,
        inliers: vec![false; n],
        inlier_count: 0,
        cost: f64::INFINITY,
        iterations: 0,
    };
    if n < sample_size || sample_size == 0 {
        return best;
    }
    // MSAC cost of `m`, abandoned (returning at least `bound`) once it reaches `bound`.
    let cost_of = |m: &M, bound: f64| {
        let mut cost = 0.0;
        for i in 0..n {
            let r2 = residual_sq(m, i);
            cost += if r2 <= threshold_sq { r2 } else { threshold_sq };
            if cost >= bound {
                break;
            }
        }
        cost
    };
    let adopt = |best: &mut RansacOutcome<M>, m: &M, cost: f64| {
        let mut count = 0;
        for (i, flag) in best.inliers.iter_mut().enumerate() {
            *flag = residual_sq(m, i) <= threshold_sq;
            count += usize::from(*flag);
        }
        best.cost = cost;
        best.inlier_count = count;
        best.model = Some(m.clone());
    };
    let mut needed = config.max_iterations.max(config.min_iterations);
    let mut it = 0;
    while it < needed {
        it += 1;
        if !rng.distinct(n, &mut sample) {
            break;
        }
        models.clear();
        fit(&sample, &mut models);
        let mut improved = false;
        for m in &models {
            let cost = cost_of(m, best.cost);
            if cost < best.cost {
                adopt(&mut best, m, cost);
                improved = true;
            }
        }
        if improved {
            for _ in 0..LOCAL_OPTIMISATION_ROUNDS {
                refits.clear();
                let Some(current) = best.model.clone() else {
                    break;
                };
                refit(&current, &best.inliers, &mut refits);
                let mut better = false;
                for m in &refits {
                    let cost = cost_of(m, best.cost);
                    if cost < best.cost {
                        adopt(&mut best, m, cost);
                        better = true;
                    }
                }
                if !better {
                    break;
                }
            }
            needed = required_iterations(config, best.inlier_count as f64 / n as f64, sample_size);
        }
    }
    best.iterations = it;
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn iteration_bound_follows_hartley_zisserman_4_18() {
        let c = RansacConfig {
            confidence: 0.99,
            min_iterations: 1,
            max_iterations: 100_000,
        };
        // H&Z table 4.3: s = 5, 50% outliers -> 146; s = 3, 30% -> 11.
        assert_eq!(required_iterations(&c, 0.5, 5), 146);
        assert_eq!(required_iterations(&c, 0.7, 3), 11);
        assert_eq!(required_iterations(&c, 0.0, 3), 100_000);
        assert_eq!(required_iterations(&c, f64::NAN, 3), 100_000);
        assert_eq!(required_iterations(&c, 1.0, 3), 1);
    }

    #[test]
    fn splitmix_is_reproducible_and_samples_are_distinct() {
        let mut a = SplitMix64::new(42);
        let mut b = SplitMix64::new(42);
        for _ in 0..100 {
            assert_eq!(a.next_u64(), b.next_u64());
        }
        let mut out = [0usize; 5];
        assert!(!a.distinct(4, &mut out));
        for _ in 0..1000 {
            assert!(a.distinct(7, &mut out));
            for (i, x) in out.iter().enumerate() {
                assert!(*x < 7);
                assert!(!out[..i].contains(x));
            }
        }
        let u = a.next_f64();
        assert!((0.0..1.0).contains(&u));
    }

    /// A 1D location model: RANSAC keeps the cluster and rejects the outliers.
    #[test]
    fn ransac_finds_the_majority_cluster() {
        let data: Vec<f64> = (0..100)
            .map(|i| {
                if i % 3 == 0 {
                    50.0 + f64::from(i)
                } else {
                    1.0 + 1e-3 * f64::from(i % 7)
                }
            })
            .collect();
        let out = ransac(
            data.len(),
            1,
            0.01 * 0.01,
            &RansacConfig::default(),
            9,
            |s, m| m.extend(s.iter().filter_map(|&i| data.get(i).copied())),
            |m, i| data.get(i).map_or(f64::INFINITY, |x| (x - m).powi(2)),
        );
        assert_eq!(out.inlier_count, 66);
        assert!(out.model.is_some_and(|m| (m - 1.0).abs() < 0.01));
        assert!(out.iterations >= RansacConfig::default().min_iterations);
    }
}
