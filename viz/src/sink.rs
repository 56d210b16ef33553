//! [`Viz`]: the Rerun sink. Fed the message stream (live from the recorder, or a recording
//! read back), it logs every topic of ARCHITECTURE.md section 3 to a Rerun recording stream.
//!
//! # Entities
//! | entity | from | archetypes |
//! |---|---|---|
//! | `world` | — | `CoordinateFrame(map)`: the 3D view's reference frame |
//! | `world/tf/<child>` | `/tf`, `/tf_static` | `Transform3D` with parent and child frame names; Rerun composes the tree |
//! | `world/frames/<frame>` | first sight of a frame | `CoordinateFrame` + `TransformAxes3D` (axes of every TF frame, from then on) |
//! | `world/robot/<link>/{boxes,cylinders,...}` | `/robot_description` or the `robot.urdf` attachment ([`crate::urdf`]) | `Boxes3D`, `Cylinders3D`, ... in the link's frame (static): `/tf` animates them |
//! | `world/camera/wrist` (`/color`, `/depth`) | `/camera/color/camera_info`, `/camera/{color,depth}/image_raw` | `Pinhole` (static: parent `camera_color_optical_frame`, child `<frame>_image_plane`), `EncodedImage` (JPEG), `EncodedDepthImage` (16-bit PNG, mm) |
//! | `world/camera/panoramic` (`/color`) | `/panoramic/camera_info`, `/panoramic/image_raw` | `Pinhole`, `EncodedImage` |
//! | `world/captures/{task,calibration}/<nnnn>` | each wrist depth capture with its colour image (calibration views: between `/calibration/command` `check`/`collect` and `solve`/`cancel`) | `Points3D` in `map` (camera pose from `/tf` at the capture), at most [`crate::encode::MAX_CAPTURE_POINTS`] |
//! | `world/calibration/x_before`, `.../x_after` | a change of the `tool0` -> `camera_color_optical_frame` edge on `/tf` (a recalibration) | `Transform3D` under `tool0` + `Pinhole` frustum (grey: before, green: after) |
//! | `world/perception/roi_cloud` | `/perception/roi_cloud` | `Points3D` in the cloud's frame |
//! | `world/poses/<name>` (`/axes`) | `/perception/target_pose`, `/base/goal` | `Transform3D` to a named frame + `TransformAxes3D` |
//! | `world/site/<body>`, `world/site/rod`, `world/site/wire` | [`Viz::log_site`]; the rod as believed ([`crate::site::RodBelief`]); the wire from a hanging-point estimate | `Boxes3D`, `Cylinders3D` |
//! | `world/sim/...` | `/sim/wire_pose`, `/sim/handle_pose`, `/sim/base_pose`, `/sim/camera_mount` | the simulator's truth: the true wire, rod and camera frustum (hidden by default) |
//! | `world/trajectories/planned`, `.../executed` | `/arm/planned_path`; `base_link`..`tool0` composed from `/tf` | `LineStrips3D` in `base_link` |
//! | `matches/image`, `matches/inliers`, `matches/rejected` | `/calibration/matches` + the wrist images at `stamp_a`, `stamp_b` | `EncodedImage` (side by side), `LineStrips2D` (green / red) |
//! | `plots/...` | wind, illuminance (measured and truth), wrist light (commanded and state), joint positions, calibration residuals and sigmas, lift command | `Scalars` (+ `SeriesLines` names) |
//! | `events/task` | `/task/event` | `StateChange` (`task/state`): lanes in the state timeline |
//! | `log/{rosout,task,calibration,commands,sim}` | `/rosout`, `/task/event`, `/calibration/hand_eye`, command topics, `/sim/rod_state`, `/sim/camera_info`, `/sim/panoramic/camera_info` (the true intrinsics, on change) | `TextLog` |
//! | `recording/metadata` | MCAP metadata records | `TextDocument` (markdown) |
//! | `recording/whatif`, `log/whatif` | a what-if file's `whatif` record (`rodlog replay --out`) | `TextDocument` (static banner), `TextLog` WARN at the open-loop time |
//!
//! # Time
//! Every message is logged at its MCAP `log_time` (robot clock, ARCHITECTURE.md section 2) on the
//! timeline [`TIMELINE_LOG_TIME`] (`robot_time`, a duration since the robot clock's epoch;
//! not named `log_time`, which Rerun reserves for its wall-clock timestamp timeline), and at
//! the number of wrist captures so far on [`TIMELINE_FRAME`]. The SDK's own wall-clock
//! `log_time` and `log_tick` timelines are disabled, so nothing in the recording depends on
//! when or how fast it was converted.
//!
//! # Executed trajectory
//! Rerun composes TF frames for display, but a trajectory is a line through past poses: the
//! sink keeps the latest transform of every edge ([`crate::tf::TfTree`]) and, after each `/tf`
//! message, appends `base_link_from_tool0` when it moved more than [`TRAJECTORY_STEP_M`];
//! the whole line is re-logged at most every [`TRAJECTORY_PERIOD_NS`] of robot time. The same
//! tree places the depth captures, the perceived wire and the left rod in `map`.

use std::collections::{BTreeMap, BTreeSet, VecDeque};

use msgs::Msg;
use msgs::builtin_interfaces::Time;
use msgs::geometry_msgs::{PoseStamped, TransformStamped};
use msgs::rcl_interfaces::Log;
use msgs::rodlog_msgs::{FeatureMatches, HandEyeCalibration, TaskEvent};
use msgs::sensor_msgs::{CameraInfo, Image, JointState};
use msgs::topics as t;
use rerun::{
    AsComponents, Boxes3D, Capsules3D, CoordinateFrame, Cylinders3D, Ellipsoids3D,
    EncodedDepthImage, EncodedImage, LineStrips2D, LineStrips3D, MediaType, Pinhole, Points3D,
    RecordingStream, Scalars, SeriesLines, StateChange, TextDocument, TextLog, TimeCell,
    Transform3D, TransformAxes3D,
};

use crate::VizError;
use crate::convert::{self, Intrinsics, PixelKind, Pixels, Pose};
use crate::encode;
use crate::site::{Body, RodBelief, Site};
use crate::tf::TfTree;
use crate::urdf::{self, Shape};

/// Timeline of the robot clock: the MCAP `log_time`, ns since the robot clock's epoch.
pub const TIMELINE_LOG_TIME: &str = "robot_time";
/// Timeline counting wrist captures (`/camera/color/image_raw` messages).
pub const TIMELINE_FRAME: &str = "frame";
/// Root of the 3D scene; its coordinate frame is `map`.
pub const WORLD: &str = "world";
/// The wrist camera's pinhole entity.
pub const WRIST: &str = "world/camera/wrist";
/// The wrist colour image.
pub const WRIST_COLOR: &str = "world/camera/wrist/color";
/// The wrist depth image.
pub const WRIST_DEPTH: &str = "world/camera/wrist/depth";
/// The panoramic camera's pinhole entity.
pub const PANORAMIC: &str = "world/camera/panoramic";
/// The panoramic image.
pub const PANORAMIC_COLOR: &str = "world/camera/panoramic/color";
/// Parent of the depth captures: `world/captures/task/0001`, ... and the calibration views
/// (between a `/calibration/command` `check` or `collect` and the next `solve` or `cancel`)
/// under [`CALIBRATION_CAPTURES`].
pub const CAPTURES: &str = "world/captures";
/// Parent of the depth captures that are calibration views (hidden in the default blueprint:
/// 4 + 18 overlapping clouds of the calibration cabinet).
pub const CALIBRATION_CAPTURES: &str = "world/captures/calibration";
/// Parent of the hand-eye frusta before and after a recalibration.
pub const CALIBRATION: &str = "world/calibration";
/// The perception ROI cloud.
pub const ROI_CLOUD: &str = "world/perception/roi_cloud";
/// Planned tool0 paths.
pub const PLANNED: &str = "world/trajectories/planned";
/// Executed tool0 path.
pub const EXECUTED: &str = "world/trajectories/executed";
/// Parent of the robot's bodies (one child per URDF link).
pub const ROBOT: &str = "world/robot";
/// The site as the robot knows it (surveyed bodies, the believed rod, the perceived wire).
pub const SITE: &str = "world/site";
/// The simulator's truth (hidden in the default blueprint).
pub const SIM: &str = "world/sim";
/// The side-by-side match image.
pub const MATCHES_IMAGE: &str = "matches/image";
/// Inlier match segments.
pub const MATCHES_INLIERS: &str = "matches/inliers";
/// Rejected match segments.
pub const MATCHES_REJECTED: &str = "matches/rejected";
/// Task states as a `StateChange` lane.
pub const STATES: &str = "events/task";
/// The metadata document.
pub const METADATA: &str = "recording/metadata";
/// Entity of a what-if file's banner ([`Viz::log_whatif`]).
pub const WHATIF: &str = "recording/whatif";

/// Frame of the believed rod (its parent changes: `map` or `tool0`).
pub const ROD_FRAME: &str = "site/rod";
/// Frame of the true rod (under `sim/handle_pose`).
pub const SIM_ROD_FRAME: &str = "sim/rod";

/// Executed path: minimum tool0 displacement between two samples (m).
pub const TRAJECTORY_STEP_M: f64 = 0.002;
/// Executed path: minimum robot time between two re-logs of the line (ns).
pub const TRAJECTORY_PERIOD_NS: u64 = 250_000_000;
/// Wrist colour images kept for the match view and for colouring depth captures.
pub const KEPT_IMAGES: usize = 32;
/// A camera edge that moved more than this (m or quaternion component) is a recalibration.
pub const RECALIBRATION_EPS: f64 = 1e-9;
/// Length of the wire drawn around a hanging point (m).
pub const WIRE_DRAWN_LENGTH_M: f32 = 4.0;
/// Wrist camera frustum depth drawn in 3D (m).
const WRIST_PLANE_M: f32 = 0.12;
/// Depth of the hand-eye frusta before and after a recalibration (m): longer than the live
/// camera's, so the two stand out of the end effector.
const CALIBRATION_PLANE_M: f32 = 0.25;
/// Panoramic camera frustum depth drawn in 3D (m).
const PANORAMIC_PLANE_M: f32 = 0.4;
/// Length of the axes drawn at every TF frame (m).
const FRAME_AXES_M: f32 = 0.06;
/// Frames whose axes carry their name in the 3D view (the arm links' names would hide the arm).
const LABELLED_FRAMES: [&str; 3] = [
    msgs::frames::MAP,
    msgs::frames::BASE_LINK,
    msgs::frames::TOOL0,
];
/// Length of the axes drawn at target and truth poses (m).
const POSE_AXES_M: f32 = 0.15;
/// Radius of the depth capture points (m).
const CAPTURE_POINT_RADIUS_M: f32 = 0.002;
/// Conductor radius when the site does not say (m): 26.8 mm diameter.
const DEFAULT_WIRE_RADIUS_M: f32 = 0.0134;

const GREEN: [u8; 3] = [40, 220, 80];
const RED: [u8; 3] = [230, 50, 50];
const ORANGE: [u8; 3] = [255, 150, 0];
const CYAN: [u8; 3] = [0, 200, 255];
const GREY: [u8; 3] = [150, 150, 150];
const WIRE_RGBA: [u8; 4] = [70, 90, 120, 255];
const TRUTH_RGBA: [u8; 4] = [255, 60, 200, 160];

/// What was drawn, per topic.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct VizStats {
    /// Messages logged, per topic.
    pub logged: BTreeMap<String, u64>,
    /// Messages of topics or types the viewer has no drawing for, per topic.
    pub skipped: BTreeMap<String, u64>,
    /// Messages that could not be drawn (malformed), per topic.
    pub failed: BTreeMap<String, u64>,
    /// Depth captures drawn as points.
    pub captures: u64,
    /// Recalibrations drawn as frusta.
    pub recalibrations: u64,
}

impl VizStats {
    /// Messages logged on all topics.
    pub fn total_logged(&self) -> u64 {
        self.logged.values().sum()
    }
}

/// The Rerun sink: a recording stream and the little state drawing needs (latest camera
/// model, recent wrist images, the TF tree, the executed path, the believed rod).
pub struct Viz {
    rec: RecordingStream,
    stats: VizStats,
    frame: i64,
    last_time_ns: u64,
    frames_seen: BTreeSet<String>,
    tf: TfTree,
    executed: Vec<[f32; 3]>,
    executed_last: Option<[f64; 3]>,
    executed_dirty: bool,
    executed_logged_ns: Option<u64>,
    wrist: Option<(Intrinsics, [u32; 2])>,
    images: VecDeque<(Time, Pixels)>,
    pending_depth: Option<(Time, Pixels)>,
    camera_edge: Option<Pose>,
    urdf_hash: Option<u64>,
    rod_state: Option<String>,
    /// The last true intrinsics logged per camera topic (`/sim/...camera_info`).
    true_intrinsics: Vec<(&'static str, [f64; 4])>,
    site: Option<Site>,
    rod: Option<RodBelief>,
    task_state: Option<String>,
    calibration_views: bool,
    now_ns: u64,
    anchored: BTreeSet<String>,
    sim_rod_drawn: bool,
    sim_wire_drawn: bool,
    sim_frustum_drawn: bool,
}

impl std::fmt::Debug for Viz {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Viz")
            .field("stats", &self.stats)
            .field("frame", &self.frame)
            .field("last_time_ns", &self.last_time_ns)
            .finish_non_exhaustive()
    }
}

/// The Transform3D of `parent_from_child` between two named frames.
fn transform(parent: &str, child: &str, p: &Pose) -> Transform3D {
    Transform3D::new()
        .with_translation(p.t_f32())
        .with_quaternion(rerun::Quaternion::from_xyzw(p.q_f32()))
        .with_parent_frame(parent)
        .with_child_frame(child)
}

/// An entity path part from a frame or joint name (`/` would split the path).
fn part(name: &str) -> String {
    let s: String = name
        .trim_start_matches('/')
        .chars()
        .map(|c| if c == '/' { '_' } else { c })
        .collect();
    if s.is_empty() { "unnamed".into() } else { s }
}

/// `frame_id`, or `default` when the header has none.
fn frame_or<'a>(frame_id: &'a str, default: &'a str) -> &'a str {
    if frame_id.is_empty() {
        default
    } else {
        frame_id
    }
}

/// Rerun log level of a `/rosout` level.
fn rosout_level(level: u8) -> &'static str {
    match level {
        l if l >= Log::FATAL => rerun::TextLogLevel::CRITICAL,
        l if l >= Log::ERROR => rerun::TextLogLevel::ERROR,
        l if l >= Log::WARN => rerun::TextLogLevel::WARN,
        l if l >= Log::INFO => rerun::TextLogLevel::INFO,
        _ => rerun::TextLogLevel::DEBUG,
    }
}

/// `q * Rx(-90 deg)`: a cylinder (axis = its z) lying along the `y` axis of `q`.
fn along_y(q: [f64; 4]) -> [f64; 4] {
    let s = std::f64::consts::FRAC_1_SQRT_2;
    Pose { t: [0.0; 3], q }
        .compose(&Pose {
            t: [0.0; 3],
            q: [-s, 0.0, 0.0, s],
        })
        .q
}

/// `q * Ry(90 deg)`: a cylinder lying along the `x` axis of `q`.
fn along_x(q: [f64; 4]) -> [f64; 4] {
    let s = std::f64::consts::FRAC_1_SQRT_2;
    Pose { t: [0.0; 3], q }
        .compose(&Pose {
            t: [0.0; 3],
            q: [0.0, s, 0.0, s],
        })
        .q
}

/// The axis `k` (0 = x, 1 = y, 2 = z) of a rotation `q`.
fn axis_of(q: [f64; 4], k: usize) -> [f64; 3] {
    let mut e = [0.0; 3];
    e[k] = 1.0;
    Pose { t: [0.0; 3], q }
        .compose(&Pose {
            t: e,
            q: [0.0, 0.0, 0.0, 1.0],
        })
        .t
}

/// Whether a `/perception/target_pose` is a hook goal on the wire (its `z` up, `y` along the
/// wire: `control::tasks::poses::hook_goal`) rather than a grasp of the handle (`tool0`'s `x`
/// along the upright rod).
pub fn is_hook_goal(q: [f64; 4]) -> bool {
    axis_of(q, 2)[2] > 0.9
}

/// A shape drawn at `frame_from_shape`, in sRGBA.
type Part = (Pose, Shape, [u8; 4]);

/// Logs the shapes of `bodies` (all in one frame) under `entity`: one `Boxes3D`, `Cylinders3D`,
/// `Ellipsoids3D`, `Capsules3D` child per kind present, each in `frame`.
fn log_bodies(
    rec: &RecordingStream,
    entity: &str,
    frame: &str,
    bodies: &[Part],
    labels: Option<&[String]>,
    static_: bool,
) -> Result<(), VizError> {
    let coordinate_frame = CoordinateFrame::new(frame);
    let pick = |want: fn(&Shape) -> bool| -> Vec<usize> {
        (0..bodies.len()).filter(|&i| want(&bodies[i].1)).collect()
    };
    let log = |name: &str, arch: &dyn AsComponents| -> Result<(), VizError> {
        let path = format!("{entity}/{name}");
        let comps: [&dyn AsComponents; 2] = [arch, &coordinate_frame];
        if static_ {
            rec.log_static(path, &comps)?;
        } else {
            rec.log(path, &comps)?;
        }
        Ok(())
    };
    let color = |i: usize| {
        let [r, g, b, a] = bodies[i].2;
        rerun::Color::from_unmultiplied_rgba(r, g, b, a)
    };
    let label_of = |idx: &[usize]| -> Vec<String> {
        labels
            .map(|l| idx.iter().filter_map(|&i| l.get(i).cloned()).collect())
            .unwrap_or_default()
    };
    let boxes = pick(|s| matches!(s, Shape::Box { .. }));
    if !boxes.is_empty() {
        let half: Vec<[f32; 3]> = boxes
            .iter()
            .filter_map(|&i| match bodies[i].1 {
                Shape::Box { half_m } => Some(half_m),
                _ => None,
            })
            .collect();
        let mut arch =
            Boxes3D::from_centers_and_half_sizes(boxes.iter().map(|&i| bodies[i].0.t_f32()), half)
                .with_quaternions(
                    boxes
                        .iter()
                        .map(|&i| rerun::Quaternion::from_xyzw(bodies[i].0.q_f32())),
                )
                .with_colors(boxes.iter().map(|&i| color(i)))
                .with_fill_mode(rerun::FillMode::Solid);
        let l = label_of(&boxes);
        if !l.is_empty() {
            arch = arch.with_labels(l).with_show_labels(false);
        }
        log("boxes", &arch)?;
    }
    let cylinders = pick(|s| matches!(s, Shape::Cylinder { .. }));
    if !cylinders.is_empty() {
        let (lengths, radii): (Vec<f32>, Vec<f32>) = cylinders
            .iter()
            .filter_map(|&i| match bodies[i].1 {
                Shape::Cylinder { radius_m, length_m } => Some((length_m, radius_m)),
                _ => None,
            })
            .unzip();
        let mut arch = Cylinders3D::from_lengths_and_radii(lengths, radii)
            .with_centers(cylinders.iter().map(|&i| bodies[i].0.t_f32()))
            .with_quaternions(
                cylinders
                    .iter()
                    .map(|&i| rerun::Quaternion::from_xyzw(bodies[i].0.q_f32())),
            )
            .with_colors(cylinders.iter().map(|&i| color(i)))
            .with_fill_mode(rerun::FillMode::Solid);
        let l = label_of(&cylinders);
        if !l.is_empty() {
            arch = arch.with_labels(l).with_show_labels(false);
        }
        log("cylinders", &arch)?;
    }
    let spheres = pick(|s| matches!(s, Shape::Sphere { .. }));
    if !spheres.is_empty() {
        let radii: Vec<f32> = spheres
            .iter()
            .filter_map(|&i| match bodies[i].1 {
                Shape::Sphere { radius_m } => Some(radius_m),
                _ => None,
            })
            .collect();
        let arch = Ellipsoids3D::from_radii(radii)
            .with_centers(spheres.iter().map(|&i| bodies[i].0.t_f32()))
            .with_colors(spheres.iter().map(|&i| color(i)))
            .with_fill_mode(rerun::FillMode::Solid);
        log("spheres", &arch)?;
    }
    let capsules = pick(|s| matches!(s, Shape::Capsule { .. }));
    if !capsules.is_empty() {
        let (lengths, radii): (Vec<f32>, Vec<f32>) = capsules
            .iter()
            .filter_map(|&i| match bodies[i].1 {
                Shape::Capsule { radius_m, length_m } => Some((length_m, radius_m)),
                _ => None,
            })
            .unzip();
        // A URDF capsule is centred at its origin; Rerun's starts there.
        let arch = Capsules3D::from_lengths_and_radii(lengths.clone(), radii)
            .with_translations(capsules.iter().zip(&lengths).map(|(&i, len)| {
                let p = bodies[i].0;
                let a = axis_of(p.q, 2);
                let h = 0.5 * f64::from(*len);
                [
                    (p.t[0] - h * a[0]) as f32,
                    (p.t[1] - h * a[1]) as f32,
                    (p.t[2] - h * a[2]) as f32,
                ]
            }))
            .with_quaternions(
                capsules
                    .iter()
                    .map(|&i| rerun::Quaternion::from_xyzw(bodies[i].0.q_f32())),
            )
            .with_colors(capsules.iter().map(|&i| color(i)));
        log("capsules", &arch)?;
    }
    Ok(())
}

fn body_parts(bodies: &[Body]) -> (Vec<Part>, Vec<String>) {
    (
        bodies.iter().map(|b| (b.pose, b.shape, b.rgba)).collect(),
        bodies.iter().map(|b| b.name.clone()).collect(),
    )
}

impl Viz {
    /// Over a recording stream the caller built (see [`crate::stream`]): disables the SDK's
    /// wall-clock timelines and logs the `map` root frame.
    ///
    /// # Errors
    /// [`VizError::Rerun`] when the stream refuses the first log call.
    pub fn new(rec: RecordingStream) -> Result<Self, VizError> {
        rec.set_log_time_enabled(false);
        rec.set_log_tick_enabled(false);
        rec.log_static(WORLD, &CoordinateFrame::new(msgs::frames::MAP))?;
        let mut viz = Self {
            rec,
            stats: VizStats::default(),
            frame: 0,
            last_time_ns: 0,
            frames_seen: BTreeSet::new(),
            tf: TfTree::new(),
            executed: Vec::new(),
            executed_last: None,
            executed_dirty: false,
            executed_logged_ns: None,
            wrist: None,
            images: VecDeque::new(),
            pending_depth: None,
            camera_edge: None,
            urdf_hash: None,
            rod_state: None,
            true_intrinsics: Vec::new(),
            site: None,
            rod: None,
            task_state: None,
            calibration_views: false,
            now_ns: 0,
            anchored: BTreeSet::new(),
            sim_rod_drawn: false,
            sim_wire_drawn: false,
            sim_frustum_drawn: false,
        };
        viz.log_series_styles()?;
        // Until odometry says otherwise, base_link sits at the map origin (recordings without a
        // base driver, e.g. the test world, still show the robot in the 3D view). Temporal at
        // t = 0, not static: static data would hide every later `/tf` of this edge.
        viz.set_time(0);
        viz.tf
            .set(msgs::frames::MAP, msgs::frames::BASE_LINK, Pose::IDENTITY);
        viz.rec.log(
            format!("world/tf/{}", msgs::frames::BASE_LINK),
            &transform(msgs::frames::MAP, msgs::frames::BASE_LINK, &Pose::IDENTITY),
        )?;
        Ok(viz)
    }

    /// The underlying stream.
    pub fn stream(&self) -> &RecordingStream {
        &self.rec
    }

    /// What was drawn so far.
    pub fn stats(&self) -> &VizStats {
        &self.stats
    }

    /// Shows the MCAP metadata records as one markdown document (static).
    ///
    /// # Errors
    /// [`VizError::Rerun`].
    pub fn log_metadata(
        &mut self,
        records: &[(String, BTreeMap<String, String>)],
    ) -> Result<(), VizError> {
        let mut md = String::from("# Recording metadata\n");
        for (name, entries) in records {
            md.push_str(&format!("\n## {name}\n\n| key | value |\n|---|---|\n"));
            for (k, v) in entries {
                let v = v.replace('|', "\\|").replace('\n', " ");
                md.push_str(&format!("| {k} | {v} |\n"));
            }
        }
        self.rec.log_static(
            METADATA,
            &TextDocument::new(md).with_media_type(rerun::MediaType::markdown()),
        )?;
        Ok(())
    }

    /// Labels a what-if file (`rodlog replay --out`) as what it is: a static banner naming the
    /// source and the changed parameters and, when the replay went open-loop, a WARN line on
    /// `log/whatif` at `open_loop_from_ns`, so the time cursor shows where the outputs stop
    /// describing what the robot did (the recorded sensors never saw the new commands).
    ///
    /// # Errors
    /// [`VizError::Rerun`].
    pub fn log_whatif(
        &mut self,
        source: &str,
        changed_parameters: &str,
        open_loop_from_ns: Option<u64>,
        first_divergent_command: &str,
    ) -> Result<(), VizError> {
        let changed = if changed_parameters.is_empty() {
            "none (the current stages, the recorded parameters)"
        } else {
            changed_parameters
        };
        let mut md = format!(
            "# What-if replay of `{source}`\n\nChanged parameters: `{changed}`\n\n\
             Recorded inputs (sensors, clock, ground truth) with the outputs the stages give now.\n"
        );
        match open_loop_from_ns {
            Some(ns) => md.push_str(&format!(
                "\n**Open-loop from {:.3} s** (first divergent command on \
                 `{first_divergent_command}`): after it the recorded sensors did not see the new \
                 commands, so the outputs show what the stages would have said, not what the robot \
                 would have done. For that, simulate again (`rodlog record --scenario REC --set ...`).\n",
                ns as f64 * 1e-9
            )),
            None => md.push_str("\nNo command diverged: the what-if stays closed-loop.\n"),
        }
        self.rec.log_static(
            WHATIF,
            &TextDocument::new(md).with_media_type(rerun::MediaType::markdown()),
        )?;
        if let Some(ns) = open_loop_from_ns {
            self.set_time(ns);
            self.rec.log(
                "log/whatif",
                &TextLog::new(format!(
                    "WHAT-IF: open-loop from here ({first_divergent_command} diverged; changed: \
                     {changed}); later outputs did not act on the recorded world"
                ))
                .with_level(rerun::TextLogLevel::WARN),
            )?;
        }
        Ok(())
    }

    /// Draws the robot from its URDF ([`crate::urdf`]): every link's visuals, static, under
    /// `world/robot/<link>` in the link's frame, so `/tf` animates them as ROS tools do. A
    /// text identical to the last one drawn is skipped.
    ///
    /// # Errors
    /// [`VizError::Urdf`] when the text is not a URDF; [`VizError::Rerun`].
    pub fn log_urdf(&mut self, urdf_text: &str) -> Result<(), VizError> {
        let h = convert::fnv1a64(&[urdf_text]);
        if self.urdf_hash == Some(h) {
            return Ok(());
        }
        let robot = urdf::robot_visuals(urdf_text)?;
        self.urdf_hash = Some(h);
        self.log_zero_pose(&robot.joints)?;
        for link in &robot.links {
            let bodies: Vec<Part> = robot
                .visuals
                .iter()
                .filter(|v| &v.link == link)
                .map(|v| (v.pose, v.shape, v.rgba))
                .collect();
            if bodies.is_empty() {
                continue;
            }
            log_bodies(
                &self.rec,
                &format!("{ROBOT}/{}", part(link)),
                link,
                &bodies,
                None,
                true,
            )?;
        }
        Ok(())
    }

    /// At t = 0, before the first `/tf` (the recording's first instant holds the drivers'
    /// messages; `robot_state` publishes a step later), every URDF joint at position 0 on the
    /// entity of its child's `/tf` edge, and the wrist camera's frame at `tool0`: as a ROS tool
    /// shows a robot description before any joint state. The first `/tf` of each edge replaces
    /// it. Without it the viewer reports the 3D view in error at t = 0 (the links' and the
    /// camera's frames have no path to `map`).
    fn log_zero_pose(&mut self, joints: &[urdf::Joint]) -> Result<(), VizError> {
        let now = self.now_ns;
        self.rec
            .set_time(TIMELINE_LOG_TIME, TimeCell::from_duration_nanos(0));
        self.rec.set_time_sequence(TIMELINE_FRAME, 0);
        let mut result = Ok(());
        let camera = (
            msgs::frames::TOOL0.to_owned(),
            msgs::frames::CAMERA_COLOR_OPTICAL_FRAME.to_owned(),
            Pose::IDENTITY,
        );
        for (parent, child, pose) in joints
            .iter()
            .map(|j| (j.parent.clone(), j.child.clone(), j.origin))
            .chain(std::iter::once(camera))
        {
            result = self.rec.log(
                format!("world/tf/{}", part(&child)),
                &transform(&parent, &child, &pose),
            );
            if result.is_err() {
                break;
            }
        }
        self.set_time(now);
        result?;
        Ok(())
    }

    /// Draws the site as the robot knows it: the surveyed fixed bodies (static, in `map`, under
    /// `world/site/<name>`), and the rod (its parts static in [`ROD_FRAME`]) on the rack when
    /// the site knows where the stored rod stands. Keeps the site for the rod's belief and the
    /// wire's radius.
    ///
    /// # Errors
    /// [`VizError::Rerun`].
    pub fn log_site(&mut self, site: &Site) -> Result<(), VizError> {
        let mut groups: BTreeMap<String, Vec<Body>> = BTreeMap::new();
        for b in &site.fixed {
            let group = b.name.split('_').next().unwrap_or("site").to_owned();
            groups.entry(group).or_default().push(b.clone());
        }
        for (group, bodies) in &groups {
            let (parts, labels) = body_parts(bodies);
            log_bodies(
                &self.rec,
                &format!("{SITE}/{}", part(group)),
                msgs::frames::MAP,
                &parts,
                Some(&labels),
                true,
            )?;
        }
        let (parts, labels) = body_parts(&site.rod_parts);
        log_bodies(
            &self.rec,
            &format!("{SITE}/rod"),
            ROD_FRAME,
            &parts,
            Some(&labels),
            true,
        )?;
        self.site = Some(site.clone());
        if let Some(p) = site.map_from_stored_rod {
            let t = self.last_time_ns;
            self.set_time(t);
            self.set_rod(RodBelief {
                parent: msgs::frames::MAP.to_owned(),
                pose: p,
            })?;
        }
        Ok(())
    }

    fn set_rod(&mut self, belief: RodBelief) -> Result<(), VizError> {
        self.rec.log(
            format!("{SITE}/rod"),
            &transform(&belief.parent, ROD_FRAME, &belief.pose),
        )?;
        self.rod = Some(belief);
        Ok(())
    }

    /// Decodes CDR bytes of `type_name` and draws them ([`Viz::log_msg`]).
    ///
    /// # Errors
    /// [`VizError::Decode`] for bytes that are not a known type, then as [`Viz::log_msg`].
    pub fn log_cdr(
        &mut self,
        topic: &str,
        type_name: &str,
        log_time_ns: u64,
        cdr: &[u8],
    ) -> Result<(), VizError> {
        match Msg::decode(type_name, cdr) {
            Ok(msg) => self.log_msg(topic, log_time_ns, &msg),
            Err(msgs::DecodeError::UnknownType { .. }) => {
                *self.stats.skipped.entry(topic.to_owned()).or_default() += 1;
                Ok(())
            }
            Err(source) => {
                *self.stats.failed.entry(topic.to_owned()).or_default() += 1;
                Err(VizError::Decode {
                    topic: topic.to_owned(),
                    log_time_ns,
                    source,
                })
            }
        }
    }

    /// Draws one message at `log_time_ns` (robot clock).
    ///
    /// A malformed message (an image shorter than its size, matches with indices out of
    /// range, ...) is counted in [`VizStats::failed`] and returned as an error; the sink
    /// stays usable. Topics without a drawing are counted in [`VizStats::skipped`].
    ///
    /// # Errors
    /// The conversion errors of [`crate::convert`] and [`VizError::Rerun`].
    pub fn log_msg(&mut self, topic: &str, log_time_ns: u64, msg: &Msg) -> Result<(), VizError> {
        self.set_time(log_time_ns);
        let result = self.dispatch(topic, log_time_ns, msg);
        let counter = match &result {
            Ok(true) => &mut self.stats.logged,
            Ok(false) => &mut self.stats.skipped,
            Err(_) => &mut self.stats.failed,
        };
        *counter.entry(topic.to_owned()).or_default() += 1;
        result.map(|_| ())
    }

    fn set_time(&mut self, log_time_ns: u64) {
        self.now_ns = log_time_ns;
        self.last_time_ns = self.last_time_ns.max(log_time_ns);
        let ns = i64::try_from(log_time_ns).unwrap_or(i64::MAX);
        self.rec
            .set_time(TIMELINE_LOG_TIME, TimeCell::from_duration_nanos(ns));
        self.rec.set_time_sequence(TIMELINE_FRAME, self.frame);
    }

    /// Puts `entity` in `map` from t = 0 (once), for an entity of the 3D scene whose own frame
    /// is logged only with its data, later: until then its implicit frame `tf#/<path>` has no
    /// path to the view's `map`, and the viewer reports the whole 3D view in error ("No
    /// transform path from tf#/world/... to the view's target frame"). The entity's data logs
    /// its real frame ([`CoordinateFrame`], a pinhole's parent) from its first message on.
    fn anchor(&mut self, entity: &str) -> Result<(), VizError> {
        if !self.anchored.insert(entity.to_owned()) {
            return Ok(());
        }
        let now = self.now_ns;
        self.rec
            .set_time(TIMELINE_LOG_TIME, TimeCell::from_duration_nanos(0));
        self.rec.set_time_sequence(TIMELINE_FRAME, 0);
        let result = self
            .rec
            .log(entity, &CoordinateFrame::new(msgs::frames::MAP));
        self.set_time(now);
        result?;
        Ok(())
    }

    /// Returns whether the message was drawn.
    fn dispatch(&mut self, topic: &str, log_time_ns: u64, msg: &Msg) -> Result<bool, VizError> {
        match (topic, msg) {
            (t::TF | t::TF_STATIC, Msg::TfMessage(m)) => {
                for ts in &m.transforms {
                    self.log_tf_edge(ts)?;
                }
                self.update_executed(log_time_ns)?;
            }
            (t::ROBOT_DESCRIPTION, Msg::String(s)) => self.log_urdf(&s.data)?,
            (t::CAMERA_COLOR_INFO, Msg::CameraInfo(info)) => {
                let k = convert::intrinsics(info)?;
                self.wrist = Some((k, [info.width, info.height]));
                self.log_pinhole(
                    WRIST,
                    info,
                    msgs::frames::CAMERA_COLOR_OPTICAL_FRAME,
                    WRIST_PLANE_M,
                )?;
            }
            (t::PANORAMIC_INFO, Msg::CameraInfo(info)) => self.log_pinhole(
                PANORAMIC,
                info,
                msgs::frames::PANORAMIC_OPTICAL_FRAME,
                PANORAMIC_PLANE_M,
            )?,
            (t::CAMERA_COLOR_IMAGE, Msg::Image(img)) => {
                self.frame += 1;
                self.rec.set_time_sequence(TIMELINE_FRAME, self.frame);
                let px =
                    self.log_image(WRIST_COLOR, img, msgs::frames::CAMERA_COLOR_OPTICAL_FRAME)?;
                self.images.push_back((img.header.stamp, px));
                while self.images.len() > KEPT_IMAGES {
                    self.images.pop_front();
                }
                // A depth image that came first: coloured now, or grey when this colour image
                // belongs to another capture.
                if let Some((stamp, depth)) = self.pending_depth.take() {
                    self.log_capture(&depth, stamp)?;
                }
            }
            (t::CAMERA_DEPTH_IMAGE, Msg::Image(img)) => {
                let px =
                    self.log_image(WRIST_DEPTH, img, msgs::frames::CAMERA_COLOR_OPTICAL_FRAME)?;
                if let Some((stamp, old)) = self.pending_depth.take() {
                    self.log_capture(&old, stamp)?;
                }
                let stamp = img.header.stamp;
                if self.images.iter().any(|(s, _)| *s == stamp) {
                    self.log_capture(&px, stamp)?;
                } else {
                    self.pending_depth = Some((stamp, px));
                }
            }
            (t::PANORAMIC_IMAGE, Msg::Image(img)) => {
                self.log_image(PANORAMIC_COLOR, img, msgs::frames::PANORAMIC_OPTICAL_FRAME)?;
            }
            (t::PERCEPTION_ROI_CLOUD, Msg::PointCloud2(cloud)) => {
                let pts = convert::cloud_points(cloud)?;
                let mut points = Points3D::new(pts.positions).with_radii([0.003f32]);
                if !pts.colors.is_empty() {
                    points = points.with_colors(pts.colors);
                } else {
                    points = points.with_colors([GREEN]);
                }
                let frame =
                    CoordinateFrame::new(frame_or(&cloud.header.frame_id, msgs::frames::BASE_LINK));
                self.anchor(ROI_CLOUD)?;
                self.rec.log(
                    ROI_CLOUD,
                    &[&points as &dyn AsComponents, &frame as &dyn AsComponents],
                )?;
            }
            (t::PERCEPTION_TARGET_POSE, Msg::PoseStamped(p)) => {
                self.log_pose("world/poses/target_pose", p, "perception/target_pose")?;
                self.log_perceived(p)?;
            }
            (t::BASE_GOAL, Msg::PoseStamped(p)) => {
                self.log_pose("world/poses/base_goal", p, "commands/base_goal")?;
                self.command_line(topic, "base goal".into())?;
            }
            (t::SIM_WIRE_POSE, Msg::PoseStamped(p)) => {
                self.log_pose(&format!("{SIM}/wire_pose"), p, "sim/wire_pose")?;
                if !self.sim_wire_drawn {
                    self.sim_wire_drawn = true;
                    let radius = self.wire_radius();
                    let wire = Shape::Cylinder {
                        radius_m: radius,
                        length_m: WIRE_DRAWN_LENGTH_M,
                    };
                    let pose = Pose {
                        t: [0.0; 3],
                        q: along_x([0.0, 0.0, 0.0, 1.0]),
                    };
                    log_bodies(
                        &self.rec,
                        &format!("{SIM}/wire"),
                        "sim/wire_pose",
                        &[(pose, wire, TRUTH_RGBA)],
                        Some(&["true wire".to_owned()]),
                        true,
                    )?;
                }
            }
            (t::SIM_HANDLE_POSE, Msg::PoseStamped(p)) => {
                self.log_pose(&format!("{SIM}/handle_pose"), p, "sim/handle_pose")?;
                self.draw_sim_rod()?;
            }
            (t::SIM_BASE_POSE, Msg::PoseStamped(p)) => {
                self.log_pose(&format!("{SIM}/base_pose"), p, "sim/base_pose")?;
            }
            (t::CALIBRATION_COMMAND, Msg::String(c)) => {
                match c.data.trim() {
                    "check" | "collect" => self.calibration_views = true,
                    "solve" | "cancel" => self.calibration_views = false,
                    _ => {}
                }
                self.command_line(topic, format!("calibration: {}", c.data))?;
            }
            (t::SIM_CAMERA_MOUNT, Msg::TransformStamped(ts)) => {
                // The true mount, drawn as its own frame (and frustum) beside the estimate.
                let pose = Pose::from_transform(&ts.transform);
                let parent = frame_or(&ts.header.frame_id, msgs::frames::TOOL0);
                self.log_named_pose(
                    &format!("{SIM}/camera_mount"),
                    parent,
                    "sim/camera_mount",
                    &pose,
                )?;
                if !self.sim_frustum_drawn
                    && let Some((k, _)) = self.wrist
                {
                    self.sim_frustum_drawn = true;
                    self.log_frustum(
                        &format!("{SIM}/camera_mount/frustum"),
                        "sim/camera_mount",
                        &k,
                        [255, 60, 200],
                    )?;
                }
            }
            (t::ARM_PLANNED_PATH, Msg::Path(path)) => {
                let pts: Vec<[f32; 3]> = path
                    .poses
                    .iter()
                    .map(|p| Pose::from_pose(&p.pose).t_f32())
                    .collect();
                let frame =
                    CoordinateFrame::new(frame_or(&path.header.frame_id, msgs::frames::BASE_LINK));
                let strips = LineStrips3D::new([pts])
                    .with_colors([ORANGE])
                    .with_radii([0.004f32]);
                self.anchor(PLANNED)?;
                self.rec.log(
                    PLANNED,
                    &[&strips as &dyn AsComponents, &frame as &dyn AsComponents],
                )?;
            }
            (t::CALIBRATION_MATCHES, Msg::FeatureMatches(m)) => self.log_matches(m)?,
            (t::CALIBRATION_HAND_EYE, Msg::HandEyeCalibration(c)) => self.log_hand_eye(c)?,
            (t::JOINT_STATES, Msg::JointState(js)) => self.log_joints(js)?,
            (t::ENV_WIND, Msg::Float64(v)) => self.scalar("plots/wind/measured", v.data)?,
            (t::SIM_WIND, Msg::Float64(v)) => self.scalar("plots/wind/truth", v.data)?,
            (t::ENV_ILLUMINANCE, Msg::Illuminance(v)) => {
                self.scalar("plots/illuminance/measured", v.illuminance)?;
            }
            (t::SIM_ILLUMINANCE, Msg::Illuminance(v)) => {
                self.scalar("plots/illuminance/truth", v.illuminance)?;
            }
            (t::LIFT_COMMAND, Msg::Float64(v)) => {
                self.scalar("plots/commands/lift_m", v.data)?;
                self.command_line(topic, format!("lift to {:.3} m", v.data))?;
            }
            (t::WRIST_LIGHT_COMMAND, Msg::Float64(v)) => {
                self.scalar("plots/wrist_light/commanded", v.data)?;
                self.command_line(topic, format!("wrist light at {:.0}%", 100.0 * v.data))?;
            }
            (t::WRIST_LIGHT_STATE, Msg::Float64(v)) => {
                self.scalar("plots/wrist_light/state", v.data)?;
            }
            (t::ROSOUT, Msg::Log(l)) => {
                let text = format!("[{}] {}", l.name, l.msg);
                self.rec.log(
                    "log/rosout",
                    &TextLog::new(text).with_level(rosout_level(l.level)),
                )?;
            }
            (t::TASK_EVENT, Msg::TaskEvent(e)) => self.log_task_event(e)?,
            (t::ARM_JOINT_TRAJECTORY, Msg::JointTrajectory(jt)) => {
                let last = jt.points.last().map(|p| {
                    p.time_from_start.sec as f64 + f64::from(p.time_from_start.nanosec) * 1e-9
                });
                let text = format!(
                    "arm trajectory: {} points over {:.2} s ({})",
                    jt.points.len(),
                    last.unwrap_or(0.0),
                    jt.joint_names.join(", ")
                );
                self.command_line(topic, text)?;
            }
            (t::CLAMP_COMMAND, Msg::ClampCommand(c)) => {
                let action = match c.action {
                    msgs::rodlog_msgs::ClampCommand::OPEN => "open",
                    msgs::rodlog_msgs::ClampCommand::CLOSE => "close",
                    msgs::rodlog_msgs::ClampCommand::STOP => "stop",
                    _ => "unknown action",
                };
                self.command_line(
                    topic,
                    format!("clamp {action} (max {:.1} N m)", c.max_torque_nm),
                )?;
            }
            (t::CAMERA_TRIGGER, Msg::Empty(_)) => {
                self.command_line(topic, "capture".into())?;
            }
            (t::SIM_ROD_STATE, Msg::String(s)) => {
                // Published at 10 Hz; the log shows the changes.
                if self.rod_state.as_deref() == Some(s.data.as_str()) {
                    return Ok(true);
                }
                self.rod_state = Some(s.data.clone());
                self.rec.log(
                    "log/sim",
                    &TextLog::new(format!("rod {}", s.data)).with_level(rerun::TextLogLevel::INFO),
                )?;
            }
            (t::SIM_CAMERA_INFO | t::SIM_PANORAMIC_INFO, Msg::CameraInfo(info)) => {
                // Sent with every capture; the log shows the first and any change.
                let key: &'static str = if topic == t::SIM_CAMERA_INFO {
                    "wrist"
                } else {
                    "panoramic"
                };
                let k = [info.k[0], info.k[4], info.k[2], info.k[5]];
                if self.true_intrinsics.contains(&(key, k)) {
                    return Ok(true);
                }
                self.true_intrinsics.retain(|(c, _)| *c != key);
                self.true_intrinsics.push((key, k));
                self.rec.log(
                    "log/sim",
                    &TextLog::new(format!(
                        "true {key} intrinsics: fx {:.2} fy {:.2} cx {:.2} cy {:.2} px, D {:?} (the published camera_info is a calibration of them)",
                        k[0], k[1], k[2], k[3], info.d
                    ))
                    .with_level(rerun::TextLogLevel::INFO),
                )?;
            }
            // /clock carries nothing to draw (the timeline is the robot clock already).
            _ => return Ok(false),
        }
        Ok(true)
    }

    fn wire_radius(&self) -> f32 {
        self.site
            .as_ref()
            .map(|s| s.wire_radius_m)
            .filter(|r| *r > 0.0)
            .unwrap_or(DEFAULT_WIRE_RADIUS_M)
    }

    /// The true rod at `/sim/handle_pose` (static parts under `sim/rod`, once).
    fn draw_sim_rod(&mut self) -> Result<(), VizError> {
        if self.sim_rod_drawn {
            return Ok(());
        }
        let Some(site) = &self.site else {
            return Ok(());
        };
        self.sim_rod_drawn = true;
        let handle_from_rod = site.rod_from_handle.inverse();
        let parts: Vec<Part> = site
            .rod_parts
            .iter()
            .map(|b| (b.pose, b.shape, TRUTH_RGBA))
            .collect();
        self.rec.log_static(
            format!("{SIM}/rod"),
            &transform("sim/handle_pose", SIM_ROD_FRAME, &handle_from_rod),
        )?;
        log_bodies(
            &self.rec,
            &format!("{SIM}/rod"),
            SIM_ROD_FRAME,
            &parts,
            None,
            true,
        )
    }

    /// A hook goal becomes the perceived wire; a grasp the perceived rod (in `map`, at the
    /// time of the estimate).
    fn log_perceived(&mut self, p: &PoseStamped) -> Result<(), VizError> {
        let frame = frame_or(&p.header.frame_id, msgs::frames::BASE_LINK);
        let Some(map_from_frame) = self.tf.lookup(msgs::frames::MAP, frame) else {
            return Ok(());
        };
        let target = map_from_frame.compose(&Pose::from_pose(&p.pose));
        if is_hook_goal(target.q) {
            let wire = Shape::Cylinder {
                radius_m: self.wire_radius(),
                length_m: WIRE_DRAWN_LENGTH_M,
            };
            let pose = Pose {
                t: target.t,
                q: along_y(target.q),
            };
            self.anchor(&format!("{SITE}/wire/cylinders"))?;
            log_bodies(
                &self.rec,
                &format!("{SITE}/wire"),
                msgs::frames::MAP,
                &[(pose, wire, WIRE_RGBA)],
                Some(&["wire (perceived)".to_owned()]),
                false,
            )?;
        } else if let Some(site) = &self.site
            && !self.rod.as_ref().is_some_and(RodBelief::held)
        {
            let pose = target.compose(&site.tool0_from_rod);
            self.set_rod(RodBelief {
                parent: msgs::frames::MAP.to_owned(),
                pose,
            })?;
        }
        Ok(())
    }

    /// One depth capture as coloured points in `map`, under `world/captures/<nnnn>`.
    fn log_capture(&mut self, depth: &Pixels, stamp: Time) -> Result<(), VizError> {
        let Some((k, _)) = self.wrist else {
            return Ok(());
        };
        let camera = msgs::frames::CAMERA_COLOR_OPTICAL_FRAME;
        let Some(map_from_camera) = self.tf.lookup(msgs::frames::MAP, camera) else {
            return Ok(());
        };
        let mm = encode::depth_mm(depth)?;
        let colour = self
            .images
            .iter()
            .rev()
            .find(|(s, _)| *s == stamp)
            .map(|(_, p)| p);
        let stride = encode::stride_for(depth.width, depth.height, encode::MAX_CAPTURE_POINTS);
        let cloud = encode::depth_cloud(
            &mm,
            depth.width,
            depth.height,
            colour,
            &k,
            &map_from_camera,
            stride,
        );
        self.stats.captures += 1;
        let mut points = Points3D::new(cloud.positions).with_radii([CAPTURE_POINT_RADIUS_M]);
        if !cloud.colors.is_empty() {
            points = points.with_colors(cloud.colors);
        }
        let group = if self.calibration_views {
            CALIBRATION_CAPTURES.to_owned()
        } else {
            format!("{CAPTURES}/task")
        };
        let entity = format!("{group}/{:04}", self.stats.captures);
        // The frame static: before the capture's time the entity must still resolve to `map`
        // (an entity without a frame at the cursor's time is in `tf#/<path>`, which has no
        // path to `map`, and the whole 3D view is reported in error).
        self.rec
            .log_static(entity.as_str(), &CoordinateFrame::new(msgs::frames::MAP))?;
        self.rec.log(entity, &points)?;
        Ok(())
    }

    fn command_line(&mut self, topic: &str, text: String) -> Result<(), VizError> {
        self.rec.log(
            "log/commands",
            &TextLog::new(format!("{topic}: {text}")).with_level(rerun::TextLogLevel::DEBUG),
        )?;
        Ok(())
    }

    fn scalar(&mut self, entity: &str, v: f64) -> Result<(), VizError> {
        self.rec.log(entity, &Scalars::new([v]))?;
        Ok(())
    }

    /// Logs the axes of `frame` the first time it is seen (at that time, not static: a frame
    /// drawn before its transform arrives is unreachable, which the viewer flags as an error).
    fn see_frame(&mut self, frame: &str) -> Result<(), VizError> {
        if self.frames_seen.contains(frame) {
            return Ok(());
        }
        self.frames_seen.insert(frame.to_owned());
        let entity = format!("world/frames/{}", part(frame));
        self.anchor(&entity)?;
        self.rec.log(
            entity,
            &[
                &CoordinateFrame::new(frame) as &dyn AsComponents,
                &TransformAxes3D::new(FRAME_AXES_M)
                    .with_show_frame(LABELLED_FRAMES.contains(&frame)),
            ],
        )?;
        Ok(())
    }

    fn log_tf_edge(&mut self, ts: &TransformStamped) -> Result<(), VizError> {
        let parent = ts.header.frame_id.trim_start_matches('/');
        let child = ts.child_frame_id.trim_start_matches('/');
        if parent.is_empty() || child.is_empty() {
            return Err(VizError::Transform {
                parent: parent.to_owned(),
                child: child.to_owned(),
            });
        }
        let pose = Pose::from_transform(&ts.transform);
        if parent == msgs::frames::TOOL0 && child == msgs::frames::CAMERA_COLOR_OPTICAL_FRAME {
            self.camera_edge_moved(&pose)?;
        }
        self.tf.set(parent, child, pose);
        self.see_frame(parent)?;
        self.see_frame(child)?;
        self.rec.log(
            format!("world/tf/{}", part(child)),
            &transform(parent, child, &pose),
        )?;
        Ok(())
    }

    /// Draws the hand-eye X before and after a change of the camera edge (a recalibration
    /// accepted by the calibration stage) as two frusta under `tool0`.
    fn camera_edge_moved(&mut self, now: &Pose) -> Result<(), VizError> {
        let Some(before) = self.camera_edge.replace(*now) else {
            return Ok(());
        };
        let moved = before
            .t
            .iter()
            .zip(&now.t)
            .chain(before.q.iter().zip(&now.q))
            .any(|(a, b)| (a - b).abs() > RECALIBRATION_EPS);
        if !moved {
            return Ok(());
        }
        let Some((k, _)) = self.wrist else {
            return Ok(());
        };
        self.stats.recalibrations += 1;
        for (name, pose, colour) in [("x_before", before, GREY), ("x_after", *now, GREEN)] {
            let frame = format!("calibration/{name}");
            let entity = format!("{CALIBRATION}/{name}");
            self.log_named_pose(&entity, msgs::frames::TOOL0, &frame, &pose)?;
            self.log_frustum(&format!("{entity}/frustum"), &frame, &k, colour)?;
        }
        let dt = [
            (now.t[0] - before.t[0]) * 1e3,
            (now.t[1] - before.t[1]) * 1e3,
            (now.t[2] - before.t[2]) * 1e3,
        ];
        let dot = before
            .q
            .iter()
            .zip(&now.q)
            .map(|(a, b)| a * b)
            .sum::<f64>()
            .abs()
            .min(1.0);
        self.rec.log(
            "log/calibration",
            &TextLog::new(format!(
                "tool0_from_camera changed by {:.2} mm, {:.3} deg (frusta: grey before, green after)",
                (dt[0] * dt[0] + dt[1] * dt[1] + dt[2] * dt[2]).sqrt(),
                (2.0 * dot.acos()).to_degrees()
            ))
            .with_level(rerun::TextLogLevel::INFO),
        )?;
        Ok(())
    }

    /// A pinhole frustum (no image) in `frame`.
    fn log_frustum(
        &mut self,
        entity: &str,
        frame: &str,
        k: &Intrinsics,
        colour: [u8; 3],
    ) -> Result<(), VizError> {
        let pinhole = Pinhole::from_focal_length_and_resolution(k.focal, k.resolution)
            .with_principal_point(k.principal)
            .with_parent_frame(frame)
            .with_child_frame(format!("{frame}_image_plane"))
            .with_image_plane_distance(CALIBRATION_PLANE_M)
            .with_color(rerun::Color::from_rgb(colour[0], colour[1], colour[2]));
        self.anchor(entity)?;
        self.rec.log(
            entity,
            &[&pinhole as &dyn AsComponents, &CoordinateFrame::new(frame)],
        )?;
        Ok(())
    }

    /// Appends `base_link_from_tool0` to the executed path when it moved, and re-logs the
    /// path at most every [`TRAJECTORY_PERIOD_NS`].
    fn update_executed(&mut self, log_time_ns: u64) -> Result<(), VizError> {
        if let Some(p) = self.tf.lookup(msgs::frames::BASE_LINK, msgs::frames::TOOL0) {
            let moved = self.executed_last.is_none_or(|q| {
                let d = [p.t[0] - q[0], p.t[1] - q[1], p.t[2] - q[2]];
                (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() > TRAJECTORY_STEP_M
            });
            if moved {
                self.executed_last = Some(p.t);
                self.executed.push(p.t_f32());
                self.executed_dirty = true;
            }
        }
        let due = self
            .executed_logged_ns
            .is_none_or(|t0| log_time_ns.saturating_sub(t0) >= TRAJECTORY_PERIOD_NS);
        if self.executed_dirty && due {
            self.log_executed(log_time_ns)?;
        }
        Ok(())
    }

    fn log_executed(&mut self, log_time_ns: u64) -> Result<(), VizError> {
        self.anchor(EXECUTED)?;
        let strips = LineStrips3D::new([self.executed.clone()])
            .with_colors([CYAN])
            .with_radii([0.003f32]);
        self.rec.log(
            EXECUTED,
            &[
                &strips as &dyn AsComponents,
                &CoordinateFrame::new(msgs::frames::BASE_LINK),
            ],
        )?;
        self.executed_dirty = false;
        self.executed_logged_ns = Some(log_time_ns);
        Ok(())
    }

    fn log_pinhole(
        &mut self,
        entity: &str,
        info: &CameraInfo,
        default_frame: &str,
        plane_m: f32,
    ) -> Result<(), VizError> {
        let k = convert::intrinsics(info)?;
        let frame = frame_or(&info.header.frame_id, default_frame);
        self.see_frame(frame)?;
        let pinhole = Pinhole::from_focal_length_and_resolution(k.focal, k.resolution)
            .with_principal_point(k.principal)
            .with_parent_frame(frame)
            .with_child_frame(format!("{frame}_image_plane"))
            .with_image_plane_distance(plane_m);
        // Static: the camera model is the recording's (a later camera info replaces it for
        // all times), and its image plane then exists at all times, so the image entity below
        // it is never without a pinhole ancestor (a view error) before the first camera info.
        self.rec.log_static(
            entity,
            &[&pinhole as &dyn AsComponents, &CoordinateFrame::new(frame)],
        )?;
        Ok(())
    }

    /// Logs a colour (JPEG) or depth (16-bit PNG, mm) image in `<frame>_image_plane` and
    /// returns its pixels.
    fn log_image(
        &mut self,
        entity: &str,
        img: &Image,
        default_frame: &str,
    ) -> Result<Pixels, VizError> {
        let px = convert::image_pixels(img)?;
        let plane_frame = format!(
            "{}_image_plane",
            frame_or(&img.header.frame_id, default_frame)
        );
        // The image plane static (its camera's static pinhole defines it at all times): every
        // temporal row of an encoded-image entity then holds an image. The viewer plays
        // encoded images through its video cache, which panicked ("index out of bounds" in
        // video_stream_cache.rs) on an entity whose chunks also held rows without one (a
        // temporal frame-only row).
        if self.anchored.insert(entity.to_owned()) {
            self.rec
                .log_static(entity, &CoordinateFrame::new(plane_frame))?;
        }
        match px.kind {
            PixelKind::Rgb8 | PixelKind::Mono8 => {
                let image =
                    EncodedImage::new(encode::jpeg(&px)?).with_media_type(MediaType::jpeg());
                self.rec.log(entity, &image)?;
            }
            PixelKind::DepthF32M | PixelKind::DepthU16Mm => {
                let mm = encode::depth_mm(&px)?;
                let depth = EncodedDepthImage::new(encode::png16(&mm, px.width, px.height)?)
                    .with_media_type(MediaType::png())
                    .with_meter(1000.0f32);
                self.rec.log(entity, &depth)?;
            }
        }
        Ok(px)
    }

    /// A pose message as a named frame `frame_name` under its header frame, with axes.
    fn log_pose(
        &mut self,
        entity: &str,
        p: &PoseStamped,
        frame_name: &str,
    ) -> Result<(), VizError> {
        let parent = frame_or(&p.header.frame_id, msgs::frames::BASE_LINK);
        self.log_named_pose(entity, parent, frame_name, &Pose::from_pose(&p.pose))
    }

    /// `frame_name` under `parent` at `pose`, with axes (named for the perception target only:
    /// the calibration's and the commands' names would crowd the robot).
    fn log_named_pose(
        &mut self,
        entity: &str,
        parent: &str,
        frame_name: &str,
        pose: &Pose,
    ) -> Result<(), VizError> {
        self.rec.log(entity, &transform(parent, frame_name, pose))?;
        let named = frame_name.starts_with("perception/");
        let axes = format!("{entity}/axes");
        self.anchor(&axes)?;
        self.rec.log(
            axes,
            &[
                &CoordinateFrame::new(frame_name) as &dyn AsComponents,
                &TransformAxes3D::new(POSE_AXES_M).with_show_frame(named),
            ],
        )?;
        Ok(())
    }

    fn log_joints(&mut self, js: &JointState) -> Result<(), VizError> {
        for (name, pos) in js.name.iter().zip(&js.position) {
            let group = if name == msgs::frames::LIFT_JOINT || name == msgs::frames::CLAMP_JOINT {
                "prismatic_m"
            } else {
                "joints_rad"
            };
            self.scalar(&format!("plots/{group}/{}", part(name)), *pos)?;
        }
        Ok(())
    }

    fn log_hand_eye(&mut self, c: &HandEyeCalibration) -> Result<(), VizError> {
        self.scalar("plots/calibration/residual_rot_deg", c.residual_rot_deg)?;
        self.scalar("plots/calibration/residual_trans_mm", c.residual_trans_mm)?;
        self.scalar("plots/calibration/sigma_rot_deg", c.sigma_rot_deg)?;
        self.scalar("plots/calibration/sigma_trans_mm", c.sigma_trans_mm)?;
        let tr = c.tool0_from_camera.translation;
        let text = format!(
            "hand-eye {} ({}): {} views, {} pairs, t = [{:.4}, {:.4}, {:.4}] m, residual {:.3} deg / {:.2} mm, sigma {:.3} deg / {:.2} mm, condition {:.1}, scale {:.4}",
            c.method,
            c.mode,
            c.views,
            c.pairs,
            tr.x,
            tr.y,
            tr.z,
            c.residual_rot_deg,
            c.residual_trans_mm,
            c.sigma_rot_deg,
            c.sigma_trans_mm,
            c.condition,
            c.scale
        );
        self.rec.log(
            "log/calibration",
            &TextLog::new(text).with_level(rerun::TextLogLevel::INFO),
        )?;
        Ok(())
    }

    fn log_task_event(&mut self, e: &TaskEvent) -> Result<(), VizError> {
        let (kind, level) = match e.kind {
            TaskEvent::REFUSED => ("REFUSED", rerun::TextLogLevel::WARN),
            TaskEvent::FAILED => ("FAILED", rerun::TextLogLevel::ERROR),
            TaskEvent::DONE => ("DONE", rerun::TextLogLevel::INFO),
            _ => ("INFO", rerun::TextLogLevel::INFO),
        };
        let reason = if e.reason_code.is_empty() {
            String::new()
        } else {
            format!(" ({})", e.reason_code)
        };
        let text = format!("[{}/{}] {kind}{reason}: {}", e.task, e.state, e.text);
        self.rec
            .log("log/task", &TextLog::new(text).with_level(level))?;
        let lane = format!("{}/{}", e.task, e.state);
        if self.task_state.as_deref() != Some(lane.as_str()) {
            self.rec.log(STATES, &StateChange::single(lane.as_str()))?;
            self.task_state = Some(lane);
            if let Some(site) = &self.site {
                let tool = self.tf.lookup(msgs::frames::MAP, msgs::frames::TOOL0);
                if let Some(next) =
                    RodBelief::after_state(self.rod.as_ref(), &e.state, site, tool.as_ref())
                {
                    self.set_rod(next)?;
                }
            }
        }
        Ok(())
    }

    fn log_matches(&mut self, m: &FeatureMatches) -> Result<(), VizError> {
        let find = |stamp: Time| {
            self.images
                .iter()
                .rev()
                .find(|(s, _)| *s == stamp)
                .map(|(_, p)| p)
        };
        let (a, b) = (find(m.stamp_a), find(m.stamp_b));
        let fallback = self.wrist.map(|(_, size)| size).unwrap_or_else(|| {
            // No camera info yet: the keypoints' extent.
            let max = |kp: &[f32], k: usize| {
                kp.iter()
                    .skip(k)
                    .step_by(2)
                    .fold(1.0f32, |acc, v| acc.max(v.ceil()))
            };
            [
                max(&m.keypoints_a, 0).max(max(&m.keypoints_b, 0)) as u32,
                max(&m.keypoints_a, 1).max(max(&m.keypoints_b, 1)) as u32,
            ]
        });
        let canvas = convert::match_canvas(m, a, b, fallback)?;
        let n_in = canvas.inliers.len();
        let n_out = canvas.rejected.len();
        let px = Pixels {
            width: canvas.width,
            height: canvas.height,
            kind: PixelKind::Rgb8,
            data: canvas.rgb,
        };
        self.rec.log(
            MATCHES_IMAGE,
            &EncodedImage::new(encode::jpeg(&px)?).with_media_type(MediaType::jpeg()),
        )?;
        let segs = |v: &[[[f32; 2]; 2]]| v.iter().map(|s| s.to_vec()).collect::<Vec<_>>();
        self.rec.log(
            MATCHES_INLIERS,
            &LineStrips2D::new(segs(&canvas.inliers))
                .with_colors([GREEN])
                .with_radii([0.75f32])
                .with_draw_order(10.0),
        )?;
        self.rec.log(
            MATCHES_REJECTED,
            &LineStrips2D::new(segs(&canvas.rejected))
                .with_colors([RED])
                .with_radii([0.5f32])
                .with_draw_order(9.0),
        )?;
        self.rec.log(
            "log/calibration",
            &TextLog::new(format!(
                "matches {}: {n_in} inliers, {n_out} rejected ({} / {} keypoints{})",
                m.method,
                m.keypoints_a.len() / 2,
                m.keypoints_b.len() / 2,
                if a.is_none() || b.is_none() {
                    ", an image was not in the stream"
                } else {
                    ""
                }
            ))
            .with_level(rerun::TextLogLevel::DEBUG),
        )?;
        Ok(())
    }

    /// Logs the static names and colours of the fixed series.
    fn log_series_styles(&mut self) -> Result<(), VizError> {
        let styles: [(&str, &str, [u8; 3]); 10] = [
            (
                "plots/wind/measured",
                "wind (anemometer, 3-s mean) m/s",
                CYAN,
            ),
            (
                "plots/wind/truth",
                "wind (simulator truth) m/s",
                [120, 120, 120],
            ),
            (
                "plots/illuminance/measured",
                "illuminance (lux sensor) lx",
                ORANGE,
            ),
            (
                "plots/illuminance/truth",
                "illuminance (truth) lx",
                [120, 120, 120],
            ),
            (
                "plots/wrist_light/commanded",
                "wrist light commanded (0..1)",
                ORANGE,
            ),
            (
                "plots/wrist_light/state",
                "wrist light state (0..1)",
                [120, 120, 120],
            ),
            (
                "plots/calibration/residual_rot_deg",
                "AX=XB residual deg",
                GREEN,
            ),
            (
                "plots/calibration/residual_trans_mm",
                "AX=XB residual mm",
                RED,
            ),
            (
                "plots/calibration/sigma_rot_deg",
                "1-sigma deg",
                [60, 120, 60],
            ),
            (
                "plots/calibration/sigma_trans_mm",
                "1-sigma mm",
                [120, 60, 60],
            ),
        ];
        for (entity, name, color) in styles {
            self.rec.log_static(
                entity,
                &SeriesLines::new().with_names([name]).with_colors([color]),
            )?;
        }
        Ok(())
    }

    /// Logs what is still pending (a depth capture without its colour, the executed path) and
    /// flushes the stream.
    ///
    /// # Errors
    /// [`VizError::Rerun`], [`VizError::Flush`].
    pub fn flush(&mut self) -> Result<(), VizError> {
        let t = self.last_time_ns;
        self.set_time(t);
        if let Some((stamp, depth)) = self.pending_depth.take() {
            self.log_capture(&depth, stamp)?;
        }
        if self.executed_dirty {
            self.log_executed(t)?;
        }
        self.rec
            .flush_blocking()
            .map_err(|e| VizError::Flush(e.to_string()))
    }

    /// Flushes and closes the stream (for a file: writes the end of the .rrd).
    ///
    /// # Errors
    /// As [`Viz::flush`].
    pub fn finish(mut self) -> Result<VizStats, VizError> {
        self.flush()?;
        self.rec.disconnect();
        Ok(self.stats)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hook_goals_and_grasps_are_told_apart_by_their_axes() {
        // Hook goal: z up, y along the wire (rotated 30 deg about z).
        let (s, c) = (15f64.to_radians().sin(), 15f64.to_radians().cos());
        assert!(is_hook_goal([0.0, 0.0, s, c]));
        // Grasp: tool0 x up (the rod), z horizontal: Ry(-90 deg).
        let h = std::f64::consts::FRAC_1_SQRT_2;
        assert!(!is_hook_goal([0.0, -h, 0.0, h]));
        assert_eq!(
            axis_of([0.0, -h, 0.0, h], 0).map(|v| v.round()),
            [0.0, 0.0, 1.0]
        );
        // A wire cylinder along the goal's y, a truth cylinder along the pose's x.
        let y = axis_of(along_y([0.0, 0.0, 0.0, 1.0]), 2);
        let x = axis_of(along_x([0.0, 0.0, 0.0, 1.0]), 2);
        for (g, w) in y.iter().chain(&x).zip([0.0, 1.0, 0.0, 1.0, 0.0, 0.0]) {
            assert!((g - w).abs() < 1e-12, "{y:?} {x:?}");
        }
    }
}
