//! Scenario files: `recordings/scenarios/NAME.toml`, the full description of one simulated
//! run (seed, hour of day, wind, camera-mount bump, robot and camera options, timed
//! commands).
//!
//! ```toml
//! name = "calib-18"           # required
//! seed = 18                   # every random process of the world derives from it
//! duration_s = 60.0           # robot time to run (required)
//! hour = 10.5                 # local solar hour at t = 0 (advances with the robot clock)
//! task = "none"               # for the task stages: none | calibrate | hang | remove
//! description = "..."
//!
//! [wind]                      # "wind" = 3-s mean speed (DESIGN.md s6)
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
//!
//! [parameters]                # stage parameters, not read by the simulator
//!
//! [[command]]                 # played by the `script` stage (control crate)
//! t_s = 1.0
//! kind = "joints"             # joints | lift | base | clamp | capture
//! values = [0.0, 0.3, 1.2, 0.0, 1.57, 0.0]
//! duration_s = 3.0            # joints only: requested time_from_start (0 = as fast as allowed)
//! ```
//!
//! Command `values`: `joints` 6 angles (rad, J1..J6); `lift` height (m); `base` `x_m, y_m,
//! yaw_rad` in `map`; `clamp` `action` (0 open, 1 close, 2 stop) and optionally
//! `max_torque_nm`; `capture` none.
//!
//! Overrides (`--set key=value`): dotted keys into the sections above (`robot.perturbation=
//! false`, `camera.scale=0.25`, `hour=18.5`, `seed=3`); values are parsed as TOML (a bare
//! word is a string). Keys of other top-level names (stage parameters) are returned to the
//! caller untouched.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::SimError;

/// Top-level keys the simulator reads.
const TOP_SCALARS: [&str; 6] = ["name", "seed", "duration_s", "hour", "task", "description"];
/// Sections the simulator reads.
const SECTIONS: [&str; 5] = ["wind", "bump", "robot", "camera", "panoramic"];
/// Other top-level entries allowed in a scenario file.
const OTHER_TOP: [&str; 2] = ["parameters", "command"];

/// Default arm pose at t = 0 (rad): elbow up, tool pointing forward and slightly down.
pub const DEFAULT_HOME_RAD: [f64; 6] = [0.0, 0.3, 1.9, 0.0, std::f64::consts::FRAC_PI_2, 0.0];
/// Default true mount translation `tool0_from_camera` (m): the robot model's nominal mount
/// ([`robot::camera_mount::NOMINAL_MOUNT_XYZ_M`]).
pub const DEFAULT_MOUNT_XYZ_M: [f64; 3] = robot::camera_mount::NOMINAL_MOUNT_XYZ_M;
/// Default true mount rotation (roll, pitch, yaw about fixed x, y, z; deg): the robot model's
/// nominal mount ([`robot::camera_mount::NOMINAL_MOUNT_RPY_DEG`]).
pub const DEFAULT_MOUNT_RPY_DEG: [f64; 3] = robot::camera_mount::NOMINAL_MOUNT_RPY_DEG;

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
}

/// Panoramic camera settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PanoramicConfig {
    /// Period (s); 0 switches the camera off. Default 1.0 (<= 1 Hz).
    pub period_s: f64,
    /// Resolution factor of 640x360. Default 0.5.
    pub scale: f64,
}

/// One `[[command]]` entry: plain data for the `script` stage (the CLI converts it to
/// `control::script::ScriptCommand`; sim never depends on control).
#[derive(Debug, Clone, PartialEq)]
pub struct ScenarioCommand {
    /// When to publish it (s of robot time).
    pub t_s: f64,
    /// `joints`, `lift`, `base`, `clamp` or `capture`.
    pub kind: String,
    /// Numbers of the command (see the module docs).
    pub values: Vec<f64>,
    /// Requested duration (s), joints only; 0 = as fast as the limits allow.
    pub duration_s: f64,
}

/// A parsed, validated scenario.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    /// Name.
    pub name: String,
    /// Seed of every random process.
    pub seed: u64,
    /// Robot time to run (s).
    pub duration_s: f64,
    /// Local solar hour at t = 0.
    pub hour: f64,
    /// Task for the task stages (`none` by default).
    pub task: String,
    /// Free text.
    pub description: String,
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
    /// Timed commands, in file order.
    pub commands: Vec<ScenarioCommand>,
    table: toml::Table,
    origin: String,
}

fn field(origin: &str, key: &str, reason: impl Into<String>) -> SimError {
    SimError::ScenarioField {
        origin: origin.to_owned(),
        key: key.to_owned(),
        reason: reason.into(),
    }
}

struct Section<'a> {
    origin: &'a str,
    name: &'a str,
    table: Option<&'a toml::Table>,
}

impl Section<'_> {
    fn key(&self, k: &str) -> String {
        if self.name.is_empty() {
            k.to_owned()
        } else {
            format!("{}.{k}", self.name)
        }
    }

    fn check_keys(&self, allowed: &[&str]) -> Result<(), SimError> {
        if let Some(t) = self.table {
            for k in t.keys() {
                if !allowed.contains(&k.as_str()) {
                    return Err(field(
                        self.origin,
                        &self.key(k),
                        format!("unknown key (allowed: {})", allowed.join(", ")),
                    ));
                }
            }
        }
        Ok(())
    }

    fn get(&self, k: &str) -> Option<&toml::Value> {
        self.table.and_then(|t| t.get(k))
    }

    fn f64_opt(&self, k: &str) -> Result<Option<f64>, SimError> {
        match self.get(k) {
            None => Ok(None),
            Some(toml::Value::Float(f)) if f.is_finite() => Ok(Some(*f)),
            Some(toml::Value::Integer(i)) => Ok(Some(*i as f64)),
            Some(v) => Err(field(
                self.origin,
                &self.key(k),
                format!("expected a finite number, got {v}"),
            )),
        }
    }

    fn f64_or(&self, k: &str, default: f64) -> Result<f64, SimError> {
        Ok(self.f64_opt(k)?.unwrap_or(default))
    }

    fn f64_in(&self, k: &str, default: f64, lo: f64, hi: f64) -> Result<f64, SimError> {
        let v = self.f64_or(k, default)?;
        if (lo..=hi).contains(&v) {
            Ok(v)
        } else {
            Err(field(
                self.origin,
                &self.key(k),
                format!("{v} is outside [{lo}, {hi}]"),
            ))
        }
    }

    fn bool_or(&self, k: &str, default: bool) -> Result<bool, SimError> {
        match self.get(k) {
            None => Ok(default),
            Some(toml::Value::Boolean(b)) => Ok(*b),
            Some(v) => Err(field(
                self.origin,
                &self.key(k),
                format!("expected true or false, got {v}"),
            )),
        }
    }

    fn str_or(&self, k: &str, default: &str) -> Result<String, SimError> {
        match self.get(k) {
            None => Ok(default.to_owned()),
            Some(toml::Value::String(s)) => Ok(s.clone()),
            Some(v) => Err(field(
                self.origin,
                &self.key(k),
                format!("expected a string, got {v}"),
            )),
        }
    }

    fn array_or<const N: usize>(&self, k: &str, default: [f64; N]) -> Result<[f64; N], SimError> {
        match self.get(k) {
            None => Ok(default),
            Some(toml::Value::Array(a)) => {
                let v = numbers(a)
                    .ok_or_else(|| field(self.origin, &self.key(k), "expected finite numbers"))?;
                <[f64; N]>::try_from(v.as_slice()).map_err(|_| {
                    field(
                        self.origin,
                        &self.key(k),
                        format!("expected {N} numbers, got {}", v.len()),
                    )
                })
            }
            Some(v) => Err(field(
                self.origin,
                &self.key(k),
                format!("expected an array of {N} numbers, got {v}"),
            )),
        }
    }
}

fn numbers(a: &[toml::Value]) -> Option<Vec<f64>> {
    a.iter()
        .map(|v| match v {
            toml::Value::Float(f) if f.is_finite() => Some(*f),
            toml::Value::Integer(i) => Some(*i as f64),
            _ => None,
        })
        .collect()
}

fn sub<'a>(
    origin: &'a str,
    table: &'a toml::Table,
    name: &'a str,
) -> Result<Section<'a>, SimError> {
    match table.get(name) {
        None => Ok(Section {
            origin,
            name,
            table: None,
        }),
        Some(toml::Value::Table(t)) => Ok(Section {
            origin,
            name,
            table: Some(t),
        }),
        Some(_) => Err(field(origin, name, "must be a table")),
    }
}

/// Number of values each command kind takes: `(min, max)`.
#[must_use]
pub fn command_arity(kind: &str) -> Option<(usize, usize)> {
    match kind {
        "joints" => Some((6, 6)),
        "lift" => Some((1, 1)),
        "base" => Some((3, 3)),
        "clamp" => Some((1, 2)),
        "capture" => Some((0, 0)),
        _ => None,
    }
}

/// Parses a `--set` value: TOML if it parses, else the bare text as a string.
fn parse_value(text: &str) -> toml::Value {
    let text = text.trim();
    match format!("v = {text}").parse::<toml::Table>() {
        Ok(mut t) => t
            .remove("v")
            .unwrap_or_else(|| toml::Value::String(text.to_owned())),
        Err(_) => toml::Value::String(text.to_owned()),
    }
}

impl Scenario {
    /// Parses scenario TOML text; `origin` names it in errors.
    ///
    /// # Errors
    /// [`SimError::ScenarioToml`], [`SimError::ScenarioField`] (unknown keys in the
    /// simulator's sections are errors, so typos do not pass silently).
    pub fn parse(text: &str, origin: &str) -> Result<Self, SimError> {
        let table: toml::Table =
            text.parse()
                .map_err(|e: toml::de::Error| SimError::ScenarioToml {
                    origin: origin.to_owned(),
                    reason: e.message().to_owned(),
                })?;
        Self::from_table(table, origin)
    }

    /// Builds from a TOML table (validated as [`Scenario::parse`] does).
    ///
    /// # Errors
    /// [`SimError::ScenarioField`].
    pub fn from_table(table: toml::Table, origin: &str) -> Result<Self, SimError> {
        let top = Section {
            origin,
            name: "",
            table: Some(&table),
        };
        let allowed: Vec<&str> = TOP_SCALARS
            .iter()
            .chain(&SECTIONS)
            .chain(&OTHER_TOP)
            .copied()
            .collect();
        top.check_keys(&allowed)?;
        let name = top.str_or("name", "")?;
        if name.is_empty() {
            return Err(field(origin, "name", "missing or empty"));
        }
        let seed = match table.get("seed") {
            None => 0,
            Some(toml::Value::Integer(i)) => {
                u64::try_from(*i).map_err(|_| field(origin, "seed", "must be >= 0"))?
            }
            Some(v) => {
                return Err(field(
                    origin,
                    "seed",
                    format!("expected an integer, got {v}"),
                ));
            }
        };
        let duration_s = top
            .f64_opt("duration_s")?
            .ok_or_else(|| field(origin, "duration_s", "missing"))?;
        if !(0.0..=86_400.0).contains(&duration_s) {
            return Err(field(
                origin,
                "duration_s",
                format!("{duration_s} is outside [0, 86400]"),
            ));
        }
        let hour = top.f64_in("hour", 12.0, 0.0, 24.0)?;
        let task = top.str_or("task", "none")?;
        let description = top.str_or("description", "")?;

        let w = sub(origin, &table, "wind")?;
        w.check_keys(&["mean_mps", "gust_mps", "direction_deg"])?;
        let mean_mps = w.f64_in("mean_mps", 0.0, 0.0, 40.0)?;
        let wind = WindConfig {
            mean_mps,
            gust_mps: w.f64_in("gust_mps", 0.3 * mean_mps, 0.0, 20.0)?,
            direction_deg: w.f64_or("direction_deg", 90.0)?,
        };

        let b = sub(origin, &table, "bump")?;
        b.check_keys(&["enabled", "time_s", "rot_deg", "trans_mm"])?;
        let bump = if b.table.is_some() && b.bool_or("enabled", true)? {
            let time_s = b.f64_opt("time_s")?;
            if let Some(t) = time_s.filter(|t| !(0.0..=duration_s).contains(t)) {
                return Err(field(
                    origin,
                    "bump.time_s",
                    format!("{t} is outside [0, duration_s = {duration_s}]"),
                ));
            }
            let rot_deg = b.f64_opt("rot_deg")?;
            let trans_mm = b.f64_opt("trans_mm")?;
            for (k, v, max) in [
                ("bump.rot_deg", rot_deg, 45.0),
                ("bump.trans_mm", trans_mm, 200.0),
            ] {
                if let Some(v) = v.filter(|v| !(0.0..=max).contains(v)) {
                    return Err(field(origin, k, format!("{v} is outside [0, {max}]")));
                }
            }
            Some(BumpConfig {
                time_s,
                rot_deg,
                trans_mm,
            })
        } else {
            None
        };

        let r = sub(origin, &table, "robot")?;
        r.check_keys(&[
            "perturbation",
            "encoder_noise",
            "encoder_noise_rad",
            "home_rad",
            "lift_m",
            "odometry_drift",
            "base_start",
            "rod",
        ])?;
        let robot = RobotConfig {
            perturbation: r.bool_or("perturbation", true)?,
            encoder_noise: r.bool_or("encoder_noise", true)?,
            encoder_noise_rad: r.f64_in("encoder_noise_rad", 5e-5, 0.0, 0.1)?,
            home_rad: r.array_or("home_rad", DEFAULT_HOME_RAD)?,
            lift_m: r.f64_in("lift_m", 0.0, 0.0, robot::kinematics::LIFT_TRAVEL_M)?,
            odometry_drift: r.bool_or("odometry_drift", true)?,
            base_start: match r.get("base_start") {
                None => None,
                Some(_) => Some(r.array_or("base_start", [0.0; 3])?),
            },
            rod: match r.str_or("rod", "rack")?.as_str() {
                "rack" => RodStart::Rack,
                "hung" => RodStart::Hung,
                other => {
                    return Err(field(
                        origin,
                        "robot.rod",
                        format!("{other:?}: expected \"rack\" or \"hung\""),
                    ));
                }
            },
        };
        let limits = robot::aubo_i10::aubo_i10_limits();
        for (i, (q, l)) in robot.home_rad.iter().zip(&limits).enumerate() {
            if !l.contains(*q) {
                return Err(field(
                    origin,
                    "robot.home_rad",
                    format!("joint {} = {q} rad is outside its limits", i + 1),
                ));
            }
        }

        let c = sub(origin, &table, "camera")?;
        c.check_keys(&[
            "scale",
            "depth_encoding",
            "capture_s",
            "exposure_delay_s",
            "mount_xyz_m",
            "mount_rpy_deg",
        ])?;
        let depth_encoding = match c.str_or("depth_encoding", "32FC1")?.as_str() {
            "32FC1" => DepthEncoding::Float32Metres,
            "16UC1" => DepthEncoding::U16Millimetres,
            other => {
                return Err(field(
                    origin,
                    "camera.depth_encoding",
                    format!("{other:?}: expected \"32FC1\" or \"16UC1\""),
                ));
            }
        };
        let capture_s = c.f64_in("capture_s", 1.0, 0.001, 60.0)?;
        let camera = CameraConfig {
            scale: c.f64_in("scale", 1.0, 0.01, 2.0)?,
            depth_encoding,
            capture_s,
            exposure_delay_s: c.f64_in("exposure_delay_s", 0.01, 0.0, capture_s)?,
            mount_xyz_m: c.array_or("mount_xyz_m", DEFAULT_MOUNT_XYZ_M)?,
            mount_rpy_deg: c.array_or("mount_rpy_deg", DEFAULT_MOUNT_RPY_DEG)?,
        };

        let p = sub(origin, &table, "panoramic")?;
        p.check_keys(&["period_s", "scale"])?;
        let period_s = p.f64_in("period_s", 1.0, 0.0, 3600.0)?;
        if period_s > 0.0 && period_s < 1.0 {
            return Err(field(
                origin,
                "panoramic.period_s",
                format!("{period_s} s: the panoramic camera runs at <= 1 Hz"),
            ));
        }
        let panoramic = PanoramicConfig {
            period_s,
            scale: p.f64_in("scale", 0.5, 0.01, 2.0)?,
        };

        let commands = match table.get("command") {
            None => Vec::new(),
            Some(toml::Value::Array(items)) => items
                .iter()
                .enumerate()
                .map(|(i, v)| parse_command(origin, i, v))
                .collect::<Result<Vec<_>, _>>()?,
            Some(_) => {
                return Err(field(
                    origin,
                    "command",
                    "must be an array of tables ([[command]])",
                ));
            }
        };
        if table.get("parameters").is_some_and(|v| !v.is_table()) {
            return Err(field(origin, "parameters", "must be a table"));
        }
        Ok(Self {
            name,
            seed,
            duration_s,
            hour,
            task,
            description,
            wind,
            bump,
            robot,
            camera,
            panoramic,
            commands,
            table,
            origin: origin.to_owned(),
        })
    }

    /// Reads a scenario file.
    ///
    /// # Errors
    /// [`SimError::ScenarioRead`] and those of [`Scenario::parse`].
    pub fn from_file(path: &Path) -> Result<Self, SimError> {
        let text = std::fs::read_to_string(path).map_err(|e| SimError::ScenarioRead {
            path: path.to_path_buf(),
            reason: e.to_string(),
        })?;
        Self::parse(&text, &path.display().to_string())
    }

    /// The directories searched for scenario names: `recordings/scenarios` under the current
    /// directory, then the workspace's (compile-time path).
    #[must_use]
    pub fn search_dirs() -> Vec<PathBuf> {
        vec![
            PathBuf::from("recordings/scenarios"),
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../recordings/scenarios"),
        ]
    }

    /// Loads `path_or_name`: an existing file, else `NAME.toml` in [`Scenario::search_dirs`].
    ///
    /// # Errors
    /// [`SimError::ScenarioNotFound`] and those of [`Scenario::from_file`].
    pub fn load(path_or_name: &str) -> Result<Self, SimError> {
        let direct = PathBuf::from(path_or_name);
        if direct.is_file() {
            return Self::from_file(&direct);
        }
        let mut tried = vec![direct];
        for dir in Self::search_dirs() {
            let candidate = dir.join(format!("{path_or_name}.toml"));
            if candidate.is_file() {
                return Self::from_file(&candidate);
            }
            tried.push(candidate);
        }
        Err(SimError::ScenarioNotFound {
            name: path_or_name.to_owned(),
            tried,
        })
    }

    /// Applies `--set key=value` overrides to the simulator's keys (top-level `name`, `seed`,
    /// `duration_s`, `hour`, `task`, `description` and the sections `wind`, `bump`, `robot`,
    /// `camera`, `panoramic`) and re-validates. Returns the keys that are not the
    /// simulator's (stage parameters), in order, for the caller to route elsewhere.
    ///
    /// # Errors
    /// [`SimError::ScenarioField`] for an invalid result (unknown key in a simulator
    /// section, wrong type, out of range); `self` is unchanged then.
    pub fn apply_overrides(
        &mut self,
        overrides: &[(String, String)],
    ) -> Result<Vec<String>, SimError> {
        let mut table = self.table.clone();
        let mut foreign = Vec::new();
        for (key, value) in overrides {
            let parts: Vec<&str> = key.trim().split('.').collect();
            let Some((first, rest)) = parts.split_first() else {
                foreign.push(key.clone());
                continue;
            };
            let mine = (rest.is_empty() && TOP_SCALARS.contains(first))
                || (!rest.is_empty() && SECTIONS.contains(first));
            if !mine {
                foreign.push(key.clone());
                continue;
            }
            set_dotted(&mut table, &parts, parse_value(value))
                .map_err(|reason| field(&self.origin, key, reason))?;
        }
        let origin = format!("{} (with --set)", self.origin);
        *self = Self::from_table(table, &origin)?;
        Ok(foreign)
    }

    /// The resolved scenario as TOML text (after overrides; keys sorted). The top-level
    /// scalars (`name`, `seed`, `duration_s`, `hour`, `task`) are written from the fields, so
    /// a caller that sets `scenario.seed` directly (`--seed`) is reflected; change the
    /// sections through [`Scenario::apply_overrides`].
    #[must_use]
    pub fn resolved_toml(&self) -> String {
        let mut t = self.table.clone();
        t.insert("name".to_owned(), toml::Value::String(self.name.clone()));
        t.insert(
            "seed".to_owned(),
            toml::Value::Integer(i64::try_from(self.seed).unwrap_or(i64::MAX)),
        );
        t.insert("duration_s".to_owned(), toml::Value::Float(self.duration_s));
        t.insert("hour".to_owned(), toml::Value::Float(self.hour));
        t.insert("task".to_owned(), toml::Value::String(self.task.clone()));
        t.to_string()
    }

    /// The `scenario` metadata record: `name`, `seed`, `duration_s`, `hour`, `task`, `origin`
    /// and `resolved_toml` (the full resolved text, from which the run can be re-created).
    #[must_use]
    pub fn to_metadata(&self) -> BTreeMap<String, String> {
        let mut m = BTreeMap::new();
        m.insert("name".to_owned(), self.name.clone());
        m.insert("seed".to_owned(), self.seed.to_string());
        m.insert("duration_s".to_owned(), format!("{:?}", self.duration_s));
        m.insert("hour".to_owned(), format!("{:?}", self.hour));
        m.insert("task".to_owned(), self.task.clone());
        m.insert("origin".to_owned(), self.origin.clone());
        m.insert("resolved_toml".to_owned(), self.resolved_toml());
        m
    }
}

fn set_dotted(table: &mut toml::Table, parts: &[&str], value: toml::Value) -> Result<(), String> {
    match parts {
        [] => Err("empty key".to_owned()),
        [last] => {
            table.insert((*last).to_owned(), value);
            Ok(())
        }
        [first, rest @ ..] => {
            let entry = table
                .entry((*first).to_owned())
                .or_insert_with(|| toml::Value::Table(toml::Table::new()));
            match entry {
                toml::Value::Table(t) => set_dotted(t, rest, value),
                other => Err(format!("{first} is {other}, not a table")),
            }
        }
    }
}

fn parse_command(origin: &str, index: usize, v: &toml::Value) -> Result<ScenarioCommand, SimError> {
    let name = format!("command[{index}]");
    let toml::Value::Table(t) = v else {
        return Err(field(origin, &name, "must be a table"));
    };
    let s = Section {
        origin,
        name: &name,
        table: Some(t),
    };
    s.check_keys(&["t_s", "kind", "values", "duration_s"])?;
    let t_s = s
        .f64_opt("t_s")?
        .ok_or_else(|| field(origin, &s.key("t_s"), "missing"))?;
    if t_s < 0.0 {
        return Err(field(origin, &s.key("t_s"), format!("{t_s} is negative")));
    }
    let kind = s.str_or("kind", "")?;
    let Some((lo, hi)) = command_arity(&kind) else {
        return Err(field(
            origin,
            &s.key("kind"),
            format!("{kind:?}: expected joints, lift, base, clamp or capture"),
        ));
    };
    let values = match t.get("values") {
        None => Vec::new(),
        Some(toml::Value::Array(a)) => {
            numbers(a).ok_or_else(|| field(origin, &s.key("values"), "expected finite numbers"))?
        }
        Some(v) => {
            return Err(field(
                origin,
                &s.key("values"),
                format!("expected an array, got {v}"),
            ));
        }
    };
    if values.len() < lo || values.len() > hi {
        return Err(field(
            origin,
            &s.key("values"),
            format!("{kind} takes {lo}..={hi} values, got {}", values.len()),
        ));
    }
    let duration_s = s.f64_in("duration_s", 0.0, 0.0, 3600.0)?;
    Ok(ScenarioCommand {
        t_s,
        kind,
        values,
        duration_s,
    })
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
perturbation = true
[[command]]
t_s = 1.0
kind = "joints"
values = [0, 0.3, 1.2, 0, 1.57, 0]
duration_s = 2
[[command]]
t_s = 3.5
kind = "capture"
"#;

    #[test]
    fn parses_defaults_and_overrides() -> Result<(), SimError> {
        let mut s = Scenario::parse(TEXT, "t.toml")?;
        assert_eq!(s.seed, 3);
        assert!((s.wind.gust_mps - 0.6).abs() < 1e-12);
        assert_eq!(s.bump.map(|b| b.time_s), Some(Some(5.0)));
        assert_eq!(s.commands.len(), 2);
        let foreign = s.apply_overrides(&[
            ("robot.perturbation".into(), "false".into()),
            ("camera.scale".into(), "0.25".into()),
            ("camera.depth_encoding".into(), "16UC1".into()),
            ("calib.method".into(), "zhi".into()),
            ("seed".into(), "9".into()),
        ])?;
        assert_eq!(foreign, vec!["calib.method".to_owned()]);
        assert!(!s.robot.perturbation);
        assert_eq!(s.camera.scale, 0.25);
        assert_eq!(s.camera.depth_encoding, DepthEncoding::U16Millimetres);
        assert_eq!(s.seed, 9);
        let meta = s.to_metadata();
        assert_eq!(meta.get("seed").map(String::as_str), Some("9"));
        let back = Scenario::parse(meta.get("resolved_toml").map_or("", |s| s.as_str()), "meta")?;
        assert_eq!(back.robot, s.robot);
        assert_eq!(back.commands, s.commands);
        Ok(())
    }

    #[test]
    fn typos_and_bad_values_are_errors() -> Result<(), SimError> {
        let mut s = Scenario::parse(TEXT, "t.toml")?;
        let before = s.clone();
        assert!(
            s.apply_overrides(&[("robot.perturbaton".into(), "false".into())])
                .is_err()
        );
        assert!(
            s.apply_overrides(&[("camera.scale".into(), "-1".into())])
                .is_err()
        );
        assert_eq!(s, before);
        let bad_kind = TEXT.replace("\"capture\"", "\"grab\"");
        assert!(
            matches!(Scenario::parse(&bad_kind, "x"), Err(SimError::ScenarioField { key, .. }) if key == "command[1].kind")
        );
        let bad_arity = TEXT.replace("[0, 0.3, 1.2, 0, 1.57, 0]", "[0, 0.3]");
        assert!(Scenario::parse(&bad_arity, "x").is_err());
        assert!(Scenario::parse("name = \"n\"", "x").is_err());
        assert!(Scenario::parse("duration_s = 1", "x").is_err());
        assert!(Scenario::parse("name = \"n\"\nduration_s = 1\nhuor = 3", "x").is_err());
        Ok(())
    }
}
