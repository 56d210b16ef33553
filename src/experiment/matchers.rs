//! `rodlog experiment matchers` (issue 6, DESIGN.md section 7): every matching method of
//! `calib::features::MatchMethod` on image pairs with known geometry, judged by that
//! geometry, never by the method's own verdict.
//!
//! # Pair sets (each `--trials` seeded pairs)
//! 1. **sim**: two wrist views of the simulated substation's calibration cabinet, a
//!    calibration-like motion apart (as `sim/examples/make_calib18.rs`: look-at point on the
//!    cabinet face, camera on a cone of 8-22 deg around the face normal at 0.38-0.52 m, roll
//!    within +-22 deg; view B's azimuth is view A's plus 80-120 deg). Colour with the wrist
//!    sensor's noise and auto-exposure at 10:30; depth noise-free and hole-free (the truth).
//!    A match `(a, b)` is **true** when A's keypoint, back-projected with A's true depth
//!    and moved by the true `b_from_a`, projects (with the lens distortion) within
//!    [`TRUE_MATCH_PX`] of B's keypoint and is not occluded in B (B's depth there is not
//!    shorter than the point's by more than [`OCCLUSION_REL`] of it + [`OCCLUSION_ABS_M`]).
//!    Because a corner sits on a depth edge as often as not, the depth is taken from any pixel
//!    of the 3x3 neighbourhood of A's keypoint (true if one of them passes). Keypoints with no
//!    depth in that neighbourhood (sky) are not judged.
//! 2. **shecar**: consecutive views `(i, i+1)` of ZHI's real sample (seeded choice), images
//!    resized by [`SHECAR_SCALE`] x `--image-scale`. The only trustworthy geometry there is
//!    the chessboard: we detect its 6x8 inner corners in both images (`calib::board`),
//!    undistort them with the dataset's intrinsics and fit the homographies board -> A and
//!    board -> B (normalised DLT). A match whose A keypoint lies on the board (the inner
//!    lattice grown by one square each side) is true when the board homography takes it within
//!    [`TRUE_MATCH_PX`] of B's keypoint (in undistorted pixels); matches off the board are
//!    **not judged** for the true rate. As a secondary, weaker check on all matches we report
//!    the fraction within [`TRUE_MATCH_PX`] of the epipolar line from the two board poses
//!    (PnP): a wrong match along the epipolar line passes it, so it is an upper bound.
//! 3. **warp**: a shecar photo and its warp by a seeded homography (rotation +-30 deg, scale
//!    0.8-1.25, shift +-5%, mild perspective) plus Gaussian noise of sigma 2 grey levels; a
//!    match is true when the homography takes A's keypoint within [`TRUE_MATCH_PX`] of B's.
//!
//! # Measures per pair and method
//! Keypoints (A and B), accepted matches, judged matches, **true matches**, the **true rate**
//! (true / judged), the **spread** (fraction of the cells of an 8x8 grid over A holding at
//! least one true match), and the wall time of detect + match + filter (measured in
//! `calib::features::match_images`; single runs, one after the other; quote medians). A
//! method that errors or accepts no match is counted as a refusal for that pair (shown in
//! the tables; its rate is then undefined, its counts are 0).
//!
//! The **orb-gms-retain-best** row is orb-gms with OpenCV's keypoint selection (the
//! strongest corners per level, `calib::features::KeypointDistribution::RetainBest`)
//! instead of the quadtree: beside the OpenCV row it separates what the selection does
//! from what the rest of the pipeline (FAST, descriptor, matching, GMS) does.
//!
//! The optional **opencv-orb-gms** column runs OpenCV's ORB (2000 features) + BFMatcher
//! (Hamming, nearest neighbour) + `cv2.xfeatures2d.matchGMS` through
//! `scripts/features/opencv_ref.py` on the same pairs (written as PNGs) when the venv of
//! `scripts/venv.sh` exists, judged the same way; its time is not comparable (process
//! start-up) and is not reported.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, Result, bail};
use calib::board::pnp::homography_dlt;
use calib::board::{BoardOptions, BoardSpec, board_view};
use calib::features::{
    FeatureError, GrayView, Keypoint, KeypointDistribution, Match, MatchImagesParams, MatchMethod,
    match_images,
};
use calib::relpose::CameraModel;
use image::GrayImage;
use nalgebra::{Isometry3, Matrix3, Point2, Point3, UnitQuaternion, Vector3};
use serde::Serialize;
use sim::render::{
    CameraIntrinsics, LightConditions, RayTable, SensorParams, render_rgbd_with_rays,
    world_from_camera_looking_at,
};

use super::progress::Progress;
use super::report::{Report, Results, Table, fmt_num, fmt_pct};
use super::stats::{RefusalCounter, Summary};
use super::{Settings, trial_seed};

/// Pairs per set when `--trials` is not given.
pub const DEFAULT_TRIALS: usize = 8;
/// A match is true when the geometry puts it within this many pixels (of the images used).
pub const TRUE_MATCH_PX: f64 = 3.0;
/// Side of the grid over image A for the spread measure.
pub const SPREAD_GRID: usize = 8;
/// Occlusion test (sim): relative depth tolerance.
pub const OCCLUSION_REL: f64 = 0.02;
/// Occlusion test (sim): absolute depth tolerance, metres.
pub const OCCLUSION_ABS_M: f64 = 0.005;
/// Resize of the 3264x1836 shecar photos before `--image-scale` (-> 1306x734, about the
/// wrist camera's 1280x1024 pixel count).
pub const SHECAR_SCALE: f64 = 0.4;
/// Smallest resize of the shecar photos (the board must stay detectable in smoke runs).
pub const SHECAR_MIN_SCALE: f64 = 0.2;
/// Scene seed of the simulated substation (the calib-18 scenario's).
pub const SIM_SCENE_SEED: u64 = 18;
/// Hour of day of the simulated pairs.
pub const SIM_HOUR: f64 = 10.5;
/// ORB features per image (`calib match`'s default, and the OpenCV column's).
pub const FEATURES: usize = 2000;
/// Every method name `rodlog calib match` may offer; those this build's
/// [`MatchMethod`] parses are run.
const CANDIDATE_METHODS: [&str; 6] = [
    "orb-gms",
    "orb-bf",
    "sift",
    "akaze",
    "sift-bf",
    "akaze-ransac",
];
/// Name of the orb-gms row with OpenCV's keypoint selection ([`KeypointDistribution`]).
pub const RETAIN_BEST_METHOD: &str = "orb-gms-retain-best";
/// Name of the OpenCV reference column.
pub const OPENCV_METHOD: &str = "opencv-orb-gms";

/// The three pair sets (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum PairSet {
    /// Simulator pairs judged by true depth and pose.
    Sim,
    /// Real shecar pairs judged on the chessboard plane.
    Shecar,
    /// Real photos and their synthetic homography warps.
    Warp,
}

impl PairSet {
    /// Short name (tables, file names).
    pub fn name(self) -> &'static str {
        match self {
            PairSet::Sim => "sim",
            PairSet::Shecar => "shecar",
            PairSet::Warp => "warp",
        }
    }

    /// How its matches are judged (report text).
    pub fn judged_by(self) -> &'static str {
        match self {
            PairSet::Sim => "true depth + relative pose, occlusion-checked",
            PairSet::Shecar => "board-plane homography (matches on the board only)",
            PairSet::Warp => "the known warp homography",
        }
    }
}

/// The verdict of the geometry on one match.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// The geometry confirms it.
    True,
    /// The geometry contradicts it.
    False,
    /// The geometry cannot tell (no depth; off the board).
    Unjudged,
}

/// Truth of a simulated pair.
#[derive(Clone, Debug)]
pub struct DepthTruth {
    /// The wrist camera (both views).
    pub camera: CameraIntrinsics,
    /// Noise-free depth of A along z, metres (NaN = none), row-major.
    pub depth_a: Vec<f32>,
    /// Same for B.
    pub depth_b: Vec<f32>,
    /// Pose of A's camera frame in B's.
    pub b_from_a: Isometry3<f64>,
}

/// Truth of a shecar pair: the board plane and the board poses.
#[derive(Clone, Debug)]
pub struct BoardTruth {
    /// The camera (distortion removed before the homographies).
    pub camera: CameraModel,
    /// Undistorted pixels of A -> board lattice coordinates (squares).
    pub board_from_a: Matrix3<f64>,
    /// Board lattice coordinates -> undistorted pixels of B.
    pub b_from_board: Matrix3<f64>,
    /// Inner corners per row and column.
    pub cols: usize,
    /// Inner corners per column.
    pub rows: usize,
    /// Fundamental matrix on undistorted pixels: `x_b^T F x_a = 0`.
    pub fundamental: Matrix3<f64>,
}

/// What a pair's matches are judged with.
#[derive(Clone, Debug)]
pub enum Truth {
    /// Simulator depth and poses.
    Depth(Box<DepthTruth>),
    /// Pixel homography A -> B.
    Homography(Matrix3<f64>),
    /// The shecar board.
    Board(Box<BoardTruth>),
}

/// `H (x, y, 1)` dehomogenised; `None` at infinity.
fn apply_h(h: &Matrix3<f64>, x: f64, y: f64) -> Option<(f64, f64)> {
    let v = h * Vector3::new(x, y, 1.0);
    (v.z.abs() > 1e-12).then(|| (v.x / v.z, v.y / v.z))
}

fn dist(p: (f64, f64), q: (f64, f64)) -> f64 {
    (p.0 - q.0).hypot(p.1 - q.1)
}

impl DepthTruth {
    fn depth(depth: &[f32], w: u32, h: u32, u: i64, v: i64) -> Option<f64> {
        if u < 0 || v < 0 || u >= i64::from(w) || v >= i64::from(h) {
            return None;
        }
        let z = *depth.get(v as usize * w as usize + u as usize)?;
        z.is_finite().then_some(f64::from(z))
    }

    fn judge(&self, a: (f64, f64), b: (f64, f64)) -> Verdict {
        let (w, h) = (self.camera.width, self.camera.height);
        let Ok([nx, ny]) = self.camera.undistort(a.0, a.1) else {
            return Verdict::Unjudged;
        };
        let (cu, cv) = (a.0.round() as i64, a.1.round() as i64);
        let mut judged = false;
        for dv in -1..=1 {
            for du in -1..=1 {
                let Some(z) = Self::depth(&self.depth_a, w, h, cu + du, cv + dv) else {
                    continue;
                };
                judged = true;
                let p_b = self.b_from_a * Point3::new(nx * z, ny * z, z);
                if p_b.z <= 0.0 {
                    continue;
                }
                let Some([u, v]) = self.camera.project(&p_b) else {
                    continue;
                };
                let (ui, vi) = (u.round() as i64, v.round() as i64);
                let Some(zb) = Self::depth(&self.depth_b, w, h, ui, vi) else {
                    // Outside B or sky there: the point is not visible in B.
                    continue;
                };
                if zb < p_b.z * (1.0 - OCCLUSION_REL) - OCCLUSION_ABS_M {
                    continue;
                }
                if dist((u, v), b) <= TRUE_MATCH_PX {
                    return Verdict::True;
                }
            }
        }
        if judged {
            Verdict::False
        } else {
            Verdict::Unjudged
        }
    }
}

/// The undistorted pixel of `p`: the ideal pinhole image `K (x/z, y/z, 1)` of its ray
/// (`CameraModel::undistort_pixel` returns normalised coordinates).
fn undistorted_px(camera: &CameraModel, p: (f64, f64)) -> Option<(f64, f64)> {
    let n = camera.undistort_pixel(&Point2::new(p.0, p.1)).ok()?;
    Some((camera.fx * n.x + camera.cx, camera.fy * n.y + camera.cy))
}

impl BoardTruth {
    fn undistort(&self, p: (f64, f64)) -> Option<(f64, f64)> {
        undistorted_px(&self.camera, p)
    }

    fn judge(&self, a: (f64, f64), b: (f64, f64)) -> Verdict {
        let (Some(ua), Some(ub)) = (self.undistort(a), self.undistort(b)) else {
            return Verdict::Unjudged;
        };
        let Some(g) = apply_h(&self.board_from_a, ua.0, ua.1) else {
            return Verdict::Unjudged;
        };
        let on_board =
            g.0 >= -1.0 && g.0 <= self.cols as f64 && g.1 >= -1.0 && g.1 <= self.rows as f64;
        if !on_board {
            return Verdict::Unjudged;
        }
        match apply_h(&self.b_from_board, g.0, g.1) {
            Some(pred) if dist(pred, ub) <= TRUE_MATCH_PX => Verdict::True,
            _ => Verdict::False,
        }
    }

    /// Distance of B's point from the epipolar line of A's (undistorted pixels).
    fn epipolar_px(&self, a: (f64, f64), b: (f64, f64)) -> Option<f64> {
        let (ua, ub) = (self.undistort(a)?, self.undistort(b)?);
        let l = self.fundamental * Vector3::new(ua.0, ua.1, 1.0);
        let n = l.x.hypot(l.y);
        (n > 1e-12).then(|| (l.x * ub.0 + l.y * ub.1 + l.z).abs() / n)
    }
}

impl Truth {
    /// The geometry's verdict on the match `a` (pixels of A) <-> `b` (pixels of B).
    pub fn judge(&self, a: (f64, f64), b: (f64, f64)) -> Verdict {
        match self {
            Truth::Depth(t) => t.judge(a, b),
            Truth::Board(t) => t.judge(a, b),
            Truth::Homography(h) => match apply_h(h, a.0, a.1) {
                Some(p) if dist(p, b) <= TRUE_MATCH_PX => Verdict::True,
                _ => Verdict::False,
            },
        }
    }

    /// For board truth: whether the match is within [`TRUE_MATCH_PX`] of its epipolar line.
    fn epipolar_ok(&self, a: (f64, f64), b: (f64, f64)) -> Option<bool> {
        match self {
            Truth::Board(t) => Some(t.epipolar_px(a, b).is_some_and(|d| d <= TRUE_MATCH_PX)),
            _ => None,
        }
    }
}

/// One image pair with its truth.
#[derive(Clone, Debug)]
pub struct ImagePair {
    /// The set it belongs to.
    pub set: PairSet,
    /// Human label (e.g. `shecar 03-04`).
    pub label: String,
    /// The trial seed it was made from.
    pub seed: u64,
    /// Image A (grey).
    pub a: GrayImage,
    /// Image B (grey).
    pub b: GrayImage,
    /// How to judge its matches.
    pub truth: Truth,
}

// ---------------------------------------------------------------------------------------
// Pair generation
// ---------------------------------------------------------------------------------------

/// Random stream ids (for `sim::rng`).
const STREAM_SIM_VIEW: u64 = 11;
const STREAM_SHECAR_ORDER: u64 = 12;
const STREAM_WARP: u64 = 13;
const STREAM_WARP_NOISE: u64 = 14;

/// Renders the simulated pairs (module docs, set 1).
fn sim_pairs(settings: &Settings, n: usize, progress: &Progress) -> Result<Vec<ImagePair>> {
    let (scene, layout) = sim::scene::SubstationBuilder::new(SIM_SCENE_SEED)
        .build()
        .context("building the simulated substation")?;
    let camera = CameraIntrinsics::wrist()
        .scaled(settings.image_scale)
        .context("scaling the wrist camera")?;
    let rays = RayTable::new(&camera).context("ray table")?;
    let light = LightConditions::from_hour(SIM_HOUR);
    let mut sensor = SensorParams::wrist();
    sensor.depth = SensorParams::ideal().depth;
    let normal = layout.calibration_target_normal;
    let target = layout.calibration_target_center + Vector3::new(0.0, 0.0, 0.15);
    let e1 = normal.cross(&Vector3::z()).normalize();
    let e2 = normal.cross(&e1).normalize();
    let mut pairs = Vec::with_capacity(n);
    for t in 0..n {
        let seed = trial_seed(settings.seed, PairSet::Sim as u64, t as u64);
        let u = |i: u64, lo: f64, hi: f64| sim::rng::uniform_in(seed, STREAM_SIM_VIEW, i, lo, hi);
        let az_a = u(0, 0.0, 360.0);
        let azimuths = [az_a, az_a + u(1, 80.0, 120.0)];
        let mut poses = Vec::with_capacity(2);
        for (k, az) in azimuths.iter().enumerate() {
            let k = 10 * (k as u64 + 1);
            let tilt = u(k, 8.0, 22.0).to_radians();
            let d = u(k + 1, 0.38, 0.52);
            let roll = u(k + 2, -22.0, 22.0).to_radians();
            let az = az.to_radians();
            let dir = normal * tilt.cos() + (e1 * az.cos() + e2 * az.sin()) * tilt.sin();
            let eye = target + dir * d;
            let look =
                world_from_camera_looking_at(&eye, &Point3::from(target.coords), &Vector3::z())
                    .context("degenerate simulated view")?;
            poses.push(look * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), roll));
        }
        let [world_from_a, world_from_b] = [poses[0], poses[1]];
        let fa = render_rgbd_with_rays(&scene, &world_from_a, &rays, &light, &sensor, seed);
        let fb = render_rgbd_with_rays(&scene, &world_from_b, &rays, &light, &sensor, seed ^ 1);
        let gray = |f: &sim::render::RgbdFrame| -> Result<GrayImage> {
            let rgb = image::RgbImage::from_raw(f.width, f.height, f.rgb.clone())
                .context("render buffer of the wrong size")?;
            Ok(calib::features::gray::rgb_to_gray(&rgb))
        };
        let angle = (world_from_a.rotation.inverse() * world_from_b.rotation)
            .angle()
            .to_degrees();
        let b_from_a = world_from_b.inverse() * world_from_a;
        pairs.push(ImagePair {
            set: PairSet::Sim,
            label: format!(
                "sim {t} ({angle:.0} deg, {:.0} mm)",
                b_from_a.translation.vector.norm() * 1e3
            ),
            seed,
            a: gray(&fa)?,
            b: gray(&fb)?,
            truth: Truth::Depth(Box::new(DepthTruth {
                camera,
                depth_a: fa.depth_m,
                depth_b: fb.depth_m,
                b_from_a,
            })),
        });
        progress.inc(1);
    }
    Ok(pairs)
}

/// The shecar photos and camera at one scale, loaded lazily.
struct Shecar {
    dataset: crate::import::Dataset,
    scale: f64,
    camera: CameraModel,
    images: BTreeMap<usize, GrayImage>,
    boards: BTreeMap<usize, std::result::Result<calib::board::BoardView, String>>,
}

impl Shecar {
    fn open(settings: &Settings) -> Result<Self> {
        let dir = compose::data::shecar_dir();
        let dataset = crate::import::shecar::read(&dir)
            .with_context(|| format!("reading shecar at {}", dir.display()))?;
        let scale = (SHECAR_SCALE * settings.image_scale).max(SHECAR_MIN_SCALE);
        let c = &dataset.camera;
        let (w, h) = (
            (f64::from(c.width) * scale).round() as u32,
            (f64::from(c.height) * scale).round() as u32,
        );
        let s = c.scaled(scale, w, h);
        let camera = CameraModel {
            k1: s.distortion[0],
            k2: s.distortion[1],
            p1: s.distortion[2],
            p2: s.distortion[3],
            k3: s.distortion[4],
            ..CameraModel::pinhole(w, h, s.fx, s.fy, s.cx, s.cy)
        };
        Ok(Self {
            dataset,
            scale,
            camera,
            images: BTreeMap::new(),
            boards: BTreeMap::new(),
        })
    }

    fn image(&mut self, i: usize) -> Result<GrayImage> {
        if let Some(img) = self.images.get(&i) {
            return Ok(img.clone());
        }
        let view = self
            .dataset
            .views
            .get(i)
            .with_context(|| format!("shecar has no view {i}"))?;
        let img = image::open(&view.image)
            .with_context(|| format!("decoding {}", view.image.display()))?
            .resize_exact(
                self.camera.width,
                self.camera.height,
                image::imageops::FilterType::Triangle,
            )
            .to_luma8();
        self.images.insert(i, img.clone());
        Ok(img)
    }

    fn board(&mut self, i: usize) -> Result<std::result::Result<calib::board::BoardView, String>> {
        if let Some(b) = self.boards.get(&i) {
            return Ok(b.clone());
        }
        let img = self.image(i)?;
        let spec = BoardSpec::new(6, 8, 0.0283).context("board spec")?;
        let view = board_view(&img, &self.camera, &spec, &BoardOptions::default())
            .map_err(|e| format!("board not found in view {i}: {e}"));
        self.boards.insert(i, view.clone());
        Ok(view)
    }
}

/// Shecar pairs (module docs, set 2). A pair whose board is not found is returned as an
/// `Err` reason (counted as a refused pair).
fn shecar_pairs(
    shecar: &mut Shecar,
    settings: &Settings,
    n: usize,
    progress: &Progress,
) -> Result<Vec<std::result::Result<ImagePair, String>>> {
    let views = shecar.dataset.views.len();
    if views < 2 {
        bail!("shecar has fewer than 2 views");
    }
    // Consecutive pairs in a seeded order, cycling when more are asked for.
    let mut order: Vec<usize> = (0..views - 1).collect();
    order.sort_by_key(|&i| sim::rng::key(settings.seed, STREAM_SHECAR_ORDER, i as u64));
    let spec = BoardSpec::new(6, 8, 0.0283).context("board spec")?;
    let mut out = Vec::with_capacity(n);
    for t in 0..n {
        let Some(&i) = order.get(t % order.len()) else {
            break;
        };
        let j = i + 1;
        let seed = trial_seed(settings.seed, PairSet::Shecar as u64, t as u64);
        let label = format!("shecar {i:02}-{j:02}");
        let pair = match (shecar.board(i)?, shecar.board(j)?) {
            (Ok(ba), Ok(bb)) => {
                board_truth(&shecar.camera, &spec, &ba, &bb).map(|truth| ImagePair {
                    set: PairSet::Shecar,
                    label: label.clone(),
                    seed,
                    a: GrayImage::new(1, 1),
                    b: GrayImage::new(1, 1),
                    truth: Truth::Board(Box::new(truth)),
                })
            }
            (Err(e), _) | (_, Err(e)) => Err(e),
        };
        let pair = match pair {
            Ok(mut p) => {
                p.a = shecar.image(i)?;
                p.b = shecar.image(j)?;
                Ok(p)
            }
            Err(e) => Err(format!("{label}: {e}")),
        };
        out.push(pair);
        progress.inc(1);
    }
    Ok(out)
}

/// Board homographies and the fundamental matrix of two board views.
fn board_truth(
    camera: &CameraModel,
    spec: &BoardSpec,
    a: &calib::board::BoardView,
    b: &calib::board::BoardView,
) -> std::result::Result<BoardTruth, String> {
    let lattice: Vec<Point2<f64>> = (0..spec.rows)
        .flat_map(|r| (0..spec.cols).map(move |c| Point2::new(c as f64, r as f64)))
        .collect();
    let und = |v: &calib::board::BoardView| -> std::result::Result<Vec<Point2<f64>>, String> {
        v.corners_px
            .iter()
            .map(|p| {
                undistorted_px(camera, (p.x, p.y))
                    .map(|(x, y)| Point2::new(x, y))
                    .ok_or_else(|| "a board corner cannot be undistorted".to_owned())
            })
            .collect()
    };
    let (ua, ub) = (und(a)?, und(b)?);
    let h_a = homography_dlt(&lattice, &ua).map_err(|e| format!("board homography: {e}"))?;
    let h_b = homography_dlt(&lattice, &ub).map_err(|e| format!("board homography: {e}"))?;
    let board_from_a = h_a
        .try_inverse()
        .ok_or_else(|| "singular board homography".to_owned())?;
    // x_b^T F x_a = 0 with F = K^-T [t]x R K^-1, (R, t) = b_from_a.
    let b_from_a = b.world_from_camera.inverse() * a.world_from_camera;
    let t = b_from_a.translation.vector;
    let tx = Matrix3::new(0.0, -t.z, t.y, t.z, 0.0, -t.x, -t.y, t.x, 0.0);
    let e = tx * b_from_a.rotation.to_rotation_matrix().into_inner();
    let k = Matrix3::new(
        camera.fx, 0.0, camera.cx, 0.0, camera.fy, camera.cy, 0.0, 0.0, 1.0,
    );
    let k_inv = k
        .try_inverse()
        .ok_or_else(|| "singular camera matrix".to_owned())?;
    Ok(BoardTruth {
        camera: *camera,
        board_from_a,
        b_from_board: h_b,
        cols: spec.cols,
        rows: spec.rows,
        fundamental: k_inv.transpose() * e * k_inv,
    })
}

/// `img` warped by `h` (A pixels -> B pixels): `B(x) = A(h^-1 x)`, bilinear, 0 outside, plus
/// Gaussian noise of sigma 2 grey levels from `sim::rng` keyed by the pixel index.
fn warp(img: &GrayImage, h: &Matrix3<f64>, seed: u64) -> Option<GrayImage> {
    let inv = h.try_inverse()?;
    let (w, hh) = img.dimensions();
    let sample = |x: f64, y: f64| -> Option<f64> {
        if x < 0.0 || y < 0.0 || x > f64::from(w - 1) || y > f64::from(hh - 1) {
            return None;
        }
        let (x0, y0) = (x.floor() as u32, y.floor() as u32);
        let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(hh - 1));
        let (fx, fy) = (x - f64::from(x0), y - f64::from(y0));
        let p = |x: u32, y: u32| f64::from(img.get_pixel(x, y).0[0]);
        Some(
            (p(x0, y0) * (1.0 - fx) + p(x1, y0) * fx) * (1.0 - fy)
                + (p(x0, y1) * (1.0 - fx) + p(x1, y1) * fx) * fy,
        )
    };
    Some(GrayImage::from_fn(w, hh, |x, y| {
        let v = apply_h(&inv, f64::from(x), f64::from(y))
            .and_then(|(sx, sy)| sample(sx, sy))
            .map_or(0.0, |v| {
                v + 2.0
                    * sim::rng::normal(
                        seed,
                        STREAM_WARP_NOISE,
                        u64::from(y) * u64::from(w) + u64::from(x),
                    )
            });
        image::Luma([v.round().clamp(0.0, 255.0) as u8])
    }))
}

/// Warp pairs (module docs, set 3).
fn warp_pairs(
    shecar: &mut Shecar,
    settings: &Settings,
    n: usize,
    progress: &Progress,
) -> Result<Vec<ImagePair>> {
    let views = shecar.dataset.views.len().max(1);
    let mut out = Vec::with_capacity(n);
    for t in 0..n {
        let seed = trial_seed(settings.seed, PairSet::Warp as u64, t as u64);
        let u = |i: u64, lo: f64, hi: f64| sim::rng::uniform_in(seed, STREAM_WARP, i, lo, hi);
        let i = (sim::rng::key(seed, STREAM_WARP, 99) % views as u64) as usize;
        let a = shecar.image(i)?;
        let (w, h) = (f64::from(a.width()), f64::from(a.height()));
        let angle = u(0, -30.0, 30.0).to_radians();
        let scale = u(1, 0.8, 1.25);
        let (tx, ty) = (u(2, -0.05, 0.05) * w, u(3, -0.05, 0.05) * h);
        let (px, py) = (u(4, -0.15, 0.15) / w, u(5, -0.15, 0.15) / h);
        let (c, s) = (angle.cos() * scale, angle.sin() * scale);
        let (cx, cy) = (0.5 * (w - 1.0), 0.5 * (h - 1.0));
        let centre = Matrix3::new(1.0, 0.0, -cx, 0.0, 1.0, -cy, 0.0, 0.0, 1.0);
        let back = Matrix3::new(1.0, 0.0, cx + tx, 0.0, 1.0, cy + ty, 0.0, 0.0, 1.0);
        let similarity = Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
        let perspective = Matrix3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, px, py, 1.0);
        let hm = back * similarity * perspective * centre;
        let b = warp(&a, &hm, seed).context("singular warp")?;
        out.push(ImagePair {
            set: PairSet::Warp,
            label: format!(
                "warp {t} (view {i:02}, {:.0} deg, x{scale:.2})",
                angle.to_degrees()
            ),
            seed,
            a,
            b,
            truth: Truth::Homography(hm),
        });
        progress.inc(1);
    }
    Ok(out)
}

// ---------------------------------------------------------------------------------------
// Running and judging the methods
// ---------------------------------------------------------------------------------------

/// What one method made of one pair, in plain coordinates (the adapter between
/// `calib::features` and the scoring).
#[derive(Clone, Debug)]
struct MethodOutput {
    keypoints_a: Vec<Keypoint>,
    keypoints_b: Vec<Keypoint>,
    /// Number of keypoints detected in A (may exceed `keypoints_a.len()`).
    n_keypoints_a: usize,
    /// Same for B.
    n_keypoints_b: usize,
    /// Accepted matches (after the method's own filter).
    accepted: Vec<Match>,
    /// Wall time detect + match + filter, ms (NaN when not measured).
    time_ms: f64,
}

impl MethodOutput {
    fn ends(&self, m: &Match) -> Option<((f64, f64), (f64, f64))> {
        let a = self.keypoints_a.get(m.query as usize)?;
        let b = self.keypoints_b.get(m.train as usize)?;
        Some((
            (f64::from(a.x), f64::from(a.y)),
            (f64::from(b.x), f64::from(b.y)),
        ))
    }
}

/// A row of the tables: a method with its parameters.
struct Variant {
    name: String,
    method: MatchMethod,
    params: MatchImagesParams,
}

/// Every available method with its defaults, then [`RETAIN_BEST_METHOD`]: orb-gms with
/// OpenCV's keypoint selection instead of the quadtree, to separate the effect of the
/// selection from that of the rest of the pipeline in the comparison with OpenCV.
fn variants() -> Vec<Variant> {
    let mut v: Vec<Variant> = available_methods()
        .into_iter()
        .map(|m| Variant {
            name: m.name().to_owned(),
            method: m,
            params: MatchImagesParams::for_method(m),
        })
        .collect();
    let mut params = MatchImagesParams::for_method(MatchMethod::OrbGms);
    params.orb.distribution = KeypointDistribution::RetainBest;
    v.push(Variant {
        name: RETAIN_BEST_METHOD.to_owned(),
        method: MatchMethod::OrbGms,
        params,
    });
    v
}

/// The methods of this build (module docs).
pub fn available_methods() -> Vec<MatchMethod> {
    CANDIDATE_METHODS
        .iter()
        .filter_map(|name| name.parse::<MatchMethod>().ok())
        .fold(Vec::new(), |mut v, m| {
            if !v.contains(&m) {
                v.push(m);
            }
            v
        })
}

fn run_method(pair: &ImagePair, variant: &Variant) -> Result<MethodOutput, FeatureError> {
    let a = GrayView::from_image(&pair.a);
    let b = GrayView::from_image(&pair.b);
    let r = match_images(&a, &b, variant.method, &variant.params)?;
    let accepted: Vec<Match> = r.inlier_matches().copied().collect();
    let t = r.timings;
    Ok(MethodOutput {
        n_keypoints_a: r.features_a.keypoints.len(),
        n_keypoints_b: r.features_b.keypoints.len(),
        keypoints_a: r.features_a.keypoints,
        keypoints_b: r.features_b.keypoints,
        accepted,
        time_ms: t.detect_ms + t.match_ms + t.filter_ms,
    })
}

/// OpenCV's ORB + BF + GMS on the pair through `opencv_ref.py` (module docs).
fn run_opencv(pair: &ImagePair, python: &Path, script: &Path, tmp: &Path) -> Result<MethodOutput> {
    let (pa, pb) = (tmp.join("a.png"), tmp.join("b.png"));
    pair.a.save(&pa).context("writing the reference input")?;
    pair.b.save(&pb).context("writing the reference input")?;
    let out = Command::new(python)
        .arg(script)
        .arg("orb-gms")
        .arg(&pa)
        .arg(&pb)
        .args(["--features", &FEATURES.to_string()])
        .output()
        .with_context(|| format!("running {}", script.display()))?;
    if !out.status.success() {
        bail!(
            "opencv_ref.py failed: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    let v: serde_json::Value =
        serde_json::from_slice(&out.stdout).context("parsing opencv_ref.py output")?;
    let count = |k: &str| v.get(k).and_then(serde_json::Value::as_u64).unwrap_or(0) as usize;
    let rows = v
        .get("matches")
        .and_then(serde_json::Value::as_array)
        .context("opencv_ref.py output has no matches")?;
    // Only the matched keypoints come back: rebuild one keypoint per match end.
    let kp = |x: f64, y: f64| Keypoint {
        x: x as f32,
        y: y as f32,
        level: 0,
        angle_rad: 0.0,
        response: 0.0,
        size: 31.0,
    };
    let mut o = MethodOutput {
        n_keypoints_a: 0,
        n_keypoints_b: 0,
        keypoints_a: Vec::with_capacity(rows.len()),
        keypoints_b: Vec::with_capacity(rows.len()),
        accepted: Vec::with_capacity(rows.len()),
        time_ms: f64::NAN,
    };
    for (i, r) in rows.iter().enumerate() {
        let f = |k: usize| r.get(k).and_then(serde_json::Value::as_f64);
        let (Some(xa), Some(ya), Some(xb), Some(yb)) = (f(0), f(1), f(3), f(4)) else {
            bail!("malformed match row {i} from opencv_ref.py");
        };
        o.keypoints_a.push(kp(xa, ya));
        o.keypoints_b.push(kp(xb, yb));
        o.accepted.push(Match {
            query: i as u32,
            train: i as u32,
            distance: 0,
        });
    }
    // Only the match ends were rebuilt: report the detector's counts.
    o.n_keypoints_a = count("keypoints_a");
    o.n_keypoints_b = count("keypoints_b");
    Ok(o)
}

/// The measures of one (pair, method); serialised into results.json.
#[derive(Clone, Debug, Serialize)]
pub struct PairScore {
    /// Pair set.
    pub set: PairSet,
    /// Pair label.
    pub pair: String,
    /// Trial seed of the pair.
    pub seed: u64,
    /// Method name.
    pub method: String,
    /// `None` when the method answered; the reason when it refused.
    pub refused: Option<String>,
    /// Keypoints in A.
    pub keypoints_a: usize,
    /// Keypoints in B.
    pub keypoints_b: usize,
    /// Accepted matches.
    pub matches: usize,
    /// Matches the geometry could judge.
    pub judged: usize,
    /// Matches the geometry confirms.
    pub true_matches: usize,
    /// `true_matches / judged` (NaN -> null when nothing was judged).
    pub true_rate: f64,
    /// Fraction of the 8x8 grid cells over A holding a true match.
    pub spread: f64,
    /// Shecar only: fraction of all accepted matches within 3 px of their epipolar line.
    pub epipolar_rate: Option<f64>,
    /// Detect + match + filter, ms (NaN -> null when not measured).
    pub time_ms: f64,
}

/// Judges `out` on `pair`; also returns the per-match verdicts (for the pictures).
fn score(pair: &ImagePair, method: &str, out: &MethodOutput) -> (PairScore, Vec<bool>) {
    let (w, h) = (f64::from(pair.a.width()), f64::from(pair.a.height()));
    let mut cells = [[false; SPREAD_GRID]; SPREAD_GRID];
    let (mut judged, mut true_n, mut epi_ok, mut epi_n) = (0usize, 0usize, 0usize, 0usize);
    let mut flags = Vec::with_capacity(out.accepted.len());
    for m in &out.accepted {
        let Some((a, b)) = out.ends(m) else {
            flags.push(false);
            continue;
        };
        let verdict = pair.truth.judge(a, b);
        if verdict != Verdict::Unjudged {
            judged += 1;
        }
        if verdict == Verdict::True {
            true_n += 1;
            let cx = ((a.0 / w * SPREAD_GRID as f64) as usize).min(SPREAD_GRID - 1);
            let cy = ((a.1 / h * SPREAD_GRID as f64) as usize).min(SPREAD_GRID - 1);
            if let Some(c) = cells.get_mut(cy).and_then(|r| r.get_mut(cx)) {
                *c = true;
            }
        }
        if let Some(ok) = pair.truth.epipolar_ok(a, b) {
            epi_n += 1;
            epi_ok += usize::from(ok);
        }
        flags.push(verdict == Verdict::True);
    }
    let covered = cells.iter().flatten().filter(|c| **c).count();
    let ratio = |k: usize, n: usize| {
        if n == 0 {
            f64::NAN
        } else {
            k as f64 / n as f64
        }
    };
    (
        PairScore {
            set: pair.set,
            pair: pair.label.clone(),
            seed: pair.seed,
            method: method.to_owned(),
            refused: None,
            keypoints_a: out.n_keypoints_a,
            keypoints_b: out.n_keypoints_b,
            matches: out.accepted.len(),
            judged,
            true_matches: true_n,
            true_rate: ratio(true_n, judged),
            spread: covered as f64 / (SPREAD_GRID * SPREAD_GRID) as f64,
            epipolar_rate: matches!(pair.truth, Truth::Board(_)).then(|| ratio(epi_ok, epi_n)),
            time_ms: out.time_ms,
        },
        flags,
    )
}

fn refused_score(pair: &ImagePair, method: &str, reason: String) -> PairScore {
    PairScore {
        set: pair.set,
        pair: pair.label.clone(),
        seed: pair.seed,
        method: method.to_owned(),
        refused: Some(reason),
        keypoints_a: 0,
        keypoints_b: 0,
        matches: 0,
        judged: 0,
        true_matches: 0,
        true_rate: f64::NAN,
        spread: 0.0,
        epipolar_rate: None,
        time_ms: f64::NAN,
    }
}

/// The match picture of one pair and method: accepted matches only, green when the geometry
/// confirms them, red when it does not or cannot judge them.
fn draw(pair: &ImagePair, out: &MethodOutput, flags: &[bool], path: &Path) -> Result<()> {
    let a = GrayView::from_image(&pair.a);
    let b = GrayView::from_image(&pair.b);
    let img = calib::features::draw::draw_matches(
        &a,
        &b,
        &out.keypoints_a,
        &out.keypoints_b,
        &out.accepted,
        flags,
    );
    img.save(path)
        .with_context(|| format!("writing {}", path.display()))
}

// ---------------------------------------------------------------------------------------
// The experiment
// ---------------------------------------------------------------------------------------

/// Summary of one (set, method) over its pairs; serialised into results.json.
#[derive(Clone, Debug, Serialize)]
pub struct CellSummary {
    /// Pair set.
    pub set: PairSet,
    /// Method.
    pub method: String,
    /// Pairs attempted.
    pub pairs: usize,
    /// Pairs refused (error or no accepted match).
    pub refused: usize,
    /// Keypoints in A.
    pub keypoints: Summary,
    /// Accepted matches.
    pub matches: Summary,
    /// True matches.
    pub true_matches: Summary,
    /// True rate per pair.
    pub true_rate: Summary,
    /// Pooled true rate: sum of true matches / sum of judged matches.
    pub pooled_true_rate: f64,
    /// Spread.
    pub spread: Summary,
    /// Epipolar rate (shecar only).
    pub epipolar_rate: Option<Summary>,
    /// Time, ms.
    pub time_ms: Summary,
}

fn summarise(set: PairSet, method: &str, scores: &[&PairScore]) -> CellSummary {
    let answered: Vec<&&PairScore> = scores.iter().filter(|s| s.refused.is_none()).collect();
    let col = |f: &dyn Fn(&PairScore) -> f64| -> Summary {
        Summary::of(&answered.iter().map(|s| f(s)).collect::<Vec<_>>())
    };
    let (t, j) = answered.iter().fold((0usize, 0usize), |(t, j), s| {
        (t + s.true_matches, j + s.judged)
    });
    CellSummary {
        set,
        method: method.to_owned(),
        pairs: scores.len(),
        refused: scores.len() - answered.len(),
        keypoints: col(&|s| s.keypoints_a as f64),
        matches: col(&|s| s.matches as f64),
        true_matches: col(&|s| s.true_matches as f64),
        true_rate: col(&|s| s.true_rate),
        pooled_true_rate: if j == 0 {
            f64::NAN
        } else {
            t as f64 / j as f64
        },
        spread: col(&|s| s.spread),
        epipolar_rate: (set == PairSet::Shecar)
            .then(|| col(&|s| s.epipolar_rate.unwrap_or(f64::NAN))),
        time_ms: col(&|s| s.time_ms),
    }
}

/// Runs the experiment (module docs) and writes report.md, results.json, plots and match
/// pictures into `settings.out`.
///
/// # Errors
/// Rendering, file and plotting errors (a method's refusal on a pair is not an error).
pub fn run(settings: &Settings) -> Result<()> {
    let n = settings.trials_or(DEFAULT_TRIALS);
    let methods = variants();
    let mut method_names: Vec<String> = methods.iter().map(|v| v.name.clone()).collect();
    let reference = if settings.reference {
        super::reference_python().zip(super::source_script("scripts/features/opencv_ref.py"))
    } else {
        None
    };
    if reference.is_some() {
        method_names.push(OPENCV_METHOD.to_owned());
    }
    let mut results = Results::new(settings.name, settings.seed);
    results.parameter("pairs_per_set", n)?;
    results.parameter("image_scale", settings.image_scale)?;
    results.parameter("true_match_px", TRUE_MATCH_PX)?;
    results.parameter("spread_grid", SPREAD_GRID)?;
    results.parameter("occlusion_rel", OCCLUSION_REL)?;
    results.parameter("occlusion_abs_m", OCCLUSION_ABS_M)?;
    results.parameter("sim_scene_seed", SIM_SCENE_SEED)?;
    results.parameter("sim_hour", SIM_HOUR)?;
    results.parameter("features", FEATURES)?;
    results.parameter("methods", &method_names)?;

    let progress = Progress::new("matchers", (3 * n * (1 + method_names.len())) as u64);
    let mut refusals = RefusalCounter::default();
    let mut notes: Vec<String> = Vec::new();
    let mut pairs: Vec<ImagePair> = Vec::new();

    progress.message("rendering sim pairs");
    pairs.extend(sim_pairs(settings, n, &progress)?);
    match Shecar::open(settings) {
        Ok(mut shecar) => {
            results.parameter("shecar_scale", shecar.scale)?;
            progress.message("shecar pairs (board detection)");
            for p in shecar_pairs(&mut shecar, settings, n, &progress)? {
                match p {
                    Ok(p) => pairs.push(p),
                    Err(reason) => {
                        for m in &method_names {
                            refusals.attempt("shecar", m);
                            refusals.refuse("shecar", m, &format!("pair not scorable: {reason}"));
                        }
                        notes.push(reason);
                    }
                }
            }
            progress.message("warp pairs");
            pairs.extend(warp_pairs(&mut shecar, settings, n, &progress)?);
        }
        Err(e) => {
            let note = format!(
                "shecar sample not available ({e:#}): the shecar and warp sets were skipped"
            );
            notes.push(note);
            progress.inc((2 * n) as u64);
        }
    }
    results.seeds = pairs.iter().map(|p| p.seed).collect();

    let tmp = settings.out.root().join(".opencv-ref-tmp");
    if reference.is_some() {
        std::fs::create_dir_all(&tmp).with_context(|| format!("creating {}", tmp.display()))?;
    }
    let mut scores: Vec<PairScore> = Vec::new();
    let mut pictures: BTreeMap<(PairSet, String), PathBuf> = BTreeMap::new();
    for pair in &pairs {
        progress.message(pair.label.clone());
        let set = pair.set.name();
        let mut outputs: Vec<(String, Result<MethodOutput>)> = methods
            .iter()
            .map(|v| {
                (
                    v.name.clone(),
                    run_method(pair, v).map_err(anyhow::Error::from),
                )
            })
            .collect();
        if let Some((python, script)) = &reference {
            outputs.push((
                OPENCV_METHOD.to_owned(),
                run_opencv(pair, python, script, &tmp),
            ));
        }
        for (name, output) in outputs {
            refusals.attempt(set, &name);
            let score_and_flags = match output {
                Err(e) => Err(format!("{e:#}")),
                Ok(o) if o.accepted.is_empty() => Err("no accepted match".to_owned()),
                Ok(o) => Ok((score(pair, &name, &o), o)),
            };
            match score_and_flags {
                Err(reason) => {
                    refusals.refuse(set, &name, &reason);
                    scores.push(refused_score(pair, &name, reason));
                }
                Ok(((s, flags), o)) => {
                    let key = (pair.set, name.clone());
                    if let std::collections::btree_map::Entry::Vacant(slot) = pictures.entry(key) {
                        let path = settings.out.image(&format!("{set}_{name}.png"));
                        draw(pair, &o, &flags, &path)?;
                        slot.insert(path);
                    }
                    scores.push(s);
                }
            }
            progress.inc(1);
        }
    }
    if reference.is_some() {
        let _ = std::fs::remove_dir_all(&tmp);
    }
    progress.finish();

    // Summaries per (set, method), in set then method order.
    let sets: Vec<PairSet> = {
        let mut s: Vec<PairSet> = pairs.iter().map(|p| p.set).collect();
        s.dedup();
        s
    };
    let mut summaries = Vec::new();
    for &set in &sets {
        for m in &method_names {
            let cell: Vec<&PairScore> = scores
                .iter()
                .filter(|s| s.set == set && &s.method == m)
                .collect();
            summaries.push(summarise(set, m, &cell));
        }
    }

    let report = write_report(
        settings,
        n,
        &sets,
        &method_names,
        &summaries,
        &scores,
        &refusals,
        &pictures,
        &notes,
        reference.is_some(),
    )?;
    results.section("summary", &summaries)?;
    results.section("pairs", &scores)?;
    results.section("refusals", &refusals)?;
    results.section("notes", &notes)?;
    results.write(settings.out.root())?;
    let path = report.write(settings.out.root())?;
    crate::cmd::print_stdout(&format!("wrote {}", path.display()))?;
    Ok(())
}

#[allow(clippy::too_many_arguments)] // One call site; the report needs all of it.
fn write_report(
    settings: &Settings,
    n: usize,
    sets: &[PairSet],
    methods: &[String],
    summaries: &[CellSummary],
    scores: &[PairScore],
    refusals: &RefusalCounter,
    pictures: &BTreeMap<(PairSet, String), PathBuf>,
    notes: &[String],
    with_reference: bool,
) -> Result<Report> {
    let mut r = Report::new("Experiment: feature matchers on pairs with known geometry");
    r.paragraph(&format!(
        "{n} seeded pairs per set (seed {}), image scale {}. A match is **true** when the \
         geometry puts it within {TRUE_MATCH_PX} px (never the method's own verdict); the true \
         rate is true / judged matches. Spread: fraction of the {SPREAD_GRID}x{SPREAD_GRID} \
         grid cells over image A holding a true match. Time: detect + match + filter, one \
         run each on this machine (median over pairs). Refused: the method errored or \
         accepted no match (its rate is then left out, its counts are 0).{}",
        settings.seed,
        settings.image_scale,
        if with_reference {
            format!(
                " `{OPENCV_METHOD}`: OpenCV {FEATURES}-feature ORB + BFMatcher + matchGMS \
                 (scripts/features/opencv_ref.py), judged the same way; no time (process start-up)."
            )
        } else {
            " (OpenCV reference column not run: no .venv-ref or --no-reference.)".to_owned()
        }
    ));
    for note in notes {
        r.paragraph(&format!("Note: {note}"));
    }
    for &set in sets {
        r.heading(&format!(
            "{} pairs: judged by {}",
            set.name(),
            set.judged_by()
        ));
        let shecar = set == PairSet::Shecar;
        let mut head = vec![
            "method",
            "refused",
            "keypoints",
            "matches",
            "true matches",
            "true rate (median [q1, q3])",
            "pooled rate",
            "spread",
            "time ms",
        ];
        if shecar {
            head.push("epipolar-consistent");
        }
        let mut t = Table::new(&head);
        for s in summaries.iter().filter(|s| s.set == set) {
            let cell = refusals.cell(set.name(), &s.method);
            let mut row = vec![
                s.method.clone(),
                cell.fraction(),
                fmt_num(s.keypoints.median, 0),
                fmt_num(s.matches.median, 0),
                fmt_num(s.true_matches.median, 0),
                format!(
                    "{} [{}, {}]",
                    fmt_pct(s.true_rate.median, 1),
                    fmt_pct(s.true_rate.q1, 1),
                    fmt_pct(s.true_rate.q3, 1)
                ),
                fmt_pct(s.pooled_true_rate, 1),
                fmt_num(s.spread.median, 2),
                fmt_num(s.time_ms.median, 1),
            ];
            if let Some(e) = &s.epipolar_rate {
                row.push(fmt_pct(e.median, 1));
            }
            t.row(row);
        }
        r.table(&t);
        let reasons: Vec<String> = methods
            .iter()
            .flat_map(|m| {
                refusals
                    .cell(set.name(), m)
                    .reasons
                    .into_iter()
                    .map(move |(why, k)| format!("{m}: {k} x {why}"))
            })
            .collect();
        if !reasons.is_empty() {
            r.paragraph(&format!("Refusals: {}.", reasons.join("; ")));
        }
        for m in methods {
            if let Some(p) = pictures.get(&(set, m.clone())) {
                r.image(
                    &format!(
                        "{} {m}: accepted matches, green when the geometry confirms them, red \
                         otherwise{}",
                        set.name(),
                        if set == PairSet::Shecar {
                            " (or off the board, not judged)"
                        } else {
                            ""
                        }
                    ),
                    &settings.out.relative(p),
                );
            }
        }
    }

    // Plots: bars of the median true rate and true matches, box plots of the rate.
    let categories: Vec<String> = sets.iter().map(|s| s.name().to_owned()).collect();
    let per_method = |f: &dyn Fn(&CellSummary) -> f64| -> Vec<(String, Vec<f64>)> {
        methods
            .iter()
            .map(|m| {
                let v = sets
                    .iter()
                    .map(|&set| {
                        summaries
                            .iter()
                            .find(|s| s.set == set && &s.method == m)
                            .map_or(f64::NAN, f)
                    })
                    .collect();
                (m.clone(), v)
            })
            .collect()
    };
    r.heading("Plots");
    let rate_bars = viz::plots::BarChart {
        title: "Median true inlier rate per pair set".into(),
        x_label: "pair set".into(),
        y_label: "true matches / judged matches".into(),
        categories: categories.clone(),
        series: per_method(&|s| s.true_rate.median),
    };
    let files = viz::plots::write_bar_chart(&rate_bars, &settings.out.plot_stem("true_rate"))?;
    r.image("median true rate", &settings.out.relative(&files.png));
    let count_bars = viz::plots::BarChart {
        title: "Median number of true matches per pair".into(),
        x_label: "pair set".into(),
        y_label: "true matches".into(),
        categories: categories.clone(),
        series: per_method(&|s| s.true_matches.median),
    };
    let files = viz::plots::write_bar_chart(&count_bars, &settings.out.plot_stem("true_matches"))?;
    r.image("median true matches", &settings.out.relative(&files.png));
    let samples = |f: &dyn Fn(&PairScore) -> f64| -> Vec<Vec<Vec<f64>>> {
        sets.iter()
            .map(|&set| {
                methods
                    .iter()
                    .map(|m| {
                        scores
                            .iter()
                            .filter(|s| s.set == set && &s.method == m && s.refused.is_none())
                            .map(f)
                            .collect()
                    })
                    .collect()
            })
            .collect()
    };
    let rate_box = viz::plots::BoxPlot {
        title: "True inlier rate per pair".into(),
        x_label: "pair set".into(),
        y_label: "true matches / judged matches".into(),
        conditions: categories.clone(),
        methods: methods.to_vec(),
        samples: samples(&|s| s.true_rate),
    };
    let files = viz::plots::write_box_plot(&rate_box, &settings.out.plot_stem("true_rate_box"))?;
    r.image("true rate per pair", &settings.out.relative(&files.png));
    let time_box = viz::plots::BoxPlot {
        title: "Time per pair (detect + match + filter)".into(),
        x_label: "pair set".into(),
        y_label: "ms".into(),
        conditions: categories,
        methods: methods.to_vec(),
        samples: samples(&|s| s.time_ms),
    };
    let files = viz::plots::write_box_plot(&time_box, &settings.out.plot_stem("time_box"))?;
    r.image("time per pair", &settings.out.relative(&files.png));

    r.heading("Per pair");
    let mut t = Table::new(&[
        "pair",
        "method",
        "keypoints A",
        "matches",
        "judged",
        "true",
        "rate",
        "spread",
        "ms",
    ])
    .align(1, super::report::Align::Left);
    for s in scores {
        t.row(vec![
            s.pair.clone(),
            s.method.clone(),
            s.keypoints_a.to_string(),
            s.matches.to_string(),
            s.judged.to_string(),
            s.true_matches.to_string(),
            s.refused
                .as_ref()
                .map_or_else(|| fmt_pct(s.true_rate, 1), |why| format!("refused: {why}")),
            fmt_num(s.spread, 2),
            fmt_num(s.time_ms, 1),
        ]);
    }
    r.table(&t);
    Ok(r)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn homography_truth_accepts_within_three_pixels_only() {
        let h = Matrix3::new(1.0, 0.0, 10.0, 0.0, 1.0, -5.0, 0.0, 0.0, 1.0);
        let t = Truth::Homography(h);
        assert_eq!(t.judge((100.0, 100.0), (110.0, 95.0)), Verdict::True);
        assert_eq!(t.judge((100.0, 100.0), (112.9, 95.0)), Verdict::True);
        assert_eq!(t.judge((100.0, 100.0), (113.1, 95.0)), Verdict::False);
    }

    #[test]
    fn depth_truth_projects_and_checks_occlusion() {
        // Camera B is A moved 0.1 m along -x (so points move right in B by f * 0.1 / z).
        let camera = CameraIntrinsics {
            k1: 0.0,
            k2: 0.0,
            p1: 0.0,
            p2: 0.0,
            k3: 0.0,
            ..CameraIntrinsics::wrist()
        }
        .scaled(0.125)
        .expect("camera");
        let n = (camera.width * camera.height) as usize;
        let b_from_a = Isometry3::translation(0.1, 0.0, 0.0);
        let mut t = DepthTruth {
            camera,
            depth_a: vec![1.0; n],
            depth_b: vec![1.0; n],
            b_from_a,
        };
        let a = (80.0, 64.0);
        let shift = camera.fx * 0.1;
        let b = (80.0 + shift, 64.0);
        assert_eq!(t.judge(a, b), Verdict::True);
        assert_eq!(t.judge(a, (b.0 + 5.0, b.1)), Verdict::False);
        // An occluder at 0.5 m in front of the point in B: not visible, so not true.
        t.depth_b = vec![0.5; n];
        assert_eq!(t.judge(a, b), Verdict::False);
        // No depth in A: not judged.
        t.depth_a = vec![f32::NAN; n];
        assert_eq!(t.judge(a, b), Verdict::Unjudged);
    }

    #[test]
    fn warp_moves_pixels_by_the_homography() {
        let img = GrayImage::from_fn(64, 48, |x, y| image::Luma([((x * 7 + y * 3) % 256) as u8]));
        let h = Matrix3::new(1.0, 0.0, 5.0, 0.0, 1.0, 3.0, 0.0, 0.0, 1.0);
        let w = warp(&img, &h, 1).expect("warp");
        // B(x + 5, y + 3) = A(x, y) up to the 2-level noise.
        let diff = i32::from(w.get_pixel(25, 23).0[0]) - i32::from(img.get_pixel(20, 20).0[0]);
        assert!(diff.abs() <= 8, "diff {diff}");
        assert_eq!(w.get_pixel(0, 0).0[0], 0);
    }

    #[test]
    fn score_counts_spread_and_rates() {
        let pair = ImagePair {
            set: PairSet::Warp,
            label: "t".into(),
            seed: 0,
            a: GrayImage::new(80, 80),
            b: GrayImage::new(80, 80),
            truth: Truth::Homography(Matrix3::identity()),
        };
        let kp = |x: f32, y: f32| Keypoint {
            x,
            y,
            level: 0,
            angle_rad: 0.0,
            response: 0.0,
            size: 31.0,
        };
        let out = MethodOutput {
            keypoints_a: vec![kp(5.0, 5.0), kp(75.0, 75.0), kp(40.0, 40.0)],
            keypoints_b: vec![kp(5.0, 6.0), kp(75.0, 75.0), kp(60.0, 40.0)],
            accepted: (0..3)
                .map(|i| Match {
                    query: i,
                    train: i,
                    distance: 0,
                })
                .collect(),
            n_keypoints_a: 3,
            n_keypoints_b: 3,
            time_ms: 1.0,
        };
        let (s, flags) = score(&pair, "x", &out);
        assert_eq!((s.matches, s.judged, s.true_matches), (3, 3, 2));
        assert_eq!(flags, vec![true, true, false]);
        assert!((s.true_rate - 2.0 / 3.0).abs() < 1e-12);
        assert!((s.spread - 2.0 / 64.0).abs() < 1e-12);
    }
}
