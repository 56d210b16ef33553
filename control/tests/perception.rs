//! Perception on synthetic captures with ground truth: wire axis accuracy (< 0.5 mm, < 0.5°),
//! the centroid bias avoided, hanging point and approach normal in `base_link`, confidence
//! and refusals, the handle, determinism.

use control::perception::PerceptionError;
use control::perception::WIRE_RADIUS_M;
use control::perception::confidence::ConfidenceThresholds;
use control::perception::cylinder::{Cylinder, RansacParams, fit_cylinder};
use control::perception::handle::{CutEnd, HandleEstimate, HandleModel, ViewWindow, fit_handle};
use control::perception::point_cloud::{
    CameraModel, DepthImage, RayTable, to_point_cloud2, wrist_nominal,
};
use control::perception::roi::{PixelRoi, extract_roi};
use control::perception::synthetic::{
    CylinderShape, NoiseModel, Scene, WireScene, render_depth, wrist_rays,
};
use control::perception::wire::{WireParams, detect_wire, estimate_wire, hanging_point};
use msgs::std_msgs::Header;
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use rng::SplitMix64;
use std::sync::OnceLock;

fn rays() -> &'static RayTable {
    static RAYS: OnceLock<RayTable> = OnceLock::new();
    RAYS.get_or_init(|| match wrist_rays() {
        Ok(r) => r,
        Err(e) => panic!("nominal camera: {e}"),
    })
}

/// ROI from a panoramic-like prior: the true axis shifted by `prior_error_m` across it.
fn prior_roi(scene: &WireScene, prior_error_m: f64) -> PixelRoi {
    let cam = wrist_nominal();
    let w = scene.wire;
    let across = w.direction.cross(&Vector3::z()).normalize();
    let c = w.centre + across * prior_error_m;
    let (p0, p1) = (c - w.direction * 0.3, c + w.direction * 0.3);
    match PixelRoi::around_segment(&cam, &p0, &p1, 80.0, 0.06) {
        Ok(r) => r,
        Err(e) => panic!("roi: {e}"),
    }
}

fn truth_cylinder(w: &CylinderShape) -> Cylinder {
    Cylinder {
        point: w.centre,
        direction: w.direction,
        radius_m: w.radius_m,
    }
}

#[test]
fn wire_axis_within_half_mm_and_half_degree_and_not_the_centroid() {
    let cam = wrist_nominal();
    let mut worst = (0.0f64, 0.0f64);
    for seed in 0..10u64 {
        let scene = WireScene::random(seed);
        let depth = scene.render(rays(), &NoiseModel::default(), 1000 + seed);
        let roi = prior_roi(&scene, 0.01);
        let obs = match detect_wire(&depth, rays(), cam.fx, &roi, &WireParams::default()) {
            Ok(o) => o,
            Err(e) => panic!("seed {seed}: {e}"),
        };
        let truth = truth_cylinder(&scene.wire);
        let angle_deg = obs.fit.cylinder.axis_angle_to(&truth).to_degrees();
        let offset_m = truth.axis_offset_near(&obs.fit.cylinder, &scene.wire.centre);
        assert!(angle_deg < 0.5, "seed {seed}: axis angle {angle_deg} deg");
        assert!(offset_m < 0.0005, "seed {seed}: axis offset {offset_m} m");
        assert!(
            (obs.fit.free_radius_m - WIRE_RADIUS_M).abs() < 0.001,
            "seed {seed}"
        );
        assert!(
            obs.support_ratio > 0.9,
            "seed {seed}: support {}",
            obs.support_ratio
        );
        assert!(
            obs.valid_depth_fraction > 0.8,
            "seed {seed}: valid {}",
            obs.valid_depth_fraction
        );
        worst = (worst.0.max(angle_deg), worst.1.max(offset_m));
        let q = obs.metrics(WIRE_RADIUS_M);
        eprintln!(
            "seed {seed}: angle {angle_deg:.4} deg offset {:.4} mm support {:.3} rms {:.3} mm valid {:.3} inliers {}",
            offset_m * 1e3,
            q.support_ratio,
            q.rms_residual_m * 1e3,
            q.valid_depth_fraction,
            q.inlier_count
        );
        // The biased alternative: the centroid of the visible surface near the target sits
        // toward the camera by about r sin(θ)/θ, i.e. > 0.6 r, measurably off.
        let near: Vec<&Point3<f64>> = obs
            .inlier_points
            .iter()
            .filter(|p| ((*p - scene.wire.centre).dot(&scene.wire.direction)).abs() < 0.02)
            .collect();
        let centroid = Point3::from(
            near.iter().map(|p| p.coords).sum::<Vector3<f64>>() / near.len().max(1) as f64,
        );
        let centroid_error_m = truth.axis_distance(&centroid);
        assert!(
            centroid_error_m > 0.6 * WIRE_RADIUS_M && centroid_error_m > 20.0 * offset_m,
            "seed {seed}: centroid {centroid_error_m} vs axis {offset_m}"
        );
    }
    eprintln!(
        "worst axis angle {:.4} deg, offset {:.4} mm",
        worst.0,
        worst.1 * 1e3
    );
}

#[test]
fn hanging_point_in_base_and_fused_confidence() {
    let cam = wrist_nominal();
    let scene = WireScene::random(42);
    let base_from_camera = Isometry3::from_parts(
        Translation3::new(0.4, -0.1, 1.9),
        UnitQuaternion::from_euler_angles(-1.9, 0.1, -1.4),
    );
    let observations: Vec<_> = (0..3u64)
        .map(|k| {
            let depth = scene.render(rays(), &NoiseModel::default(), 77 + k);
            let roi = prior_roi(&scene, 0.015);
            match detect_wire(&depth, rays(), cam.fx, &roi, &WireParams::default()) {
                Ok(o) => (o, base_from_camera),
                Err(e) => panic!("capture {k}: {e}"),
            }
        })
        .collect();
    let near_in_base = base_from_camera * (scene.wire.centre + Vector3::new(0.0, 0.004, 0.0));
    let camera_in_base = base_from_camera * Point3::origin();
    let estimate = match estimate_wire(
        &observations,
        &near_in_base,
        &camera_in_base,
        WIRE_RADIUS_M,
        &ConfidenceThresholds::default(),
    ) {
        Ok(e) => e,
        Err(e) => panic!("estimate: {e}"),
    };
    let truth = truth_cylinder(&scene.wire);
    let truth_in_base = Cylinder {
        point: base_from_camera * truth.point,
        direction: base_from_camera.rotation * truth.direction,
        radius_m: truth.radius_m,
    };
    let truth_hanging = match hanging_point(&truth_in_base, &near_in_base, &camera_in_base) {
        Ok(h) => h,
        Err(e) => panic!("{e}"),
    };
    let error_m = (estimate.hanging.point - truth_hanging.point).norm();
    assert!(error_m < 0.0005, "hanging point error {error_m} m");
    let normal_angle = estimate
        .hanging
        .approach_normal
        .dot(&truth_hanging.approach_normal)
        .clamp(-1.0, 1.0)
        .acos();
    assert!(normal_angle.to_degrees() < 0.5, "normal {normal_angle} rad");
    // The approach normal points from the axis toward the camera, perpendicular to the axis.
    assert!(
        estimate
            .hanging
            .approach_normal
            .dot(&(camera_in_base - estimate.hanging.point))
            > 0.0
    );
    assert!(
        estimate
            .hanging
            .approach_normal
            .dot(&estimate.hanging.axis)
            .abs()
            < 1e-9
    );
    // The pose's z is the approach direction, x the axis.
    let z = estimate.hanging.frame_from_hanging.rotation * Vector3::z();
    assert!((z + estimate.hanging.approach_normal).norm() < 1e-9);
    assert!(estimate.confidence.score > 0.9, "{:?}", estimate.confidence);
    assert_eq!(estimate.metrics.captures, 3);
    let cloud = to_point_cloud2(&observations[0].0.inlier_points, Header::default());
    assert_eq!(cloud.data.len(), observations[0].0.inlier_points.len() * 12);
}

#[test]
fn refuses_when_captures_disagree_or_quality_is_poor() {
    let cam = wrist_nominal();
    let scene = WireScene::random(5);
    let roi = prior_roi(&scene, 0.0);
    let depth = scene.render(rays(), &NoiseModel::default(), 1);
    let obs = match detect_wire(&depth, rays(), cam.fx, &roi, &WireParams::default()) {
        Ok(o) => o,
        Err(e) => panic!("{e}"),
    };
    // Two captures 10 mm apart (the wire swung between them): not held to agree, but the
    // sway they show comes with the estimate, its band at least the 5 mm either side of
    // the centre (the task takes more captures, and holds or refuses a wide band).
    let moved = Isometry3::translation(0.0, 0.0, 0.01);
    let pair = [(obs.clone(), Isometry3::identity()), (obs.clone(), moved)];
    let result = estimate_wire(
        &pair,
        &scene.wire.centre,
        &Point3::origin(),
        WIRE_RADIUS_M,
        &ConfidenceThresholds::default(),
    );
    let Ok(swinging) = result else {
        panic!("{result:?}");
    };
    assert!(swinging.sway.is_swaying(), "{:?}", swinging.sway);
    let band = swinging
        .sway
        .envelope_m
        .hypot(swinging.sway.vertical_envelope_m);
    assert!(band >= 0.005, "{:?}", swinging.sway);
    // Two captures at an angle of 3 deg to each other: refused, not averaged.
    let turned = Isometry3::rotation(Vector3::z() * 3f64.to_radians());
    let pair = [(obs.clone(), Isometry3::identity()), (obs.clone(), turned)];
    let result = estimate_wire(
        &pair,
        &scene.wire.centre,
        &Point3::origin(),
        WIRE_RADIUS_M,
        &ConfidenceThresholds::default(),
    );
    assert!(
        matches!(
            result,
            Err(PerceptionError::LowConfidence {
                limiting: "agreement_angle",
                ..
            })
        ),
        "{result:?}"
    );
    // Ten times the depth noise: refused on the residual (or no cylinder at all).
    let noisy = NoiseModel {
        sigma_at_half_metre_m: 0.001,
        ..NoiseModel::default()
    };
    let depth = scene.render(rays(), &noisy, 2);
    let outcome = detect_wire(&depth, rays(), cam.fx, &roi, &WireParams::default()).and_then(|o| {
        estimate_wire(
            &[(o, Isometry3::identity())],
            &scene.wire.centre,
            &Point3::origin(),
            WIRE_RADIUS_M,
            &ConfidenceThresholds::default(),
        )
    });
    assert!(
        matches!(
            outcome,
            Err(PerceptionError::LowConfidence { .. } | PerceptionError::NoCylinder { .. })
        ),
        "{outcome:?}"
    );
    // No wire at all (plane and boxes only): no cylinder, or refused.
    let mut empty = scene.clone();
    empty.scene.cylinders.clear();
    let depth = empty.render(rays(), &NoiseModel::default(), 3);
    let outcome = detect_wire(
        &depth,
        rays(),
        cam.fx,
        &PixelRoi::full(&cam, 0.2, 2.0),
        &WireParams::default(),
    )
    .and_then(|o| {
        estimate_wire(
            &[(o, Isometry3::identity())],
            &scene.wire.centre,
            &Point3::origin(),
            WIRE_RADIUS_M,
            &ConfidenceThresholds::default(),
        )
    });
    assert!(
        outcome.is_err(),
        "a wire was found in an empty scene: {outcome:?}"
    );
}

/// The default handle at `centre` along `direction`, before a floor 0.9 m away.
fn handle_scene(centre: Point3<f64>, direction: Vector3<f64>) -> (CylinderShape, Scene) {
    let model = HandleModel::default();
    let handle = CylinderShape {
        centre,
        direction,
        radius_m: model.radius_m,
        half_length_m: 0.5 * model.length_m,
    };
    let scene = Scene {
        cylinders: vec![handle],
        boxes: vec![],
        planes: vec![(Point3::new(0.0, 0.0, 0.9), -Vector3::z())],
    };
    (handle, scene)
}

/// Renders `scene` (depth noise from `seed`) and fits the handle model to `roi` of it, seen
/// through that ROI; with the depth image.
fn fit_rendered_handle(
    scene: &Scene,
    roi: &PixelRoi,
    seed: u64,
) -> (DepthImage, Result<HandleEstimate, PerceptionError>) {
    let cam = wrist_nominal();
    let depth = render_depth(
        scene,
        rays(),
        &NoiseModel::default(),
        &mut SplitMix64::new(seed),
    );
    let cloud = extract_roi(&depth, rays(), roi, 2);
    let normal_of = |k: usize| {
        let (u, v) = *cloud.pixels.get(k)?;
        depth.normal(rays(), cam.fx, u as usize, v as usize)
    };
    let window = ViewWindow {
        camera: &cam,
        roi,
        edge_px: 6.0,
    };
    let result = fit_handle(
        &cloud.points,
        normal_of,
        &HandleModel::default(),
        &RansacParams::default(),
        &Point3::origin(),
        &window,
    );
    (depth, result)
}

#[test]
fn handle_centre_and_axis() {
    let cam = wrist_nominal();
    let model = HandleModel::default();
    let (handle, scene) = handle_scene(
        Point3::new(0.01, -0.02, 0.42),
        Vector3::new(0.9, 0.3, 0.2).normalize(),
    );
    let roi = PixelRoi::full(&cam, 0.2, 0.7);
    let estimate = match fit_rendered_handle(&scene, &roi, 9).1 {
        Ok(e) => e,
        Err(e) => panic!("{e}"),
    };
    let centre_error = (estimate.pose.point - handle.centre).norm();
    assert!(centre_error < 0.003, "handle centre error {centre_error} m");
    assert!(estimate.pose.axis.dot(&handle.direction).abs() > 0.5f64.to_radians().cos());
    assert!((estimate.measured_length_m - model.length_m).abs() < 0.01);
}

/// A handle whose one end runs out of the image (or of the ROI) is placed from the end that
/// is seen and the model length; its midpoint would be off by half the cut. Both ends cut
/// refuse.
#[test]
fn a_handle_cut_by_the_view_is_placed_from_the_end_it_sees() {
    let cam = wrist_nominal();
    let model = HandleModel::default();
    let fit = |centre: Point3<f64>, roi: PixelRoi| {
        fit_rendered_handle(&handle_scene(centre, Vector3::x()).1, &roi, 11).1
    };
    let full = PixelRoi::full(&cam, 0.2, 0.7);
    // 0.42 m away the image spans about +-0.15 m: a handle centred 6 cm (or -6 cm) off the
    // optical axis loses 3 cm of one end beyond the image's edge, at 4.5 cm about 1.5 cm
    // (within the length tolerance: its midpoint would be 7 mm off).
    for (x, cut) in [
        (0.045, CutEnd::High),
        (0.06, CutEnd::High),
        (-0.06, CutEnd::Low),
    ] {
        let centre = Point3::new(x, 0.0, 0.42);
        let estimate = match fit(centre, full) {
            Ok(e) => e,
            Err(e) => panic!("{e}"),
        };
        let seen_short = model.length_m - estimate.measured_length_m;
        assert!(seen_short > 0.01, "only {seen_short} m cut");
        let cut = if estimate.fit.cylinder.direction.x < 0.0 {
            // Low and high are along the fitted axis, whose sign is the fit's: flip with it.
            match cut {
                CutEnd::High => CutEnd::Low,
                CutEnd::Low => CutEnd::High,
                CutEnd::None => CutEnd::None,
            }
        } else {
            cut
        };
        assert_eq!(estimate.cut, cut);
        let error = (estimate.pose.point - centre).norm();
        assert!(
            error < 0.003,
            "centre {error} m off with {seen_short} m cut"
        );
    }
    // A ROI around a prior 4 cm off cuts the other end the same way.
    let roi = PixelRoi {
        u_min: 0,
        v_min: 0,
        u_max: (cam.cx + cam.fx * 0.09 / 0.42) as usize,
        v_max: cam.height as usize,
        z_min_m: 0.2,
        z_max_m: 0.7,
    };
    let centre = Point3::new(0.0, 0.0, 0.42);
    match fit(centre, roi) {
        Ok(e) => {
            assert_ne!(e.cut, CutEnd::None);
            let error = (e.pose.point - centre).norm();
            assert!(error < 0.003, "centre {error} m off");
        }
        Err(e) => panic!("{e}"),
    }
    // Both ends cut: nothing places the centre.
    let narrow = PixelRoi {
        u_min: (cam.cx - cam.fx * 0.1 / 0.42) as usize,
        u_max: (cam.cx + cam.fx * 0.1 / 0.42) as usize,
        ..full
    };
    let result = fit(centre, narrow);
    assert!(
        matches!(result, Err(PerceptionError::HandleCut { .. })),
        "{result:?}"
    );
}

#[test]
fn cylinder_fit_is_deterministic() {
    let cam = wrist_nominal();
    let scene = WireScene::random(3);
    let depth = scene.render(rays(), &NoiseModel::default(), 4);
    let roi = prior_roi(&scene, 0.0);
    let a = detect_wire(&depth, rays(), cam.fx, &roi, &WireParams::default());
    let b = detect_wire(&depth, rays(), cam.fx, &roi, &WireParams::default());
    assert_eq!(a, b);
    // And the two-sample RANSAC handles points that are all on one side of nothing: too few.
    let few = [Point3::origin(); 5];
    assert!(matches!(
        fit_cylinder(&few, |_| None, &RansacParams::default()),
        Err(PerceptionError::TooFewPoints { got: 5, .. })
    ));
}

/// The hanging-point error over 30 random scenes, with the panoramic prior 0-20 mm off and
/// the requested location = the axis point nearest the ROI centre's ray (what the task stage
/// does): median and 95th percentile (simulator target: < 3 mm and < 8 mm).
#[test]
fn hanging_point_error_distribution_over_random_scenes() {
    use control::perception::wire::axis_point_nearest_ray;
    let cam = wrist_nominal();
    let mut errors_mm = Vec::new();
    let mut rng = SplitMix64::new(99);
    for seed in 100..130u64 {
        let scene = WireScene::random(seed);
        let depth = scene.render(rays(), &NoiseModel::default(), seed);
        let roi = prior_roi(&scene, rng.uniform(-0.02, 0.02));
        let obs = match detect_wire(&depth, rays(), cam.fx, &roi, &WireParams::default()) {
            Ok(o) => o,
            Err(e) => panic!("seed {seed}: {e}"),
        };
        let (u, v) = roi.centre_px();
        let x = cam
            .undistort_pixel(&nalgebra::Point2::new(u, v))
            .expect("the ROI centre undistorts");
        let ray = Vector3::new(x.x, x.y, 1.0);
        let truth = truth_cylinder(&scene.wire);
        let (Ok(near_est), Ok(near_true)) = (
            axis_point_nearest_ray(&obs.fit.cylinder, &Point3::origin(), &ray),
            axis_point_nearest_ray(&truth, &Point3::origin(), &ray),
        ) else {
            panic!("seed {seed}: ray parallel to the wire");
        };
        let (Ok(est), Ok(tru)) = (
            hanging_point(&obs.fit.cylinder, &near_est, &Point3::origin()),
            hanging_point(&truth, &near_true, &Point3::origin()),
        ) else {
            panic!("seed {seed}: degenerate");
        };
        errors_mm.push((est.point - tru.point).norm() * 1e3);
    }
    errors_mm.sort_by(f64::total_cmp);
    let median = errors_mm[errors_mm.len() / 2];
    let p95 = errors_mm[(errors_mm.len() * 95).div_ceil(100) - 1];
    eprintln!(
        "hanging point error: median {median:.4} mm, p95 {p95:.4} mm, max {:.4} mm",
        errors_mm[errors_mm.len() - 1]
    );
    assert!(
        median < 0.5 && p95 < 1.0,
        "median {median} mm, p95 {p95} mm"
    );
}

#[test]
fn look_pose_points_the_camera_at_the_wire() {
    use control::perception::roi::wrist_look_pose;
    let wire_point = Point3::new(0.8, 0.2, 2.9);
    let wire_dir = Vector3::new(0.1, 1.0, 0.05);
    let robot = Point3::new(0.0, 0.0, 1.5);
    let base_from_camera = match wrist_look_pose(&wire_point, &wire_dir, &robot, 0.45) {
        Ok(p) => p,
        Err(e) => panic!("{e}"),
    };
    let in_camera = base_from_camera.inverse() * wire_point;
    assert!(in_camera.x.abs() < 1e-12 && in_camera.y.abs() < 1e-12);
    assert!((in_camera.z - 0.45).abs() < 1e-12);
    // The wire runs along the image x axis.
    let dir_in_camera = base_from_camera.inverse().rotation * wire_dir.normalize();
    assert!(dir_in_camera.x.abs() > 1.0 - 1e-12);
    // The camera is on the robot's side of the wire.
    let cam = base_from_camera * Point3::origin();
    assert!((cam - wire_point).dot(&(robot - wire_point)) > 0.0);
    assert!(matches!(
        wrist_look_pose(&wire_point, &wire_dir, &(wire_point + wire_dir), 0.45),
        Err(PerceptionError::Degenerate { .. })
    ));
    let cam_model = wrist_nominal();
    let behind = PixelRoi::around_segment(
        &cam_model,
        &Point3::new(0.0, 0.0, -1.0),
        &Point3::new(0.1, 0.0, -1.0),
        10.0,
        0.01,
    );
    assert!(matches!(behind, Err(PerceptionError::Degenerate { .. })));
}

#[test]
fn washed_out_capture_is_refused_on_depth_validity() {
    let cam = wrist_nominal();
    let scene = WireScene::random(8);
    let mut depth = scene.render(rays(), &NoiseModel::default(), 8);
    let roi = prior_roi(&scene, 0.0);
    // Sun washes out 70% of the 16x16 blocks (the projected pattern is lost there).
    let mut rng = SplitMix64::new(80);
    let (bw, bh) = (depth.width.div_ceil(16), depth.height.div_ceil(16));
    for bj in 0..bh {
        for bi in 0..bw {
            if rng.next_f64() >= 0.7 {
                continue;
            }
            for v in bj * 16..((bj + 1) * 16).min(depth.height) {
                for u in bi * 16..((bi + 1) * 16).min(depth.width) {
                    if let Some(d) = depth.depth_m.get_mut(v * depth.width + u) {
                        *d = 0.0;
                    }
                }
            }
        }
    }
    let outcome = detect_wire(&depth, rays(), cam.fx, &roi, &WireParams::default()).and_then(|o| {
        estimate_wire(
            &[(o, Isometry3::identity())],
            &scene.wire.centre,
            &Point3::origin(),
            WIRE_RADIUS_M,
            &ConfidenceThresholds::default(),
        )
    });
    assert!(
        matches!(
            outcome,
            Err(PerceptionError::LowConfidence {
                limiting: "valid_depth",
                ..
            })
        ),
        "{outcome:?}"
    );
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig {
        cases: 32,
        rng_seed: proptest::test_runner::RngSeed::Fixed(0x5EED_0032),
        failure_persistence: None,
        ..proptest::prelude::ProptestConfig::default()
    })]
    /// Points on the visible arc (±60°) of a random cylinder, 0.1 mm noise, normals with ~2°
    /// noise, 40% uniform outliers: the axis comes back within 0.2 mm and 0.2°.
    #[test]
    fn ransac_recovers_random_cylinders(seed in 0u64..1_000_000) {
        let mut rng = SplitMix64::new(seed);
        let direction = control::perception::synthetic::unit_vector(&mut rng);
        let truth = Cylinder {
            point: Point3::new(rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1), rng.uniform(0.3, 0.6)),
            direction,
            radius_m: WIRE_RADIUS_M,
        };
        let view = -truth.point.coords.normalize();
        let e1 = (view - direction * view.dot(&direction)).normalize();
        let e2 = direction.cross(&e1);
        let mut points = Vec::new();
        let mut normals = Vec::new();
        for _ in 0..3000 {
            let angle = rng.uniform(-1.05, 1.05);
            let n = e1 * angle.cos() + e2 * angle.sin();
            let along = rng.uniform(-0.15, 0.15);
            let p = truth.point + direction * along + n * (WIRE_RADIUS_M + 1e-4 * rng.normal());
            points.push(p);
            normals.push((n + control::perception::synthetic::unit_vector(&mut rng) * 0.035).normalize());
        }
        for _ in 0..2000 {
            points.push(truth.point + Vector3::new(rng.uniform(-0.2, 0.2), rng.uniform(-0.2, 0.2), rng.uniform(-0.1, 0.3)));
            normals.push(control::perception::synthetic::unit_vector(&mut rng));
        }
        let fit = fit_cylinder(&points, |k| normals.get(k).copied(), &RansacParams::default());
        proptest::prop_assert!(fit.is_ok(), "{:?}", fit);
        if let Ok(fit) = fit {
            let angle = fit.cylinder.axis_angle_to(&truth).to_degrees();
            let offset = truth.axis_offset_near(&fit.cylinder, &truth.point);
            proptest::prop_assert!(angle < 0.2 && offset < 2e-4, "angle {} deg, offset {} m", angle, offset);
        }
    }
}

#[test]
fn partial_handle_view_is_refused_and_messages_round_trip() {
    let cam = wrist_nominal();
    let model = HandleModel::default();
    let handle = CylinderShape {
        centre: Point3::new(0.0, 0.0, 0.4),
        direction: Vector3::x(),
        radius_m: model.radius_m,
        half_length_m: 0.03, // only 60 mm of the 250 mm handle visible
    };
    let scene = Scene {
        cylinders: vec![handle],
        ..Scene::default()
    };
    let (depth, result) = fit_rendered_handle(&scene, &PixelRoi::full(&cam, 0.2, 0.7), 1);
    assert!(
        matches!(result, Err(PerceptionError::HandleLength { .. })),
        "{result:?}"
    );
    // CameraInfo and depth Image round trips.
    let info = cam.to_camera_info(Header::default());
    assert_eq!(CameraModel::from_camera_info(&info), Ok(cam));
    let image = depth.to_image(Header::default());
    assert_eq!(
        control::perception::point_cloud::DepthImage::from_image(&image),
        Ok(depth)
    );
    let fisheye = msgs::sensor_msgs::CameraInfo {
        distortion_model: "equidistant".into(),
        ..info
    };
    assert!(matches!(
        CameraModel::from_camera_info(&fisheye),
        Err(robot::camera::CameraError::BadCameraInfo { .. })
    ));
}
