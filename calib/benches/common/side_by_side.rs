//! What the detector benches share to compare rodlog with OpenCV on the same pixels in the
//! same run: the venv's Python on the frame pair saved as PNGs, its JSON answer, and the
//! metrics both sides are scored with (repeatability under the known warp, medians).

use std::path::{Path, PathBuf};
use std::process::Command;

use calib::features::GrayBuf;
use calib::features::synth::apply_homography;
use nalgebra::Matrix3;

/// Repeatability: a keypoint is repeated when one of the other image lies within this many
/// pixels of its mapped position.
pub const REPEAT_PX: f64 = 2.5;

/// The OpenCV side of a comparison: the venv's Python and the frame pair saved for it.
pub struct OpenCvSide {
    python: PathBuf,
    a_png: PathBuf,
    b_png: PathBuf,
}

impl OpenCvSide {
    /// Saves `a` and `b` to `target/<dir_name>/{a,b}.png`; `None` (with a note) when the
    /// venv's Python is missing or the files cannot be written.
    pub fn prepare(dir_name: &str, a: &GrayBuf, b: &GrayBuf) -> Option<Self> {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let dir = root.join("target").join(dir_name);
        let python = root.join(".venv-ref/bin/python");
        let (a_png, b_png) = (dir.join("a.png"), dir.join("b.png"));
        let saved = std::fs::create_dir_all(&dir).is_ok()
            && [(a, &a_png), (b, &b_png)].iter().all(|(img, p)| {
                image::GrayImage::from_raw(img.width as u32, img.height as u32, img.data.clone())
                    .is_some_and(|g| g.save(p).is_ok())
            });
        if !saved || !python.exists() {
            eprintln!(
                "OpenCV comparison skipped (no {} or cannot write {})",
                python.display(),
                dir.display()
            );
            return None;
        }
        Some(Self {
            python,
            a_png,
            b_png,
        })
    }

    /// Runs `script` with the arguments `a.png b.png runs` and parses the JSON it prints;
    /// `None` (with the reason) when it cannot run or prints no JSON.
    pub fn run(&self, script: &str, runs: usize) -> Option<serde_json::Value> {
        let out = Command::new(&self.python)
            .arg("-c")
            .arg(script)
            .arg(&self.a_png)
            .arg(&self.b_png)
            .arg(runs.to_string())
            .output();
        let Ok(out) = out else {
            eprintln!(
                "OpenCV comparison skipped: cannot run {}",
                self.python.display()
            );
            return None;
        };
        let parsed = serde_json::from_slice::<serde_json::Value>(&out.stdout);
        if parsed.is_err() {
            eprintln!(
                "OpenCV comparison failed: {}",
                String::from_utf8_lossy(&out.stderr)
            );
        }
        parsed.ok()
    }
}

/// The rows of `v[key]` that are arrays of exactly `n` numbers.
#[allow(dead_code)] // not every bench reads rows (the SIFT bench does: its match pairs)
pub fn json_rows(v: &serde_json::Value, key: &str, n: usize) -> Vec<Vec<f64>> {
    v[key]
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(|p| {
                    let r: Vec<f64> = p.as_array()?.iter().filter_map(|x| x.as_f64()).collect();
                    (r.len() == n).then_some(r)
                })
                .collect()
        })
        .unwrap_or_default()
}

/// `v[key]` as `(x, y)` points: the first two numbers of each row (rows may carry more,
/// e.g. size and angle).
pub fn json_points(v: &serde_json::Value, key: &str) -> Vec<(f64, f64)> {
    v[key]
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(|p| Some((p.get(0)?.as_f64()?, p.get(1)?.as_f64()?)))
                .collect()
        })
        .unwrap_or_default()
}

/// `v[key]` as a list of numbers (timings, ms).
pub fn json_numbers(v: &serde_json::Value, key: &str) -> Vec<f64> {
    v[key]
        .as_array()
        .map(|a| a.iter().filter_map(serde_json::Value::as_f64).collect())
        .unwrap_or_default()
}

/// The median (upper middle for even counts); NaN when empty.
pub fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

/// Repeatability of `ka` (image A) and `kb` (image B) under `b_from_a` in a `w` x `hgt`
/// image: keypoints repeated within [`REPEAT_PX`] over the smaller of the two counts in the
/// common region; also returns those counts.
pub fn repeatability(
    ka: &[(f64, f64)],
    kb: &[(f64, f64)],
    h: &Matrix3<f64>,
    w: f64,
    hgt: f64,
) -> (f64, usize, usize) {
    let Some(hinv) = h.try_inverse() else {
        return (0.0, 0, 0);
    };
    let inside = |(x, y): (f64, f64)| x >= 0.0 && y >= 0.0 && x < w && y < hgt;
    let a_common: Vec<(f64, f64)> = ka
        .iter()
        .map(|p| apply_homography(h, p.0, p.1))
        .filter(|p| inside(*p))
        .collect();
    let b_common: Vec<(f64, f64)> = kb
        .iter()
        .copied()
        .filter(|p| inside(*p) && inside(apply_homography(&hinv, p.0, p.1)))
        .collect();
    let cell = REPEAT_PX;
    let gw = (w / cell).ceil() as usize + 1;
    let gh = (hgt / cell).ceil() as usize + 1;
    let mut grid: Vec<Vec<(f64, f64)>> = vec![Vec::new(); gw * gh];
    for p in &b_common {
        grid[(p.1 / cell) as usize * gw + (p.0 / cell) as usize].push(*p);
    }
    let mut repeated = 0usize;
    for (x, y) in &a_common {
        let (cx, cy) = ((x / cell) as isize, (y / cell) as isize);
        let mut hit = false;
        for dy in -1..=1 {
            for dx in -1..=1 {
                let (gx, gy) = (cx + dx, cy + dy);
                if gx < 0 || gy < 0 || gx as usize >= gw || gy as usize >= gh {
                    continue;
                }
                hit |= grid[gy as usize * gw + gx as usize]
                    .iter()
                    .any(|q| (q.0 - x).hypot(q.1 - y) <= REPEAT_PX);
            }
        }
        repeated += usize::from(hit);
    }
    let denom = a_common.len().min(b_common.len()).max(1);
    (
        repeated as f64 / denom as f64,
        a_common.len(),
        b_common.len(),
    )
}
