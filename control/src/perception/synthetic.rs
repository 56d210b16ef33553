//! Seeded synthetic depth captures for tests and benches: a wire (finite cylinder), a
//! background plane and boxes, ray-cast through the same [`RayTable`] the point cloud uses,
//! with the wrist camera's error model (the wrist RGB-D camera's datasheet figures):
//!
//! - depth noise `σ_z = NOISE_AT_HALF_METRE (z / 0.5 m)²` (0.1 mm at 0.5 m, growing with z²);
//! - holes at grazing angles: no depth where the angle between the viewing ray and the surface
//!   normal exceeds `max_incidence_rad` (so only the camera-facing part of the wire is seen,
//!   without its edges);
//! - random dropouts and outliers (uniform depth in `[0.2, 1.5]` m).
//!
//! Because the depth image stores z and the rays are `(x_n, y_n, 1)`, the ray parameter of a
//! hit is its depth. Not a physical simulator (no sun wash-out, no multipath): that is the
//! `sim` crate's job; this is ground truth for the geometry.
//!
//! [`render_wire_rgb`] draws a panoramic frame: a sky gradient and a dark straight wire of
//! known radius, antialiased, through a distorted pinhole camera.

use super::WIRE_RADIUS_M;
use super::point_cloud::{CameraModel, DepthImage, RayTable, wrist_nominal};
use nalgebra::{Isometry3, Point2, Point3, Translation3, UnitQuaternion, Vector3};
use rng::SplitMix64;

/// Luminance of the wire in [`render_wire_rgb`] (of 255).
pub const WIRE_LUMA: f64 = 40.0;
/// Luminance of the sky at the top of the image in [`render_wire_rgb`] (of 255); it darkens
/// by 40 levels towards the bottom.
pub const SKY_LUMA: f64 = 200.0;

/// Depth noise 1-σ at 0.5 m (m).
pub const NOISE_AT_HALF_METRE_M: f64 = 0.0001;

/// A finite cylinder (wire span or handle bar).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CylinderShape {
    /// A point on the axis (the segment's centre), camera frame (m).
    pub centre: Point3<f64>,
    /// Unit axis direction.
    pub direction: Vector3<f64>,
    /// Radius (m).
    pub radius_m: f64,
    /// Half-length along the axis (m).
    pub half_length_m: f64,
}

/// An oriented box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoxShape {
    /// `camera_from_box` (box centred at its origin).
    pub camera_from_box: Isometry3<f64>,
    /// Half extents along the box axes (m).
    pub half_extents_m: Vector3<f64>,
}

/// What the camera sees.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Scene {
    /// Cylinders.
    pub cylinders: Vec<CylinderShape>,
    /// Boxes.
    pub boxes: Vec<BoxShape>,
    /// Infinite planes as `(point, unit normal)`.
    pub planes: Vec<(Point3<f64>, Vector3<f64>)>,
}

/// The camera's error model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseModel {
    /// Depth noise 1-σ at 0.5 m (m), scaled by `(z / 0.5)²`. Default 0.1 mm.
    pub sigma_at_half_metre_m: f64,
    /// No depth beyond this incidence angle (rad). Default 65 deg.
    pub max_incidence_rad: f64,
    /// Fraction of valid pixels randomly dropped. Default 0.02.
    pub dropout: f64,
    /// Fraction of pixels replaced by a uniform random depth in [0.2, 1.5] m. Default 0.002.
    pub outliers: f64,
}

impl Default for NoiseModel {
    fn default() -> Self {
        Self {
            sigma_at_half_metre_m: NOISE_AT_HALF_METRE_M,
            max_incidence_rad: 65f64.to_radians(),
            dropout: 0.02,
            outliers: 0.002,
        }
    }
}

/// Nearest hit `(depth, unit normal)` of ray `d = (x, y, 1)` (from the origin) with the scene.
fn cast(scene: &Scene, d: &Vector3<f64>) -> Option<(f64, Vector3<f64>)> {
    let mut best: Option<(f64, Vector3<f64>)> = None;
    let mut offer = |t: f64, n: Vector3<f64>| {
        if t > 1e-6 && best.is_none_or(|(bt, _)| t < bt) {
            best = Some((t, n));
        }
    };
    for c in &scene.cylinders {
        let a = c.direction;
        let w = -c.centre.coords;
        let dp = d - a * d.dot(&a);
        let wp = w - a * w.dot(&a);
        let qa = dp.norm_squared();
        let qb = 2.0 * dp.dot(&wp);
        let qc = wp.norm_squared() - c.radius_m * c.radius_m;
        let disc = qb * qb - 4.0 * qa * qc;
        if qa <= 0.0 || disc < 0.0 {
            continue;
        }
        let t = (-qb - disc.sqrt()) / (2.0 * qa);
        let hit = d * t;
        let rel = hit - c.centre.coords;
        let along = rel.dot(&a);
        if along.abs() <= c.half_length_m {
            let radial = rel - a * along;
            offer(t, radial / c.radius_m);
        }
    }
    for b in &scene.boxes {
        let inv = b.camera_from_box.inverse();
        let o = inv.translation.vector;
        let dir = inv.rotation * d;
        let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
        let mut axis0 = 0usize;
        let mut ok = true;
        for k in 0..3 {
            let h = b.half_extents_m[k];
            if dir[k].abs() < 1e-15 {
                if o[k].abs() > h {
                    ok = false;
                }
                continue;
            }
            let (mut ta, mut tb) = ((-h - o[k]) / dir[k], (h - o[k]) / dir[k]);
            if ta > tb {
                std::mem::swap(&mut ta, &mut tb);
            }
            if ta > t0 {
                t0 = ta;
                axis0 = k;
            }
            t1 = t1.min(tb);
        }
        if ok && t0 <= t1 && t0 > 0.0 {
            let mut n_box = Vector3::zeros();
            n_box[axis0] = -dir[axis0].signum();
            offer(t0, b.camera_from_box.rotation * n_box);
        }
    }
    for (p, n) in &scene.planes {
        let denom = n.dot(d);
        if denom.abs() > 1e-12 {
            offer(n.dot(&p.coords) / denom, *n);
        }
    }
    best
}

/// Renders a depth image of `scene` through `rays` with `noise` drawn from `rng`.
#[must_use]
pub fn render_depth(
    scene: &Scene,
    rays: &RayTable,
    noise: &NoiseModel,
    rng: &mut SplitMix64,
) -> DepthImage {
    let (width, height) = (rays.width(), rays.height());
    let cos_max = noise.max_incidence_rad.cos();
    let mut depth_m = vec![0.0f32; width * height];
    for v in 0..height {
        for u in 0..width {
            let Some([x, y]) = rays.ray(u, v) else {
                continue;
            };
            let d = Vector3::new(x, y, 1.0);
            let mut z = 0.0;
            if let Some((t, n)) = cast(scene, &d) {
                let cos_inc = n.dot(&d).abs() / d.norm();
                if cos_inc >= cos_max {
                    let sigma = noise.sigma_at_half_metre_m * (t / 0.5).powi(2);
                    z = t + sigma * rng.normal();
                }
                if rng.next_f64() < noise.dropout {
                    z = 0.0;
                }
            }
            if rng.next_f64() < noise.outliers {
                z = rng.uniform(0.2, 1.5);
            }
            depth_m[v * width + u] = z as f32;
        }
    }
    DepthImage {
        width,
        height,
        depth_m,
    }
}

/// A random wire capture's ground truth and scene.
#[derive(Debug, Clone, PartialEq)]
pub struct WireScene {
    /// The wire (radius [`WIRE_RADIUS_M`]), camera frame.
    pub wire: CylinderShape,
    /// Everything rendered (wire, background plane, boxes).
    pub scene: Scene,
}

impl WireScene {
    /// A seeded scene: the wire's axis passes within ±30 mm (image plane) of the optical axis at
    /// a depth of 0.3-0.6 m to its surface, direction mostly across the view (any in-plane
    /// angle, tilted up to ±25 deg toward the optical axis), a background plane 0.4-1.0 m
    /// behind it and two boxes beside it.
    #[must_use]
    pub fn random(seed: u64) -> Self {
        let mut rng = SplitMix64::new(seed);
        let surface_z = rng.uniform(0.3, 0.6);
        let centre = Point3::new(
            rng.uniform(-0.03, 0.03),
            rng.uniform(-0.03, 0.03),
            surface_z + WIRE_RADIUS_M,
        );
        let yaw = rng.uniform(0.0, std::f64::consts::PI);
        let tilt = rng.uniform(-25f64, 25.0).to_radians();
        let direction = Vector3::new(yaw.cos() * tilt.cos(), yaw.sin() * tilt.cos(), tilt.sin());
        let wire = CylinderShape {
            centre,
            direction,
            radius_m: WIRE_RADIUS_M,
            half_length_m: 2.0,
        };
        let plane_z = centre.z + rng.uniform(0.4, 1.0);
        let plane_normal =
            Vector3::new(rng.uniform(-0.2, 0.2), rng.uniform(-0.2, 0.2), -1.0).normalize();
        let mut boxes = Vec::new();
        for side in [-1.0, 1.0] {
            // Beside the wire: offset across it in the image plane.
            let across = Vector3::new(-direction.y, direction.x, 0.0).normalize();
            let at = centre.coords
                + across * side * rng.uniform(0.07, 0.12)
                + Vector3::new(0.0, 0.0, rng.uniform(0.05, 0.2));
            let rotation = UnitQuaternion::from_axis_angle(
                &nalgebra::Unit::new_normalize(unit_vector(&mut rng)),
                rng.uniform(0.0, 1.0),
            );
            boxes.push(BoxShape {
                camera_from_box: Isometry3::from_parts(Translation3::from(at), rotation),
                half_extents_m: Vector3::new(
                    rng.uniform(0.01, 0.03),
                    rng.uniform(0.01, 0.03),
                    rng.uniform(0.01, 0.03),
                ),
            });
        }
        Self {
            wire,
            scene: Scene {
                cylinders: vec![wire],
                boxes,
                planes: vec![(Point3::new(0.0, 0.0, plane_z), plane_normal)],
            },
        }
    }

    /// Renders this scene with the wrist camera's noise (seeded by `seed`).
    #[must_use]
    pub fn render(&self, rays: &RayTable, noise: &NoiseModel, seed: u64) -> DepthImage {
        render_depth(&self.scene, rays, noise, &mut SplitMix64::new(seed))
    }
}

/// The nominal wrist camera's ray table (1280x1024).
///
/// # Errors
/// Never for the nominal camera; kept fallible for the signature of [`RayTable::new`].
pub fn wrist_rays() -> Result<RayTable, super::PerceptionError> {
    RayTable::new(&wrist_nominal())
}

/// A uniformly distributed unit vector (a normalised Gaussian triple) from `rng`.
pub fn unit_vector(rng: &mut rng::SplitMix64) -> nalgebra::Vector3<f64> {
    loop {
        let v = nalgebra::Vector3::new(rng.normal(), rng.normal(), rng.normal());
        let n = v.norm();
        if n > 1e-9 {
            return v / n;
        }
    }
}

/// An `rgb8` frame of `camera` at `world_from_camera`: a sky gradient ([`SKY_LUMA`] at the top,
/// 40 levels darker at the bottom, slightly blue) and, when `wire` is given as `(point,
/// direction)` in the world frame, a straight wire of `radius_m` in [`WIRE_LUMA`] (2x2
/// samples per pixel; only in front of the camera).
#[must_use]
pub fn render_wire_rgb(
    camera: &CameraModel,
    world_from_camera: &Isometry3<f64>,
    wire: Option<(Point3<f64>, Vector3<f64>)>,
    radius_m: f64,
) -> Vec<u8> {
    let (w, h) = (camera.width as usize, camera.height as usize);
    let mut data = vec![0u8; w * h * 3];
    let origin = world_from_camera.translation.vector;
    for v in 0..h {
        for u in 0..w {
            let mut cover = 0.0;
            if let Some((point, direction)) = wire {
                let axis = direction.normalize();
                for (su, sv) in [(0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75)] {
                    let px = Point2::new(u as f64 - 0.5 + su, v as f64 - 0.5 + sv);
                    let Ok(x) = camera.undistort_pixel(&px) else {
                        continue;
                    };
                    let ray = world_from_camera.rotation * Vector3::new(x.x, x.y, 1.0);
                    let normal = ray.cross(&axis);
                    let Some(n) = normal.try_normalize(1e-12) else {
                        continue;
                    };
                    let to_wire = point.coords - origin;
                    // The ray's point nearest the wire must lie in front of the camera.
                    let along = to_wire.cross(&axis).dot(&normal) / normal.norm();
                    if to_wire.dot(&n).abs() <= radius_m && along > 0.0 {
                        cover += 0.25;
                    }
                }
            }
            let sky = SKY_LUMA - 40.0 * v as f64 / h as f64;
            let value = sky * (1.0 - cover) + WIRE_LUMA * cover;
            let i = (v * w + u) * 3;
            if let Some(px) = data.get_mut(i..i + 3) {
                px.copy_from_slice(&[(value * 0.9) as u8, (value * 0.95) as u8, value as u8]);
            }
        }
    }
    data
}
