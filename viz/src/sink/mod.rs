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
//! | `world/calibration/check_reference` (`/axes`) | `/calibration/check_reference` | `Transform3D` under `tool0` to the frame `calibration/check_reference` + `TransformAxes3D` |
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
//! The drawing is split by what it draws: `shapes` (bodies as archetypes), `frames` (TF axes,
//! the executed path), `cameras` (pinholes, images, captures, hand-eye frusta), `scene` (the
//! site, the rod, the wire, named poses), `calibration` (hand-eye results, matches) and `series`
//! (scalars, states, text lanes); this module holds the sink, its entities and the dispatch.
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
use msgs::rcl_interfaces::Log;
use msgs::topics as t;
use rerun::{
    AsComponents, CoordinateFrame, LineStrips3D, Points3D, RecordingStream, TextDocument, TextLog,
    TimeCell, Transform3D,
};

use crate::VizError;
use crate::convert::{self, Intrinsics, Pixels, Pose};
use crate::site::{RodBelief, Site};
use crate::tf::TfTree;
use crate::urdf::{self, Shape};

mod calibration;
mod cameras;
mod frames;
mod scene;
mod series;
mod shapes;

pub use shapes::is_hook_goal;
use shapes::{Part, along_x, log_bodies};

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
            (t::CALIBRATION_CHECK_REFERENCE, Msg::TransformStamped(ts)) => {
                // The drift check's reference: where its views put the camera, beside the
                // camera edge in use.
                let pose = Pose::from_transform(&ts.transform);
                let parent = frame_or(&ts.header.frame_id, msgs::frames::TOOL0);
                self.log_named_pose(
                    &format!("{CALIBRATION}/check_reference"),
                    parent,
                    "calibration/check_reference",
                    &pose,
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
