//! Unit tests of the SIFT detector and descriptor on synthetic images with known answers.

use super::*;
use crate::features::GrayBuf;
use crate::features::synth::{similarity, textured_image, warp_homography};

/// A `w x h` image rendered from `f(x, y)` in grey levels, rounded and clamped.
fn render(w: usize, h: usize, f: impl Fn(f64, f64) -> f64) -> GrayBuf {
    let mut data = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            data.push(f(x as f64, y as f64).round().clamp(0.0, 255.0) as u8);
        }
    }
    GrayBuf {
        data,
        width: w,
        height: h,
    }
}

fn gauss(x: f64, y: f64, cx: f64, cy: f64, s: f64) -> f64 {
    (-((x - cx).powi(2) + (y - cy).powi(2)) / (2.0 * s * s)).exp()
}

fn nearest(kps: &[SiftKeypoint], x: f32, y: f32) -> Option<&SiftKeypoint> {
    kps.iter().min_by(|a, b| {
        let da = (a.x - x).powi(2) + (a.y - y).powi(2);
        let db = (b.x - x).powi(2) + (b.y - y).powi(2);
        da.total_cmp(&db)
    })
}

#[test]
fn gaussian_blob_is_found_at_its_centre_and_scale() {
    // The scale-normalised Laplacian of a Gaussian blob of std s peaks at sigma = s
    // (Lindeberg; Lowe sec. 3), so the keypoint's size (2 sigma) should be ~2 s.
    for &s in &[3.0f64, 5.0, 8.0] {
        let (cx, cy) = (64.3, 60.7);
        let img = render(128, 128, |x, y| 40.0 + 180.0 * gauss(x, y, cx, cy, s));
        let f = detect_and_describe(&img.view(), &SiftParams::default()).expect("sift");
        let k = nearest(&f.keypoints, cx as f32, cy as f32).expect("a keypoint");
        let d = ((k.x - cx as f32).powi(2) + (k.y - cy as f32).powi(2)).sqrt();
        assert!(d < 0.3, "s={s}: centre off by {d} px ({k:?})");
        let ratio = f64::from(k.size) / (2.0 * s);
        assert!(
            (0.85..1.2).contains(&ratio),
            "s={s}: size {} ({ratio})",
            k.size
        );
        assert_eq!(f.descriptors.len(), f.keypoints.len());
    }
}

#[test]
fn orientation_follows_a_rotated_image() {
    // Keypoints of a textured scene and of its rotation by theta about the centre, paired
    // by position (through the rotation) and size; only points with a single orientation in
    // both images are compared, so no pairing by angle can hide an error.
    let a = textured_image(256, 256, 21);
    let p = SiftParams::default();
    let fa = detect_and_describe(&a.view(), &p).expect("sift");
    let single = |kps: &[SiftKeypoint], k: &SiftKeypoint| {
        kps.iter()
            .filter(|o| o.x == k.x && o.y == k.y && o.size == k.size)
            .count()
            == 1
    };
    for deg in [30.0f64, 90.0, -75.0, 150.0] {
        let h = similarity(deg.to_radians(), 1.0, 128.0, 128.0, 0.0, 0.0);
        let b = warp_homography(&a, &h, 256, 256, 0).expect("warp");
        let fb = detect_and_describe(&b.view(), &p).expect("sift");
        let mut diffs = Vec::new();
        for ka in fa.keypoints.iter().filter(|k| single(&fa.keypoints, k)) {
            let (x, y) =
                crate::features::synth::apply_homography(&h, f64::from(ka.x), f64::from(ka.y));
            let hit = fb.keypoints.iter().find(|kb| {
                (f64::from(kb.x) - x).hypot(f64::from(kb.y) - y) < 1.0
                    && (kb.size / ka.size - 1.0).abs() < 0.1
                    && single(&fb.keypoints, kb)
            });
            if let Some(kb) = hit {
                let d = (kb.angle_rad - ka.angle_rad).to_degrees() - deg as f32;
                diffs.push(((d + 540.0).rem_euclid(360.0) - 180.0).abs());
            }
        }
        diffs.sort_by(f32::total_cmp);
        assert!(
            diffs.len() >= 20,
            "rotation {deg}: only {} pairs",
            diffs.len()
        );
        let median = diffs[diffs.len() / 2];
        let within5 = diffs.iter().filter(|&&d| d < 5.0).count();
        assert!(median < 2.0, "rotation {deg}: median error {median} deg");
        assert!(
            within5 * 10 >= diffs.len() * 8,
            "rotation {deg}: {within5} of {} within 5 deg",
            diffs.len()
        );
    }
}

#[test]
fn parallel_and_sequential_give_identical_features() {
    let img = textured_image(200, 160, 3);
    let p = SiftParams::default();
    let seq = SiftParams {
        parallel: false,
        ..p.clone()
    };
    let a = detect_and_describe(&img.view(), &p).expect("sift");
    let b = detect_and_describe(&img.view(), &seq).expect("sift");
    assert!(a.keypoints.len() > 20, "{}", a.keypoints.len());
    assert_eq!(a, b);
}

#[test]
fn n_features_keeps_the_strongest() {
    let img = textured_image(200, 160, 5);
    let all = detect_and_describe(&img.view(), &SiftParams::default()).expect("sift");
    let n = all.keypoints.len() / 3;
    let some = detect_and_describe(
        &img.view(),
        &SiftParams {
            n_features: n,
            ..Default::default()
        },
    )
    .expect("sift");
    assert_eq!(some.keypoints.len(), n);
    let mut r: Vec<f32> = all.keypoints.iter().map(|k| k.response).collect();
    r.sort_by(|a, b| b.total_cmp(a));
    let weakest_kept = some
        .keypoints
        .iter()
        .map(|k| k.response)
        .fold(f32::INFINITY, f32::min);
    assert!(weakest_kept >= r[n - 1]);
}

#[test]
fn descriptors_are_normalised_integers() {
    let img = textured_image(160, 160, 9);
    let f = detect_and_describe(&img.view(), &SiftParams::default()).expect("sift");
    for d in &f.descriptors {
        assert!(
            d.iter()
                .all(|v| v.fract() == 0.0 && (0.0..=255.0).contains(v))
        );
        let n = d.iter().map(|v| v * v).sum::<f32>().sqrt();
        // 512 after renormalisation, up to rounding of 128 entries.
        assert!((n - 512.0).abs() < 8.0, "norm {n}");
    }
}

#[test]
fn matches_a_rotated_scaled_synthetic_scene() {
    let a = textured_image(320, 256, 11);
    let h = similarity(0.5, 0.8, 160.0, 128.0, 5.0, -3.0);
    let b = warp_homography(&a, &h, 320, 256, 0).expect("warp");
    let p = SiftParams::default();
    let fa = detect_and_describe(&a.view(), &p).expect("sift");
    let fb = detect_and_describe(&b.view(), &p).expect("sift");
    let m = match_l2_ratio(
        &fa.descriptors,
        &fb.descriptors,
        &SiftMatchParams::default(),
    );
    let good = m
        .iter()
        .filter(|m| {
            let ka = &fa.keypoints[m.query as usize];
            let kb = &fb.keypoints[m.train as usize];
            let (x, y) =
                crate::features::synth::apply_homography(&h, f64::from(ka.x), f64::from(ka.y));
            (x - f64::from(kb.x)).hypot(y - f64::from(kb.y)) < 3.0
        })
        .count();
    assert!(m.len() >= 30, "{} matches", m.len());
    assert!(good * 10 >= m.len() * 9, "{good} of {} correct", m.len());
}

#[test]
fn rejects_bad_input() {
    let img = textured_image(10, 40, 1);
    assert!(matches!(
        detect_and_describe(&img.view(), &SiftParams::default()),
        Err(FeatureError::ImageTooSmall { .. })
    ));
    let img = textured_image(40, 40, 1);
    let p = SiftParams {
        n_octave_layers: 0,
        ..Default::default()
    };
    assert!(matches!(
        detect_and_describe(&img.view(), &p),
        Err(FeatureError::InvalidParam { .. })
    ));
}

#[test]
fn fast_atan2_is_within_a_hundredth_of_a_degree() {
    for k in 0..3600 {
        let t = (k as f32 * 0.1).to_radians();
        for r in [0.01f32, 1.0, 300.0] {
            let (y, x) = (r * t.sin(), r * t.cos());
            let mut exact = y.atan2(x).to_degrees();
            if exact < 0.0 {
                exact += 360.0;
            }
            let got = fast_atan2_deg(y, x);
            let mut d = (got - exact).abs();
            d = d.min(360.0 - d);
            assert!(
                d < 0.01 && (0.0..360.0).contains(&got),
                "{k}: {got} vs {exact}"
            );
        }
    }
    assert_eq!(fast_atan2_deg(0.0, 0.0), 0.0);
}

#[test]
fn vector_width_does_not_change_features_or_matches() {
    use simd::{Level, with_max_level};
    let a = textured_image(192, 160, 13);
    let b = warp_homography(&a, &similarity(0.3, 0.9, 96.0, 80.0, 0.0, 0.0), 192, 160, 0)
        .expect("warp");
    let run = || {
        let p = SiftParams::default();
        let fa = detect_and_describe(&a.view(), &p).expect("sift");
        let fb = detect_and_describe(&b.view(), &p).expect("sift");
        let m = match_l2_ratio(
            &fa.descriptors,
            &fb.descriptors,
            &SiftMatchParams::default(),
        );
        (fa, fb, m)
    };
    let wide = run();
    let base = with_max_level(Level::Baseline, run);
    assert!(!wide.2.is_empty());
    assert_eq!(wide, base);
}
