//! Depth images against analytic distances of known primitives, and the depth noise model.

use nalgebra::{Isometry3, Matrix3, Point3, Vector3};
use sim::render::{
    CameraModel, LightConditions, SensorParams, render_rgbd, world_from_camera_looking_at,
    wrist_camera,
};
use sim::scene::{Material, Scene, SceneBuilder, Shape, Texture};

type TestResult = Result<(), Box<dyn std::error::Error>>;

fn camera() -> Result<CameraModel, Box<dyn std::error::Error>> {
    Ok(wrist_camera().scaled(0.25)?)
}

fn one_shape(shape: Option<Shape>, ground: bool) -> Result<Scene, Box<dyn std::error::Error>> {
    let mut b = SceneBuilder::new();
    let m = b.material(Material::matte([0.4, 0.4, 0.4], Texture::Uniform, 1));
    if let Some(s) = shape {
        b.add(s, m);
    }
    if ground {
        b.ground(sim::scene::GroundPlane::level(0.0), m);
    }
    Ok(b.build()?)
}

/// Unit ray of pixel (u, v) in the camera frame, from the camera model (not the renderer).
fn pixel_ray(k: &CameraModel, u: u32, v: u32) -> Result<Vector3<f64>, Box<dyn std::error::Error>> {
    let x = k.undistort_pixel(&nalgebra::Point2::new(f64::from(u), f64::from(v)))?;
    Ok(Vector3::new(x.x, x.y, 1.0).normalize())
}

/// Compares the rendered depth with `analytic(ray_in_world, origin) -> Option<t>` for every
/// pixel; returns (pixels compared, max error).
fn compare(
    scene: &Scene,
    pose: &Isometry3<f64>,
    analytic: impl Fn(&Point3<f64>, &Vector3<f64>) -> Option<f64>,
) -> Result<(usize, f64), Box<dyn std::error::Error>> {
    let k = camera()?;
    let frame = render_rgbd(
        scene,
        pose,
        &k,
        &LightConditions::from_hour(10.0),
        &SensorParams::ideal(),
        1,
    )?;
    let origin = Point3::from(pose.translation.vector);
    let mut n = 0;
    let mut max_err: f64 = 0.0;
    for v in 0..k.height {
        for u in 0..k.width {
            let dc = pixel_ray(&k, u, v)?;
            let dw = pose.rotation * dc;
            let got = frame.depth_at(u, v).ok_or("pixel")?;
            match analytic(&origin, &dw) {
                Some(t) => {
                    let want = t * dc.z;
                    assert!(got.is_finite(), "hole at ({u}, {v}), expected {want}");
                    max_err = max_err.max((f64::from(got) - want).abs());
                    n += 1;
                }
                None => assert!(got.is_nan(), "depth {got} at ({u}, {v}) where nothing is"),
            }
        }
    }
    eprintln!("{n} pixels, max |error| {max_err:e} m");
    Ok((n, max_err))
}

#[test]
fn plane_depth_matches_analytic() -> TestResult {
    let scene = one_shape(None, true)?;
    let pose = world_from_camera_looking_at(
        &Point3::new(0.2, -0.1, 0.55),
        &Point3::new(0.5, 0.3, 0.0),
        &Vector3::y(),
    )
    .ok_or("pose")?;
    let (n, err) = compare(&scene, &pose, |o, d| (d.z < 0.0).then(|| -o.z / d.z))?;
    assert!(n > 50_000, "{n}");
    assert!(err < 1e-6, "max error {err} m");
    Ok(())
}

#[test]
fn sphere_depth_matches_analytic() -> TestResult {
    let c = Point3::new(0.1, 0.6, 1.0);
    let r = 0.08;
    let scene = one_shape(
        Some(Shape::Sphere {
            center: c,
            radius_m: r,
        }),
        false,
    )?;
    let pose = world_from_camera_looking_at(&Point3::new(0.0, 0.0, 1.0), &c, &Vector3::z())
        .ok_or("pose")?;
    let (n, err) = compare(&scene, &pose, |o, d| {
        // Geometric form: closest approach along the ray, then back off by the half chord.
        let b = d.dot(&(c - o));
        let q2 = (c - o).norm_squared() - b * b;
        (q2 <= r * r).then(|| b - (r * r - q2).sqrt())
    })?;
    assert!(n > 1000, "{n}");
    assert!(err < 1e-6, "max error {err} m");
    Ok(())
}

#[test]
fn cylinder_depth_matches_analytic() -> TestResult {
    // Vertical cylinder, seen from the side: the caps are outside the view.
    let (cx, cy, r) = (0.0, 0.5, 0.05);
    let scene = one_shape(
        Some(Shape::Cylinder {
            base: Point3::new(cx, cy, 0.0),
            axis: Vector3::z(),
            length_m: 3.0,
            radius_m: r,
        }),
        false,
    )?;
    let pose = world_from_camera_looking_at(
        &Point3::new(0.03, 0.0, 1.5),
        &Point3::new(cx, cy, 1.45),
        &Vector3::z(),
    )
    .ok_or("pose")?;
    let (n, err) = compare(&scene, &pose, |o, d| {
        // 2-D circle intersection in the xy plane, the parameter scaled by the 3-D ray.
        let (dx, dy) = (d.x, d.y);
        let (ox, oy) = (o.x - cx, o.y - cy);
        let a = dx * dx + dy * dy;
        let b = ox * dx + oy * dy;
        let cc = ox * ox + oy * oy - r * r;
        let disc = b * b - a * cc;
        if disc < 0.0 {
            return None;
        }
        let t = (-b - disc.sqrt()) / a;
        let z = o.z + t * d.z;
        (t > 0.0 && (0.0..=3.0).contains(&z)).then_some(t)
    })?;
    assert!(n > 5000, "{n}");
    assert!(err < 1e-6, "max error {err} m");
    Ok(())
}

#[test]
fn rotated_box_depth_matches_analytic() -> TestResult {
    let rot = *nalgebra::Rotation3::from_euler_angles(0.2, -0.3, 0.5).matrix();
    let center = Point3::new(0.0, 0.7, 0.2);
    let half = Vector3::new(0.15, 0.1, 0.12);
    let scene = one_shape(
        Some(Shape::Box {
            center,
            rotation: rot,
            half_extents_m: half,
        }),
        false,
    )?;
    let pose = world_from_camera_looking_at(&Point3::new(0.05, 0.1, 0.35), &center, &Vector3::z())
        .ok_or("pose")?;
    let rt: Matrix3<f64> = rot.transpose();
    let (n, err) = compare(&scene, &pose, |o, d| {
        // Slabs in the box frame.
        let ol = rt * (o - center);
        let dl = rt * d;
        let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
        for k in 0..3 {
            let a = (-half[k] - ol[k]) / dl[k];
            let b = (half[k] - ol[k]) / dl[k];
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
        }
        (t0 <= t1 && t0 > 0.0).then_some(t0)
    })?;
    assert!(n > 5000, "{n}");
    assert!(err < 1e-6, "max error {err} m");
    Ok(())
}

/// Std of (measured - true) depth on a plane facing the camera at distance `z`.
fn plane_noise_std(z: f64) -> Result<(f64, usize), Box<dyn std::error::Error>> {
    let scene = one_shape(None, true)?;
    // Looking straight down from height z: every pixel's true depth is z.
    let pose = world_from_camera_looking_at(
        &Point3::new(0.0, 0.0, z),
        &Point3::new(0.0, 0.0, 0.0),
        &Vector3::y(),
    )
    .ok_or("pose")?;
    let mut sensor = SensorParams::wrist();
    sensor.depth.noise_enabled = true;
    let frame = render_rgbd(
        &scene,
        &pose,
        &camera()?,
        &LightConditions::from_hour(18.5),
        &sensor,
        99,
    )?;
    let errs: Vec<f64> = frame
        .depth_m
        .iter()
        .filter(|d| d.is_finite())
        .map(|&d| f64::from(d) - z)
        .collect();
    let n = errs.len();
    let mean = errs.iter().sum::<f64>() / n as f64;
    let var = errs.iter().map(|e| (e - mean) * (e - mean)).sum::<f64>() / (n as f64 - 1.0);
    Ok((var.sqrt(), n))
}

#[test]
fn depth_noise_follows_the_z_squared_model() -> TestResult {
    let model = SensorParams::wrist().depth;
    for z in [0.3, 0.6] {
        let (std, n) = plane_noise_std(z)?;
        let want = model.sigma_m(z);
        eprintln!("z {z} m: std {std:e} m, model {want:e} m, {n} pixels");
        assert!(n > 70_000, "only {n} valid pixels at {z} m");
        assert!(
            (std / want - 1.0).abs() < 0.2,
            "z = {z}: std {std} vs model {want}"
        );
    }
    Ok(())
}

#[test]
fn grazing_surfaces_and_out_of_range_become_holes() -> TestResult {
    let scene = one_shape(None, true)?;
    // Nearly horizontal view over the ground: far pixels are beyond range or grazing.
    let pose = world_from_camera_looking_at(
        &Point3::new(0.0, 0.0, 0.3),
        &Point3::new(0.0, 1.0, 0.05),
        &Vector3::z(),
    )
    .ok_or("pose")?;
    let frame = render_rgbd(
        &scene,
        &pose,
        &camera()?,
        &LightConditions::from_hour(18.5),
        &SensorParams::wrist(),
        5,
    )?;
    let w = frame.width;
    // Bottom row sees the ground nearby at a moderate angle; the row just below the
    // horizon sees it at grazing incidence.
    let bottom = (0..w)
        .filter(|&u| {
            frame
                .depth_at(u, frame.height - 1)
                .is_some_and(f32::is_finite)
        })
        .count();
    let mid = (0..w)
        .filter(|&u| {
            frame
                .depth_at(u, frame.height / 2 - 10)
                .is_some_and(f32::is_finite)
        })
        .count();
    assert!(bottom as f64 > 0.9 * f64::from(w), "{bottom}");
    assert_eq!(mid, 0);
    assert!(frame.depth_mm().contains(&0));
    Ok(())
}
