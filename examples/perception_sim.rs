//! Wire perception against the simulator.
//!
//! `cargo run --release --example perception_sim [-- SCENES [SCALE [all|handle]]]` runs the
//! full protocol (default 100 seeded scenes at full wrist resolution) in three light
//! conditions plus a wash-out stress condition, then the handle check on as many scenes,
//! and prints the table; `tests/perception_sim.rs` runs a quick version of the same code.
//!
//! # Protocol (per seed `s` and condition)
//! 1. Build the substation with seed `s`; draw a span fraction in `[0.3, 0.7]` of the target
//!    conductor from the seed: the true hanging location `w` with tangent `t`.
//! 2. The prior (what the panoramic stage gives): `w` moved by up to [`PRIOR_OFFSET_M`] in
//!    each axis, its direction tilted by up to [`PRIOR_TILT_DEG`].
//! 3. The robot side: the arm base with the lift raised, above the robot spot (height drawn
//!    from [`ARM_BASE_HEIGHT_RANGE_M`]). Captures: `wrist_look_pose(prior, robot, standoff)` with a
//!    standoff in `[0.3, 0.6]` m, each capture moved by a few mm and rolled/tilted by a few
//!    degrees (the arm re-positions between captures).
//! 4. Render RGB-D (`render_rgbd_with_rays`, wrist sensor model) at an hour drawn from the
//!    condition's range; turn the frame into `sensor_msgs/Image` (32FC1) and `CameraInfo`
//!    through the camera driver's own functions (`sim::cameras`), and back through
//!    `CameraModel::from_camera_info` / `DepthImage::from_image` (the message seam).
//! 5. ROI = the prior segment (±0.25 m) projected into the image with a margin;
//!    `detect_wire` per capture, `estimate_wire` over the captures (map frame, poses
//!    known), near point = the prior, robot point as in 3.
//! 6. Errors against the analytic catenary: hanging point to the axis (`closest_point`),
//!    split into across-wire (perpendicular to the axis and to the approach) and
//!    along-approach components; angle between the fitted and true axis (deg).
//!
//! A seed draws the same scene, prior and camera poses in every condition (only the hour and
//! the sensor's wash-out differ), so the conditions are paired.
//!
//! Handle ([`run_handle_trial`]): the rod hung on the target conductor (remove flow), its
//! handle fitted with `HandleModel::default()`; centre and axis errors against the
//! simulator's rod.
//!
//! Refusals (`PerceptionError`) are counted per condition, never dropped silently; the hook
//! window (±15 mm across, ±10 mm along the approach, ARCHITECTURE.md section 6) is checked on every
//! accepted estimate.

use anyhow::Context as _;
use control::perception::colour::LumaImage;
use control::perception::confidence::ConfidenceThresholds;
use control::perception::point_cloud::{CameraModel, DepthImage, RayTable};
use control::perception::roi::{PixelRoi, wrist_look_pose};
use control::perception::wire::{WireObservation, WireParams, detect_wire, estimate_wire};
use control::perception::{PerceptionError, WIRE_RADIUS_M};
use msgs::std_msgs::Header;
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use rng::SplitMix64;
use sim::cameras::{color_image, depth_image};
use sim::config::DepthEncoding;
use sim::render::{LightConditions, SensorParams, render_rgbd_with_rays, wrist_camera};
use sim::scene::substation::SubstationBuilder;

/// Range of the height above the ground of the point the camera looks from (m), drawn per
/// seed: the robot side of the approach. The wire hangs at ~3.7-3.9 m, 1.3 m north of the
/// robot spot, so the camera looks at it from level (the task's look, `control::tasks::poses`)
/// to 50 deg below the horizontal, from the south: at noon the sun (62 deg high, due south)
/// lights the part of the conductor the camera sees when the view is flat (depth wash-out),
/// and not when it looks up steeply.
pub const ARM_BASE_HEIGHT_RANGE_M: (f64, f64) = (2.2, 3.8);
/// Largest prior offset per axis (m): the panoramic stage is a few cm off.
pub const PRIOR_OFFSET_M: f64 = 0.03;
/// Largest tilt of the prior direction (deg).
pub const PRIOR_TILT_DEG: f64 = 3.0;
/// Half-length of the prior segment projected into the image (m).
pub const PRIOR_HALF_LENGTH_M: f64 = 0.25;
/// ROI margin around the projected prior (m at the wire, turned into pixels per capture).
pub const ROI_MARGIN_M: f64 = 0.06;
/// Working distance range of the wrist camera (m), ARCHITECTURE.md section 6.
pub const STANDOFF_RANGE_M: (f64, f64) = (0.3, 0.6);
/// Hook capture window across the wire (m), ARCHITECTURE.md section 6.
pub const HOOK_ACROSS_M: f64 = 0.015;
/// Hook capture window along the approach (m), ARCHITECTURE.md section 6.
pub const HOOK_APPROACH_M: f64 = 0.010;

/// A light condition: a name and the range of hours drawn from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Condition {
    /// Table label.
    pub name: &'static str,
    /// Hours `[lo, hi]` (local solar time).
    pub hours: (f64, f64),
    /// Depth wash-out override `(start lx, full lx, max probability)`; `None` = the wrist
    /// sensor's defaults (50 klx, 90 klx, 0.9).
    pub washout: Option<(f64, f64, f64)>,
    /// The wrist light is on (full brightness, `sim::render::Lamp::wrist`).
    pub wrist_light: bool,
}

/// Daylight, hour 11.
pub const DAYLIGHT: Condition = Condition {
    name: "daylight 11:00",
    hours: (11.0, 11.0),
    washout: None,
    wrist_light: false,
};
/// Sunset, 18:00: ~400 lx (ARCHITECTURE.md section 6; `sim::render::light`).
pub const DUSK_400LX: Condition = Condition {
    name: "dusk 18:00 (400 lx)",
    hours: (18.0, 18.0),
    washout: None,
    wrist_light: false,
};
/// End of civil twilight: sun 6 deg below the horizon at hour
/// `6 + 12 (1 + asin(6/62) / pi)` = 18.37, ~3 lx.
pub const DUSK_3LX: Condition = Condition {
    name: "dusk 18:22 (3 lx)",
    hours: (18.37, 18.37),
    washout: None,
    wrist_light: false,
};
/// Night, 19:00 (0.4 lx), lit by the wrist light.
pub const NIGHT_LIT: Condition = Condition {
    name: "night 19:00, wrist light",
    hours: (19.0, 19.0),
    washout: None,
    wrist_light: true,
};
/// Strong sun (depth wash-out), 12:00-13:00.
pub const STRONG_SUN: Condition = Condition {
    name: "strong sun 12-13",
    hours: (12.0, 13.0),
    washout: None,
    wrist_light: false,
};
/// Stress: strong sun on a sensor whose pattern washes out at half the illuminance and
/// almost surely (20 klx -> 45 klx, up to 0.98): shows that the confidence refuses before
/// the errors leave the hook window.
pub const HARSH_SUN: Condition = Condition {
    name: "harsh sun 12-13 (stress)",
    hours: (12.0, 13.0),
    washout: Some((20_000.0, 45_000.0, 0.98)),
    wrist_light: false,
};

/// Settings of one run.
#[derive(Debug, Clone)]
pub struct Protocol {
    /// Wrist camera intrinsics (possibly scaled).
    pub intrinsics: CameraModel,
    /// Captures fused per estimate (2-3).
    pub captures: usize,
    /// Wire detection settings.
    pub wire: WireParams,
    /// Confidence thresholds.
    pub thresholds: ConfidenceThresholds,
    /// Depth encoding of the message seam.
    pub encoding: DepthEncoding,
}

impl Protocol {
    /// The wrist camera resampled by `scale` (1 = full resolution), 3 captures, defaults.
    ///
    /// # Errors
    /// Invalid scale.
    pub fn new(scale: f64) -> anyhow::Result<Self> {
        Ok(Self {
            intrinsics: wrist_camera().scaled(scale)?,
            captures: 3,
            wire: WireParams::default(),
            thresholds: ConfidenceThresholds::default(),
            encoding: DepthEncoding::Float32Metres,
        })
    }
}

/// The accepted estimate's errors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Errors {
    /// Distance from the hanging point to the true axis (m).
    pub hanging_m: f64,
    /// Component perpendicular to the axis and the approach (m, signed).
    pub across_m: f64,
    /// Component along the approach normal (m, signed, + toward the robot).
    pub approach_m: f64,
    /// Angle between the fitted and the true axis (deg).
    pub axis_deg: f64,
    /// Confidence score.
    pub score: f64,
    /// The factor that limited the score.
    pub limiting: &'static str,
    /// Valid depth fraction in the fitted silhouette (worst capture).
    pub valid_depth_fraction: f64,
    /// Colour contrast (step over spread) of the silhouette (worst capture).
    pub colour_contrast: f64,
}

impl Errors {
    /// Whether the hook would capture the wire.
    #[must_use]
    pub fn in_hook_window(&self) -> bool {
        self.across_m.abs() <= HOOK_ACROSS_M && self.approach_m.abs() <= HOOK_APPROACH_M
    }
}

/// One trial.
#[derive(Debug, Clone, PartialEq)]
pub struct Trial {
    /// Scene seed.
    pub seed: u64,
    /// Hour rendered.
    pub hour: f64,
    /// Errors, or why perception refused.
    pub outcome: Result<Errors, PerceptionError>,
}

/// Runs one seed in one condition.
///
/// # Errors
/// Simulator or camera-model failures (not perception refusals, which are outcomes).
pub fn run_trial(
    protocol: &Protocol,
    rays_sim: &sim::render::RayTable,
    seed: u64,
    condition: &Condition,
) -> anyhow::Result<Trial> {
    let (scene, layout) = SubstationBuilder::new(seed).build().context("substation")?;
    let conductor = layout.target_conductor().context("no target conductor")?;
    let mut rng = SplitMix64::new(seed ^ 0x11_5EED_0000);
    let u = conductor.span_m() * rng.uniform(0.3, 0.7);
    let wire_point = conductor.point_at(u);
    let wire_tangent = conductor.tangent_at(u);
    let prior_point = wire_point
        + Vector3::new(
            rng.uniform(-PRIOR_OFFSET_M, PRIOR_OFFSET_M),
            rng.uniform(-PRIOR_OFFSET_M, PRIOR_OFFSET_M),
            rng.uniform(-PRIOR_OFFSET_M, PRIOR_OFFSET_M),
        );
    let tilt = UnitQuaternion::from_scaled_axis(
        control::perception::synthetic::unit_vector(&mut rng)
            * PRIOR_TILT_DEG.to_radians()
            * rng.uniform(0.0, 1.0),
    );
    let prior_direction = tilt * wire_tangent;
    let spot = layout.world_from_robot_spot.translation.vector;
    let arm_height = rng.uniform(ARM_BASE_HEIGHT_RANGE_M.0, ARM_BASE_HEIGHT_RANGE_M.1);
    let robot_point = Point3::new(spot.x, spot.y, spot.z + arm_height);
    let standoff = rng.uniform(STANDOFF_RANGE_M.0, STANDOFF_RANGE_M.1);
    let look = wrist_look_pose(&prior_point, &prior_direction, &robot_point, standoff)?;
    let hour = rng.uniform(condition.hours.0, condition.hours.1.max(condition.hours.0));
    let light = LightConditions::from_hour(hour)
        .with_lamp(condition.wrist_light.then(|| sim::render::Lamp::wrist(1.0)));
    let mut sensor = SensorParams::wrist();
    if let Some((start, full, p_max)) = condition.washout {
        sensor.depth.sun_washout_start_lux = start;
        sensor.depth.sun_washout_full_lux = full;
        sensor.depth.sun_washout_max_probability = p_max;
    }
    let header = Header {
        frame_id: msgs::frames::CAMERA_COLOR_OPTICAL_FRAME.to_owned(),
        ..Header::default()
    };

    let mut observations: Vec<(WireObservation, Isometry3<f64>)> = Vec::new();
    let mut first_refusal = None;
    for k in 0..protocol.captures.max(1) {
        // The arm re-positions slightly between captures (the first is the nominal pose).
        let jitter = if k == 0 {
            Isometry3::identity()
        } else {
            Isometry3::from_parts(
                Translation3::from(control::perception::synthetic::unit_vector(&mut rng) * 0.005),
                UnitQuaternion::from_scaled_axis(
                    control::perception::synthetic::unit_vector(&mut rng) * 2f64.to_radians(),
                ),
            )
        };
        let world_from_camera = look * jitter;
        let frame = render_rgbd_with_rays(
            &scene,
            &world_from_camera,
            rays_sim,
            &light,
            &sensor,
            seed.wrapping_mul(31).wrapping_add(k as u64),
        );
        // The message seam, exactly as the camera driver publishes.
        let info = protocol.intrinsics.to_camera_info(header.clone());
        let image = depth_image(&frame, header.clone(), protocol.encoding);
        let camera = CameraModel::from_camera_info(&info)?;
        let depth = DepthImage::from_image(&image)?;
        let colour = LumaImage::from_image(&color_image(&frame, header.clone()))?;
        let rays = ray_table(&camera)?;
        let camera_from_world = world_from_camera.inverse();
        let p0 = camera_from_world * (prior_point - prior_direction * PRIOR_HALF_LENGTH_M);
        let p1 = camera_from_world * (prior_point + prior_direction * PRIOR_HALF_LENGTH_M);
        let margin_px = ROI_MARGIN_M * camera.fx / standoff;
        let roi = match PixelRoi::around_segment(&camera, &p0, &p1, margin_px, ROI_MARGIN_M) {
            Ok(r) => r,
            Err(e) => {
                first_refusal.get_or_insert(e);
                continue;
            }
        };
        match detect_wire(&depth, &rays, camera.fx, &roi, &protocol.wire) {
            Ok(o) => observations.push((o.confirm_in_colour(&colour, &camera), world_from_camera)),
            Err(e) => {
                first_refusal.get_or_insert(e);
            }
        }
    }
    if observations.is_empty() {
        return Ok(Trial {
            seed,
            hour,
            outcome: Err(first_refusal.unwrap_or(PerceptionError::NoCaptures)),
        });
    }
    let outcome = estimate_wire(
        &observations,
        &prior_point,
        &robot_point,
        WIRE_RADIUS_M,
        &protocol.thresholds,
    )
    .map(|est| {
        let h = est.hanging.point;
        let truth = conductor.closest_point(&h);
        let t = conductor.tangent_at(truth.u_m);
        let e = h - truth.point;
        let to_robot = robot_point - truth.point;
        let n = (to_robot - t * to_robot.dot(&t)).normalize();
        let across = t.cross(&n);
        let cos = est
            .axis_in_base
            .direction
            .normalize()
            .dot(&t)
            .abs()
            .min(1.0);
        Errors {
            hanging_m: truth.distance_m,
            across_m: e.dot(&across),
            approach_m: e.dot(&n),
            axis_deg: cos.acos().to_degrees(),
            score: est.confidence.score,
            limiting: est.confidence.limiting,
            valid_depth_fraction: est.metrics.valid_depth_fraction,
            colour_contrast: est.metrics.colour_contrast.unwrap_or(f64::NAN),
        }
    });
    Ok(Trial {
        seed,
        hour,
        outcome,
    })
}

/// The perception ray table of `camera`, cached across calls with the same camera.
fn ray_table(camera: &CameraModel) -> Result<std::sync::Arc<RayTable>, PerceptionError> {
    use std::sync::{Arc, Mutex};
    static CACHE: Mutex<Option<(CameraModel, Arc<RayTable>)>> = Mutex::new(None);
    let mut cache = CACHE
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    if let Some((c, r)) = cache.as_ref()
        && c == camera
    {
        return Ok(Arc::clone(r));
    }
    let rays = Arc::new(RayTable::new(camera)?);
    *cache = Some((*camera, Arc::clone(&rays)));
    Ok(rays)
}

/// Height of the arm base above the ground for the handle capture (m): the handle of a
/// hung rod is ~1.8 m below the wire, so ~1.9-2.1 m up.
pub const ARM_BASE_LOW_M: f64 = 1.4;
/// Standoff for the handle (m): the 0.25 m handle fills the 0.73 z wide view at z = 0.34 m,
/// so the handle is seen from 0.4-0.6 m.
pub const HANDLE_STANDOFF_RANGE_M: (f64, f64) = (0.4, 0.6);

/// Result of one handle trial: centre error (m), axis error (deg) and the colour contrast of
/// the silhouette, or the refusal.
pub type HandleOutcome = Result<(f64, f64, f64), PerceptionError>;

/// The rod hung on the target conductor (remove flow: hook centre on the wire axis at a
/// seeded span fraction, rod vertical), its handle seen from a standoff in
/// [`HANDLE_STANDOFF_RANGE_M`] at `hour`; the handle is fitted with `model` in the ROI of
/// its true segment (3 cm margin), confirmed in the colour image like the task does
/// (`HandleEstimate::confirm_in_colour`), and compared with the simulator's handle (rod
/// frame `z` in `[0, HANDLE_LENGTH_M]`).
///
/// # Errors
/// Simulator or camera-model failures.
pub fn run_handle_trial(
    protocol: &Protocol,
    rays_sim: &sim::render::RayTable,
    seed: u64,
    model: &control::perception::handle::HandleModel,
    hour: f64,
    wrist_light: bool,
) -> anyhow::Result<HandleOutcome> {
    use sim::scene::grounding_rod::{HANDLE_LENGTH_M, HOOK_CENTER_IN_ROD};
    let (mut scene, layout) = SubstationBuilder::new(seed).build().context("substation")?;
    let conductor = layout.target_conductor().context("no target conductor")?;
    let mut rng = SplitMix64::new(seed ^ 0x4A4D_0000);
    let hook = conductor.point_at(conductor.span_m() * rng.uniform(0.3, 0.7));
    let [hx, hy, hz] = HOOK_CENTER_IN_ROD;
    let world_from_rod = Isometry3::translation(hook.x - hx, hook.y - hy, hook.z - hz);
    scene.set_object_pose(layout.rod_object, world_from_rod)?;
    let axis = world_from_rod.rotation * Vector3::z();
    let bottom = world_from_rod * Point3::origin();
    let top = world_from_rod * Point3::new(0.0, 0.0, HANDLE_LENGTH_M);
    let centre = nalgebra::center(&bottom, &top);
    let spot = layout.world_from_robot_spot.translation.vector;
    let robot_point = Point3::new(spot.x, spot.y, spot.z + ARM_BASE_LOW_M);
    let standoff = rng.uniform(HANDLE_STANDOFF_RANGE_M.0, HANDLE_STANDOFF_RANGE_M.1);
    let world_from_camera = wrist_look_pose(&centre, &axis, &robot_point, standoff)?;
    let frame = render_rgbd_with_rays(
        &scene,
        &world_from_camera,
        rays_sim,
        &LightConditions::from_hour(hour)
            .with_lamp(wrist_light.then(|| sim::render::Lamp::wrist(1.0))),
        &SensorParams::wrist(),
        seed,
    );
    let header = Header::default();
    let colour = LumaImage::from_image(&color_image(&frame, header.clone()))?;
    let camera =
        CameraModel::from_camera_info(&protocol.intrinsics.to_camera_info(header.clone()))?;
    let depth = DepthImage::from_image(&depth_image(&frame, header, protocol.encoding))?;
    let rays = ray_table(&camera)?;
    let camera_from_world = world_from_camera.inverse();
    let margin_px = 0.03 * camera.fx / standoff;
    let roi = PixelRoi::around_segment(
        &camera,
        &(camera_from_world * bottom),
        &(camera_from_world * top),
        margin_px,
        0.05,
    )?;
    let cloud = control::perception::roi::extract_roi(&depth, &rays, &roi, protocol.wire.stride_px);
    let normal_of = |k: usize| {
        let (u, v) = *cloud.pixels.get(k)?;
        depth.normal(&rays, camera.fx, u as usize, v as usize)
    };
    let robot_in_camera = camera_from_world * robot_point;
    let window = control::perception::handle::ViewWindow {
        camera: &camera,
        roi: &roi,
        edge_px: 3.0 * protocol.wire.stride_px.max(1) as f64,
    };
    let fitted = control::perception::handle::fit_handle(
        &cloud.points,
        normal_of,
        model,
        &protocol.wire.ransac,
        &robot_in_camera,
        &window,
    );
    Ok(fitted.and_then(|h| {
        let contrast =
            h.confirm_in_colour(&cloud.points, &colour, &camera, &protocol.thresholds)?;
        let centre_est = world_from_camera * h.pose.point;
        let axis_est = world_from_camera.rotation * h.pose.axis;
        Ok((
            (centre_est - centre).norm(),
            axis_est.dot(&axis).abs().min(1.0).acos().to_degrees(),
            contrast,
        ))
    }))
}

/// Statistics of one condition.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// Condition label.
    pub name: &'static str,
    /// Trials run.
    pub trials: usize,
    /// Refusals.
    pub refusals: usize,
    /// Median hanging-point error of the accepted estimates (m).
    pub median_m: f64,
    /// 95th percentile (m).
    pub p95_m: f64,
    /// Largest (m).
    pub max_m: f64,
    /// Median |across| (m).
    pub median_across_m: f64,
    /// Median |along the approach| (m).
    pub median_approach_m: f64,
    /// Median axis angle error (deg).
    pub median_axis_deg: f64,
    /// 95th percentile axis angle error (deg).
    pub p95_axis_deg: f64,
    /// Accepted estimates outside the hook window.
    pub hook_violations: usize,
    /// Median confidence of the accepted estimates.
    pub median_score: f64,
    /// Median colour contrast of the accepted estimates.
    pub median_colour_contrast: f64,
    /// Refusal reasons with counts.
    pub reasons: Vec<(String, usize)>,
}

/// Nearest-rank percentile `q` in `[0, 1]` of `v` (NaN when empty).
#[must_use]
pub fn percentile(v: &[f64], q: f64) -> f64 {
    let mut s: Vec<f64> = v.to_vec();
    s.sort_by(f64::total_cmp);
    if s.is_empty() {
        return f64::NAN;
    }
    let rank = ((q * s.len() as f64).ceil() as usize).clamp(1, s.len());
    s.get(rank - 1).copied().unwrap_or(f64::NAN)
}

/// Summarises one condition's trials.
#[must_use]
pub fn summarize(name: &'static str, trials: &[Trial]) -> Summary {
    let ok: Vec<Errors> = trials
        .iter()
        .filter_map(|t| t.outcome.as_ref().ok().copied())
        .collect();
    let col = |f: fn(&Errors) -> f64| ok.iter().map(f).collect::<Vec<f64>>();
    let hanging = col(|e| e.hanging_m);
    let mut reasons: Vec<(String, usize)> = Vec::new();
    for t in trials {
        if let Err(e) = &t.outcome {
            let key = match e {
                PerceptionError::LowConfidence { limiting, .. } => {
                    format!("low confidence ({limiting})")
                }
                PerceptionError::NoCylinder { .. } => "no cylinder".to_owned(),
                PerceptionError::TooFewPoints { .. } => "too few points".to_owned(),
                other => other.to_string(),
            };
            match reasons.iter_mut().find(|(k, _)| *k == key) {
                Some((_, n)) => *n += 1,
                None => reasons.push((key, 1)),
            }
        }
    }
    Summary {
        name,
        trials: trials.len(),
        refusals: trials.len() - ok.len(),
        median_m: percentile(&hanging, 0.5),
        p95_m: percentile(&hanging, 0.95),
        max_m: percentile(&hanging, 1.0),
        median_across_m: percentile(&col(|e| e.across_m.abs()), 0.5),
        median_approach_m: percentile(&col(|e| e.approach_m.abs()), 0.5),
        median_axis_deg: percentile(&col(|e| e.axis_deg), 0.5),
        p95_axis_deg: percentile(&col(|e| e.axis_deg), 0.95),
        hook_violations: ok.iter().filter(|e| !e.in_hook_window()).count(),
        median_score: percentile(&col(|e| e.score), 0.5),
        median_colour_contrast: percentile(&col(|e| e.colour_contrast), 0.5),
        reasons,
    }
}

/// Runs `seeds` in `condition`.
///
/// # Errors
/// Those of [`run_trial`].
pub fn run_condition(
    protocol: &Protocol,
    seeds: std::ops::Range<u64>,
    condition: &Condition,
) -> anyhow::Result<Vec<Trial>> {
    let rays_sim = sim::render::RayTable::new(&protocol.intrinsics)?;
    seeds
        .map(|s| run_trial(protocol, &rays_sim, s, condition))
        .collect()
}

/// The table header.
pub const TABLE_HEADER: &str = "| condition | trials | refused | median mm | p95 mm | max mm | med across mm | med approach mm | med axis deg | p95 axis deg | outside hook window | med score | med colour contrast |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|";

/// One table row.
#[must_use]
pub fn table_row(s: &Summary) -> String {
    format!(
        "| {} | {} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.3} | {:.3} | {} | {:.2} | {:.1} |",
        s.name,
        s.trials,
        s.refusals,
        s.median_m * 1e3,
        s.p95_m * 1e3,
        s.max_m * 1e3,
        s.median_across_m * 1e3,
        s.median_approach_m * 1e3,
        s.median_axis_deg,
        s.p95_axis_deg,
        s.hook_violations,
        s.median_score,
        s.median_colour_contrast,
    )
}

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let scenes: u64 = args.next().map_or(Ok(100), |a| a.parse())?;
    let scale: f64 = args.next().map_or(Ok(1.0), |a| a.parse())?;
    let conditions: &[Condition] = match args.next().as_deref() {
        None | Some("all") => &[DAYLIGHT, DUSK_400LX, DUSK_3LX, STRONG_SUN, HARSH_SUN],
        Some("handle") => &[],
        Some(other) => anyhow::bail!("unknown part {other:?} (all | handle)"),
    };
    let protocol = Protocol::new(scale)?;
    println!(
        "wire perception vs simulator: {scenes} scenes, {}x{}, {} captures",
        protocol.intrinsics.width, protocol.intrinsics.height, protocol.captures
    );
    let mut rows = Vec::new();
    for condition in conditions {
        let started = std::time::Instant::now();
        let trials = run_condition(&protocol, 0..scenes, condition)?;
        for t in &trials {
            match &t.outcome {
                Ok(e) => println!(
                    "  {} seed {:3} h {:5.2}: {:.2} mm (across {:+.2}, approach {:+.2}), axis {:.3} deg, score {:.2} ({}), valid depth {:.2}, colour {:.1}{}",
                    condition.name,
                    t.seed,
                    t.hour,
                    e.hanging_m * 1e3,
                    e.across_m * 1e3,
                    e.approach_m * 1e3,
                    e.axis_deg,
                    e.score,
                    e.limiting,
                    e.valid_depth_fraction,
                    e.colour_contrast,
                    if e.in_hook_window() {
                        ""
                    } else {
                        "  OUTSIDE HOOK WINDOW"
                    }
                ),
                Err(e) => println!(
                    "  {} seed {:3} h {:5.2}: no estimate: {e}",
                    condition.name, t.seed, t.hour
                ),
            }
        }
        let summary = summarize(condition.name, &trials);
        println!(
            "{}: {:.1} s, refusals {:?}",
            condition.name,
            started.elapsed().as_secs_f64(),
            summary.reasons
        );
        rows.push(summary);
    }
    let rays_sim = sim::render::RayTable::new(&protocol.intrinsics)?;
    let model = control::perception::handle::HandleModel::default();
    let handle_scenes = scenes;
    let mut handle_rows = Vec::new();
    for (name, hour) in [("hour 11", 11.0), ("dusk 18:22 (3 lx)", DUSK_3LX.hours.0)] {
        let (mut centres, mut axes, mut contrasts, mut refused) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for seed in 0..handle_scenes {
            match run_handle_trial(&protocol, &rays_sim, seed, &model, hour, false)? {
                Ok((c, a, k)) => {
                    println!(
                        "  handle {name} seed {seed:3}: centre {:.2} mm, axis {a:.3} deg, colour {k:.1}",
                        c * 1e3
                    );
                    centres.push(c);
                    axes.push(a);
                    contrasts.push(k);
                }
                Err(e) => {
                    println!("  handle {name} seed {seed:3}: no estimate: {e}");
                    refused.push(e);
                }
            }
        }
        handle_rows.push(format!(
            "handle (rod hung on the wire, {name}): {handle_scenes} scenes, {} refused{}, centre median {:.2} mm, p95 {:.2} mm, max {:.2} mm, axis median {:.3} deg, colour contrast median {:.1}",
            refused.len(),
            refused
                .first()
                .map_or(String::new(), |e| format!(" (first: {e})")),
            percentile(&centres, 0.5) * 1e3,
            percentile(&centres, 0.95) * 1e3,
            percentile(&centres, 1.0) * 1e3,
            percentile(&axes, 0.5),
            percentile(&contrasts, 0.5),
        ));
    }
    println!("\n{TABLE_HEADER}");
    for s in &rows {
        println!("{}", table_row(s));
    }
    for row in &handle_rows {
        println!("\n{row}");
    }
    Ok(())
}
