//! Wind, its effect on wire and platform, daylight, and the robot's environment sensors
//! (anemometer, lux meter).
//!
//! # Wind
//! Instantaneous horizontal speed `u(t)` (m/s) along a fixed direction: an Ornstein-Uhlenbeck
//! process around the scenario mean, stepped every [`WIND_STEP_S`]:
//! `u_{k+1} = m + (u_k - m) a + g sqrt(1 - a^2) n_k`, `a = exp(-dt / tau)`, `tau` =
//! [`WIND_TAU_S`], `g` = gust 1-sigma, `n_k` seeded normals; `u >= 0`. "Wind" everywhere
//! means the **3-s mean** of `u` (ARCHITECTURE.md section 6); gusts above it are normal.
//!
//! # Sway
//! Each conductor swings rigidly about its chord (a pendulum of effective length 0.8 sag):
//! `th'' + 2 z w th' + w^2 th = w^2 th_eq`, `w = sqrt(g / (0.8 sag))`, `z` =
//! [`WIRE_DAMPING`], `th_eq = atan(q)` with `q = 0.5 rho Cd d u_perp |u_perp| / (m g)` the drag
//! per weight of the 26.8 mm conductor (rho 1.225 kg/m^3, Cd 1.0, 1.6 kg/m), `u_perp` the
//! wind component across the wire. At 2 m/s the lowest point moves ~4 mm, at 10 m/s ~0.1 m.
//! The lift column tilts about its foot, perpendicular to the wind, with the same oscillator
//! form (1.5 Hz, damping 0.15) towards `phi_eq = K_PLATFORM u |u| (0.5 + 0.5 lift/travel)`,
//! [`PLATFORM_TILT_PER_MPS2`] (0.06 deg at 2 m/s fully raised: ~3 mm at the arm base).
//! Both integrate with semi-implicit Euler at the world tick (1 ms).
//!
//! # Light
//! [`LightConditions::from_hour`] of `hour + t / 3600` (the renderer's model: 100 klx noon,
//! 400 lx sunset, 3 lx end of civil twilight).
//!
//! # Sensors (1 Hz)
//! * Anemometer (`/env/wind`, producer `anemometer`): the 3-s mean of `u` ending at the
//!   sample time (so it lags the instantaneous wind by 1.5 s on average) plus Gaussian noise
//!   of 1-sigma `0.05 m/s + 2 %` of the reading ([`ANEMOMETER_SIGMA_MPS`],
//!   [`ANEMOMETER_SIGMA_REL`]); unbiased except where clipped at 0.
//! * Lux meter (`/env/illuminance`, producer `lux_meter`): global horizontal illuminance with
//!   Gaussian noise of 1-sigma `3 %` + 0.05 lx ([`LUX_SIGMA_REL`], [`LUX_SIGMA_LX`]), clipped at
//!   0; `variance` carries that sigma squared.

use msgs::RobotTime;
use msgs::drivers::{DriverError, EnvironmentSensors};
use msgs::sensor_msgs::Illuminance;
use msgs::std_msgs::{Float64, Header};
use nalgebra::Vector3;

use crate::config::WindConfig;
use crate::render::LightConditions;
use crate::rng::{self, streams};

/// Wind process step (s).
pub const WIND_STEP_S: f64 = 0.01;
/// Wind process step (ns).
pub const WIND_STEP_NS: u64 = 10_000_000;
/// Correlation time of the turbulence (s).
pub const WIND_TAU_S: f64 = 3.0;
/// Samples in the 3-s mean.
pub const WIND_WINDOW: usize = 300;
/// Conductor drag per weight per (m/s)^2: `0.5 * 1.225 * 1.0 * 0.0268 / (1.6 * 9.81)`.
pub const WIRE_DRAG_PER_MPS2: f64 = 0.5 * 1.225 * 1.0 * 0.0268 / (1.6 * 9.81);
/// Damping ratio of the wire swing.
pub const WIRE_DAMPING: f64 = 0.05;
/// Platform tilt per (m/s)^2 at full lift (rad).
pub const PLATFORM_TILT_PER_MPS2: f64 = 2.5e-4;
/// Platform natural frequency (rad/s): 1.5 Hz.
pub const PLATFORM_OMEGA_RAD_S: f64 = 1.5 * std::f64::consts::TAU;
/// Platform damping ratio.
pub const PLATFORM_DAMPING: f64 = 0.15;
/// Anemometer noise, absolute part (m/s, 1-sigma).
pub const ANEMOMETER_SIGMA_MPS: f64 = 0.05;
/// Anemometer noise, relative part (1-sigma).
pub const ANEMOMETER_SIGMA_REL: f64 = 0.02;
/// Lux meter noise, relative part (1-sigma).
pub const LUX_SIGMA_REL: f64 = 0.03;
/// Lux meter noise, absolute part (lx, 1-sigma).
pub const LUX_SIGMA_LX: f64 = 0.05;
/// Producer of `/env/wind`.
pub const ANEMOMETER: &str = "anemometer";
/// Producer of `/env/illuminance`.
pub const LUX_METER: &str = "lux_meter";

/// A damped second-order system driven towards a target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Oscillator {
    /// Natural frequency (rad/s).
    pub omega_rad_s: f64,
    /// Damping ratio.
    pub damping: f64,
    /// Position.
    pub x: f64,
    /// Velocity.
    pub v: f64,
}

impl Oscillator {
    /// One semi-implicit Euler step of `dt_s` towards `target`.
    pub fn step(&mut self, dt_s: f64, target: f64) {
        let w = self.omega_rad_s;
        let a = w * w * (target - self.x) - 2.0 * self.damping * w * self.v;
        self.v += a * dt_s;
        self.x += self.v * dt_s;
    }
}

/// The wind process and the sway it causes.
#[derive(Debug, Clone)]
pub struct Wind {
    seed: u64,
    config: WindConfig,
    /// Unit direction the wind blows towards (map, horizontal).
    direction: Vector3<f64>,
    u_mps: f64,
    ring: Vec<f64>,
    ring_next: usize,
    step_index: u64,
    wire: Oscillator,
    platform: Oscillator,
}

impl Wind {
    /// The process for `config`, pre-run for one window so the 3-s mean is defined at t = 0;
    /// wire and platform start at their equilibrium for the wind at t = 0. `sag_m` sets the
    /// wire's swing frequency, `lift_fraction` (in [0, 1]) the platform's compliance.
    #[must_use]
    pub fn new(seed: u64, config: WindConfig, sag_m: f64, lift_fraction: f64) -> Self {
        let d = config.direction_deg.to_radians();
        let omega_wire = (9.81 / (0.8 * sag_m.max(0.05))).sqrt();
        let mut w = Self {
            seed,
            config,
            direction: Vector3::new(d.cos(), d.sin(), 0.0),
            u_mps: (config.mean_mps + config.gust_mps * rng::normal(seed, streams::WIND, u64::MAX))
                .max(0.0),
            ring: vec![0.0; WIND_WINDOW],
            ring_next: 0,
            step_index: 0,
            wire: Oscillator {
                omega_rad_s: omega_wire,
                damping: WIRE_DAMPING,
                x: 0.0,
                v: 0.0,
            },
            platform: Oscillator {
                omega_rad_s: PLATFORM_OMEGA_RAD_S,
                damping: PLATFORM_DAMPING,
                x: 0.0,
                v: 0.0,
            },
        };
        for _ in 0..WIND_WINDOW {
            w.step_turbulence();
        }
        let q = w.wire_drag_ratio();
        w.wire.x = q.atan();
        w.platform.x = w.platform_target(lift_fraction);
        w
    }

    fn step_turbulence(&mut self) {
        let a = (-WIND_STEP_S / WIND_TAU_S).exp();
        let n = rng::normal(self.seed, streams::WIND, self.step_index);
        let m = self.config.mean_mps;
        self.u_mps =
            (m + (self.u_mps - m) * a + self.config.gust_mps * (1.0 - a * a).sqrt() * n).max(0.0);
        if let Some(slot) = self.ring.get_mut(self.ring_next) {
            *slot = self.u_mps;
        }
        self.ring_next = (self.ring_next + 1) % WIND_WINDOW;
        self.step_index += 1;
    }

    fn wire_drag_ratio(&self) -> f64 {
        let u_perp = self.u_mps * self.direction.y; // conductors run along x
        WIRE_DRAG_PER_MPS2 * u_perp * u_perp.abs()
    }

    /// Advances by one world tick of `dt_s`; `tick_ns` is the tick's end time (the
    /// turbulence steps on multiples of [`WIND_STEP_NS`]). `lift_fraction` in [0, 1].
    pub fn tick(&mut self, dt_s: f64, tick_ns: u64, lift_fraction: f64) {
        if tick_ns.is_multiple_of(WIND_STEP_NS) {
            self.step_turbulence();
        }
        self.wire.step(dt_s, self.wire_drag_ratio().atan());
        let target = self.platform_target(lift_fraction);
        self.platform.step(dt_s, target);
    }

    fn platform_target(&self, lift_fraction: f64) -> f64 {
        PLATFORM_TILT_PER_MPS2
            * self.u_mps
            * self.u_mps
            * (0.5 + 0.5 * lift_fraction.clamp(0.0, 1.0))
    }

    /// Instantaneous speed (m/s).
    #[must_use]
    pub fn speed_mps(&self) -> f64 {
        self.u_mps
    }

    /// The 3-s mean speed ending now (m/s): "the wind".
    #[must_use]
    pub fn mean_3s_mps(&self) -> f64 {
        self.ring.iter().sum::<f64>() / WIND_WINDOW as f64
    }

    /// Unit direction the wind blows towards (map).
    #[must_use]
    pub fn direction(&self) -> Vector3<f64> {
        self.direction
    }

    /// Wire swing about the chord (rad, right-handed about +x: positive moves the wire
    /// towards +y).
    #[must_use]
    pub fn wire_sway_rad(&self) -> f64 {
        self.wire.x
    }

    /// Platform tilt (rad) about `z x direction` (leaning downwind).
    #[must_use]
    pub fn platform_tilt_rad(&self) -> f64 {
        self.platform.x
    }
}

/// Daylight at robot time `t`, starting at local solar hour `hour`.
#[must_use]
pub fn light_at(hour: f64, t: RobotTime) -> LightConditions {
    LightConditions::from_hour(hour + t.as_secs_f64() / 3600.0)
}

/// The anemometer and lux meter ([`EnvironmentSensors`]) reading a shared [`Wind`] snapshot.
#[derive(Debug, Clone)]
pub struct EnvironmentSim {
    seed: u64,
    hour: f64,
    /// The latest 3-s mean wind the world fed in (m/s).
    pub wind_mean_3s_mps: f64,
}

impl EnvironmentSim {
    /// Sensors for a seed and the start hour.
    #[must_use]
    pub fn new(seed: u64, hour: f64) -> Self {
        Self {
            seed,
            hour,
            wind_mean_3s_mps: 0.0,
        }
    }

    /// True global horizontal illuminance at `now` (lx).
    #[must_use]
    pub fn true_lux(&self, now: RobotTime) -> f64 {
        light_at(self.hour, now).horizontal_lux()
    }
}

fn header(now: RobotTime, frame_id: &str) -> Result<Header, DriverError> {
    let stamp = now.to_ros().map_err(|e| DriverError::Fault {
        device: "environment".to_owned(),
        now,
        reason: e.to_string(),
    })?;
    Ok(Header {
        stamp,
        frame_id: frame_id.to_owned(),
    })
}

impl EnvironmentSensors for EnvironmentSim {
    fn wind_mps(&mut self, now: RobotTime) -> Result<Float64, DriverError> {
        let m = self.wind_mean_3s_mps;
        let sigma = ANEMOMETER_SIGMA_MPS + ANEMOMETER_SIGMA_REL * m;
        let n = rng::normal(self.seed, streams::ANEMOMETER, now.as_nanos());
        Ok(Float64 {
            data: (m + sigma * n).max(0.0),
        })
    }

    fn illuminance(&mut self, now: RobotTime) -> Result<Illuminance, DriverError> {
        let e = self.true_lux(now);
        let sigma = LUX_SIGMA_REL * e + LUX_SIGMA_LX;
        let n = rng::normal(self.seed, streams::LUX_METER, now.as_nanos());
        Ok(Illuminance {
            header: header(now, msgs::frames::BASE_LINK)?,
            illuminance: (e + sigma * n).max(0.0),
            variance: sigma * sigma,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wind_mean_matches_the_configured_mean_and_gusts_exceed_it() {
        let cfg = WindConfig {
            mean_mps: 2.0,
            gust_mps: 0.6,
            direction_deg: 90.0,
        };
        let mut w = Wind::new(5, cfg, 0.9, 1.0);
        let (mut sum, mut n, mut max_u) = (0.0, 0, 0.0_f64);
        for k in 1..=600_000u64 {
            w.tick(0.001, k * 1_000_000, 1.0);
            if k % 1000 == 0 {
                sum += w.mean_3s_mps();
                n += 1;
            }
            max_u = max_u.max(w.speed_mps());
        }
        let mean = sum / f64::from(n);
        assert!((mean - 2.0).abs() < 0.15, "{mean}");
        assert!(max_u > 3.0, "gusts above the mean: {max_u}");
        assert!(w.wire_sway_rad().abs() < 0.05);
    }

    #[test]
    fn sensors_are_unbiased_within_their_documented_error() -> Result<(), DriverError> {
        let mut s = EnvironmentSim::new(3, 12.0);
        s.wind_mean_3s_mps = 2.0;
        let n = 4000u64;
        let (mut ew, mut el) = (0.0, 0.0);
        let truth = s.true_lux(RobotTime::ZERO);
        for k in 0..n {
            let t = RobotTime::from_millis(k);
            ew += s.wind_mps(t)?.data - 2.0;
            el += (s.illuminance(t)?.illuminance - s.true_lux(t)) / truth;
        }
        let sw = ANEMOMETER_SIGMA_MPS + ANEMOMETER_SIGMA_REL * 2.0;
        assert!(
            (ew / n as f64).abs() < 4.0 * sw / (n as f64).sqrt(),
            "wind bias {}",
            ew / n as f64
        );
        assert!(
            (el / n as f64).abs() < 4.0 * LUX_SIGMA_REL / (n as f64).sqrt(),
            "lux bias {}",
            el / n as f64
        );
        Ok(())
    }
}
