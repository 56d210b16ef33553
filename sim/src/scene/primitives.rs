//! Analytic primitives: spheres, capped cylinders, oriented boxes; rays and bounding boxes.
//!
//! Ray `r(t) = o + t d` with `|d| = 1`, so `t` is the Euclidean distance in metres.
//!
//! * Sphere `|p - c|^2 = r^2`: `t^2 + 2 (o - c).d t + |o - c|^2 - r^2 = 0`.
//! * Capped cylinder of axis `a` (unit), base `b`, length `h`, radius `r`: with
//!   `o' = o - b`, the lateral surface solves `|P(o') + t P(d)|^2 = r^2` where
//!   `P(v) = v - (v.a) a`, restricted to `0 <= (o' + t d).a <= h`; the caps are the planes
//!   `(p - b).a = 0` and `= h` restricted to the disc of radius `r`.
//! * Oriented box: the ray is expressed in the box frame and clipped by the three slabs
//!   (Kay & Kajiya, SIGGRAPH 1986).
//!
//! Quadratics use the cancellation-free form `q = -(B + sign(B) sqrt(D)) / 2`,
//! `t = q / A` and `t = C / q` (Numerical Recipes 5.6), so depths are exact to ~1e-12 m.
//! Degenerate cases: a ray parallel to a cylinder's axis has `|P(d)| = 0` and only meets the
//! caps; a ray parallel to a slab misses it unless its origin lies between the planes.

use nalgebra::{Matrix3, Point3, Vector3};

use super::MaterialId;

/// A ray with unit direction.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    /// Origin (metres).
    pub origin: Point3<f64>,
    /// Unit direction.
    pub dir: Vector3<f64>,
}

impl Ray {
    /// Ray from an origin and a direction (normalised here; a zero direction gives NaNs that
    /// hit nothing).
    #[must_use]
    pub fn new(origin: Point3<f64>, dir: Vector3<f64>) -> Self {
        Self {
            origin,
            dir: dir.normalize(),
        }
    }

    /// Point at distance `t_m`.
    #[must_use]
    pub fn at(&self, t_m: f64) -> Point3<f64> {
        self.origin + self.dir * t_m
    }
}

/// Axis-aligned bounding box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Minimum corner.
    pub min: [f64; 3],
    /// Maximum corner.
    pub max: [f64; 3],
}

impl Aabb {
    /// The empty box (grows from any point).
    pub const EMPTY: Self = Self {
        min: [f64::INFINITY; 3],
        max: [f64::NEG_INFINITY; 3],
    };

    /// Grows the box to contain `p`.
    pub fn grow_point(&mut self, p: [f64; 3]) {
        for ((lo, hi), x) in self.min.iter_mut().zip(self.max.iter_mut()).zip(p) {
            *lo = lo.min(x);
            *hi = hi.max(x);
        }
    }

    /// Union with another box.
    pub fn grow(&mut self, b: &Self) {
        for k in 0..3 {
            self.min[k] = self.min[k].min(b.min[k]);
            self.max[k] = self.max[k].max(b.max[k]);
        }
    }

    /// Centre point.
    #[must_use]
    pub fn centroid(&self) -> [f64; 3] {
        [
            0.5 * (self.min[0] + self.max[0]),
            0.5 * (self.min[1] + self.max[1]),
            0.5 * (self.min[2] + self.max[2]),
        ]
    }

    /// Surface area (0 for the empty box).
    #[must_use]
    pub fn area(&self) -> f64 {
        let d = [
            self.max[0] - self.min[0],
            self.max[1] - self.min[1],
            self.max[2] - self.min[2],
        ];
        if d.iter().any(|v| *v < 0.0) {
            return 0.0;
        }
        2.0 * (d[0] * d[1] + d[1] * d[2] + d[2] * d[0])
    }

    /// Slab test: entry distance if the ray meets the box within `[0, t_max]`.
    #[inline]
    #[must_use]
    pub fn hit(&self, o: &[f64; 3], inv_d: &[f64; 3], t_max: f64) -> Option<f64> {
        let mut t0 = 0.0_f64;
        let mut t1 = t_max;
        for k in 0..3 {
            let a = (self.min[k] - o[k]) * inv_d[k];
            let b = (self.max[k] - o[k]) * inv_d[k];
            let (near, far) = if a < b { (a, b) } else { (b, a) };
            // `max`/`min` ignore the NaN of 0 * inf (origin on a slab plane, parallel ray).
            t0 = t0.max(near);
            t1 = t1.min(far);
        }
        (t0 <= t1).then_some(t0)
    }

    /// Box containing the 8 corners transformed by `f`.
    #[must_use]
    pub fn transformed(&self, f: impl Fn(Point3<f64>) -> Point3<f64>) -> Self {
        let mut out = Self::EMPTY;
        for i in 0..8 {
            let p = Point3::new(
                if i & 1 == 0 { self.min[0] } else { self.max[0] },
                if i & 2 == 0 { self.min[1] } else { self.max[1] },
                if i & 4 == 0 { self.min[2] } else { self.max[2] },
            );
            let q = f(p);
            out.grow_point([q.x, q.y, q.z]);
        }
        out
    }
}

/// Geometry of one primitive (metres, in its object's frame).
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    /// Sphere.
    Sphere {
        /// Centre.
        center: Point3<f64>,
        /// Radius (m).
        radius_m: f64,
    },
    /// Capped cylinder from `base` along the unit `axis` for `length_m`.
    Cylinder {
        /// Centre of the first cap.
        base: Point3<f64>,
        /// Unit axis.
        axis: Vector3<f64>,
        /// Length along the axis (m).
        length_m: f64,
        /// Radius (m).
        radius_m: f64,
    },
    /// Box with centre, rotation (columns = the box axes in the object frame) and half sizes.
    Box {
        /// Centre.
        center: Point3<f64>,
        /// `object_from_box` rotation; columns are the box's axes.
        rotation: Matrix3<f64>,
        /// Half extents along the box axes (m).
        half_extents_m: Vector3<f64>,
    },
}

/// A shape with its material.
#[derive(Clone, Debug, PartialEq)]
pub struct Primitive {
    /// Geometry.
    pub shape: Shape,
    /// Material index in the scene.
    pub material: MaterialId,
}

/// Surface attributes at a hit, in the primitive's object frame.
#[derive(Clone, Copy, Debug)]
pub struct LocalSurface {
    /// Hit point (object frame).
    pub point: Point3<f64>,
    /// Outward unit normal (object frame).
    pub normal: Vector3<f64>,
    /// Surface coordinates in metres (face plane, or arc length x axial length).
    pub uv_m: [f64; 2],
    /// Small integer telling faces apart (box face 0..6, cylinder side 0 / caps 1, 2).
    pub face: u8,
}

#[inline]
fn stable_quadratic(a: f64, b: f64, c: f64) -> Option<(f64, f64)> {
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 || a == 0.0 {
        return None;
    }
    let q = -0.5 * (b + b.signum() * disc.sqrt());
    if q == 0.0 {
        return Some((0.0, 0.0));
    }
    let (t0, t1) = (q / a, c / q);
    Some(if t0 < t1 { (t0, t1) } else { (t1, t0) })
}

/// `rotation^T v` (box axes are the columns of `rotation`), each component the dot product
/// `(c_0 v_0 + c_1 v_1) + c_2 v_2` in the order nalgebra's `tr_mul` uses, as plain arrays.
#[inline(always)]
fn box_from_object(r: &Matrix3<f64>, v: &Vector3<f64>) -> [f64; 3] {
    [
        r.m11 * v.x + r.m21 * v.y + r.m31 * v.z,
        r.m12 * v.x + r.m22 * v.y + r.m32 * v.z,
        r.m13 * v.x + r.m23 * v.y + r.m33 * v.z,
    ]
}

/// Unit vector perpendicular to `a` (deterministic choice; Duff et al., JCGT 2017).
#[must_use]
pub fn perpendicular(a: &Vector3<f64>) -> Vector3<f64> {
    let s = if a.z >= 0.0 { 1.0 } else { -1.0 };
    let k = -1.0 / (s + a.z);
    let b = a.x * a.y * k;
    Vector3::new(1.0 + s * a.x * a.x * k, s * b, -s * a.x)
}

impl Shape {
    /// Moves the shape by `v`.
    pub fn translate(&mut self, v: &Vector3<f64>) {
        match self {
            Self::Sphere { center, .. } | Self::Box { center, .. } => *center += v,
            Self::Cylinder { base, .. } => *base += v,
        }
    }

    /// Bounding box.
    #[must_use]
    pub fn bounds(&self) -> Aabb {
        let mut b = Aabb::EMPTY;
        match self {
            Self::Sphere { center, radius_m } => {
                b.grow_point([
                    center.x - radius_m,
                    center.y - radius_m,
                    center.z - radius_m,
                ]);
                b.grow_point([
                    center.x + radius_m,
                    center.y + radius_m,
                    center.z + radius_m,
                ]);
            }
            Self::Cylinder {
                base,
                axis,
                length_m,
                radius_m,
            } => {
                let top = base + axis * *length_m;
                for k in 0..3 {
                    // Extent of a disc of radius r with normal a along axis k: r sqrt(1 - a_k^2).
                    let e = radius_m * (1.0 - axis[k] * axis[k]).max(0.0).sqrt();
                    b.min[k] = base[k].min(top[k]) - e;
                    b.max[k] = base[k].max(top[k]) + e;
                }
            }
            Self::Box {
                center,
                rotation,
                half_extents_m,
            } => {
                for k in 0..3 {
                    let e = rotation.row(k).abs().dot(&half_extents_m.transpose());
                    b.min[k] = center[k] - e;
                    b.max[k] = center[k] + e;
                }
            }
        }
        b
    }

    /// Nearest intersection distance in `(t_min, t_max)`.
    #[inline]
    #[must_use]
    pub fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<f64> {
        let ok = |t: f64| t > t_min && t < t_max;
        match self {
            Self::Sphere { center, radius_m } => {
                let oc = ray.origin - center;
                let (t0, t1) = stable_quadratic(
                    1.0,
                    2.0 * oc.dot(&ray.dir),
                    oc.norm_squared() - radius_m * radius_m,
                )?;
                if ok(t0) {
                    Some(t0)
                } else if ok(t1) {
                    Some(t1)
                } else {
                    None
                }
            }
            Self::Cylinder {
                base,
                axis,
                length_m,
                radius_m,
            } => {
                let o = ray.origin - base;
                let d_par = ray.dir.dot(axis);
                let o_par = o.dot(axis);
                let d_perp = ray.dir - axis * d_par;
                let o_perp = o - axis * o_par;
                let mut best = f64::INFINITY;
                if let Some((t0, t1)) = stable_quadratic(
                    d_perp.norm_squared(),
                    2.0 * o_perp.dot(&d_perp),
                    o_perp.norm_squared() - radius_m * radius_m,
                ) {
                    for t in [t0, t1] {
                        let h = o_par + t * d_par;
                        if ok(t) && (0.0..=*length_m).contains(&h) {
                            best = best.min(t);
                            break;
                        }
                    }
                }
                if d_par != 0.0 {
                    for plane in [0.0, *length_m] {
                        let t = (plane - o_par) / d_par;
                        if ok(t)
                            && t < best
                            && (o_perp + d_perp * t).norm_squared() <= radius_m * radius_m
                        {
                            best = t;
                        }
                    }
                }
                best.is_finite().then_some(best)
            }
            Self::Box { .. } => self
                .box_from_origin(&ray.origin)?
                .intersect(&ray.dir, t_min, t_max),
        }
    }

    /// For a box, the terms of its ray-slab test that depend only on the ray origin (see
    /// [`BoxFromOrigin`]); `None` for other shapes.
    #[inline]
    #[must_use]
    pub fn box_from_origin(&self, origin: &Point3<f64>) -> Option<BoxFromOrigin> {
        let Self::Box {
            center,
            rotation,
            half_extents_m,
        } = self
        else {
            return None;
        };
        let r = rotation;
        let o = box_from_object(r, &(origin - center));
        let h = [half_extents_m.x, half_extents_m.y, half_extents_m.z];
        Some(BoxFromOrigin {
            axes: [
                [r.m11, r.m21, r.m31],
                [r.m12, r.m22, r.m32],
                [r.m13, r.m23, r.m33],
            ],
            o,
            h,
            lo: [0, 1, 2].map(|k| -h[k] - o[k]),
            hi: [0, 1, 2].map(|k| h[k] - o[k]),
        })
    }
}

/// A box's ray-slab test with the origin-only terms evaluated: the origin `o` in the box
/// frame and the slab offsets `-h - o`, `h - o`. Rays from one origin (a camera's primary
/// rays) share them, so each ray only rotates its direction into the box frame; the
/// arithmetic is that of [`Shape::intersect`] (which uses this type), so results agree
/// bit for bit.
#[derive(Clone, Copy, Debug)]
pub struct BoxFromOrigin {
    /// The box axes (columns of its rotation), one per row.
    axes: [[f64; 3]; 3],
    o: [f64; 3],
    h: [f64; 3],
    lo: [f64; 3],
    hi: [f64; 3],
}

impl BoxFromOrigin {
    /// Nearest intersection distance in `(t_min, t_max)` along the unit `dir` from the
    /// origin this was made for (Kay-Kajiya slabs in the box frame).
    #[inline]
    #[must_use]
    pub fn intersect(&self, dir: &Vector3<f64>, t_min: f64, t_max: f64) -> Option<f64> {
        let mut t0 = f64::NEG_INFINITY;
        let mut t1 = f64::INFINITY;
        for k in 0..3 {
            let a = &self.axes[k];
            // (a0 d0 + a1 d1) + a2 d2, the order of `box_from_object`.
            let d = a[0] * dir.x + a[1] * dir.y + a[2] * dir.z;
            if d == 0.0 {
                if self.o[k].abs() > self.h[k] {
                    return None;
                }
                continue;
            }
            let inv = 1.0 / d;
            let a = self.lo[k] * inv;
            let b = self.hi[k] * inv;
            // Finite (d != 0): plain comparisons equal f64::max/min here.
            let (near, far) = if a < b { (a, b) } else { (b, a) };
            t0 = if near > t0 { near } else { t0 };
            t1 = if far < t1 { far } else { t1 };
        }
        let ok = |t: f64| t > t_min && t < t_max;
        if t0 > t1 {
            None
        } else if ok(t0) {
            Some(t0)
        } else if ok(t1) {
            Some(t1)
        } else {
            None
        }
    }
}

impl Shape {
    /// Surface attributes at `p` (a point on the surface, e.g. from [`Shape::intersect`]).
    #[must_use]
    #[inline]
    pub fn surface(&self, p: Point3<f64>) -> LocalSurface {
        match self {
            Self::Sphere { center, radius_m } => {
                let n = (p - center) / *radius_m;
                let u = n.y.atan2(n.x) * radius_m;
                let v = n.z.clamp(-1.0, 1.0).acos() * radius_m;
                LocalSurface {
                    point: p,
                    normal: n,
                    uv_m: [u, v],
                    face: 0,
                }
            }
            Self::Cylinder {
                base,
                axis,
                length_m,
                radius_m,
            } => {
                let o = p - base;
                let h = o.dot(axis);
                let radial = o - axis * h;
                let e1 = perpendicular(axis);
                let e2 = axis.cross(&e1);
                let (x, y) = (radial.dot(&e1), radial.dot(&e2));
                let r2 = radial.norm_squared();
                // Classify by the distance to each surface (robust at the rim).
                let d_side = (r2.sqrt() - radius_m).abs();
                let d_cap0 = h.abs();
                let d_cap1 = (h - length_m).abs();
                if d_side <= d_cap0.min(d_cap1) {
                    let n = radial / r2.sqrt().max(1e-300);
                    LocalSurface {
                        point: p,
                        normal: n,
                        uv_m: [y.atan2(x) * radius_m, h],
                        face: 0,
                    }
                } else if d_cap0 < d_cap1 {
                    LocalSurface {
                        point: p,
                        normal: -axis,
                        uv_m: [x, y],
                        face: 1,
                    }
                } else {
                    LocalSurface {
                        point: p,
                        normal: *axis,
                        uv_m: [x, y],
                        face: 2,
                    }
                }
            }
            Self::Box {
                center,
                rotation,
                half_extents_m,
            } => {
                let q = box_from_object(rotation, &(p - center));
                let h = [half_extents_m.x, half_extents_m.y, half_extents_m.z];
                let dist = [0, 1, 2].map(|i| (q[i].abs() - h[i]).abs());
                // The face nearest to p (first on ties, as a strict-less scan).
                let k = if dist[1] < dist[0] {
                    if dist[2] < dist[1] { 2 } else { 1 }
                } else if dist[2] < dist[0] {
                    2
                } else {
                    0
                };
                let positive = q[k] >= 0.0;
                let axis = match k {
                    0 => Vector3::new(rotation.m11, rotation.m21, rotation.m31),
                    1 => Vector3::new(rotation.m12, rotation.m22, rotation.m32),
                    _ => Vector3::new(rotation.m13, rotation.m23, rotation.m33),
                };
                let normal = if positive { axis } else { -axis };
                let (i, j) = match k {
                    0 => (1, 2),
                    1 => (0, 2),
                    _ => (0, 1),
                };
                let uv_m = [q[i] + h[i], q[j] + h[j]];
                let face = (2 * k + usize::from(positive)) as u8;
                LocalSurface {
                    point: p,
                    normal,
                    uv_m,
                    face,
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cylinder_side_and_cap_hits() {
        let c = Shape::Cylinder {
            base: Point3::new(0.0, 0.0, 0.0),
            axis: Vector3::z(),
            length_m: 1.0,
            radius_m: 0.1,
        };
        let side = Ray::new(Point3::new(-1.0, 0.0, 0.5), Vector3::x());
        assert!((c.intersect(&side, 0.0, 10.0).unwrap_or(0.0) - 0.9).abs() < 1e-12);
        let cap = Ray::new(Point3::new(0.05, 0.0, 2.0), -Vector3::z());
        assert!((c.intersect(&cap, 0.0, 10.0).unwrap_or(0.0) - 1.0).abs() < 1e-12);
        let s = c.surface(cap.at(1.0));
        assert_eq!(s.face, 2);
        let miss = Ray::new(Point3::new(-1.0, 0.0, 1.5), Vector3::x());
        assert!(c.intersect(&miss, 0.0, 10.0).is_none());
    }

    #[test]
    fn rotated_box_bounds_contain_corners() {
        let r = *nalgebra::Rotation3::from_euler_angles(0.3, -0.2, 0.9).matrix();
        let b = Shape::Box {
            center: Point3::new(1.0, 2.0, 3.0),
            rotation: r,
            half_extents_m: Vector3::new(0.5, 0.1, 0.2),
        };
        let bb = b.bounds();
        for i in 0..8 {
            let l = Vector3::new(
                if i & 1 == 0 { -0.5 } else { 0.5 },
                if i & 2 == 0 { -0.1 } else { 0.1 },
                if i & 4 == 0 { -0.2 } else { 0.2 },
            );
            let p = Point3::new(1.0, 2.0, 3.0) + r * l;
            for k in 0..3 {
                assert!(p[k] >= bb.min[k] - 1e-12 && p[k] <= bb.max[k] + 1e-12);
            }
        }
    }
}
