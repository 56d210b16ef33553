//! Distribution functions and quantiles the statistical decisions use: the normal, the
//! chi-square with 3 degrees of freedom (a 3-vector's squared Mahalanobis norm), Fisher's F
//! and Hotelling's T^2 (the same norm against a covariance that was itself estimated).
//! Quantiles are found by bisection on the CDF; every function is pure and deterministic.

/// `erf(x)` (Abramowitz & Stegun 7.1.26, absolute error below 1.5e-7).
pub fn erf(x: f64) -> f64 {
    let t = 1.0 / (1.0 + 0.327_591_1 * x.abs());
    let poly = t
        * (0.254_829_592
            + t * (-0.284_496_736
                + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    let y = 1.0 - poly * (-x * x).exp();
    if x >= 0.0 { y } else { -y }
}

/// Standard normal CDF.
pub fn normal_cdf(z: f64) -> f64 {
    0.5 * (1.0 + erf(z / std::f64::consts::SQRT_2))
}

/// `Phi^-1(q)`.
pub fn normal_quantile(q: f64) -> f64 {
    bisect(normal_cdf, q.clamp(1e-12, 1.0 - 1e-12), -40.0, 40.0)
}

/// `P(chi^2_3 <= x) = erf(sqrt(x / 2)) - sqrt(2 x / pi) exp(-x / 2)`.
pub fn chi2_3_cdf(x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    erf((0.5 * x).sqrt()) - (2.0 * x / std::f64::consts::PI).sqrt() * (-0.5 * x).exp()
}

/// `F^-1_chi2_3(q)`.
pub fn chi2_3_quantile(q: f64) -> f64 {
    bisect(chi2_3_cdf, q.clamp(0.0, 1.0 - 1e-12), 0.0, 200.0)
}

/// `ln Gamma(x)`, `x > 0` (Lanczos, g = 7, 9 terms; relative error below 1e-13).
pub fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection: Gamma(x) Gamma(1 - x) = pi / sin(pi x).
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + G + 0.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// The regularised incomplete beta function `I_x(a, b)` by its continued fraction (modified
/// Lentz; Press et al., Numerical Recipes, 3rd ed., section 6.4).
pub fn incomplete_beta(x: f64, a: f64, b: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    let front =
        (ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * x.ln() + b * (1.0 - x).ln()).exp();
    // The fraction converges fast for x < (a + 1) / (a + b + 2); use the symmetry otherwise.
    if x > (a + 1.0) / (a + b + 2.0) {
        return 1.0 - incomplete_beta(1.0 - x, b, a);
    }
    const TINY: f64 = 1e-300;
    let mut c = 1.0;
    let mut d = 1.0 - (a + b) * x / (a + 1.0);
    if d.abs() < TINY {
        d = TINY;
    }
    d = 1.0 / d;
    let mut h = d;
    for m in 1..300 {
        let m = f64::from(m);
        let m2 = 2.0 * m;
        // Even step.
        let aa = m * (b - m) * x / ((a + m2 - 1.0) * (a + m2));
        d = 1.0 + aa * d;
        d = if d.abs() < TINY { TINY } else { d };
        c = 1.0 + aa / c;
        c = if c.abs() < TINY { TINY } else { c };
        d = 1.0 / d;
        h *= d * c;
        // Odd step.
        let aa = -(a + m) * (a + b + m) * x / ((a + m2) * (a + m2 + 1.0));
        d = 1.0 + aa * d;
        d = if d.abs() < TINY { TINY } else { d };
        c = 1.0 + aa / c;
        c = if c.abs() < TINY { TINY } else { c };
        d = 1.0 / d;
        let step = d * c;
        h *= step;
        if (step - 1.0).abs() < 1e-15 {
            break;
        }
    }
    front * h / a
}

/// `P(F_{d1, d2} <= f)`.
pub fn f_cdf(f: f64, d1: f64, d2: f64) -> f64 {
    if f <= 0.0 {
        return 0.0;
    }
    incomplete_beta(d1 * f / (d1 * f + d2), 0.5 * d1, 0.5 * d2)
}

/// `F^-1_{d1, d2}(q)`.
pub fn f_quantile(q: f64, d1: f64, d2: f64) -> f64 {
    let q = q.clamp(0.0, 1.0 - 1e-12);
    let mut hi = 1.0;
    while f_cdf(hi, d1, d2) < q && hi < 1e12 {
        hi *= 2.0;
    }
    bisect(|f| f_cdf(f, d1, d2), q, 0.0, hi)
}

/// The `q`-quantile of Hotelling's `T^2 = d^T S^-1 d` for a `p`-vector `d ~ N(0, Sigma)`
/// against a covariance `S` estimated from `samples` independent replicates (`samples - 1`
/// degrees of freedom): `T^2 = p (samples - 1) / (samples - p) F_{p, samples - p}`
/// (Hotelling 1931). It exceeds the chi-square quantile the same test has against the
/// true `Sigma`, the more so the fewer the samples; NaN for `samples <= p`.
pub fn hotelling_t2_quantile(q: f64, p: usize, samples: usize) -> f64 {
    if samples <= p {
        return f64::NAN;
    }
    let (p, n) = (p as f64, samples as f64);
    p * (n - 1.0) / (n - p) * f_quantile(q, p, n - p)
}

/// The `q`-quantile of an increasing CDF on `[lo, hi]` by bisection.
fn bisect(cdf: impl Fn(f64) -> f64, q: f64, mut lo: f64, mut hi: f64) -> f64 {
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if cdf(mid) < q {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_match_tables() {
        // chi^2_3: 95% 7.815, 97.5% 9.348; normal: 95% 1.6449.
        assert!((chi2_3_quantile(0.95) - 7.8147).abs() < 1e-3);
        assert!((chi2_3_quantile(0.975) - 9.3484).abs() < 1e-3);
        assert!((normal_quantile(0.95) - 1.6449).abs() < 1e-3);
        assert!((chi2_3_quantile(0.975).sqrt() - 3.0575).abs() < 1e-3);
        // F tables (95%): F(3, 15) = 3.287, F(3, 5) = 5.409, F(1, 10) = 4.965.
        assert!((f_quantile(0.95, 3.0, 15.0) - 3.287).abs() < 2e-3);
        assert!((f_quantile(0.95, 3.0, 5.0) - 5.409).abs() < 2e-3);
        assert!((f_quantile(0.95, 1.0, 10.0) - 4.965).abs() < 2e-3);
        // ln Gamma: Gamma(5) = 24, Gamma(0.5) = sqrt(pi).
        assert!((ln_gamma(5.0) - 24f64.ln()).abs() < 1e-12);
        assert!((ln_gamma(0.5) - std::f64::consts::PI.sqrt().ln()).abs() < 1e-12);
        // T^2 with 18 samples of a 3-vector: 3 * 17 / 15 * F(3, 15) = 11.18; many samples
        // approach chi^2_3.
        assert!((hotelling_t2_quantile(0.95, 3, 18) - 11.18).abs() < 0.01);
        assert!((hotelling_t2_quantile(0.95, 3, 100_000) - 7.8147).abs() < 0.01);
        assert!(hotelling_t2_quantile(0.95, 3, 3).is_nan());
    }
}
