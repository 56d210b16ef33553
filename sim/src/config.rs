//! The simulator's configuration, [`SimConfig`], read from a scenario's parameters: hour of
//! day, wind, camera-mount bump, robot and camera options. Each key is declared through a
//! [`scenario::Reader`] with its default and unit (`rodlog params NAME` lists them):
//!
//! ```toml
//! hour = 10.5                 # local solar hour at t = 0 (advances with the robot clock)
//! noise_seed = 7              # seed of what differs from one run to the next on the same robot
//!                             # and bay (sensor noise, encoders, odometry, gusts); default `seed`
//!
//! [wind]                      # "wind" = 3-s mean speed
//! mean_mps = 1.5              # default 0
//! gust_mps = 0.5              # 1-sigma of the turbulence around the mean, default 0.3 mean
//! direction_deg = 0.0         # direction the wind blows towards, from +x (east), ccw
//!
//! [bump]                      # camera-mount bump; absent = none
//! time_s = 30.0               # default: seeded in [0.2, 0.8] duration
//! rot_deg = 2.0               # default: seeded in [1, 3] deg
//! trans_mm = 5.0              # default: seeded in [3, 10] mm
//!
//! [robot]
//! perturbation = true         # seeded DH perturbation of the true arm
//! encoder_noise = true        # Gaussian encoder noise
//! encoder_noise_rad = 5e-5    # its 1-sigma
//! home_rad = [..6 values..]   # arm joints at t = 0
//! lift_m = 0.0                # lift at t = 0
//! odometry_drift = true
//! base_start = [12.0, -3.9, 1.5708]  # base pose at t = 0 (map x, y, yaw); default the working spot
//! rod = "rack"                # the rod at t = 0: "rack" (stored) or "hung" (clamped on the
//!                             # target wire at the hanging point, as a hang leaves it)
//!
//! [camera]                    # wrist RGB-D camera
//! scale = 1.0                 # 0.25 -> 320x256
//! depth_encoding = "32FC1"    # or "16UC1"
//! capture_s = 1.0             # request -> images available
//! exposure_delay_s = 0.01     # request -> exposure (header.stamp)
//! mount_xyz_m = [...]         # true tool0_from_camera at t = 0 (before any bump)
//! mount_rpy_deg = [...]
//!
//! [panoramic]
//! period_s = 1.0              # 0 = off
//! scale = 0.5                 # of 640x360
//! ```
//!
//! The scenario file itself (name, seed, duration, commands) is the `scenario` crate's; the
//! composition root checks that every key of a scenario is consumed by some part.

use scenario::{ParamError, Reader};

/// Wind settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WindConfig {
    /// Mean of the 3-s mean wind speed (m/s). Default 0.
    pub mean_mps: f64,
    /// 1-sigma turbulence around it (m/s). Default `0.3 mean_mps`.
    pub gust_mps: f64,
    /// Direction the wind blows towards, from +x (east) counter-clockwise (deg). Default 90
    /// (towards north, across the conductors).
    pub direction_deg: f64,
}

/// Camera-mount bump settings (`None` fields are drawn from the seed).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BumpConfig {
    /// When (s); default seeded in `[0.2, 0.8] duration_s`.
    pub time_s: Option<f64>,
    /// Rotation (deg); default seeded in `[1, 3]`.
    pub rot_deg: Option<f64>,
    /// Translation (mm); default seeded in `[3, 10]`.
    pub trans_mm: Option<f64>,
}

/// Robot settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RobotConfig {
    /// Seeded DH perturbation of the true arm. Default true.
    pub perturbation: bool,
    /// Encoder noise on arm, lift and clamp joint states. Default true.
    pub encoder_noise: bool,
    /// Arm encoder noise 1-sigma (rad). Default 5e-5.
    pub encoder_noise_rad: f64,
    /// Arm joints at t = 0 (rad). Default [`DEFAULT_HOME_RAD`].
    pub home_rad: [f64; 6],
    /// Lift at t = 0 (m). Default 0.
    pub lift_m: f64,
    /// Odometry drift noise. Default true.
    pub odometry_drift: bool,
    /// Base pose at t = 0 (`map` x, y in m, yaw in rad). Default `None`: the working spot.
    pub base_start: Option<[f64; 3]>,
    /// Where the rod is at t = 0. Default on the rack.
    pub rod: RodStart,
}

/// Where the grounding rod is at t = 0.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RodStart {
    /// Stored on the rack.
    Rack,
    /// Clamped on the target wire at the hanging point, hook mouth facing away from the
    /// working spot (as the hang flow leaves it).
    Hung,
}

/// Depth image encoding of the wrist camera.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DepthEncoding {
    /// `32FC1`, metres, NaN = no data.
    Float32Metres,
    /// `16UC1`, millimetres, 0 = no data.
    U16Millimetres,
}

/// Wrist camera settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraConfig {
    /// Resolution factor of 1280x1024. Default 1.
    pub scale: f64,
    /// Depth encoding. Default `32FC1`.
    pub depth_encoding: DepthEncoding,
    /// Request -> images available (s). Default 1.0.
    pub capture_s: f64,
    /// Request -> exposure (s), the images' stamp. Default 0.01.
    pub exposure_delay_s: f64,
    /// True mount translation (m). Default [`DEFAULT_MOUNT_XYZ_M`].
    pub mount_xyz_m: [f64; 3],
    /// True mount rotation, roll-pitch-yaw (deg). Default [`DEFAULT_MOUNT_RPY_DEG`].
    pub mount_rpy_deg: [f64; 3],
    /// The published `camera_info` is a calibration of the true intrinsics, with a real
    /// calibration's error (`crate::cameras::calibrated`); false publishes the truth.
    /// Default true.
    pub info_error: bool,
    /// A wrist light beside the lens (`crate::wrist_light`). Default false.
    pub light: bool,
}

/// Panoramic camera settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PanoramicConfig {
    /// Period (s); 0 switches the camera off. Default 1.0 (<= 1 Hz).
    pub period_s: f64,
    /// Resolution factor of 640x360. Default 0.5.
    pub scale: f64,
    /// As [`CameraConfig::info_error`], for the panoramic camera. Default true.
    pub info_error: bool,
}

/// Default arm pose at t = 0 (rad): elbow up, tool pointing forward and slightly down.
pub const DEFAULT_HOME_RAD: [f64; 6] = [0.0, 0.3, 1.9, 0.0, std::f64::consts::FRAC_PI_2, 0.0];
/// Default true mount translation `tool0_from_camera` (m): the robot model's nominal mount
/// ([`robot::camera_mount::NOMINAL_MOUNT_XYZ_M`]).
pub const DEFAULT_MOUNT_XYZ_M: [f64; 3] = robot::camera_mount::NOMINAL_MOUNT_XYZ_M;
/// Default true mount rotation (roll, pitch, yaw about fixed x, y, z; deg): the robot model's
/// nominal mount ([`robot::camera_mount::NOMINAL_MOUNT_RPY_DEG`]).
pub const DEFAULT_MOUNT_RPY_DEG: [f64; 3] = robot::camera_mount::NOMINAL_MOUNT_RPY_DEG;

/// The simulator's configuration (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct SimConfig {
    /// Seed of the world: the bay, the true arm's DH perturbation, the cameras' calibration
    /// errors, the bump.
    pub seed: u64,
    /// Seed of what differs from one run to the next on the same robot and bay: camera and
    /// encoder noise, odometry drift, the wind's gusts (`noise_seed`, default `seed`). Two runs
    /// with one `seed` and different `noise_seed`s are two days of the same robot at the same
    /// bay.
    pub noise_seed: u64,
    /// Robot time to run (s).
    pub duration_s: f64,
    /// Local solar hour at t = 0.
    pub hour: f64,
    /// Wind.
    pub wind: WindConfig,
    /// Bump, if any.
    pub bump: Option<BumpConfig>,
    /// Robot.
    pub robot: RobotConfig,
    /// Wrist camera.
    pub camera: CameraConfig,
    /// Panoramic camera.
    pub panoramic: PanoramicConfig,
    /// The bay's geometry: the fixed default bay, or one drawn from the seed.
    pub site_layout: SiteLayout,
}

/// Which bay the world builds (scenario `site.layout`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SiteLayout {
    /// The default bay of [`crate::scene::SubstationParams::default`] (the committed golden
    /// recordings, and every run the robot's built-in site map describes exactly).
    Fixed,
    /// A bay drawn from the seed ([`crate::scene::SubstationParams::seeded`]): conductor
    /// height and sag, phase spacing, the working position along the span and beside the
    /// phase, the cabinet and rack placements.
    Seeded,
}

fn invalid(key: &str, value: impl std::fmt::Display, reason: impl Into<String>) -> ParamError {
    ParamError::Value {
        key: key.to_owned(),
        value: value.to_string(),
        reason: reason.into(),
    }
}

impl SimConfig {
    /// Reads the simulator's keys (module docs) through `r`, for a run of `duration_s` with
    /// `seed`.
    ///
    /// # Errors
    /// [`ParamError::Value`] for a wrong type or an out-of-range value, naming the key.
    pub fn from_params(r: &mut Reader<'_>, seed: u64, duration_s: f64) -> Result<Self, ParamError> {
        let hour = r.section("").f64_in(
            "hour",
            12.0,
            0.0..=24.0,
            "h",
            "local solar hour at t = 0 (advances with the robot clock)",
        )?;
        let noise_seed = r.section("").u64(
            "noise_seed",
            seed,
            "",
            "seed of what differs from run to run on the same robot and bay: sensor and encoder noise, odometry drift, the wind's gusts (default: the scenario's seed)",
        )?;

        let mut w = r.section("wind");
        let mean_mps = w.f64_in(
            "mean_mps",
            0.0,
            0.0..=40.0,
            "m/s",
            "mean of the 3-s mean wind speed",
        )?;
        let wind = WindConfig {
            mean_mps,
            gust_mps: w.f64_in(
                "gust_mps",
                0.3 * mean_mps,
                0.0..=20.0,
                "m/s",
                "1-sigma turbulence around the mean (default 0.3 mean_mps)",
            )?,
            direction_deg: w.f64(
                "direction_deg",
                90.0,
                "deg",
                "direction the wind blows towards, from +x (east) counter-clockwise",
            )?,
        };

        let mut b = r.section("bump");
        let bump_present =
            b.present("a camera-mount bump (an empty [bump] draws every value from the seed)");
        let enabled = b.bool("enabled", true, "the bump happens (with [bump] present)")?;
        let time_s = b.f64_opt(
            "time_s",
            "seeded in [0.2, 0.8] duration",
            "s",
            "when the mount is knocked",
        )?;
        let rot_deg = b.f64_opt(
            "rot_deg",
            "seeded in [1, 3]",
            "deg",
            "rotation of the knock",
        )?;
        let trans_mm = b.f64_opt(
            "trans_mm",
            "seeded in [3, 10]",
            "mm",
            "translation of the knock",
        )?;
        if let Some(t) = time_s.filter(|t| !(0.0..=duration_s).contains(t)) {
            return Err(invalid(
                "bump.time_s",
                t,
                format!("outside [0, duration_s = {duration_s}]"),
            ));
        }
        for (k, v, max) in [
            ("bump.rot_deg", rot_deg, 45.0),
            ("bump.trans_mm", trans_mm, 200.0),
        ] {
            if let Some(v) = v.filter(|v| !(0.0..=max).contains(v)) {
                return Err(invalid(k, v, format!("outside [0, {max}]")));
            }
        }
        let bump = (bump_present && enabled).then_some(BumpConfig {
            time_s,
            rot_deg,
            trans_mm,
        });

        let mut rs = r.section("robot");
        let robot = RobotConfig {
            perturbation: rs.bool(
                "perturbation",
                true,
                "seeded DH perturbation of the true arm",
            )?,
            encoder_noise: rs.bool(
                "encoder_noise",
                true,
                "Gaussian noise on arm, lift and clamp encoders",
            )?,
            encoder_noise_rad: rs.f64_in(
                "encoder_noise_rad",
                5e-5,
                0.0..=0.1,
                "rad",
                "arm encoder noise, 1-sigma",
            )?,
            home_rad: rs.f64s("home_rad", DEFAULT_HOME_RAD, "rad", "arm joints at t = 0")?,
            lift_m: rs.f64_in(
                "lift_m",
                0.0,
                0.0..=robot::kinematics::LIFT_TRAVEL_M,
                "m",
                "lift height at t = 0",
            )?,
            odometry_drift: rs.bool("odometry_drift", true, "odometry drift noise of the base")?,
            base_start: rs.f64s_opt(
                "base_start",
                "the working spot",
                "m, m, rad",
                "base pose at t = 0: map x, y, yaw",
            )?,
            rod: match rs
                .choice(
                    "rod",
                    "rack",
                    &["rack", "hung"],
                    "the rod at t = 0: stored on the rack, or hung on the wire",
                )?
                .as_str()
            {
                "hung" => RodStart::Hung,
                _ => RodStart::Rack,
            },
        };
        let limits = robot::aubo_i10::aubo_i10_limits();
        for (i, (q, l)) in robot.home_rad.iter().zip(&limits).enumerate() {
            if !l.contains(*q) {
                return Err(invalid(
                    "robot.home_rad",
                    q,
                    format!("joint {} is outside its limits", i + 1),
                ));
            }
        }

        let mut c = r.section("camera");
        let depth_encoding = match c
            .choice(
                "depth_encoding",
                "32FC1",
                &["32FC1", "16UC1"],
                "depth image encoding: metres as float, or millimetres",
            )?
            .as_str()
        {
            "16UC1" => DepthEncoding::U16Millimetres,
            _ => DepthEncoding::Float32Metres,
        };
        let scale = c.f64_in(
            "scale",
            1.0,
            0.01..=2.0,
            "",
            "resolution factor of 1280x1024",
        )?;
        let capture_s = c.f64_in(
            "capture_s",
            1.0,
            0.001..=60.0,
            "s",
            "capture request -> images available",
        )?;
        let camera = CameraConfig {
            scale,
            depth_encoding,
            capture_s,
            exposure_delay_s: c.f64_in(
                "exposure_delay_s",
                0.01,
                0.0..=capture_s,
                "s",
                "capture request -> exposure (the images' stamp)",
            )?,
            mount_xyz_m: c.f64s(
                "mount_xyz_m",
                DEFAULT_MOUNT_XYZ_M,
                "m",
                "true tool0_from_camera translation at t = 0",
            )?,
            mount_rpy_deg: c.f64s(
                "mount_rpy_deg",
                DEFAULT_MOUNT_RPY_DEG,
                "deg",
                "true tool0_from_camera roll, pitch, yaw at t = 0",
            )?,
            info_error: c.bool(
                "info_error",
                true,
                "the published camera_info carries a calibration's error (fx, fy ~0.3%, principal point ~2 px, distortion); false publishes the true intrinsics (accuracy tests of the hand-eye alone)",
            )?,
            light: c.bool(
                "light",
                false,
                "the robot has a dimmable LED wrist light beside the lens (/wrist_light/command, /wrist_light/state)",
            )?,
        };

        let mut p = r.section("panoramic");
        let period_s = p.f64_in(
            "period_s",
            1.0,
            0.0..=3600.0,
            "s",
            "panoramic frame period (0 = off, else >= 1)",
        )?;
        if period_s > 0.0 && period_s < 1.0 {
            return Err(invalid(
                "panoramic.period_s",
                period_s,
                "the panoramic camera runs at <= 1 Hz",
            ));
        }
        let panoramic = PanoramicConfig {
            period_s,
            scale: p.f64_in("scale", 0.5, 0.01..=2.0, "", "resolution factor of 640x360")?,
            info_error: p.bool(
                "info_error",
                true,
                "the published panoramic camera_info carries a calibration's error; false publishes the truth",
            )?,
        };
        let site_layout = match r
            .section("site")
            .choice(
                "layout",
                "fixed",
                &["fixed", "seeded"],
                "the bay: the fixed default bay, or one drawn from the seed (conductor height, sag, phase spacing, working position, cabinet and rack placement)",
            )?
            .as_str()
        {
            "seeded" => SiteLayout::Seeded,
            _ => SiteLayout::Fixed,
        };
        Ok(Self {
            seed,
            noise_seed,
            duration_s,
            site_layout,
            hour,
            wind,
            bump,
            robot,
            camera,
            panoramic,
        })
    }

    /// The simulator's part of `scenario`, for the simulator's own tests and examples: the
    /// other keys are left alone (the composition root is what rejects unconsumed keys).
    ///
    /// # Errors
    /// Those of [`SimConfig::from_params`].
    pub fn of_scenario(scenario: &scenario::Scenario) -> Result<Self, ParamError> {
        let mut r = Reader::new(&scenario.params);
        Self::from_params(&mut r, scenario.seed, scenario.duration.as_secs_f64())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = r#"
name = "t"
seed = 3
duration_s = 10
hour = 17.5
[wind]
mean_mps = 2.0
[bump]
time_s = 5.0
[robot]
perturbation = false
[camera]
depth_encoding = "16UC1"
[parameters]
task.standoff_m = 0.5
"#;

    fn config(text: &str) -> Result<SimConfig, Box<dyn std::error::Error>> {
        let s = scenario::Scenario::parse(text, "t.toml")?;
        Ok(SimConfig::of_scenario(&s)?)
    }

    #[test]
    fn reads_values_and_defaults() -> Result<(), Box<dyn std::error::Error>> {
        let c = config(TEXT)?;
        assert_eq!(c.seed, 3);
        assert_eq!(c.noise_seed, 3, "noise_seed defaults to the seed");
        assert_eq!(config(&format!("noise_seed = 11\n{TEXT}"))?.noise_seed, 11);
        assert_eq!(c.hour, 17.5);
        assert!((c.wind.gust_mps - 0.6).abs() < 1e-12);
        assert_eq!(c.bump.map(|b| b.time_s), Some(Some(5.0)));
        assert!(!c.robot.perturbation && c.robot.encoder_noise);
        assert_eq!(c.camera.depth_encoding, DepthEncoding::U16Millimetres);
        assert_eq!(c.panoramic.period_s, 1.0);
        assert!(
            config("name = \"n\"\nduration_s = 1\n[bump]\n")?
                .bump
                .is_some()
        );
        assert!(config("name = \"n\"\nduration_s = 1\n")?.bump.is_none());
        Ok(())
    }

    #[test]
    fn only_the_simulators_keys_are_declared() -> Result<(), Box<dyn std::error::Error>> {
        let s = scenario::Scenario::parse(TEXT, "t.toml")?;
        let mut r = Reader::new(&s.params);
        SimConfig::from_params(&mut r, s.seed, 10.0)?;
        let left: Vec<String> = r.problems().iter().map(|p| p.key().to_owned()).collect();
        assert_eq!(left, vec!["task.standoff_m".to_owned()]);
        Ok(())
    }

    #[test]
    fn bad_values_name_their_key() {
        for (text, key) in [
            ("[robot]\nperturbation = 3", "robot.perturbation"),
            ("[camera]\nscale = -1", "camera.scale"),
            (
                "[camera]\ndepth_encoding = \"8UC1\"",
                "camera.depth_encoding",
            ),
            ("[bump]\ntime_s = 99", "bump.time_s"),
            ("[panoramic]\nperiod_s = 0.5", "panoramic.period_s"),
            ("hour = 25", "hour"),
            ("[robot]\nhome_rad = [0, 0]", "robot.home_rad"),
        ] {
            let text = format!("name = \"n\"\nduration_s = 10\n{text}");
            let err = config(&text)
                .err()
                .map(|e| e.to_string())
                .unwrap_or_default();
            assert!(err.contains(key), "{text}: {err}");
        }
    }
}
