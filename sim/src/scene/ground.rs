//! The ground: an analytic plane (not in a BVH), level or graded.
//!
//! A substation yard is graded so that rain drains off it: the plane
//! `z = h + g_x (x - x_0) + g_y (y - y_0)` of grade `g = (g_x, g_y)` (rise over run) through
//! `(x_0, y_0, h)`. Structures stand on it at their footprints
//! ([`crate::scene::SubstationBuilder`]), and so does the robot's base
//! ([`crate::base::BaseSim::on_ground`]).

use nalgebra::{Point3, Unit, UnitQuaternion, Vector3};

use super::MaterialId;
use super::primitives::Ray;

/// A plane `z = height_m + grade . (xy - origin_xy_m)` (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GroundPlane {
    /// Height at `origin_xy_m` (m).
    pub height_m: f64,
    /// Where `height_m` is measured (m).
    pub origin_xy_m: [f64; 2],
    /// Rise over run along x and along y (0.01 = 1 %).
    pub grade: [f64; 2],
}

impl GroundPlane {
    /// The level plane `z = height_m`.
    #[must_use]
    pub fn level(height_m: f64) -> Self {
        Self {
            height_m,
            origin_xy_m: [0.0; 2],
            grade: [0.0; 2],
        }
    }

    /// Whether the plane is level (a zero grade).
    #[must_use]
    pub fn is_level(&self) -> bool {
        self.grade == [0.0; 2]
    }

    /// Height of the ground at `(x, y)` (m).
    #[inline]
    #[must_use]
    pub fn height_at(&self, x_m: f64, y_m: f64) -> f64 {
        self.height_m
            + self.grade[0] * (x_m - self.origin_xy_m[0])
            + self.grade[1] * (y_m - self.origin_xy_m[1])
    }

    /// The lowest height of the ground under the rectangle of half sizes `half_xy_m` about
    /// `(x, y)` (axis-aligned): where a level foundation of that footprint rests.
    #[must_use]
    pub fn lowest_under(&self, x_m: f64, y_m: f64, half_xy_m: [f64; 2]) -> f64 {
        self.height_at(x_m, y_m)
            - self.grade[0].abs() * half_xy_m[0]
            - self.grade[1].abs() * half_xy_m[1]
    }

    /// The plane's upward unit normal `(-g_x, -g_y, 1) / |.|`.
    #[must_use]
    pub fn normal(&self) -> Vector3<f64> {
        if self.is_level() {
            return Vector3::z();
        }
        Vector3::new(-self.grade[0], -self.grade[1], 1.0).normalize()
    }

    /// The grade's magnitude (rise over run along the steepest direction).
    #[must_use]
    pub fn steepest_grade(&self) -> f64 {
        self.grade[0].hypot(self.grade[1])
    }

    /// The smallest rotation taking `+z` to [`Self::normal`]: how a body resting on the
    /// plane is tilted (the identity on level ground).
    #[must_use]
    pub fn tilt(&self) -> UnitQuaternion<f64> {
        let n = self.normal();
        let axis = Vector3::z().cross(&n);
        match Unit::try_new(axis, 1e-15) {
            Some(axis) => UnitQuaternion::from_axis_angle(&axis, n.z.clamp(-1.0, 1.0).acos()),
            None => UnitQuaternion::identity(),
        }
    }

    /// The point of the plane under `(x, y)`.
    #[must_use]
    pub fn point_under(&self, x_m: f64, y_m: f64) -> Point3<f64> {
        Point3::new(x_m, y_m, self.height_at(x_m, y_m))
    }

    /// Distance `t` to the plane along `ray` if it lies in `(t_min, t_max)`:
    /// `t = (height_at(o_xy) - o_z) / (d_z - g . d_xy)`. With `t_min >= 0` a ray whose
    /// numerator and denominator differ in sign (or with a zero numerator) has `t <= 0` and
    /// is answered without the division (most shadow rays and every upward primary ray):
    /// the same answer, one division fewer. On level ground this is `(h - o_z) / d_z` bit
    /// for bit.
    #[inline]
    #[must_use]
    pub fn hit(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<f64> {
        let den = ray.dir.z - self.grade[0] * ray.dir.x - self.grade[1] * ray.dir.y;
        if den == 0.0 {
            return None;
        }
        let num = self.height_at(ray.origin.x, ray.origin.y) - ray.origin.z;
        let towards = (num > 0.0 && den > 0.0) || (num < 0.0 && den < 0.0);
        if t_min >= 0.0 && !towards {
            return None;
        }
        let t = num / den;
        (t > t_min && t < t_max).then_some(t)
    }
}

/// The ground of a scene: its plane and material.
#[derive(Clone, Copy, Debug)]
pub struct Ground {
    /// The plane.
    pub plane: GroundPlane,
    /// Its material.
    pub material: MaterialId,
}

impl Ground {
    /// [`GroundPlane::hit`].
    #[inline]
    #[must_use]
    pub fn hit(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<f64> {
        self.plane.hit(ray, t_min, t_max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn graded() -> GroundPlane {
        GroundPlane {
            height_m: 0.3,
            origin_xy_m: [10.0, -2.0],
            grade: [0.012, -0.007],
        }
    }

    /// The sign shortcut of [`GroundPlane::hit`] gives the plain division's answer, bit for
    /// bit, on level ground, for rays towards and away from the plane, parallel ones, origins
    /// on it, and negative `t_min`.
    #[test]
    fn a_level_hit_equals_the_plain_division() {
        let g = GroundPlane::level(0.25);
        let plain = |ray: &Ray, t_min: f64, t_max: f64| {
            if ray.dir.z == 0.0 {
                return None;
            }
            let t = (g.height_m - ray.origin.z) / ray.dir.z;
            (t > t_min && t < t_max).then_some(t)
        };
        let mut hits = 0;
        for i in 0..4000_u32 {
            let f = |k: u32| f64::from((i.wrapping_mul(2_654_435_761) >> k) % 1000) / 500.0 - 1.0;
            let z0 = [0.25, -3.0, 0.250_000_1, 4.0][(i % 4) as usize];
            let dz = if i % 7 == 0 { 0.0 } else { f(3) };
            let ray = Ray {
                origin: Point3::new(f(1), f(2), z0),
                dir: Vector3::new(f(5), f(7), dz),
            };
            for (t_min, t_max) in [(0.0, f64::INFINITY), (1e-6, 2.0), (-5.0, 5.0)] {
                let (a, b) = (g.hit(&ray, t_min, t_max), plain(&ray, t_min, t_max));
                assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits), "{ray:?}");
                hits += usize::from(a.is_some());
            }
        }
        assert!(hits > 1000, "{hits}");
    }

    /// On graded ground a ray's hit lies on the plane, and a ray running along the plane
    /// (parallel to it) misses.
    #[test]
    fn a_graded_hit_lies_on_the_plane() {
        let g = graded();
        let mut hits = 0;
        for i in 0..500_u32 {
            let f = |k: u32| f64::from((i.wrapping_mul(2_654_435_761) >> k) % 1000) / 50.0 - 10.0;
            let ray = Ray {
                origin: Point3::new(f(1), f(2), 2.0),
                dir: Vector3::new(f(5) / 10.0, f(7) / 10.0, -1.0).normalize(),
            };
            if let Some(t) = g.hit(&ray, 0.0, f64::INFINITY) {
                let p = ray.at(t);
                assert!((p.z - g.height_at(p.x, p.y)).abs() < 1e-12, "{p:?}");
                hits += 1;
            }
        }
        assert_eq!(hits, 500);
        let n = g.normal();
        let along = Vector3::new(1.0, 0.0, 0.0).cross(&n);
        let ray = Ray {
            origin: Point3::new(0.0, 0.0, 5.0),
            dir: along.normalize(),
        };
        assert!(g.hit(&ray, 0.0, 1e3).is_none_or(|t| t > 1e9));
    }

    /// The tilt takes +z to the normal, which is perpendicular to lines on the plane; the
    /// lowest point under a footprint is at its downhill corner.
    #[test]
    fn the_tilt_and_the_lowest_point_follow_the_grade() {
        let g = graded();
        let n = g.normal();
        assert!((g.tilt() * Vector3::z() - n).norm() < 1e-12);
        let (a, b) = (g.point_under(3.0, 4.0), g.point_under(-7.0, 1.5));
        assert!((b - a).dot(&n).abs() < 1e-12);
        let lowest = g.lowest_under(1.0, 1.0, [2.0, 3.0]);
        // Downhill corner: x smaller (grade_x > 0), y larger (grade_y < 0).
        assert!((lowest - g.height_at(-1.0, 4.0)).abs() < 1e-12);
        assert_eq!(GroundPlane::level(0.0).tilt(), UnitQuaternion::identity());
        assert!((g.steepest_grade() - 0.012_f64.hypot(0.007)).abs() < 1e-15);
    }
}
