//! The OpenCV depth-PnP peer of our RGB-D self-calibration (`scripts/opencv_peer_selfcal.py`,
//! stock OpenCV: SIFT, ratio test, `solvePnPRansac` + `solvePnPRefineLM` of each pair's
//! matches on the first view's depth, a maximum spanning tree of the pairs, then
//! `calibrateHandEye` with its five solvers), run on the very pixels our calibration saw:
//! the views, noise included, are written to a folder (`views.json`, gray PNGs, raw float
//! depth) that the script reads instead of a recording.
//!
//! It answers one question of the noise experiment: with depth noise along the ray, does our
//! RGB-D calibration stay ahead of the obvious OpenCV pipeline on the same views? Its
//! figures are the peer's best solver per level, so the comparison favours the peer.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, Result, bail};
use calib::relpose::CameraModel;
use calib::selfcal::CalibView;
use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use super::noise::PoseErrors;

/// The peer's hand-eye solvers (OpenCV's `CALIB_HAND_EYE_*`), as named in its JSON.
pub const SOLVERS: [&str; 5] = ["tsai", "park", "horaud", "andreff", "daniilidis"];

/// The peer's answer on one set of views: each solver's errors against the true mount, or
/// the peer's refusal (its last line of stderr).
pub type PeerOutcome = Result<Vec<(String, PoseErrors)>, String>;

/// The reference Python and the peer script, found as the other reference columns are.
#[derive(Clone, Debug)]
pub struct Peer {
    python: PathBuf,
    script: PathBuf,
    /// A folder of its own for the views of each run (under the experiment's output).
    tmp: PathBuf,
}

impl Peer {
    /// The peer when the reference venv and the script are there (`None` otherwise, or with
    /// `--no-reference`); `tmp` is created and holds one run's views at a time.
    ///
    /// # Errors
    /// Creating `tmp`.
    pub fn find(reference: bool, tmp: PathBuf) -> Result<Option<Self>> {
        if !reference {
            return Ok(None);
        }
        let Some((python, script)) =
            super::reference_python().zip(super::source_script("scripts/opencv_peer_selfcal.py"))
        else {
            return Ok(None);
        };
        std::fs::create_dir_all(&tmp).with_context(|| format!("creating {}", tmp.display()))?;
        Ok(Some(Self {
            python,
            script,
            tmp,
        }))
    }

    /// Runs the peer in RGB-D mode on `views` seen by `camera`, scored against `truth`.
    /// `tag` names the run's folder (removed afterwards).
    ///
    /// # Errors
    /// Writing the views or starting the script; the peer's own refusal is an `Ok(Err(..))`.
    pub fn run(
        &self,
        views: &[CalibView],
        camera: &CameraModel,
        truth: &Isometry3<f64>,
        tag: &str,
    ) -> Result<PeerOutcome> {
        let dir = self.tmp.join(tag);
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        write_views(&dir, views, camera)?;
        let out = Command::new(&self.python)
            .arg(&self.script)
            .arg(&dir)
            .args(["--mode", "rgbd", "--threads", "2"])
            .output()
            .with_context(|| format!("running {}", self.script.display()));
        let _ = std::fs::remove_dir_all(&dir);
        let out = out?;
        if !out.status.success() {
            let err = String::from_utf8_lossy(&out.stderr);
            let last = err
                .lines()
                .rev()
                .find(|l| !l.trim().is_empty())
                .unwrap_or("");
            return Ok(Err(format!("the peer refused: {}", last.trim())));
        }
        let answer: PeerAnswer =
            serde_json::from_slice(&out.stdout).context("parsing opencv_peer_selfcal.py output")?;
        SOLVERS
            .iter()
            .map(|&name| {
                let r = answer
                    .methods
                    .get(name)
                    .with_context(|| format!("the peer's output has no {name}"))?;
                Ok((name.to_owned(), PoseErrors::of(&r.isometry()?, truth)))
            })
            .collect::<Result<Vec<_>>>()
            .map(Ok)
    }
}

impl Drop for Peer {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir(&self.tmp);
    }
}

/// `opencv_peer_selfcal.py`'s JSON (the fields used).
#[derive(Deserialize)]
struct PeerAnswer {
    methods: std::collections::BTreeMap<String, PeerSolution>,
}

#[derive(Deserialize)]
struct PeerSolution {
    translation_m: [f64; 3],
    rotation: [[f64; 3]; 3],
}

impl PeerSolution {
    /// `tool0_from_camera`; the rotation re-orthonormalised (it comes through decimal JSON).
    fn isometry(&self) -> Result<Isometry3<f64>> {
        let m = Matrix3::from_fn(|i, j| self.rotation[i][j]);
        if !m.iter().all(|v| v.is_finite()) || !self.translation_m.iter().all(|v| v.is_finite()) {
            bail!("the peer answered a non-finite pose");
        }
        let r = Rotation3::from_matrix_eps(&m, 1e-12, 100, Rotation3::identity());
        Ok(Isometry3::from_parts(
            Translation3::from(Vector3::from(self.translation_m)),
            UnitQuaternion::from_rotation_matrix(&r),
        ))
    }
}

/// `views.json` (module docs of the script).
#[derive(Serialize)]
struct ViewsFile {
    k: [f64; 9],
    dist: [f64; 5],
    views: Vec<ViewEntry>,
}

#[derive(Serialize)]
struct ViewEntry {
    gray: String,
    depth: Option<String>,
    width: u32,
    height: u32,
    base_from_tool0: [f64; 16],
}

/// Writes `views` into `dir` as the script reads them.
fn write_views(dir: &Path, views: &[CalibView], camera: &CameraModel) -> Result<()> {
    let mut entries = Vec::with_capacity(views.len());
    for (i, v) in views.iter().enumerate() {
        let gray = format!("v{i:02}.png");
        v.gray
            .save(dir.join(&gray))
            .with_context(|| format!("writing {gray}"))?;
        let depth = match &v.depth_m {
            Some(d) => {
                let name = format!("v{i:02}.f32");
                let bytes: Vec<u8> = d.iter().flat_map(|z| z.to_le_bytes()).collect();
                std::fs::write(dir.join(&name), bytes)
                    .with_context(|| format!("writing {name}"))?;
                Some(name)
            }
            None => None,
        };
        let m = v.base_from_tool0.to_homogeneous();
        entries.push(ViewEntry {
            gray,
            depth,
            width: v.gray.width(),
            height: v.gray.height(),
            base_from_tool0: std::array::from_fn(|k| m[(k / 4, k % 4)]),
        });
    }
    let c = camera;
    let file = ViewsFile {
        k: [c.fx, 0.0, c.cx, 0.0, c.fy, c.cy, 0.0, 0.0, 1.0],
        dist: [c.k1, c.k2, c.p1, c.p2, c.k3],
        views: entries,
    };
    let json = serde_json::to_vec_pretty(&file).context("encoding views.json")?;
    std::fs::write(dir.join("views.json"), json).context("writing views.json")
}

/// One level's comparison: over the trials where both answered, ours' medians and the peer's
/// best solver's (the solver with the smallest median rotation error there).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LevelComparison {
    /// The condition (e.g. `sigma=0.10`).
    pub condition: String,
    /// Trials where ours and the peer both answered.
    pub trials: usize,
    /// The peer's refusals, of the trials it ran.
    pub peer_refused: usize,
    /// Trials the peer ran at this level.
    pub peer_runs: usize,
    /// Of those, the trials ours answered.
    pub ours_answered: usize,
    /// Ours' median rotation error, degrees.
    pub ours_deg: f64,
    /// Ours' median translation error, mm.
    pub ours_mm: f64,
    /// The peer's best solver; `-` where no trial had answers from both to compare.
    pub peer_solver: String,
    /// Its median rotation error, degrees.
    pub peer_deg: f64,
    /// Its median translation error, mm.
    pub peer_mm: f64,
}

impl LevelComparison {
    /// Ours ahead: it answered at least as often as the peer, and over the trials both
    /// answered its medians are smaller on both rotation and translation (when there are none,
    /// it answered and the peer did not).
    pub fn ahead(&self) -> bool {
        let peer_answered = self.peer_runs - self.peer_refused;
        if self.ours_answered < peer_answered {
            return false;
        }
        if self.trials == 0 {
            return self.ours_answered > 0;
        }
        self.ours_deg < self.peer_deg && self.ours_mm < self.peer_mm
    }
}

/// Compares `ours[t]` (ours-rgbd's outcome at trial `t`) with `peer[t]` at one level.
pub fn compare_level(
    condition: &str,
    ours: &[Option<&PoseErrors>],
    peer: &[Option<&PeerOutcome>],
) -> LevelComparison {
    let mut ours_deg = Vec::new();
    let mut ours_mm = Vec::new();
    let mut per_solver: Vec<(Vec<f64>, Vec<f64>)> = vec![(Vec::new(), Vec::new()); SOLVERS.len()];
    let (mut peer_runs, mut peer_refused, mut ours_answered) = (0, 0, 0);
    for (o, p) in ours.iter().zip(peer) {
        let Some(p) = p else { continue };
        peer_runs += 1;
        ours_answered += usize::from(o.is_some());
        let Ok(solvers) = p else {
            peer_refused += 1;
            continue;
        };
        let Some(o) = o else { continue };
        ours_deg.push(o.theta_deg);
        ours_mm.push(o.e_t_mm);
        for (k, name) in SOLVERS.iter().enumerate() {
            if let Some((_, e)) = solvers.iter().find(|(n, _)| n == name) {
                per_solver[k].0.push(e.theta_deg);
                per_solver[k].1.push(e.e_t_mm);
            }
        }
    }
    let median = |v: &[f64]| super::stats::Summary::of(v).median;
    let (best, (peer_deg, peer_mm)) = per_solver
        .iter()
        .map(|(d, m)| (median(d), median(m)))
        .enumerate()
        .min_by(|a, b| a.1.0.total_cmp(&b.1.0))
        .unwrap_or((0, (f64::NAN, f64::NAN)));
    // With no trial both answered every median is NaN and no solver was best.
    let peer_solver = if peer_deg.is_finite() {
        SOLVERS[best].to_owned()
    } else {
        "-".to_owned()
    };
    LevelComparison {
        condition: condition.to_owned(),
        trials: ours_deg.len(),
        peer_refused,
        peer_runs,
        ours_answered,
        ours_deg: median(&ours_deg),
        ours_mm: median(&ours_mm),
        peer_solver,
        peer_deg,
        peer_mm,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn errors(theta_deg: f64, e_t_mm: f64) -> PoseErrors {
        PoseErrors {
            e_r: 0.0,
            theta_deg,
            e_t_mm,
            mahalanobis: None,
        }
    }

    fn peer_answer(park: (f64, f64), tsai: (f64, f64)) -> PeerOutcome {
        Ok(SOLVERS
            .iter()
            .map(|&n| {
                let (d, m) = match n {
                    "park" => park,
                    "tsai" => tsai,
                    _ => (9.0, 9.0),
                };
                (n.to_owned(), errors(d, m))
            })
            .collect())
    }

    #[test]
    fn a_level_compares_the_trials_both_answered_with_the_peers_best_solver() {
        let ours = [errors(0.02, 0.3), errors(0.04, 0.5), errors(0.03, 0.4)];
        let peer = [
            peer_answer((0.03, 0.2), (0.05, 0.1)),
            Err("the peer refused: only 2 views".to_owned()),
            peer_answer((0.05, 0.6), (0.06, 0.2)),
        ];
        let ours_refs: Vec<_> = [Some(&ours[0]), Some(&ours[1]), None].into_iter().collect();
        let peer_refs: Vec<_> = peer.iter().map(Some).collect();
        let c = compare_level("sigma=0.10", &ours_refs, &peer_refs);
        // Trial 1: the peer refused; trial 2: ours refused: only trial 0 counts.
        assert_eq!((c.trials, c.peer_runs, c.peer_refused), (1, 3, 1));
        assert_eq!(c.ours_answered, 2);
        assert_eq!(c.peer_solver, "park");
        assert_eq!(
            (c.ours_deg, c.ours_mm, c.peer_deg, c.peer_mm),
            (0.02, 0.3, 0.03, 0.2)
        );
        // Ahead on rotation, behind on translation: not ahead.
        assert!(!c.ahead());
        let smaller_t = LevelComparison {
            ours_mm: 0.1,
            ..c.clone()
        };
        assert!(smaller_t.ahead());
        // Answering less often than the peer is behind, whatever the medians.
        assert!(
            !LevelComparison {
                ours_answered: 1,
                ..smaller_t.clone()
            }
            .ahead()
        );
        // Where the peer refused every trial, ours answering is ahead.
        let alone = LevelComparison {
            trials: 0,
            peer_refused: 3,
            ours_deg: f64::NAN,
            ..smaller_t
        };
        assert!(alone.ahead());
        // A level where the peer answered nothing names no solver.
        let refused: PeerOutcome = Err("the peer refused".to_owned());
        let none = compare_level("sigma=0.30", &ours_refs, &[Some(&refused); 3]);
        assert_eq!((none.trials, none.peer_solver.as_str()), (0, "-"));
        assert!(
            !LevelComparison {
                ours_answered: 0,
                ..alone
            }
            .ahead()
        );
    }

    #[test]
    fn the_peer_reads_what_is_written() {
        let dir = tempfile::tempdir().expect("tempdir");
        let gray = image::GrayImage::from_fn(4, 3, |x, y| image::Luma([(x + 4 * y) as u8]));
        let view = CalibView {
            stamp_ns: 1,
            gray,
            depth_m: Some((0..12).map(|k| k as f32 * 0.25).collect()),
            base_from_tool0: Isometry3::translation(0.1, 0.2, 0.3),
        };
        let cam = CameraModel::pinhole(4, 3, 100.0, 101.0, 2.0, 1.5);
        write_views(dir.path(), &[view], &cam).expect("write");
        let spec: serde_json::Value = serde_json::from_slice(
            &std::fs::read(dir.path().join("views.json")).expect("views.json"),
        )
        .expect("json");
        assert_eq!(spec["k"][0], 100.0);
        assert_eq!(spec["views"][0]["base_from_tool0"][3], 0.1);
        assert_eq!(spec["views"][0]["base_from_tool0"][7], 0.2);
        let depth = std::fs::read(dir.path().join("v00.f32")).expect("depth");
        assert_eq!(depth.len(), 48);
        assert_eq!(
            f32::from_le_bytes([depth[4], depth[5], depth[6], depth[7]]),
            0.25
        );
    }
}
