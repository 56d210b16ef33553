//! Fast Explicit Diffusion (FED) step sizes.
//!
//! Grewenig, Weickert & Bruhn, "From box filtering to fast explicit diffusion" (DAGM 2010),
//! as used by AKAZE (Alcantarilla, Nuevo & Bartoli, BMVC 2013, sec. 3.1). One FED cycle of
//! `n` explicit steps with the varying step sizes
//!
//! ```text
//! tau_k = tau_max / (2 cos^2(pi (2k + 1) / (4n + 2))),   k = 0 .. n-1
//! ```
//!
//! reaches the stopping time `sum_k tau_k = tau_max (n^2 + n) / 3` while each step alone may
//! exceed the stability limit `tau_max` (0.25 for the 2D explicit scheme). For a requested
//! time `T` the least `n` with `tau_max (n^2 + n) / 3 >= T` is
//! `n = ceil(sqrt(3 T / tau_max + 1/4) - 1/2)`, and the steps are scaled by
//! `3 T / (tau_max n (n + 1))` to land on `T` exactly. The steps are reordered with the
//! `kappa`-cycle of Grewenig et al. (`kappa = n / 2`, modulus the next prime above `n`)
//! to limit the growth of rounding errors.

/// Stability limit of the explicit 2D diffusion scheme with the 3x3 five-point stencil.
pub const TAU_MAX: f32 = 0.25;

/// The FED step sizes of one cycle reaching the diffusion time `t` (module docs); empty
/// when `t <= 0` or not finite.
pub fn fed_steps(t: f32, tau_max: f32) -> Vec<f32> {
    if !(t.is_finite() && t > 0.0 && tau_max > 0.0) {
        return Vec::new();
    }
    let n = ((3.0 * t / tau_max + 0.25).sqrt() - 0.5 - 1e-8)
        .ceil()
        .max(1.0) as usize;
    let scale = 3.0 * t / (tau_max * (n * (n + 1)) as f32);
    let c = 1.0 / (4.0 * n as f32 + 2.0);
    let d = scale * tau_max / 2.0;
    let tauh: Vec<f32> = (0..n)
        .map(|k| {
            let h = (std::f32::consts::PI * (2.0 * k as f32 + 1.0) * c).cos();
            d / (h * h)
        })
        .collect();
    // kappa-cycle reordering.
    let kappa = n / 2;
    let mut prime = n + 1;
    while !is_prime(prime) {
        prime += 1;
    }
    let mut tau = Vec::with_capacity(n);
    let mut k = 0usize;
    while tau.len() < n {
        let index = ((k + 1) * kappa) % prime;
        k += 1;
        // index in 1..=n maps to tauh[index - 1]; 0 and > n are skipped.
        if index >= 1 && index <= n {
            tau.push(tauh[index - 1]);
        }
        if k > 4 * prime {
            // kappa = 0 (n = 1) never produces a valid index: keep the natural order.
            return tauh;
        }
    }
    tau
}

fn is_prime(n: usize) -> bool {
    if n < 2 {
        return false;
    }
    let mut d = 2;
    while d * d <= n {
        if n.is_multiple_of(d) {
            return false;
        }
        d += 1;
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_sum_to_the_requested_time_and_are_a_permutation() {
        for &t in &[0.3f32, 0.53, 1.06, 4.1, 17.0, 70.0] {
            let tau = fed_steps(t, TAU_MAX);
            let sum: f32 = tau.iter().sum();
            assert!((sum - t).abs() < 1e-4 * t.max(1.0), "t {t}: sum {sum}");
            let n = tau.len();
            assert!(TAU_MAX * (n * (n + 1)) as f32 / 3.0 >= t - 1e-5);
            if n > 1 {
                assert!(TAU_MAX * ((n - 1) * n) as f32 / 3.0 < t);
            }
            let mut sorted = tau.clone();
            sorted.sort_by(f32::total_cmp);
            let mut natural: Vec<f32> = {
                let c = 1.0 / (4.0 * n as f32 + 2.0);
                let scale = 3.0 * t / (TAU_MAX * (n * (n + 1)) as f32);
                (0..n)
                    .map(|k| {
                        let h = (std::f32::consts::PI * (2.0 * k as f32 + 1.0) * c).cos();
                        scale * TAU_MAX / 2.0 / (h * h)
                    })
                    .collect()
            };
            natural.sort_by(f32::total_cmp);
            assert_eq!(sorted, natural);
        }
        assert!(fed_steps(0.0, TAU_MAX).is_empty());
        assert!(fed_steps(f32::NAN, TAU_MAX).is_empty());
    }
}
