//! The folder dataset of ARCHITECTURE.md section 5:
//!
//! ```text
//! DIR/camera.yaml         fx, fy, cx, cy, k1, k2, p1, p2, k3, width, height (flat `key: value`)
//! DIR/images/NNNNNN.png   (or .jpg) colour or grey images
//! DIR/depth/NNNNNN.png    optional, 16-bit, millimetres, registered to the image
//! DIR/hand_poses.txt      TUM (`timestamp tx ty tz qx qy qz qw`), base_from_tool0,
//!                         timestamp = image index
//! ```

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use calib::handeye::pose_file::parse_tum;

use super::{CameraModel, Dataset, View};

/// Reads a folder dataset (no pixels are decoded here).
///
/// # Errors
/// Missing or malformed `camera.yaml` (naming the key), malformed pose file (with its line),
/// a hand pose whose image is missing, a timestamp that is not an image index.
pub fn read(dir: &Path) -> Result<Dataset> {
    let camera = read_camera_yaml(&dir.join("camera.yaml"))?;
    let poses_path = dir.join("hand_poses.txt");
    let text = std::fs::read_to_string(&poses_path)
        .with_context(|| format!("cannot read {}", poses_path.display()))?;
    let poses = parse_tum(&text).with_context(|| format!("in {}", poses_path.display()))?;
    if poses.is_empty() {
        bail!("{} has no poses", poses_path.display());
    }
    let mut views = Vec::with_capacity(poses.len());
    let mut previous: Option<u64> = None;
    for pose in &poses {
        let t = pose.timestamp;
        if !(t >= 0.0 && t.fract() == 0.0 && t < 1e6) {
            bail!(
                "{}: timestamp {t} is not an image index (0..999999)",
                poses_path.display()
            );
        }
        let index = t as u64;
        if previous.is_some_and(|p| index <= p) {
            bail!(
                "{}: image indices must increase, {index} follows {}",
                poses_path.display(),
                previous.unwrap_or(0)
            );
        }
        previous = Some(index);
        let image = find_image(&dir.join("images"), index)?;
        let depth_path = dir.join("depth").join(format!("{index:06}.png"));
        views.push(View {
            image,
            depth: depth_path.is_file().then_some(depth_path),
            base_from_tool0: pose.pose,
        });
    }
    Ok(Dataset {
        source: "folder",
        origin: dir.display().to_string(),
        camera,
        views,
    })
}

fn find_image(images: &Path, index: u64) -> Result<PathBuf> {
    for ext in ["png", "jpg", "jpeg"] {
        let p = images.join(format!("{index:06}.{ext}"));
        if p.is_file() {
            return Ok(p);
        }
    }
    bail!(
        "no image {}/{index:06}.(png|jpg) for hand pose {index}",
        images.display()
    )
}

/// Parses the flat `key: value` camera file (comments after `#`).
fn read_camera_yaml(path: &Path) -> Result<CameraModel> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut values = BTreeMap::new();
    for (i, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let Some((key, value)) = line.split_once(':') else {
            bail!(
                "{}:{}: expected `key: value`, got {raw:?}",
                path.display(),
                i + 1
            );
        };
        let value: f64 = value.trim().parse().with_context(|| {
            format!(
                "{}:{}: {} is not a number",
                path.display(),
                i + 1,
                value.trim()
            )
        })?;
        if !value.is_finite() {
            bail!("{}:{}: {key} is not finite", path.display(), i + 1);
        }
        values.insert(key.trim().to_owned(), value);
    }
    let get = |key: &str| -> Result<f64> {
        values
            .get(key)
            .copied()
            .with_context(|| format!("{}: missing `{key}`", path.display()))
    };
    let dim = |key: &str| -> Result<u32> {
        let v = get(key)?;
        if !(v >= 1.0 && v.fract() == 0.0 && v <= 65535.0) {
            bail!("{}: {key} = {v} is not an image size", path.display());
        }
        Ok(v as u32)
    };
    let fx = get("fx")?;
    let fy = get("fy")?;
    if fx <= 0.0 || fy <= 0.0 {
        bail!(
            "{}: focal lengths must be positive (fx {fx}, fy {fy})",
            path.display()
        );
    }
    let opt = |key: &str| values.get(key).copied().unwrap_or(0.0);
    let camera = CameraModel::pinhole(
        dim("width")?,
        dim("height")?,
        fx,
        fy,
        get("cx")?,
        get("cy")?,
    );
    Ok(camera.with_distortion([opt("k1"), opt("k2"), opt("p1"), opt("p2"), opt("k3")]))
}
