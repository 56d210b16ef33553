//! The wire's sway seen in a series of wrist captures: the centre it swings about, and the
//! band it swings in.
//!
//! # Model
//! A conductor in a cross wind swings about its chord as a pendulum of angle `theta(t)` (the
//! rigid swing of line clearance design, whose static angle has the wind load per weight of
//! conductor for its tangent; ARCHITECTURE.md section 6): a point hanging `L` below the chord
//! moves by `L sin theta` horizontally, across the wire, and by `L (1 - cos theta)`
//! vertically. At the swing angles of a working wind (`theta` < 0.05 rad) the vertical part
//! is below `theta / 2` of the horizontal one (< 1 mm for 30 mm of swing), so the sway is a
//! motion along the horizontal direction across the wire, `s = normalize(z x a)` for the
//! axis direction `a` in `base_link` (z up).
//!
//! Each capture `i` sees the axis through `p_i` (its axis point nearest the requested
//! location `q`); its sway offset is `d_i = (p_i - p_bar) . s` about the mean point
//! `p_bar`, and its vertical offset `e_i = (p_i - p_bar) . u`, `u = a x s`. The vertical part
//! is small for the conductor but not for the robot: the wind tilts the lift column, which
//! the arm's joints do not see, and a tilt of a few mrad moves the camera's view of the wire
//! by millimetres up and down. Both are tracked; the hook's window is +-10 mm along the
//! approach (horizontal) and +-15 mm across the wire (vertical).
//!
//! # Centre and band
//! The hook goes to the centre `p_bar` of the swing, whose 1-sigma is `s_d / sqrt(N)` for
//! the offsets' sample standard deviation `s_d` over `N` captures. The captures sample the
//! swing at times unrelated to its period (the wrist camera takes about 1 s per capture, the
//! pendulum's period is 1.4-1.8 s for a 0.6-1 m sag), so for a sinusoidal swing of
//! amplitude `A` the offsets have a standard deviation near `A / sqrt 2`. The band's
//! half-width [`SwayTrack::envelope_m`] is bounded from above at 95 %:
//! `A_95 = sqrt 2 s_d sqrt((N - 1) / chi2_{0.05, N-1})`, and never below the largest offset
//! seen. The band sizes the clearance the approach keeps from the conductors, and a band
//! wider than the task allows is a refusal (`wire_sway`) rather than an attempt.
//!
//! The phase is not tracked: captures a second apart alias a 1.4-1.8 s swing, and the hook
//! needs none. It waits at the centre with the clamp closing, and the clamp bites when the
//! swinging wire passes through the hook's capture window (`robot::grounding_rod`).
//!
//! Nor could the phase be tracked for long enough to time the hook by it. The turbulence
//! drives the lightly damped pendulum at its own frequency, so the swing forgets its phase
//! within a second. `examples/sway_phase.rs` measures it on the simulator's wind (400 trials
//! per speed, RMS across the wire): at 3 m/s the swing is 6.1 mm about the captures' centre;
//! the true angle, rate and wind at the last capture predict it to 1.4 mm 0.5 s ahead but
//! 4.2 mm 1 s ahead; a sine at the pendulum's exact frequency fitted to six captures, or
//! `c + k u^2` on the anemometer's readings, is no better than the centre from 0.5 s on
//! (5.5-6.1 mm against 6.0 mm); ten captures a second gain under 10 % (5.5 against 6.1 mm).

use nalgebra::{Point3, Vector3};

use super::cylinder::Cylinder;

/// Offsets' standard deviation below which the captures show no sway beyond the fit's own
/// scatter (m): the axis point of a single capture scatters by about 0.3 mm at 0.5 m.
pub const STILL_SPREAD_M: f64 = 0.0015;

/// Lower 5 % points of chi-square with 1..=9 degrees of freedom.
const CHI2_LOWER_5: [f64; 9] = [
    0.0039, 0.1026, 0.3518, 0.7107, 1.1455, 1.6354, 2.1673, 2.7326, 3.3251,
];

/// The sway seen in a series of captures (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct SwayTrack {
    /// Unit horizontal direction across the wire the conductor swings along (`base_link`).
    pub direction: Vector3<f64>,
    /// Each capture's offset from the centre along [`Self::direction`] (m), in capture order.
    pub offsets_m: Vec<f64>,
    /// The offsets' sample standard deviation (m; 0 for one capture).
    pub spread_m: f64,
    /// 1-sigma of the centre along [`Self::direction`] (m).
    pub centre_sigma_m: f64,
    /// Half-width of the band the wire swings in, bounded from above at 95 % (m).
    pub envelope_m: f64,
    /// Each capture's vertical offset from the centre (m).
    pub vertical_offsets_m: Vec<f64>,
    /// The vertical offsets' sample standard deviation (m).
    pub vertical_spread_m: f64,
    /// Half-width of the vertical band, bounded from above at 95 % (m).
    pub vertical_envelope_m: f64,
}

impl SwayTrack {
    /// Whether the captures show a swing beyond the fit's scatter ([`STILL_SPREAD_M`]),
    /// horizontally or vertically.
    #[must_use]
    pub fn is_swaying(&self) -> bool {
        self.spread_m.max(self.vertical_spread_m) > STILL_SPREAD_M
    }
}

/// The horizontal direction across an axis of direction `a` (`base_link`, z up); `None` for
/// a vertical axis.
#[must_use]
pub fn sway_direction(a: &Vector3<f64>) -> Option<Vector3<f64>> {
    Vector3::z().cross(a).try_normalize(1e-9)
}

/// Tracks the sway of `axes` (one per capture, `base_link`) about their mean point nearest
/// `near` (module docs). `None` without an axis or for a vertical one.
#[must_use]
pub fn track_sway(axes: &[Cylinder], near: &Point3<f64>) -> Option<SwayTrack> {
    let first = axes.first()?;
    let direction = sway_direction(&first.direction)?;
    let points: Vec<Vector3<f64>> = axes
        .iter()
        .map(|a| a.axis_point_nearest(near).coords)
        .collect();
    let n = points.len() as f64;
    let mean = points.iter().sum::<Vector3<f64>>() / n;
    let up = first.direction.cross(&direction).normalize();
    let up = if up.z < 0.0 { -up } else { up };
    let offsets_m: Vec<f64> = points.iter().map(|p| (p - mean).dot(&direction)).collect();
    let vertical_offsets_m: Vec<f64> = points.iter().map(|p| (p - mean).dot(&up)).collect();
    let (spread_m, envelope_m) = band(&offsets_m);
    let (vertical_spread_m, vertical_envelope_m) = band(&vertical_offsets_m);
    Some(SwayTrack {
        direction,
        spread_m,
        centre_sigma_m: spread_m / n.sqrt(),
        envelope_m,
        offsets_m,
        vertical_offsets_m,
        vertical_spread_m,
        vertical_envelope_m,
    })
}

/// The sample standard deviation of zero-mean `offsets` and the 95 % upper bound of the
/// amplitude of a sinusoid they sample (module docs), never below the largest offset.
fn band(offsets: &[f64]) -> (f64, f64) {
    let dof = offsets.len().saturating_sub(1);
    if dof == 0 {
        return (0.0, 0.0);
    }
    let spread = (offsets.iter().map(|d| d * d).sum::<f64>() / dof as f64).sqrt();
    let chi2 = match dof {
        1..=9 => CHI2_LOWER_5[dof - 1],
        // Wilson-Hilferty: chi2_p(k) = k (1 - 2/(9k) + z_p sqrt(2/(9k)))^3, z_0.05 = -1.645.
        k => {
            let k = k as f64;
            k * (1.0 - 2.0 / (9.0 * k) - 1.645 * (2.0 / (9.0 * k)).sqrt()).powi(3)
        }
    };
    let largest = offsets.iter().fold(0.0_f64, |m, d| m.max(d.abs()));
    let bound = std::f64::consts::SQRT_2 * spread * (dof as f64 / chi2).sqrt();
    (spread, bound.max(largest))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn axis_at(y: f64, z: f64) -> Cylinder {
        Cylinder {
            point: Point3::new(0.3, y, z),
            direction: Vector3::x(),
            radius_m: 0.0134,
        }
    }

    #[test]
    fn a_still_wire_shows_no_sway() {
        let axes: Vec<Cylinder> = [0.0, 0.0002, -0.0003]
            .iter()
            .map(|&e| axis_at(0.1 + e, 0.5 - e))
            .collect();
        let t = track_sway(&axes, &Point3::new(0.0, 0.1, 0.5)).expect("track");
        assert!(!t.is_swaying(), "{t:?}");
        assert!(
            t.envelope_m < 0.002 && t.vertical_envelope_m < 0.002,
            "{t:?}"
        );
        assert!((t.direction.abs() - Vector3::y()).norm() < 1e-12);
    }

    #[test]
    fn a_swinging_wire_is_bounded_by_its_band_and_centred() {
        // A 12 mm swing of period 1.6 s sampled once a second, about y = 0.2.
        let amplitude = 0.012;
        let omega = std::f64::consts::TAU / 1.6;
        let axes: Vec<Cylinder> = (0..5)
            .map(|k| axis_at(0.2 + amplitude * (omega * k as f64 + 0.4).sin(), 0.5))
            .collect();
        let t = track_sway(&axes, &Point3::new(0.0, 0.2, 0.5)).expect("track");
        assert!(t.is_swaying());
        assert!(
            t.envelope_m >= amplitude,
            "band {} below the swing",
            t.envelope_m
        );
        assert!(t.envelope_m < 4.0 * amplitude, "band {}", t.envelope_m);
        let mean: f64 = t.offsets_m.iter().sum();
        assert!(mean.abs() < 1e-12);
        assert!(t.vertical_envelope_m < 1e-12, "a horizontal swing: {t:?}");
        assert!(t.centre_sigma_m < amplitude / 2.0, "{t:?}");
    }

    #[test]
    fn the_band_covers_the_swing_in_most_series() {
        // Random phases: the 95 % bound holds in (about) 95 % of the series of 5 captures.
        let amplitude = 0.01;
        let mut covered = 0;
        let trials = 400;
        let mut r = rng::SplitMix64::new(0x5A7);
        for _ in 0..trials {
            let axes: Vec<Cylinder> = (0..5)
                .map(|_| axis_at(amplitude * r.uniform(0.0, std::f64::consts::TAU).sin(), 0.5))
                .collect();
            let t = track_sway(&axes, &Point3::new(0.0, 0.0, 0.5)).expect("track");
            covered += usize::from(t.envelope_m >= amplitude);
        }
        let rate = covered as f64 / trials as f64;
        assert!((0.9..=1.0).contains(&rate), "covered {rate}");
    }

    #[test]
    fn no_track_without_axes_or_for_a_vertical_axis() {
        assert!(track_sway(&[], &Point3::origin()).is_none());
        let vertical = Cylinder {
            point: Point3::origin(),
            direction: Vector3::z(),
            radius_m: 0.01,
        };
        assert!(track_sway(&[vertical], &Point3::origin()).is_none());
    }
}
