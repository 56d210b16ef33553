//! Pure conversions from rodlog messages to what the viewer draws: tightly packed pixels,
//! point positions, pinhole parameters, poses and the side-by-side match canvas.
//!
//! No rerun types here: the functions take message structs and return plain data, so they
//! are unit-tested without a recording stream ([`crate::sink`] turns them into archetypes).
//!
//! # Conventions
//! Poses are `parent_from_child` ([`Pose`]: translation in metres, unit quaternion
//! `(x, y, z, w)`), as in `geometry_msgs/Transform` and tf2. Pixels are row-major, origin at
//! the top-left pixel corner, `x` right, `y` down (OpenCV, `sensor_msgs/Image`).

use msgs::geometry_msgs::{Pose as PoseMsg, Transform};
use msgs::rodlog_msgs::FeatureMatches;
use msgs::sensor_msgs::{CameraInfo, Image, PointCloud2, PointField, image_encodings};

use crate::VizError;

/// A rigid transform `parent_from_child`: `p_parent = R(q) p_child + t`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// Translation (m).
    pub t: [f64; 3],
    /// Unit quaternion `(x, y, z, w)`.
    pub q: [f64; 4],
}

impl Pose {
    /// The identity.
    pub const IDENTITY: Self = Self {
        t: [0.0; 3],
        q: [0.0, 0.0, 0.0, 1.0],
    };

    /// From a `geometry_msgs/Transform`, quaternion normalised (a zero quaternion becomes the
    /// identity rotation).
    pub fn from_transform(tf: &Transform) -> Self {
        let r = tf.rotation;
        Self {
            t: [tf.translation.x, tf.translation.y, tf.translation.z],
            q: normalized([r.x, r.y, r.z, r.w]),
        }
    }

    /// From a `geometry_msgs/Pose` (the pose of a frame in its parent = `parent_from_frame`).
    pub fn from_pose(p: &PoseMsg) -> Self {
        let o = p.orientation;
        Self {
            t: [p.position.x, p.position.y, p.position.z],
            q: normalized([o.x, o.y, o.z, o.w]),
        }
    }

    /// `self * other`: `a_from_c = a_from_b * b_from_c`, i.e. `t = t_ab + R_ab t_bc`,
    /// `q = q_ab q_bc` (Hamilton product).
    pub fn compose(&self, other: &Pose) -> Pose {
        let r = rotate(self.q, other.t);
        Pose {
            t: [self.t[0] + r[0], self.t[1] + r[1], self.t[2] + r[2]],
            q: normalized(quat_mul(self.q, other.q)),
        }
    }

    /// `child_from_parent`: `q* `, `-R(q*) t`.
    pub fn inverse(&self) -> Pose {
        let q = [-self.q[0], -self.q[1], -self.q[2], self.q[3]];
        let t = rotate(q, self.t);
        Pose {
            t: [-t[0], -t[1], -t[2]],
            q,
        }
    }

    /// Translation as `f32` (the viewer's precision).
    pub fn t_f32(&self) -> [f32; 3] {
        [self.t[0] as f32, self.t[1] as f32, self.t[2] as f32]
    }

    /// Quaternion `(x, y, z, w)` as `f32`.
    pub fn q_f32(&self) -> [f32; 4] {
        [
            self.q[0] as f32,
            self.q[1] as f32,
            self.q[2] as f32,
            self.q[3] as f32,
        ]
    }
}

impl Default for Pose {
    /// The identity.
    fn default() -> Self {
        Self::IDENTITY
    }
}

fn normalized(q: [f64; 4]) -> [f64; 4] {
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    if n.is_finite() && n > 1e-12 {
        [q[0] / n, q[1] / n, q[2] / n, q[3] / n]
    } else {
        [0.0, 0.0, 0.0, 1.0]
    }
}

/// Hamilton product `a b` of quaternions `(x, y, z, w)`.
fn quat_mul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    let [ax, ay, az, aw] = a;
    let [bx, by, bz, bw] = b;
    [
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    ]
}

/// `R(q) v` via `v + 2 w (u x v) + 2 u x (u x v)`, `u = (x, y, z)` (unit `q`).
fn rotate(q: [f64; 4], v: [f64; 3]) -> [f64; 3] {
    let u = [q[0], q[1], q[2]];
    let w = q[3];
    let c1 = cross(u, v);
    let c2 = cross(u, c1);
    [
        v[0] + 2.0 * (w * c1[0] + c2[0]),
        v[1] + 2.0 * (w * c1[1] + c2[1]),
        v[2] + 2.0 * (w * c1[2] + c2[2]),
    ]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// What the pixels of an [`Image`] are, once repacked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PixelKind {
    /// 8-bit RGB (from `rgb8`, or `bgr8` with the channels swapped).
    Rgb8,
    /// 8-bit grey (`mono8`).
    Mono8,
    /// Depth in metres, `f32` little-endian (`32FC1`).
    DepthF32M,
    /// Depth in millimetres, `u16` little-endian (`16UC1`, `mono16`).
    DepthU16Mm,
}

impl PixelKind {
    /// Bytes per pixel.
    pub const fn bytes_per_pixel(self) -> usize {
        match self {
            Self::Rgb8 => 3,
            Self::Mono8 => 1,
            Self::DepthF32M => 4,
            Self::DepthU16Mm => 2,
        }
    }
}

/// Tightly packed (`step = width * bytes_per_pixel`), little-endian pixels.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Pixels {
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Pixel format.
    pub kind: PixelKind,
    /// `width * height * bytes_per_pixel` bytes.
    pub data: Vec<u8>,
}

/// Repacks an image message: drops row padding (`step > width * bpp`), swaps `bgr8` to RGB and
/// big-endian depth to little-endian.
///
/// # Errors
/// [`VizError::Image`] for an unsupported encoding, a `step` shorter than a row, or fewer
/// bytes than `step * height`.
pub fn image_pixels(img: &Image) -> Result<Pixels, VizError> {
    let bad = |reason: String| VizError::Image {
        encoding: img.encoding.clone(),
        width: img.width,
        height: img.height,
        reason,
    };
    let (kind, bgr) = match img.encoding.as_str() {
        image_encodings::RGB8 => (PixelKind::Rgb8, false),
        image_encodings::BGR8 => (PixelKind::Rgb8, true),
        image_encodings::MONO8 => (PixelKind::Mono8, false),
        image_encodings::TYPE_32FC1 => (PixelKind::DepthF32M, false),
        image_encodings::TYPE_16UC1 | image_encodings::MONO16 => (PixelKind::DepthU16Mm, false),
        other => return Err(bad(format!("unsupported encoding {other:?}"))),
    };
    let bpp = kind.bytes_per_pixel();
    let (w, h) = (img.width as usize, img.height as usize);
    let row = w * bpp;
    let step = img.step as usize;
    if step < row {
        return Err(bad(format!("step {step} < width * {bpp} = {row}")));
    }
    let need = step * h;
    if img.data.len() < need {
        return Err(bad(format!(
            "{} data bytes < step * height = {need}",
            img.data.len()
        )));
    }
    let mut data = Vec::with_capacity(row * h);
    for r in img.data.chunks_exact(step.max(1)).take(h) {
        data.extend_from_slice(&r[..row]);
    }
    if bgr {
        for px in data.chunks_exact_mut(3) {
            px.swap(0, 2);
        }
    }
    if img.is_bigendian != 0 && bpp > 1 && kind != PixelKind::Rgb8 {
        for v in data.chunks_exact_mut(bpp) {
            v.reverse();
        }
    }
    Ok(Pixels {
        width: img.width,
        height: img.height,
        kind,
        data,
    })
}

/// Pinhole intrinsics from a `CameraInfo`: `K = [fx s cx; 0 fy cy; 0 0 1]` (row-major `k`).
///
/// Rerun's pinhole has no distortion: the `plumb_bob` coefficients are not drawn (the images
/// are the raw, distorted ones; at rodlog's ~1e-2 coefficients the difference is a few
/// pixels at the corners).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Intrinsics {
    /// Focal lengths (px).
    pub focal: [f32; 2],
    /// Principal point (px).
    pub principal: [f32; 2],
    /// Image size `[width, height]` (px).
    pub resolution: [f32; 2],
}

/// The pinhole of a camera info.
///
/// # Errors
/// [`VizError::CameraInfo`] when `fx` or `fy` is not a positive finite number or the size is
/// zero.
pub fn intrinsics(info: &CameraInfo) -> Result<Intrinsics, VizError> {
    let (fx, fy, cx, cy) = (info.k[0], info.k[4], info.k[2], info.k[5]);
    let ok = |v: f64| v.is_finite() && v > 0.0;
    if !ok(fx) || !ok(fy) || !cx.is_finite() || !cy.is_finite() {
        return Err(VizError::CameraInfo {
            frame: info.header.frame_id.clone(),
            reason: format!("K has fx {fx}, fy {fy}, cx {cx}, cy {cy}"),
        });
    }
    if info.width == 0 || info.height == 0 {
        return Err(VizError::CameraInfo {
            frame: info.header.frame_id.clone(),
            reason: format!("size {}x{}", info.width, info.height),
        });
    }
    Ok(Intrinsics {
        focal: [fx as f32, fy as f32],
        principal: [cx as f32, cy as f32],
        resolution: [info.width as f32, info.height as f32],
    })
}

/// Points of a cloud: positions, and colours when it has a packed `rgb`/`rgba` field.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CloudPoints {
    /// Finite `(x, y, z)` in the cloud's frame (m).
    pub positions: Vec<[f32; 3]>,
    /// One `(r, g, b)` per position, or empty.
    pub colors: Vec<[u8; 3]>,
}

/// Reads `x`, `y`, `z` (float32 or float64) and an optional packed `rgb` (float32 or uint32
/// `0x00RRGGBB`, PCL's layout) of every point of `cloud`, skipping non-finite points (holes).
///
/// # Errors
/// [`VizError::PointCloud`] when a coordinate field is missing or of another type, or a point
/// lies outside `data` (`point_step`, `row_step` inconsistent with the size).
pub fn cloud_points(cloud: &PointCloud2) -> Result<CloudPoints, VizError> {
    let bad = |reason: String| VizError::PointCloud {
        frame: cloud.header.frame_id.clone(),
        reason,
    };
    let field = |name: &str| cloud.fields.iter().find(|f| f.name == name);
    let coord = |name: &str| -> Result<(usize, u8), VizError> {
        let f = field(name).ok_or_else(|| bad(format!("no field {name:?}")))?;
        match f.datatype {
            PointField::FLOAT32 | PointField::FLOAT64 => Ok((f.offset as usize, f.datatype)),
            d => Err(bad(format!(
                "field {name:?} has datatype {d}, not float32/64"
            ))),
        }
    };
    let xyz = [coord("x")?, coord("y")?, coord("z")?];
    let rgb = field("rgb")
        .or_else(|| field("rgba"))
        .filter(|f| matches!(f.datatype, PointField::FLOAT32 | PointField::UINT32))
        .map(|f| f.offset as usize);
    let be = cloud.is_bigendian;
    let read = |bytes: &[u8], off: usize, dt: u8| -> Option<f64> {
        if dt == PointField::FLOAT64 {
            let b: [u8; 8] = bytes.get(off..off + 8)?.try_into().ok()?;
            Some(if be {
                f64::from_be_bytes(b)
            } else {
                f64::from_le_bytes(b)
            })
        } else {
            let b: [u8; 4] = bytes.get(off..off + 4)?.try_into().ok()?;
            Some(f64::from(if be {
                f32::from_be_bytes(b)
            } else {
                f32::from_le_bytes(b)
            }))
        }
    };
    let (w, h) = (cloud.width as usize, cloud.height as usize);
    let (ps, rs) = (cloud.point_step as usize, cloud.row_step as usize);
    let mut out = CloudPoints::default();
    for r in 0..h {
        for c in 0..w {
            let base = r * rs + c * ps;
            let Some(pt) = cloud.data.get(base..base + ps) else {
                return Err(bad(format!(
                    "point ({r}, {c}) at byte {base} + {ps} beyond {} bytes",
                    cloud.data.len()
                )));
            };
            let mut p = [0.0f32; 3];
            let mut finite = true;
            for (k, (off, dt)) in xyz.iter().enumerate() {
                let v = read(pt, *off, *dt)
                    .ok_or_else(|| bad(format!("field at offset {off} beyond point_step {ps}")))?;
                finite &= v.is_finite();
                p[k] = v as f32;
            }
            if !finite {
                continue;
            }
            out.positions.push(p);
            if let Some(off) = rgb {
                let b: [u8; 4] = pt
                    .get(off..off + 4)
                    .and_then(|s| s.try_into().ok())
                    .ok_or_else(|| bad(format!("rgb at offset {off} beyond point_step {ps}")))?;
                let v = if be {
                    u32::from_be_bytes(b)
                } else {
                    u32::from_le_bytes(b)
                };
                out.colors.push([(v >> 16) as u8, (v >> 8) as u8, v as u8]);
            }
        }
    }
    Ok(out)
}

/// Widest half of the match canvas (px): larger images are shrunk by an integer factor.
pub const MATCH_CANVAS_HALF_WIDTH: u32 = 640;

/// Two images side by side with the matches between them, ready to draw.
#[derive(Debug, Clone, PartialEq)]
pub struct MatchCanvas {
    /// Canvas columns (`2 * half width`).
    pub width: u32,
    /// Canvas rows.
    pub height: u32,
    /// RGB pixels, `width * height * 3`: image a on the left, image b on the right (black
    /// where an image is missing).
    pub rgb: Vec<u8>,
    /// Shrink factor applied to both images and keypoints.
    pub shrink: u32,
    /// Segments of matches flagged inlier, `[a, b]` in canvas pixels.
    pub inliers: Vec<[[f32; 2]; 2]>,
    /// Segments of rejected matches.
    pub rejected: Vec<[[f32; 2]; 2]>,
}

/// Lays out image `a` and image `b` (either may be missing, then its half is black) side by
/// side and maps each match `(ia, ib)` to the segment from keypoint `ia` of `a` to keypoint
/// `ib` of `b` shifted by the half width. `size` is the camera's `[width, height]`, used
/// when an image is missing. Images larger than [`MATCH_CANVAS_HALF_WIDTH`] are shrunk by
/// the smallest integer factor that fits (box filter), keypoints by the same factor.
///
/// # Errors
/// [`VizError::Matches`] for odd keypoint or pair arrays, a flag count different from the
/// pair count, or a keypoint index out of range.
pub fn match_canvas(
    m: &FeatureMatches,
    a: Option<&Pixels>,
    b: Option<&Pixels>,
    size: [u32; 2],
) -> Result<MatchCanvas, VizError> {
    let bad = |reason: String| VizError::Matches {
        method: m.method.clone(),
        reason,
    };
    if [m.keypoints_a.len(), m.keypoints_b.len(), m.pairs.len()]
        .iter()
        .any(|n| !n.is_multiple_of(2))
    {
        return Err(bad(format!(
            "odd array length: keypoints_a {}, keypoints_b {}, pairs {}",
            m.keypoints_a.len(),
            m.keypoints_b.len(),
            m.pairs.len()
        )));
    }
    let n_pairs = m.pairs.len() / 2;
    if m.inlier.len() != n_pairs {
        return Err(bad(format!(
            "{} inlier flags for {n_pairs} pairs",
            m.inlier.len()
        )));
    }
    let (na, nb) = (m.keypoints_a.len() / 2, m.keypoints_b.len() / 2);
    let full_w = a.or(b).map_or(size[0], |p| p.width).max(1);
    let full_h = [a, b]
        .iter()
        .flatten()
        .map(|p| p.height)
        .max()
        .unwrap_or(size[1])
        .max(1);
    let shrink = full_w.div_ceil(MATCH_CANVAS_HALF_WIDTH).max(1);
    let half_w = full_w.div_ceil(shrink);
    let height = full_h.div_ceil(shrink);
    let width = 2 * half_w;
    let mut rgb = vec![0u8; width as usize * height as usize * 3];
    for (i, img) in [a, b].into_iter().enumerate() {
        if let Some(img) = img {
            blit_shrunk(
                &mut rgb,
                width,
                height,
                i as u32 * half_w,
                half_w,
                img,
                shrink,
            );
        }
    }
    let s = shrink as f32;
    let mut inliers = Vec::new();
    let mut rejected = Vec::new();
    for (k, pair) in m.pairs.chunks_exact(2).enumerate() {
        let (ia, ib) = (pair[0] as usize, pair[1] as usize);
        if ia >= na || ib >= nb {
            return Err(bad(format!(
                "pair {k} = ({ia}, {ib}) beyond {na} / {nb} keypoints"
            )));
        }
        let pa = [m.keypoints_a[2 * ia] / s, m.keypoints_a[2 * ia + 1] / s];
        let pb = [
            m.keypoints_b[2 * ib] / s + half_w as f32,
            m.keypoints_b[2 * ib + 1] / s,
        ];
        if m.inlier[k] {
            inliers.push([pa, pb]);
        } else {
            rejected.push([pa, pb]);
        }
    }
    Ok(MatchCanvas {
        width,
        height,
        rgb,
        shrink,
        inliers,
        rejected,
    })
}

/// Box-filters `img` by `shrink` into the canvas at column `x0` (clipped to `half_w` columns);
/// grey and depth images are drawn as grey (depth scaled to its own maximum).
fn blit_shrunk(
    canvas: &mut [u8],
    canvas_w: u32,
    canvas_h: u32,
    x0: u32,
    half_w: u32,
    img: &Pixels,
    shrink: u32,
) {
    let (w, h) = (img.width as usize, img.height as usize);
    let s = shrink as usize;
    let grey = |i: usize| -> [f32; 3] {
        match img.kind {
            PixelKind::Rgb8 => [
                f32::from(img.data[3 * i]),
                f32::from(img.data[3 * i + 1]),
                f32::from(img.data[3 * i + 2]),
            ],
            PixelKind::Mono8 => [f32::from(img.data[i]); 3],
            PixelKind::DepthU16Mm => {
                let v = u16::from_le_bytes([img.data[2 * i], img.data[2 * i + 1]]);
                [f32::from(v) * (255.0 / 2000.0); 3]
            }
            PixelKind::DepthF32M => {
                let v = f32::from_le_bytes([
                    img.data[4 * i],
                    img.data[4 * i + 1],
                    img.data[4 * i + 2],
                    img.data[4 * i + 3],
                ]);
                [if v.is_finite() {
                    v * (255.0 / 2.0)
                } else {
                    0.0
                }; 3]
            }
        }
    };
    let out_w = w.div_ceil(s).min(half_w as usize);
    let out_h = h.div_ceil(s).min(canvas_h as usize);
    for oy in 0..out_h {
        for ox in 0..out_w {
            let mut acc = [0.0f32; 3];
            let mut n = 0.0f32;
            for y in oy * s..((oy + 1) * s).min(h) {
                for x in ox * s..((ox + 1) * s).min(w) {
                    let c = grey(y * w + x);
                    acc[0] += c[0];
                    acc[1] += c[1];
                    acc[2] += c[2];
                    n += 1.0;
                }
            }
            let o = 3 * (oy * canvas_w as usize + x0 as usize + ox);
            for k in 0..3 {
                canvas[o + k] = (acc[k] / n.max(1.0)).round().clamp(0.0, 255.0) as u8;
            }
        }
    }
}

/// FNV-1a 64-bit hash of `parts` (each followed by a 0xff separator byte): the deterministic
/// recording id of a recording ([`recording_id`]).
pub fn fnv1a64(parts: &[&str]) -> u64 {
    const OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
    const PRIME: u64 = 0x0000_0100_0000_01b3;
    let mut h = OFFSET;
    for p in parts {
        for b in p.bytes().chain(std::iter::once(0xff)) {
            h ^= u64::from(b);
            h = h.wrapping_mul(PRIME);
        }
    }
    h
}

/// A deterministic Rerun recording id from what identifies a recording (e.g. its scenario
/// metadata and summary): `rodlog-` and 16 hex digits of [`fnv1a64`].
pub fn recording_id(parts: &[&str]) -> String {
    format!("rodlog-{:016x}", fnv1a64(parts))
}

#[cfg(test)]
mod tests {
    use super::*;
    use msgs::geometry_msgs::{Quaternion, Vector3};
    use msgs::std_msgs::Header;

    fn img(encoding: &str, w: u32, h: u32, step: u32, data: Vec<u8>) -> Image {
        Image {
            header: Header::default(),
            height: h,
            width: w,
            encoding: encoding.into(),
            is_bigendian: 0,
            step,
            data,
        }
    }

    #[test]
    fn composing_a_quarter_turn_then_a_translation_rotates_the_translation() {
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let a_from_b = Pose {
            t: [1.0, 0.0, 0.0],
            q: [0.0, 0.0, s, s], // +90 deg about z
        };
        let b_from_c = Pose {
            t: [1.0, 0.0, 0.0],
            q: [0.0, 0.0, s, s],
        };
        let a_from_c = a_from_b.compose(&b_from_c);
        let expect_t = [1.0, 1.0, 0.0];
        for (got, want) in a_from_c.t.iter().zip(expect_t) {
            assert!((got - want).abs() < 1e-12, "{a_from_c:?}");
        }
        // Two quarter turns = half turn about z: (0, 0, 1, 0) up to sign.
        assert!((a_from_c.q[2].abs() - 1.0).abs() < 1e-12, "{a_from_c:?}");
        assert!(a_from_c.q[3].abs() < 1e-12);
    }

    #[test]
    fn a_zero_quaternion_is_read_as_the_identity_rotation() {
        let p = Pose::from_transform(&Transform {
            translation: Vector3 {
                x: 1.0,
                y: 2.0,
                z: 3.0,
            },
            rotation: Quaternion {
                x: 0.0,
                y: 0.0,
                z: 0.0,
                w: 0.0,
            },
        });
        assert_eq!(p.q, [0.0, 0.0, 0.0, 1.0]);
    }

    #[test]
    fn bgr_with_row_padding_is_repacked_to_rgb() -> Result<(), VizError> {
        // 2x2 bgr8, step 8 (2 padding bytes per row).
        let data = vec![
            1, 2, 3, 4, 5, 6, 99, 99, //
            7, 8, 9, 10, 11, 12, 99, 99,
        ];
        let p = image_pixels(&img("bgr8", 2, 2, 8, data))?;
        assert_eq!(p.kind, PixelKind::Rgb8);
        assert_eq!(p.data, vec![3, 2, 1, 6, 5, 4, 9, 8, 7, 12, 11, 10]);
        Ok(())
    }

    #[test]
    fn big_endian_16uc1_depth_is_swapped_to_little_endian() -> Result<(), VizError> {
        let mut i = img("16UC1", 2, 1, 4, vec![0x01, 0x02, 0x03, 0x04]);
        i.is_bigendian = 1;
        let p = image_pixels(&i)?;
        assert_eq!(p.kind, PixelKind::DepthU16Mm);
        assert_eq!(p.data, vec![0x02, 0x01, 0x04, 0x03]);
        Ok(())
    }

    #[test]
    fn short_or_unknown_images_are_errors_not_panics() {
        let short = image_pixels(&img("rgb8", 4, 4, 12, vec![0; 47]));
        assert!(matches!(short, Err(VizError::Image { .. })), "{short:?}");
        let step = image_pixels(&img("rgb8", 4, 1, 11, vec![0; 12]));
        assert!(matches!(step, Err(VizError::Image { .. })), "{step:?}");
        let enc = image_pixels(&img("yuv422", 2, 2, 4, vec![0; 8]));
        assert!(
            enc.as_ref()
                .err()
                .is_some_and(|e| e.to_string().contains("yuv422")),
            "{enc:?}"
        );
    }

    fn cloud(fields: Vec<PointField>, point_step: u32, n: u32, data: Vec<u8>) -> PointCloud2 {
        PointCloud2 {
            header: Header::default(),
            height: 1,
            width: n,
            fields,
            is_bigendian: false,
            point_step,
            row_step: point_step * n,
            data,
            is_dense: false,
        }
    }

    fn field(name: &str, offset: u32, datatype: u8) -> PointField {
        PointField {
            name: name.into(),
            offset,
            datatype,
            count: 1,
        }
    }

    #[test]
    fn cloud_points_skip_holes_and_read_packed_rgb() -> Result<(), VizError> {
        let mut data = Vec::new();
        for (p, rgb) in [
            ([0.5f32, 0.25, 1.75], 0x00ff_8000u32),
            ([f32::NAN, 0.0, 0.0], 0),
            ([1.0, 2.0, 3.0], 0x0000_00ff),
        ] {
            for v in p {
                data.extend_from_slice(&v.to_le_bytes());
            }
            data.extend_from_slice(&rgb.to_le_bytes());
        }
        let c = cloud(
            vec![
                field("x", 0, PointField::FLOAT32),
                field("y", 4, PointField::FLOAT32),
                field("z", 8, PointField::FLOAT32),
                field("rgb", 12, PointField::UINT32),
            ],
            16,
            3,
            data,
        );
        let pts = cloud_points(&c)?;
        assert_eq!(pts.positions, vec![[0.5, 0.25, 1.75], [1.0, 2.0, 3.0]]);
        assert_eq!(pts.colors, vec![[255, 128, 0], [0, 0, 255]]);
        Ok(())
    }

    #[test]
    fn a_cloud_without_z_or_with_too_few_bytes_is_an_error() {
        let no_z = cloud(
            vec![
                field("x", 0, PointField::FLOAT32),
                field("y", 4, PointField::FLOAT32),
            ],
            8,
            1,
            vec![0; 8],
        );
        assert!(matches!(
            cloud_points(&no_z),
            Err(VizError::PointCloud { .. })
        ));
        let short = cloud(
            vec![
                field("x", 0, PointField::FLOAT64),
                field("y", 8, PointField::FLOAT64),
                field("z", 16, PointField::FLOAT64),
            ],
            24,
            2,
            vec![0; 30],
        );
        assert!(matches!(
            cloud_points(&short),
            Err(VizError::PointCloud { .. })
        ));
    }

    fn matches(pairs: Vec<u32>, inlier: Vec<bool>) -> FeatureMatches {
        FeatureMatches {
            method: "orb-gms".into(),
            keypoints_a: vec![100.0, 200.0, 1000.0, 50.0],
            keypoints_b: vec![110.0, 210.0, 990.0, 60.0],
            pairs,
            inlier,
            ..FeatureMatches::default()
        }
    }

    #[test]
    fn match_canvas_puts_b_right_of_a_and_splits_inliers_from_rejected() -> Result<(), VizError> {
        // 1280-wide images shrink by 2 into 640-wide halves.
        let a = Pixels {
            width: 1280,
            height: 4,
            kind: PixelKind::Mono8,
            data: vec![200; 1280 * 4],
        };
        let m = matches(vec![0, 0, 1, 1], vec![true, false]);
        let c = match_canvas(&m, Some(&a), None, [1280, 4])?;
        assert_eq!((c.width, c.height, c.shrink), (1280, 2, 2));
        assert_eq!(c.inliers, vec![[[50.0, 100.0], [640.0 + 55.0, 105.0]]]);
        assert_eq!(c.rejected, vec![[[500.0, 25.0], [640.0 + 495.0, 30.0]]]);
        // Left half is the grey image, right half (no image b) is black.
        assert_eq!(&c.rgb[..3], &[200, 200, 200]);
        let right = 3 * 700;
        assert_eq!(&c.rgb[right..right + 3], &[0, 0, 0]);
        Ok(())
    }

    #[test]
    fn match_canvas_rejects_inconsistent_messages() {
        let out_of_range = match_canvas(&matches(vec![0, 5], vec![true]), None, None, [64, 48]);
        assert!(matches!(out_of_range, Err(VizError::Matches { .. })));
        let flags = match_canvas(&matches(vec![0, 0], vec![]), None, None, [64, 48]);
        assert!(matches!(flags, Err(VizError::Matches { .. })));
    }

    #[test]
    fn recording_ids_are_stable_and_separate_their_parts() {
        assert_eq!(recording_id(&["a", "b"]), recording_id(&["a", "b"]));
        assert_ne!(recording_id(&["ab", ""]), recording_id(&["a", "b"]));
        // FNV-1a 64 of the empty input is its offset basis; one 0xff separator byte here.
        assert_eq!(fnv1a64(&[]), 0xcbf2_9ce4_8422_2325);
        assert!(recording_id(&["x"]).starts_with("rodlog-"));
    }

    #[test]
    fn intrinsics_reject_a_zero_focal_length() {
        let mut info = CameraInfo {
            width: 64,
            height: 48,
            ..CameraInfo::default()
        };
        assert!(intrinsics(&info).is_err());
        info.k = [100.0, 0.0, 32.0, 0.0, 101.0, 24.0, 0.0, 0.0, 1.0];
        let k = intrinsics(&info).ok();
        assert_eq!(
            k.map(|k| (k.focal, k.principal)),
            Some(([100.0, 101.0], [32.0, 24.0]))
        );
    }
}
