//! Shared synthetic scenes of the relative-pose tests, the OpenCV comparison and the bench
//! (included with `#[path]`; as its own test target it checks the generator's consistency).
#![allow(dead_code)] // each including file uses a different subset

use calib::relpose::CameraModel;
use calib::relpose::ransac::SplitMix64;
use nalgebra::{Isometry3, Point2, Point3, Translation3, UnitQuaternion, Vector2, Vector3};

/// The wrist camera of ARCHITECTURE.md section 6 with a small plumb_bob distortion.
pub fn wrist_camera() -> CameraModel {
    CameraModel {
        width: 1280,
        height: 1024,
        fx: 1745.0,
        fy: 1745.5,
        cx: 641.3,
        cy: 509.8,
        k1: -0.08,
        k2: 0.12,
        p1: 4e-4,
        p2: -3e-4,
        k3: -0.05,
    }
}

/// The asymmetric test motion: 20 deg about a skew axis, t = (0.08, -0.03, 0.02) m.
pub fn true_a_from_b() -> Isometry3<f64> {
    let axis = nalgebra::Unit::new_normalize(Vector3::new(-0.25, -0.4, 1.0));
    Isometry3::from_parts(
        Translation3::new(0.08, -0.03, 0.02),
        UnitQuaternion::from_axis_angle(&axis, 20f64.to_radians()),
    )
}

/// What to generate.
#[derive(Debug, Clone, Copy)]
pub struct SceneSpec {
    /// Number of correspondences.
    pub n: usize,
    /// Probability that a correspondence is a gross mismatch.
    pub outlier_fraction: f64,
    /// Keypoint noise in both images, pixels.
    pub pixel_sigma_px: f64,
    /// Depth noise at 0.5 m (grows with z^2), metres; 0 for none.
    pub depth_sigma_ref_m: f64,
    /// Nearest true depth in camera b, metres.
    pub depth_min_m: f64,
    /// Farthest true depth in camera b, metres.
    pub depth_max_m: f64,
    /// Generator seed.
    pub seed: u64,
}

impl SceneSpec {
    /// Noise-free, outlier-free matches at 0.3-0.6 m.
    pub fn clean(n: usize, seed: u64) -> Self {
        Self {
            n,
            outlier_fraction: 0.0,
            pixel_sigma_px: 0.0,
            depth_sigma_ref_m: 0.0,
            depth_min_m: 0.3,
            depth_max_m: 0.6,
            seed,
        }
    }
    /// the noise of ARCHITECTURE.md section 6 (0.5 px keypoints, 0.1 mm depth at 0.5 m growing with z^2).
    pub fn noisy(n: usize, outlier_fraction: f64, seed: u64) -> Self {
        Self {
            n,
            outlier_fraction,
            pixel_sigma_px: 0.5,
            depth_sigma_ref_m: 1e-4,
            depth_min_m: 0.3,
            depth_max_m: 0.6,
            seed,
        }
    }
}

/// Matched measurements of one view pair.
#[derive(Debug, Clone)]
pub struct Scene {
    /// True motion.
    pub a_from_b: Isometry3<f64>,
    /// Camera of both views.
    pub camera: CameraModel,
    /// Measured (noisy) pixels.
    pub px_a: Vec<Point2<f64>>,
    /// Measured pixels in b.
    pub px_b: Vec<Point2<f64>>,
    /// Undistorted normalised coordinates of the measured pixels.
    pub x_a: Vec<Point2<f64>>,
    /// Normalised coordinates in b.
    pub x_b: Vec<Point2<f64>>,
    /// Back-projected measured points.
    pub p_in_a: Vec<Point3<f64>>,
    /// Back-projected points in b.
    pub p_in_b: Vec<Point3<f64>>,
    /// Ground-truth match flag.
    pub is_inlier: Vec<bool>,
}

fn uniform(rng: &mut SplitMix64, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.next_f64()
}

fn random_pixel(rng: &mut SplitMix64, cam: &CameraModel) -> Point2<f64> {
    let m = 10.0;
    Point2::new(
        uniform(rng, m, f64::from(cam.width) - m),
        uniform(rng, m, f64::from(cam.height) - m),
    )
}

/// Draws a scene: true points visible in both images, outliers re-drawn in a, noise added.
pub fn generate(spec: &SceneSpec, a_from_b: &Isometry3<f64>) -> Scene {
    let cam = wrist_camera();
    let mut rng = SplitMix64::new(spec.seed);
    let mut s = Scene {
        a_from_b: *a_from_b,
        camera: cam,
        px_a: Vec::new(),
        px_b: Vec::new(),
        x_a: Vec::new(),
        x_b: Vec::new(),
        p_in_a: Vec::new(),
        p_in_b: Vec::new(),
        is_inlier: Vec::new(),
    };
    let sigma_z = |z: f64| spec.depth_sigma_ref_m * (z / 0.5) * (z / 0.5);
    while s.px_a.len() < spec.n {
        let px_b_true = random_pixel(&mut rng, &cam);
        let z_b = uniform(&mut rng, spec.depth_min_m, spec.depth_max_m);
        let p_b_true = cam.backproject(&px_b_true, z_b).expect("backproject b");
        let mut p_a_true = a_from_b * p_b_true;
        let Some(mut px_a_true) = cam.project(&p_a_true) else {
            continue;
        };
        if !cam.contains(&px_a_true) || p_a_true.z < 0.1 {
            continue;
        }
        let outlier = rng.next_f64() < spec.outlier_fraction;
        if outlier {
            px_a_true = random_pixel(&mut rng, &cam);
            let z_a = uniform(&mut rng, spec.depth_min_m, spec.depth_max_m);
            p_a_true = cam.backproject(&px_a_true, z_a).expect("backproject a");
        }
        let px_a = px_a_true + spec.pixel_sigma_px * Vector2::new(rng.normal(), rng.normal());
        let px_b = px_b_true + spec.pixel_sigma_px * Vector2::new(rng.normal(), rng.normal());
        let za = p_a_true.z + sigma_z(p_a_true.z) * rng.normal();
        let zb = p_b_true.z + sigma_z(p_b_true.z) * rng.normal();
        s.x_a.push(cam.undistort_pixel(&px_a).expect("undistort a"));
        s.x_b.push(cam.undistort_pixel(&px_b).expect("undistort b"));
        s.p_in_a
            .push(cam.backproject(&px_a, za).expect("backproject a"));
        s.p_in_b
            .push(cam.backproject(&px_b, zb).expect("backproject b"));
        s.px_a.push(px_a);
        s.px_b.push(px_b);
        s.is_inlier.push(!outlier);
    }
    s
}

/// Rotation error angle of `est` against `truth`, radians.
pub fn rotation_error_rad(est: &Isometry3<f64>, truth: &Isometry3<f64>) -> f64 {
    let q = truth.rotation.inverse() * est.rotation;
    2.0 * q.imag().norm().atan2(q.scalar().abs())
}

/// Translation error, metres.
pub fn translation_error_m(est: &Isometry3<f64>, truth: &Isometry3<f64>) -> f64 {
    (est.translation.vector - truth.translation.vector).norm()
}

/// Angle between the translation directions, radians.
pub fn direction_error_rad(est: &Isometry3<f64>, truth: &Isometry3<f64>) -> f64 {
    let (a, b) = (est.translation.vector, truth.translation.vector);
    a.cross(&b).norm().atan2(a.dot(&b))
}

/// (true positives, false positives, false negatives) of an inlier mask.
pub fn confusion(found: &[bool], truth: &[bool]) -> (usize, usize, usize) {
    let mut tp = 0;
    let mut fp = 0;
    let mut fn_ = 0;
    for (&f, &t) in found.iter().zip(truth) {
        match (f, t) {
            (true, true) => tp += 1,
            (true, false) => fp += 1,
            (false, true) => fn_ += 1,
            _ => {}
        }
    }
    (tp, fp, fn_)
}

#[test]
fn relpose_generator_is_consistent() {
    let s = generate(&SceneSpec::clean(50, 3), &true_a_from_b());
    for i in 0..50 {
        let pa = s.a_from_b * s.p_in_b[i];
        assert!((pa - s.p_in_a[i]).norm() < 1e-9, "point {i}");
        let x = Point2::new(s.p_in_a[i].x / s.p_in_a[i].z, s.p_in_a[i].y / s.p_in_a[i].z);
        assert!((x - s.x_a[i]).norm() < 1e-12);
    }
}
