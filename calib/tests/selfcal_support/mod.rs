//! Synthetic RGB-D scenes for the self-calibration tests: a textured plane (random
//! rectangles, 1 mm texels) rendered by a tiny ray caster through the plumb_bob camera.
#![allow(dead_code)] // each test binary uses a subset

use calib::relpose::CameraModel;
use calib::selfcal::CalibView;
use image::GrayImage;
use nalgebra::{Isometry3, Point2, Point3, Translation3, UnitQuaternion, Vector3};

/// The asymmetric true mount of ARCHITECTURE.md section 6: t = (0.05, 0.02, -0.08) m, 30 deg about a skew
/// axis.
pub fn true_x() -> Isometry3<f64> {
    let axis = nalgebra::Unit::new_normalize(Vector3::new(1.0, 2.0, 3.0));
    Isometry3::from_parts(
        Translation3::new(0.05, 0.02, -0.08),
        UnitQuaternion::from_axis_angle(&axis, 30f64.to_radians()),
    )
}

/// Fixed `base_from_world` (the plane is z = 0 in world).
pub fn base_from_world() -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(0.7, -0.2, -0.4),
        UnitQuaternion::from_euler_angles(0.0, 0.0, 0.3),
    )
}

/// A 640x512 camera with small plumb_bob distortion.
pub fn camera() -> CameraModel {
    let mut c = CameraModel::pinhole(640, 512, 872.0, 872.0, 319.5, 255.5);
    c.k1 = -0.04;
    c.k2 = 0.01;
    c.p1 = 2e-4;
    c.p2 = -1e-4;
    c
}

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Standard normal deviates: Box-Muller on a seeded SplitMix64 stream (deterministic).
pub struct Normals(Rng);

impl Normals {
    /// The stream of `seed`.
    pub fn new(seed: u64) -> Self {
        Self(Rng(seed))
    }

    /// The next deviate.
    pub fn sample(&mut self) -> f64 {
        let (u1, u2) = (self.0.unit().max(1e-300), self.0.unit());
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

/// Texture of the plane: `N x N` texels of 1 mm centred on the world origin.
pub struct Texture {
    n: usize,
    texels: Vec<f32>,
}

impl Texture {
    /// Random overlapping rectangles and discs, seeded.
    pub fn new(seed: u64) -> Self {
        let n = 1200;
        let mut t = vec![110.0f32; n * n];
        let mut rng = Rng(seed);
        for _ in 0..5000 {
            let (cx, cy) = (rng.unit() * n as f64, rng.unit() * n as f64);
            let (w, h) = (4.0 + rng.unit() * 40.0, 4.0 + rng.unit() * 40.0);
            let v = (rng.unit() * 255.0) as f32;
            let disc = rng.unit() < 0.3;
            let (x0, x1) = ((cx - w).max(0.0) as usize, ((cx + w) as usize).min(n));
            let (y0, y1) = ((cy - h).max(0.0) as usize, ((cy + h) as usize).min(n));
            for y in y0..y1 {
                for x in x0..x1 {
                    let (dx, dy) = ((x as f64 - cx) / w, (y as f64 - cy) / h);
                    if !disc || dx * dx + dy * dy <= 1.0 {
                        t[y * n + x] = v;
                    }
                }
            }
        }
        Self { n, texels: t }
    }

    /// Bilinear grey level at world `(x, y)` metres; `None` off the texture.
    fn sample(&self, x: f64, y: f64) -> Option<f32> {
        let u = x * 1000.0 + self.n as f64 / 2.0;
        let v = y * 1000.0 + self.n as f64 / 2.0;
        if u < 0.0 || v < 0.0 || u >= (self.n - 1) as f64 || v >= (self.n - 1) as f64 {
            return None;
        }
        let (u0, v0) = (u.floor() as usize, v.floor() as usize);
        let (fu, fv) = ((u - u0 as f64) as f32, (v - v0 as f64) as f32);
        let at = |a: usize, b: usize| self.texels[b * self.n + a];
        Some(
            (1.0 - fv) * ((1.0 - fu) * at(u0, v0) + fu * at(u0 + 1, v0))
                + fv * ((1.0 - fu) * at(u0, v0 + 1) + fu * at(u0 + 1, v0 + 1)),
        )
    }
}

/// Normalised undistorted ray `(x, y)` of every pixel (row-major).
pub fn ray_table(cam: &CameraModel) -> Vec<Point2<f64>> {
    let mut rays = Vec::with_capacity((cam.width * cam.height) as usize);
    for v in 0..cam.height {
        for u in 0..cam.width {
            let px = Point2::new(f64::from(u), f64::from(v));
            rays.push(cam.undistort_pixel(&px).unwrap_or(Point2::new(1e3, 1e3)));
        }
    }
    rays
}

/// Boxes standing on the plane (`min`, `max` corners, metres): 3D structure, so that the
/// essential matrix is not degenerate (a single plane has a two-fold ambiguity).
const BOXES: [([f64; 3], [f64; 3]); 6] = [
    ([-0.12, -0.10, 0.0], [-0.05, -0.02, 0.08]),
    ([0.04, -0.13, 0.0], [0.12, -0.06, 0.05]),
    ([-0.02, 0.03, 0.0], [0.05, 0.09, 0.12]),
    ([-0.15, 0.06, 0.0], [-0.08, 0.14, 0.04]),
    ([0.08, 0.05, 0.0], [0.14, 0.12, 0.09]),
    ([-0.03, -0.04, 0.0], [0.01, 0.0, 0.03]),
];

/// Renders grey image and depth (metres, 0 = no hit) of the plane seen from
/// `world_from_camera`.
pub fn render(
    tex: &Texture,
    cam: &CameraModel,
    rays: &[Point2<f64>],
    world_from_camera: &Isometry3<f64>,
) -> (GrayImage, Vec<f32>) {
    let (w, h) = (cam.width as usize, cam.height as usize);
    let mut gray = vec![0u8; w * h];
    let mut depth = vec![0f32; w * h];
    let r = world_from_camera.rotation;
    let c = world_from_camera.translation.vector;
    for (k, ray) in rays.iter().enumerate() {
        let d = r * Vector3::new(ray.x, ray.y, 1.0);
        // Nearest hit among the ground plane z = 0 and the boxes; t = Z depth because the
        // camera-frame ray has z = 1.
        let mut best: Option<(f64, usize)> = None; // (t, face axis: 2 = horizontal)
        if d.z < -1e-9 {
            let t = -c.z / d.z;
            if t > 0.0 {
                best = Some((t, 2));
            }
        }
        for b in BOXES {
            let (mut tn, mut tf, mut axis) = (f64::MIN, f64::MAX, 2);
            for a in 0..3 {
                if d[a].abs() < 1e-12 {
                    if c[a] < b.0[a] || c[a] > b.1[a] {
                        tn = f64::MAX;
                    }
                    continue;
                }
                let (t1, t2) = ((b.0[a] - c[a]) / d[a], (b.1[a] - c[a]) / d[a]);
                let (lo, hi) = if t1 < t2 { (t1, t2) } else { (t2, t1) };
                if lo > tn {
                    tn = lo;
                    axis = a;
                }
                tf = tf.min(hi);
            }
            if tn <= tf && tn > 0.0 && best.is_none_or(|(t, _)| tn < t) {
                best = Some((tn, axis));
            }
        }
        let Some((t, axis)) = best else {
            gray[k] = 128;
            continue;
        };
        let p = c + t * d;
        let (tu, tv) = match axis {
            0 => (p.y + 0.31, p.z - 0.27),
            1 => (p.x - 0.29, p.z + 0.33),
            _ => (p.x, p.y),
        };
        match tex.sample(tu, tv) {
            Some(g) => {
                gray[k] = g.round().clamp(0.0, 255.0) as u8;
                depth[k] = t as f32;
            }
            None => gray[k] = 128,
        }
    }
    (
        GrayImage::from_raw(w as u32, h as u32, gray).unwrap_or_default(),
        depth,
    )
}

/// `world_from_camera` looking from `eye` at `target` with roll `roll_rad` about the optical
/// axis (OpenCV axes: z forward, y down).
pub fn look_at(eye: Point3<f64>, target: Point3<f64>, roll_rad: f64) -> Isometry3<f64> {
    let z = (target - eye).normalize();
    let up = if z.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let x = up.cross(&z).normalize();
    let y = z.cross(&x);
    let m = nalgebra::Matrix3::from_columns(&[x, y, z]);
    let rot = UnitQuaternion::from_matrix(&m)
        * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), roll_rad);
    Isometry3::from_parts(Translation3::from(eye.coords), rot)
}

/// `n` camera poses over the plane with varied tilts and rolls (rotation axes in all
/// directions).
pub fn camera_poses(n: usize) -> Vec<Isometry3<f64>> {
    (0..n)
        .map(|k| {
            let a = k as f64 * 2.399_963; // golden angle
            let rad = 0.08 + 0.12 * ((k % 4) as f64 / 3.0);
            let eye = Point3::new(rad * a.cos(), rad * a.sin(), 0.45 + 0.05 * ((k % 3) as f64));
            let target = Point3::new(0.03 * (a * 1.7).sin(), 0.03 * (a * 1.3).cos(), 0.0);
            let roll = 0.6 * (a * 0.7).sin();
            look_at(eye, target, roll)
        })
        .collect()
}

/// RGB-D views of the plane from the given camera poses with mount `x`: the hand pose is
/// `base_from_tool0 = base_from_world world_from_camera x^-1`.
pub fn views(
    cam_poses: &[Isometry3<f64>],
    x: &Isometry3<f64>,
    with_depth: bool,
) -> (Vec<CalibView>, CameraModel) {
    views_with_camera(cam_poses, x, with_depth, camera())
}

/// The wrist camera of ARCHITECTURE.md section 6: 1280x1024, f = 1745 px, small plumb_bob distortion.
pub fn wrist_camera() -> CameraModel {
    let mut c = CameraModel::pinhole(1280, 1024, 1745.0, 1745.0, 639.5, 511.5);
    c.k1 = -0.04;
    c.k2 = 0.01;
    c.p1 = 2e-4;
    c.p2 = -1e-4;
    c
}

/// As [`views`] with a given camera.
pub fn views_with_camera(
    cam_poses: &[Isometry3<f64>],
    x: &Isometry3<f64>,
    with_depth: bool,
    cam: CameraModel,
) -> (Vec<CalibView>, CameraModel) {
    let rays = ray_table(&cam);
    let tex = Texture::new(7);
    let views = cam_poses
        .iter()
        .enumerate()
        .map(|(k, world_from_camera)| {
            let (gray, depth) = render(&tex, &cam, &rays, world_from_camera);
            CalibView {
                stamp_ns: (k as u64 + 1) * 1_000_000_000,
                gray,
                depth_m: with_depth.then_some(depth),
                base_from_tool0: base_from_world() * world_from_camera * x.inverse(),
            }
        })
        .collect();
    (views, cam)
}
