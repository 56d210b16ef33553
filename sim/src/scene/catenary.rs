//! The conductor's analytic catenary (ground truth for wire perception).
//!
//! With attachment points `A`, `B`, horizontal span `L = |(B - A)_xy|`, horizontal unit
//! `h = (B - A)_xy / L` and horizontal coordinate `u in [0, L]` from `A`:
//!
//! `p(u) = A + u h + z(u) e_z`,
//! `z(u) = (z_B - z_A) u / L + c (cosh((u - L/2) / c) - cosh(L / (2c)))`
//!
//! i.e. the level-span catenary of parameter `c = H / w` (horizontal tension over weight per
//! metre) hung below the chord. For equal heights this is the exact catenary; for inclined
//! spans it is the usual "catenary below the chord" approximation (Kiessling et al.,
//! *Overhead Power Lines*, Springer 2003, section 14.2). The mid-span sag below the chord is
//! `s = c (cosh(L / (2c)) - 1)`, solved here for `c` by bisection (the right side decreases
//! monotonically in `c`). Degenerate cases: `L` ~ 0 (vertical) or a non-positive sag are
//! rejected.
//!
//! Wind sway is a rigid rotation of the whole curve about the chord `AB` (the conductor
//! swings as a pendulum about its attachment line), see [`Catenary::sway_pose`].

use nalgebra::{Isometry3, Point3, Translation3, Unit, UnitQuaternion, Vector3};

/// Conductor diameter (m) from ARCHITECTURE.md section 6.
pub const CONDUCTOR_DIAMETER_M: f64 = 0.0268;

/// Errors of catenary construction.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum CatenaryError {
    /// Attachment points too close horizontally.
    #[error("horizontal span {span_m} m is too short (min 1 m)")]
    SpanTooShort {
        /// Horizontal span.
        span_m: f64,
    },
    /// Sag must be positive and smaller than half the span.
    #[error("sag {sag_m} m is outside (0, {max_m}) m for this span")]
    BadSag {
        /// Requested sag.
        sag_m: f64,
        /// Largest accepted sag.
        max_m: f64,
    },
}

/// A catenary between two attachment points (world frame, at rest).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Catenary {
    /// First attachment point.
    pub start: Point3<f64>,
    /// Second attachment point.
    pub end: Point3<f64>,
    /// Mid-span sag below the chord (m).
    pub sag_m: f64,
    /// Catenary parameter `c = H / w` (m).
    pub parameter_m: f64,
    span_m: f64,
    horizontal: Vector3<f64>,
}

/// Closest point on the curve.
#[derive(Clone, Copy, Debug)]
pub struct ClosestPoint {
    /// Horizontal coordinate `u` from the start (m).
    pub u_m: f64,
    /// The point on the axis.
    pub point: Point3<f64>,
    /// Distance from the query to the axis (m).
    pub distance_m: f64,
}

impl Catenary {
    /// Catenary through `start` and `end` with mid-span sag `sag_m` below the chord.
    ///
    /// # Errors
    /// [`CatenaryError::SpanTooShort`] below 1 m of horizontal span;
    /// [`CatenaryError::BadSag`] unless `0 < sag < span / 2`.
    pub fn new(start: Point3<f64>, end: Point3<f64>, sag_m: f64) -> Result<Self, CatenaryError> {
        let d = end - start;
        let span_m = d.x.hypot(d.y);
        if span_m.is_nan() || span_m < 1.0 {
            return Err(CatenaryError::SpanTooShort { span_m });
        }
        let max_m = span_m / 2.0;
        if sag_m.is_nan() || sag_m <= 0.0 || sag_m >= max_m {
            return Err(CatenaryError::BadSag { sag_m, max_m });
        }
        let f = |c: f64| c * ((span_m / (2.0 * c)).cosh() - 1.0) - sag_m;
        // f decreases in c; f(lo) > 0 > f(hi).
        let (mut lo, mut hi) = (span_m / 40.0, span_m * span_m / sag_m);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if f(mid) > 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let horizontal = Vector3::new(d.x / span_m, d.y / span_m, 0.0);
        Ok(Self {
            start,
            end,
            sag_m,
            parameter_m: 0.5 * (lo + hi),
            span_m,
            horizontal,
        })
    }

    /// Horizontal span (m).
    #[must_use]
    pub fn span_m(&self) -> f64 {
        self.span_m
    }

    /// Height offset from `start` at horizontal coordinate `u_m`.
    #[must_use]
    pub fn height_m(&self, u_m: f64) -> f64 {
        let c = self.parameter_m;
        let l = self.span_m;
        (self.end.z - self.start.z) * u_m / l
            + c * (((u_m - l / 2.0) / c).cosh() - (l / (2.0 * c)).cosh())
    }

    /// Point on the axis at horizontal coordinate `u_m` (0 = start, span = end).
    #[must_use]
    pub fn point_at(&self, u_m: f64) -> Point3<f64> {
        let p = self.start + self.horizontal * u_m;
        Point3::new(p.x, p.y, self.start.z + self.height_m(u_m))
    }

    /// Unit tangent at `u_m` (towards the end).
    #[must_use]
    pub fn tangent_at(&self, u_m: f64) -> Vector3<f64> {
        let c = self.parameter_m;
        let l = self.span_m;
        let dz = (self.end.z - self.start.z) / l + ((u_m - l / 2.0) / c).sinh();
        (self.horizontal + Vector3::z() * dz).normalize()
    }

    /// Lowest point of the axis (searched on a fine grid then refined).
    #[must_use]
    pub fn lowest_point(&self) -> Point3<f64> {
        let mut best = 0.0;
        let mut zb = f64::INFINITY;
        for i in 0..=1000 {
            let u = self.span_m * i as f64 / 1000.0;
            let z = self.height_m(u);
            if z < zb {
                zb = z;
                best = u;
            }
        }
        self.point_at(self.refine(best, |u| self.height_m(u)))
    }

    /// Closest point of the axis to `p` (at rest; apply the sway pose's inverse to `p`
    /// first when the wire is swung).
    #[must_use]
    pub fn closest_point(&self, p: &Point3<f64>) -> ClosestPoint {
        let dist2 = |u: f64| (self.point_at(u) - p).norm_squared();
        let n = 400;
        let mut best = 0.0;
        let mut db = f64::INFINITY;
        for i in 0..=n {
            let u = self.span_m * i as f64 / n as f64;
            let d = dist2(u);
            if d < db {
                db = d;
                best = u;
            }
        }
        let u = self.refine(best, dist2);
        let point = self.point_at(u);
        ClosestPoint {
            u_m: u,
            point,
            distance_m: (point - p).norm(),
        }
    }

    /// Golden-section refinement of a minimum bracketed by one grid step around `u0`.
    fn refine(&self, u0: f64, f: impl Fn(f64) -> f64) -> f64 {
        let step = self.span_m / 400.0;
        let (mut a, mut b) = ((u0 - step).max(0.0), (u0 + step).min(self.span_m));
        let g = 0.5 * (5.0_f64.sqrt() - 1.0);
        for _ in 0..80 {
            let c = b - g * (b - a);
            let d = a + g * (b - a);
            if f(c) < f(d) {
                b = d;
            } else {
                a = c;
            }
        }
        0.5 * (a + b)
    }

    /// Sampled axis: `segments + 1` points evenly spaced in `u`.
    #[must_use]
    pub fn polyline(&self, segments: usize) -> Vec<Point3<f64>> {
        let n = segments.max(1);
        (0..=n)
            .map(|i| self.point_at(self.span_m * i as f64 / n as f64))
            .collect()
    }

    /// `world_from_wire` for a sway of `angle_rad` about the chord (positive = right-handed
    /// about `end - start`).
    #[must_use]
    pub fn sway_pose(&self, angle_rad: f64) -> Isometry3<f64> {
        let axis = Unit::new_normalize(self.end - self.start);
        let r = UnitQuaternion::from_axis_angle(&axis, angle_rad);
        let a = self.start.coords;
        Isometry3::from_parts(Translation3::from(a - r * a), r)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sag_and_endpoints() -> Result<(), CatenaryError> {
        let c = Catenary::new(
            Point3::new(0.0, 0.0, 10.0),
            Point3::new(30.0, 0.0, 10.0),
            1.5,
        )?;
        assert!((c.point_at(0.0).z - 10.0).abs() < 1e-9);
        assert!((c.point_at(30.0).z - 10.0).abs() < 1e-9);
        assert!((c.point_at(15.0).z - 8.5).abs() < 1e-9);
        assert!((c.lowest_point().z - 8.5).abs() < 1e-9);
        let q = Point3::new(12.0, 0.3, 9.0);
        let cp = c.closest_point(&q);
        // The offset from the closest point is perpendicular to the tangent.
        assert!((q - cp.point).dot(&c.tangent_at(cp.u_m)).abs() < 1e-7);
        Ok(())
    }

    #[test]
    fn sway_keeps_attachments() -> Result<(), CatenaryError> {
        let c = Catenary::new(
            Point3::new(0.0, 1.0, 10.0),
            Point3::new(25.0, 2.0, 9.0),
            1.0,
        )?;
        let s = c.sway_pose(0.2);
        assert!(((s * c.start) - c.start).norm() < 1e-12);
        assert!(((s * c.end) - c.end).norm() < 1e-12);
        Ok(())
    }
}
