//! Can the wire's swing be predicted, so that the hook is timed to its phase?
//!
//! `cargo run --release --example sway_phase [-- TRIALS [STEP_S]]` (default 400 trials per
//! wind speed, captures 1 s apart).
//!
//! The simulator's wire (`sim::environment`: a pendulum of effective length 0.8 sag, damping
//! ratio 0.05, driven by the drag of turbulent wind with a 3 s correlation time) is sampled
//! the way the hang samples it: captures over 5 s, `STEP_S` apart (1 s: the structured-light
//! camera's cadence; 0.1 s asks what a 10 Hz sensor would give), each with 0.3 mm of fit
//! scatter, and the anemometer's reading (the 3-s mean with its noise) with each. The hanging
//! point's offset across the wire `x(t)` is then predicted `dt` after the last capture by
//! - **centre**: the captures' mean (where the hang's hook goes);
//! - **wind regression**: `x = c + k u^2` fitted to the captures and the anemometer's readings
//!   with them (the static swing angle's tangent is proportional to `u^2`), evaluated at the
//!   reading at `dt`;
//! - **sine, exact w**: least squares of `c + a cos(w t) + b sin(w t)` with the simulator's
//!   own pendulum frequency (better than the robot can know: it has the sag from its survey);
//! - **sine, w +-5 %**: the same with the frequency 5 % off (a sag known to 10 %);
//! - **oracle state**: the true angle, rate and instantaneous wind at the last capture,
//!   propagated with the turbulence decaying to its mean (its expectation). No sensor gives
//!   more; its error is what the turbulence to come leaves unpredictable.
//!
//! It prints the RMS prediction error per method and horizon, and the swing's RMS about the
//! captures' centre, per mean wind speed. Sags (0.6-1 m) and seeds come from
//! `rng::SplitMix64`, so the table is the same on every run.

use nalgebra::{Matrix3, Vector3};
use sim::config::WindConfig;
use sim::environment::{WIND_TAU_S, WIRE_DAMPING, WIRE_DRAG_PER_MPS2, Wind};

/// The captures span this long (s).
const CAPTURE_SPAN_S: f64 = 5.0;
/// Fit scatter of one capture's axis point (m).
const CAPTURE_SIGMA_M: f64 = 0.0003;
/// Horizons after the last capture (s).
const HORIZONS_S: [f64; 6] = [0.0, 0.25, 0.5, 1.0, 2.0, 3.0];
/// World tick (s), as the simulator's.
const TICK_S: f64 = 0.001;
/// Time before the first capture (s): the wind and swing forget their start.
const WARM_UP_S: f64 = 30.0;
/// The predictors, in the table's order (module docs).
const METHODS: [&str; 5] = [
    "centre",
    "wind regression",
    "sine, exact w",
    "sine, w +-5 %",
    "oracle state",
];

/// Least squares `c + a cos(w t) + b sin(w t)` through `(t, x)`; `None` when singular.
fn fit_sine(samples: &[(f64, f64)], w: f64) -> Option<Vector3<f64>> {
    let mut ata = Matrix3::zeros();
    let mut atb = Vector3::zeros();
    for &(t, x) in samples {
        let r = Vector3::new(1.0, (w * t).cos(), (w * t).sin());
        ata += r * r.transpose();
        atb += r * x;
    }
    ata.try_inverse().map(|inv| inv * atb)
}

fn eval_sine(p: &Vector3<f64>, w: f64, t: f64) -> f64 {
    p.x + p.y * (w * t).cos() + p.z * (w * t).sin()
}

/// Least squares `y = c + k g` through `(g, y)`: `(mean g, mean y, k)`.
fn fit_line(g: &[f64], y: &[f64]) -> (f64, f64, f64) {
    let n = g.len().max(1) as f64;
    let (gm, ym) = (g.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let sgg: f64 = g.iter().map(|v| (v - gm).powi(2)).sum();
    let sgy: f64 = g.iter().zip(y).map(|(a, b)| (a - gm) * (b - ym)).sum();
    (gm, ym, if sgg > 0.0 { sgy / sgg } else { 0.0 })
}

/// The swing angle `dt` after a state `(theta, rate)` with the wind `u0` now, the
/// turbulence decaying to the mean `mean` (`sim::environment`'s oscillator, its step).
fn propagate(theta: f64, rate: f64, u0: f64, mean: f64, w: f64, dt: f64) -> f64 {
    let (mut th, mut v, mut t) = (theta, rate, 0.0);
    while t + 0.5 * TICK_S < dt {
        t += TICK_S;
        let u = mean + (u0 - mean) * (-t / WIND_TAU_S).exp();
        let eq = (WIRE_DRAG_PER_MPS2 * u * u).atan();
        v += (w * w * (eq - th) - 2.0 * WIRE_DAMPING * w * v) * TICK_S;
        th += v * TICK_S;
    }
    th
}

/// The simulated wind and wire, stepped at the world tick.
struct Clock {
    wind: Wind,
    t_s: f64,
    t_ns: u64,
}

impl Clock {
    fn advance_to(&mut self, until_s: f64) {
        while self.t_s + 0.5 * TICK_S < until_s {
            self.t_ns += 1_000_000;
            self.t_s += TICK_S;
            self.wind.tick(TICK_S, self.t_ns, 1.0);
        }
    }

    /// The anemometer: the 3-s mean with 0.05 m/s + 2 % of noise.
    fn anemometer(&self, rng: &mut rng::SplitMix64) -> f64 {
        let m = self.wind.mean_3s_mps();
        (m + (0.05 + 0.02 * m) * rng.normal()).max(0.0)
    }
}

fn arg<T: std::str::FromStr>(n: usize, what: &str, default: T) -> Result<T, String> {
    match std::env::args().nth(n) {
        None => Ok(default),
        Some(s) => s
            .parse()
            .map_err(|_| format!("argument {n} ({what}): cannot read {s:?}")),
    }
}

fn main() -> Result<(), String> {
    let trials: usize = arg(1, "TRIALS, a count", 400)?;
    let step_s: f64 = arg(2, "STEP_S, seconds between captures", 1.0)?;
    if !(step_s > 0.0 && step_s <= CAPTURE_SPAN_S) {
        return Err(format!("STEP_S must be in (0, {CAPTURE_SPAN_S}] s"));
    }
    let captures = (CAPTURE_SPAN_S / step_s).round() as usize + 1;
    println!(
        "{trials} trials per speed, {captures} captures {step_s} s apart; RMS errors (mm) of \
         the predicted offset across the wire"
    );
    println!(
        "| wind (m/s) | swing RMS (mm) | method | {} |",
        HORIZONS_S.map(|h| format!("dt {h} s")).join(" | ")
    );
    println!("|---|---|---|{}", "---|".repeat(HORIZONS_S.len()));
    for mean in [2.0, 2.5, 3.0, 3.5, 4.0] {
        let mut rng = rng::SplitMix64::new(0x5eed_0000 + (mean * 10.0) as u64);
        let mut sq = [[0.0f64; HORIZONS_S.len()]; METHODS.len()];
        let mut swing_sq = 0.0;
        for _ in 0..trials {
            let sag_m = rng.uniform(0.6, 1.0);
            // The hanging point near mid-span hangs about the sag below the chord.
            let depth_m = sag_m;
            let cfg = WindConfig {
                mean_mps: mean,
                gust_mps: 0.3 * mean,
                direction_deg: 90.0,
            };
            let mut clock = Clock {
                wind: Wind::new(rng.next_u64(), cfg, sag_m, 1.0),
                t_s: 0.0,
                t_ns: 0,
            };
            let w_true = (9.81 / (0.8 * sag_m)).sqrt();
            let offset = |clock: &Clock| depth_m * clock.wind.wire_sway_rad().sin();
            let mut samples = Vec::with_capacity(captures);
            let mut gusts = Vec::with_capacity(captures);
            for k in 0..captures {
                let tk = WARM_UP_S + k as f64 * step_s;
                clock.advance_to(tk);
                samples.push((tk, offset(&clock) + CAPTURE_SIGMA_M * rng.normal()));
                gusts.push(clock.anemometer(&mut rng).powi(2));
            }
            let xs: Vec<f64> = samples.iter().map(|s| s.1).collect();
            let (gm, centre, k_wind) = fit_line(&gusts, &xs);
            let sine_exact = fit_sine(&samples, w_true);
            let w_off = w_true * if rng.next_f64() < 0.5 { 0.95 } else { 1.05 };
            let sine_off = fit_sine(&samples, w_off);
            let t_last = WARM_UP_S + (captures - 1) as f64 * step_s;
            let (theta0, u0) = (clock.wind.wire_sway_rad(), clock.wind.speed_mps());
            clock.advance_to(t_last + TICK_S);
            let rate0 = (clock.wind.wire_sway_rad() - theta0) / TICK_S;
            for (h, dt) in HORIZONS_S.iter().enumerate() {
                clock.advance_to(t_last + dt);
                let x = offset(&clock);
                let u2 = clock.anemometer(&mut rng).powi(2);
                let t = t_last + dt;
                let predictions = [
                    Some(centre),
                    Some(centre + k_wind * (u2 - gm)),
                    sine_exact.map(|p| eval_sine(&p, w_true, t)),
                    sine_off.map(|p| eval_sine(&p, w_off, t)),
                    Some(depth_m * propagate(theta0, rate0, u0, mean, w_true, *dt).sin()),
                ];
                for (m, p) in predictions.iter().enumerate() {
                    sq[m][h] += (p.unwrap_or(centre) - x).powi(2);
                }
                swing_sq += (x - centre).powi(2);
            }
        }
        let rms_mm = |s: f64, n: usize| 1e3 * (s / n.max(1) as f64).sqrt();
        let swing_mm = rms_mm(swing_sq, trials * HORIZONS_S.len());
        for (m, name) in METHODS.iter().enumerate() {
            let cells: Vec<String> = sq[m]
                .iter()
                .map(|s| format!("{:.1}", rms_mm(*s, trials)))
                .collect();
            println!(
                "| {mean} | {swing_mm:.1} | {name} | {} |",
                cells.join(" | ")
            );
        }
    }
    Ok(())
}
