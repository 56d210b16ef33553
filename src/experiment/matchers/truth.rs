//! What a pair's matches are judged with: true depth and pose (simulator pairs), the
//! chessboard plane (shecar pairs), or the known homography (synthetic warps).

use super::*;

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
    pub camera: CameraModel,
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
pub(super) fn apply_h(h: &Matrix3<f64>, x: f64, y: f64) -> Option<(f64, f64)> {
    let v = h * Vector3::new(x, y, 1.0);
    (v.z.abs() > 1e-12).then(|| (v.x / v.z, v.y / v.z))
}

pub(super) fn dist(p: (f64, f64), q: (f64, f64)) -> f64 {
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

    pub(super) fn judge(&self, a: (f64, f64), b: (f64, f64)) -> Verdict {
        let (w, h) = (self.camera.width, self.camera.height);
        let Ok(n) = self.camera.undistort_pixel(&Point2::new(a.0, a.1)) else {
            return Verdict::Unjudged;
        };
        let (nx, ny) = (n.x, n.y);
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
                let Some(px) = self.camera.project(&p_b) else {
                    continue;
                };
                let (u, v) = (px.x, px.y);
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
pub(super) fn undistorted_px(camera: &CameraModel, p: (f64, f64)) -> Option<(f64, f64)> {
    let n = camera.undistort_pixel(&Point2::new(p.0, p.1)).ok()?;
    Some((camera.fx * n.x + camera.cx, camera.fy * n.y + camera.cy))
}

impl BoardTruth {
    fn undistort(&self, p: (f64, f64)) -> Option<(f64, f64)> {
        undistorted_px(&self.camera, p)
    }

    pub(super) fn judge(&self, a: (f64, f64), b: (f64, f64)) -> Verdict {
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
    pub(super) fn epipolar_ok(&self, a: (f64, f64), b: (f64, f64)) -> Option<bool> {
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
