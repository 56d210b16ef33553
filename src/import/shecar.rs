//! ZHI's public sample layout (`../shared/data/shecar`, the paper's "dataset 2"):
//!
//! - `NN.jpg`: the views, in index order;
//! - `handposes.txt`: one line per view, 12 comma-separated numbers: a 3x4 `[R | t]` stored
//!   column by column (R's columns, then t), metres, `T_base_hand` = base_from_tool0;
//! - `intrinsic.txt` (Theia): one line per image `name f cx cy aspect skew k1 k2`, where
//!   Theia's pinhole radial model `x_d = x (1 + k1 r^2 + k2 r^4)` on normalised coordinates
//!   is plumb_bob with `p1 = p2 = k3 = 0`, and `fy = f * aspect`.

use std::path::Path;

use anyhow::{Context, Result, bail};
use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};

use super::{CameraModel, Dataset, View};

/// Reads the shecar layout (no pixels are decoded here; the size comes from the first JPEG's
/// header).
///
/// # Errors
/// Missing files, malformed lines (with their number), a rotation that is not orthonormal,
/// images of different intrinsics.
pub fn read(dir: &Path) -> Result<Dataset> {
    let poses_path = dir.join("handposes.txt");
    let text = std::fs::read_to_string(&poses_path)
        .with_context(|| format!("cannot read {}", poses_path.display()))?;
    let mut views = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = raw.trim();
        if line.is_empty() {
            continue;
        }
        let numbers: Vec<f64> = line
            .split(',')
            .map(|s| s.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .with_context(|| {
                format!(
                    "{}:{}: expected 12 comma-separated numbers",
                    poses_path.display(),
                    i + 1
                )
            })?;
        let Ok(n) = <[f64; 12]>::try_from(numbers.as_slice()) else {
            bail!(
                "{}:{}: expected 12 numbers, got {}",
                poses_path.display(),
                i + 1,
                numbers.len()
            );
        };
        let pose =
            base_from_hand(&n).with_context(|| format!("{}:{}", poses_path.display(), i + 1))?;
        let index = views.len();
        let image = dir.join(format!("{index:02}.jpg"));
        if !image.is_file() {
            bail!("no image {} for hand pose line {}", image.display(), i + 1);
        }
        views.push(View {
            image,
            depth: None,
            base_from_tool0: pose,
        });
    }
    let camera = read_intrinsics(
        &dir.join("intrinsic.txt"),
        views.first().map(|v| v.image.as_path()),
    )?;
    Ok(Dataset {
        source: "shecar",
        origin: dir.display().to_string(),
        camera,
        views,
    })
}

/// `[R | t]` from 12 numbers stored column by column.
fn base_from_hand(n: &[f64; 12]) -> Result<Isometry3<f64>> {
    if n.iter().any(|v| !v.is_finite()) {
        bail!("non-finite number in pose");
    }
    let r = Matrix3::new(n[0], n[3], n[6], n[1], n[4], n[7], n[2], n[5], n[8]);
    let orthonormality = (r.transpose() * r - Matrix3::identity()).abs().max();
    if orthonormality > 1e-4 || r.determinant() < 0.0 {
        bail!(
            "rotation is not a proper rotation (|R^T R - I| = {orthonormality:.2e}, det {:.4})",
            r.determinant()
        );
    }
    // Project to SO(3): the file's 6-7 significant digits leave ~1e-6 non-orthogonality.
    let rotation = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix(&r));
    Ok(Isometry3::from_parts(
        Translation3::from(Vector3::new(n[9], n[10], n[11])),
        rotation,
    ))
}

fn read_intrinsics(path: &Path, first_image: Option<&Path>) -> Result<CameraModel> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut camera: Option<[f64; 7]> = None;
    for (i, raw) in text.lines().enumerate() {
        let fields: Vec<&str> = raw.split_whitespace().collect();
        if fields.is_empty() {
            continue;
        }
        let [_, rest @ ..] = fields.as_slice() else {
            continue;
        };
        let values: Vec<f64> = rest
            .iter()
            .map(|s| s.parse::<f64>())
            .collect::<Result<_, _>>()
            .with_context(|| {
                format!(
                    "{}:{}: expected `name f cx cy aspect skew k1 k2`",
                    path.display(),
                    i + 1
                )
            })?;
        let Ok(v) = <[f64; 7]>::try_from(values.as_slice()) else {
            bail!(
                "{}:{}: expected 7 numbers after the name, got {}",
                path.display(),
                i + 1,
                values.len()
            );
        };
        match camera {
            None => camera = Some(v),
            Some(c) if c == v => {}
            Some(_) => bail!(
                "{}:{}: the images have different intrinsics; one camera is expected",
                path.display(),
                i + 1
            ),
        }
    }
    let Some([f, cx, cy, aspect, skew, k1, k2]) = camera else {
        bail!("{} has no intrinsics", path.display());
    };
    let Some(first) = first_image else {
        bail!("no images");
    };
    let (width, height) = image::image_dimensions(first)
        .with_context(|| format!("cannot read {}", first.display()))?;
    if skew != 0.0 {
        bail!(
            "{}: skew {skew} px: rodlog's camera model (pinhole + plumb_bob) has none; correct the images for it first",
            path.display()
        );
    }
    Ok(CameraModel::pinhole(width, height, f, f * aspect, cx, cy)
        .with_distortion([k1, k2, 0.0, 0.0, 0.0]))
}

/// Resize of the 3264x1836 shecar photos before `--image-scale` in the experiments (1306x734,
/// about the wrist camera's 1280x1024 pixel count).
pub const EXPERIMENT_SCALE: f64 = 0.4;
/// Smallest resize in the experiments (the chessboard must stay detectable).
pub const EXPERIMENT_MIN_SCALE: f64 = 0.2;

/// The shecar dataset as the experiments use it: read from `dir`, with the photos' resize
/// (`EXPERIMENT_SCALE x image_scale`, at least [`EXPERIMENT_MIN_SCALE`]) and calib's model of
/// the camera at that size.
pub struct Resized {
    /// The dataset (full-size photos on disk).
    pub dataset: Dataset,
    /// The resize factor.
    pub scale: f64,
    /// The camera of the resized photos (plumb_bob kept).
    pub camera: CameraModel,
}

/// Reads shecar for an experiment run at `image_scale` (see [`Resized`]).
///
/// # Errors
/// Those of [`read`].
pub fn open_resized(dir: &Path, image_scale: f64) -> Result<Resized> {
    let dataset = read(dir).with_context(|| format!("reading shecar at {}", dir.display()))?;
    let scale = (EXPERIMENT_SCALE * image_scale).max(EXPERIMENT_MIN_SCALE);
    let camera = dataset.camera.scaled(scale)?;
    Ok(Resized {
        dataset,
        scale,
        camera,
    })
}
