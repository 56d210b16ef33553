//! Feature front end: FAST, orientation, quadtree, matching under known geometry, GMS
//! rates, thread-count independence, and a real shecar image when it is present.

use calib::features::fast::{FastDetector, Rect};
use calib::features::gms::{GmsParams, gms_filter};
use calib::features::gray::{GrayBuf, GrayView};
use calib::features::matcher::{Match, MatchParams, match_brute_force};
use calib::features::orb::{OrbParams, ic_angle};
use calib::features::quadtree::Quadtree;
use calib::features::synth::{
    SplitMix64, apply_homography, similarity, textured_image, warp_homography,
};
use calib::features::{
    Keypoint, MatchImagesParams, MatchMethod, MatchResult, detect_and_describe, match_images,
};
use nalgebra::Matrix3;

/// Squares whose brightness peaks at their four corners (250 at a corner, one level less
/// per pixel of L1 distance to the nearest corner) on a dark background: every square
/// corner is a FAST corner whose score is the unique local maximum.
#[test]
fn fast_finds_synthetic_corners_exactly() {
    let (w, h) = (120usize, 90usize);
    let mut img = vec![20u8; w * h];
    let squares = [(10usize, 12usize, 20usize), (50, 30, 24), (85, 55, 18)];
    let mut expected = Vec::new();
    for &(x0, y0, s) in &squares {
        let (x1, y1) = (x0 + s - 1, y0 + s - 1);
        for y in y0..=y1 {
            for x in x0..=x1 {
                let d = (x - x0).min(x1 - x) + (y - y0).min(y1 - y);
                img[y * w + x] = 250 - d as u8;
            }
        }
        expected.extend([(x0, y0), (x1, y0), (x0, y1), (x1, y1)]);
    }
    let view = GrayView::new(&img, w, h).expect("view");
    let mut det = FastDetector::new();
    let mut out = Vec::new();
    det.detect(
        &view,
        Rect {
            x0: 0,
            y0: 0,
            x1: w,
            y1: h,
        },
        20,
        true,
        &mut out,
    );
    let mut got: Vec<(usize, usize)> = out.iter().map(|c| (c.x as usize, c.y as usize)).collect();
    got.sort_unstable();
    expected.sort_unstable();
    assert_eq!(got, expected);
    // The score is the contrast margin: 250 - 20.
    assert!(out.iter().all(|c| c.score == 230), "{out:?}");
    // Without suppression the plateau next to each corner is found too.
    let mut all = Vec::new();
    det.detect(
        &view,
        Rect {
            x0: 0,
            y0: 0,
            x1: w,
            y1: h,
        },
        20,
        false,
        &mut all,
    );
    assert!(all.len() > got.len());
    // Above the contrast, nothing.
    let mut none = Vec::new();
    det.detect(
        &view,
        Rect {
            x0: 0,
            y0: 0,
            x1: w,
            y1: h,
        },
        230,
        true,
        &mut none,
    );
    assert!(none.is_empty());
}

/// Renders a 41x41 asymmetric patch (two Gaussian blobs and a ramp) rotated by `theta`
/// about its centre.
fn rotated_patch(theta: f64) -> Vec<u8> {
    let n = 41usize;
    let c = 20.0;
    let (s, co) = theta.sin_cos();
    let mut out = vec![0u8; n * n];
    for y in 0..n {
        for x in 0..n {
            // Back-rotate the pixel into the patch's own frame.
            let (dx, dy) = (x as f64 - c, y as f64 - c);
            let (u, v) = (co * dx + s * dy, -s * dx + co * dy);
            let blob = |bx: f64, by: f64, sig: f64| {
                (-((u - bx).powi(2) + (v - by).powi(2)) / (2.0 * sig * sig)).exp()
            };
            let val = 60.0 + 120.0 * blob(7.0, 2.0, 3.5) + 60.0 * blob(-4.0, 8.0, 2.5) + 1.5 * u;
            out[y * n + x] = val.round().clamp(0.0, 255.0) as u8;
        }
    }
    out
}

#[test]
fn orientation_follows_patch_rotation() {
    let umax: Vec<i32> = (0..=15)
        .map(|v: i32| (f64::from(225 - v * v)).sqrt().round() as i32)
        .collect();
    let base = rotated_patch(0.0);
    let a0 = ic_angle(&GrayView::new(&base, 41, 41).expect("view"), 20, 20, &umax);
    for deg in [-170.0f64, -60.0, 12.0, 30.0, 90.0, 145.0] {
        let img = rotated_patch(deg.to_radians());
        let a = ic_angle(&GrayView::new(&img, 41, 41).expect("view"), 20, 20, &umax);
        let mut diff = f64::from(a - a0).to_degrees() - deg;
        diff = (diff + 540.0).rem_euclid(360.0) - 180.0;
        assert!(
            diff.abs() < 2.0,
            "rotation {deg} deg: orientation off by {diff} deg"
        );
    }
}

#[test]
fn quadtree_gives_exact_count_and_spread() {
    // 6000 points, 80% packed into one corner cluster with higher responses.
    let mut rng = SplitMix64::new(7);
    let (w, h) = (640.0f32, 480.0f32);
    let mut xy = Vec::new();
    let mut resp = Vec::new();
    for i in 0..6000 {
        if i % 5 != 0 {
            xy.push([
                (rng.next_f64() * 100.0) as f32,
                (rng.next_f64() * 100.0) as f32,
            ]);
            resp.push(100.0 + rng.next_f64() as f32);
        } else {
            xy.push([
                (rng.next_f64() * f64::from(w)) as f32,
                (rng.next_f64() * f64::from(h)) as f32,
            ]);
            resp.push(rng.next_f64() as f32);
        }
    }
    let mut out = Vec::new();
    let mut qt = Quadtree::new();
    for n in [1usize, 17, 300, 1000] {
        qt.distribute(&xy, &resp, (0.0, 0.0, w, h), n, &mut out);
        assert_eq!(out.len(), n, "asked for {n}");
        assert!(out.windows(2).all(|p| p[0] < p[1]), "sorted, distinct");
    }
    // Spread: of the 8x6 cells (80 px) holding input points, >= 90% hold a chosen one at
    // n = 300, while the 300 strongest all sit in the cluster (2 cells).
    qt.distribute(&xy, &resp, (0.0, 0.0, w, h), 300, &mut out);
    let cell = |p: &[f32; 2]| (p[0] / 80.0) as usize + 8 * (p[1] / 80.0) as usize;
    let mut occupied = [false; 48];
    let mut covered = [false; 48];
    for p in &xy {
        occupied[cell(p)] = true;
    }
    for &i in &out {
        covered[cell(&xy[i as usize])] = true;
    }
    let n_occ = occupied.iter().filter(|&&o| o).count();
    let n_cov = covered.iter().filter(|&&c| c).count();
    assert!(n_cov * 10 >= n_occ * 9, "{n_cov} of {n_occ} cells covered");
    let in_cluster = out
        .iter()
        .filter(|&&i| xy[i as usize][0] < 100.0 && xy[i as usize][1] < 100.0)
        .count();
    assert!(in_cluster < 150, "{in_cluster} of 300 in the cluster");
    // Asking for more than there are returns all of them.
    qt.distribute(&xy[..10], &resp[..10], (0.0, 0.0, w, h), 50, &mut out);
    assert_eq!(out.len(), 10);
}

#[test]
fn orb_returns_requested_count_spread_over_levels() {
    let img = textured_image(1280, 1024, 11);
    let f = detect_and_describe(&img.view(), &OrbParams::default()).expect("orb");
    assert_eq!(f.keypoints.len(), 2000);
    assert_eq!(f.descriptors.len(), 2000);
    let levels: std::collections::BTreeSet<u8> = f.keypoints.iter().map(|k| k.level).collect();
    assert!(levels.len() >= 6, "levels used: {levels:?}");
    for k in &f.keypoints {
        let s = 1.2f32.powi(i32::from(k.level));
        assert!(
            k.x >= 19.0 * s - 1e-3 && k.x <= 1280.0 - 19.0 * s + 1.0,
            "{k:?}"
        );
        assert!(
            k.y >= 19.0 * s - 1e-3 && k.y <= 1024.0 - 19.0 * s + 1.0,
            "{k:?}"
        );
    }
    let small = detect_and_describe(
        &img.view(),
        &OrbParams {
            n_features: 150,
            ..Default::default()
        },
    )
    .expect("orb");
    assert_eq!(small.keypoints.len(), 150);
}

/// Correct matches: B keypoint within `tol * 1.2^level` px of H(A keypoint) (`tol` pixels
/// of the level the A keypoint was found in).
fn true_matches(r: &MatchResult, b_from_a: &Matrix3<f64>, tol: f64) -> (usize, usize) {
    let mut good = 0;
    let mut kept = 0;
    for m in r.inlier_matches() {
        let a = &r.features_a.keypoints[m.query as usize];
        let b = &r.features_b.keypoints[m.train as usize];
        let (x, y) = apply_homography(b_from_a, f64::from(a.x), f64::from(a.y));
        kept += 1;
        if (x - f64::from(b.x)).hypot(y - f64::from(b.y)) < tol * 1.2f64.powi(i32::from(a.level)) {
            good += 1;
        }
    }
    (good, kept)
}

#[test]
fn matches_rotated_and_scaled_image() {
    let a = textured_image(800, 600, 3);
    for (deg, scale, rot) in [(10.0f64, 1.0, false), (35.0, 0.8, true), (-90.0, 1.0, true)] {
        let hb = similarity(deg.to_radians(), scale, 400.0, 300.0, 5.0, -3.0);
        let b = warp_homography(&a, &hb, 800, 600, 0).expect("warp");
        let mut p = MatchImagesParams::for_method(MatchMethod::OrbGms);
        p.gms.with_rotation = rot;
        let r = match_images(&a.view(), &b.view(), MatchMethod::OrbGms, &p).expect("match");
        let (good, kept) = true_matches(&r, &hb, 3.0);
        eprintln!("{deg} deg x{scale}: {good} of {kept} GMS matches correct");
        assert!(kept >= 300, "{deg} deg x{scale}: only {kept} GMS matches");
        assert!(
            good * 100 >= kept * 95,
            "{deg} deg x{scale}: {good} of {kept} correct"
        );
    }
}

/// 1500 true matches (under a similarity, 0.5 px noise) and 1500 uniformly random ones
/// over a 1280x1024 image pair; returns (keypoints A, keypoints B, matches, is_true).
struct Planted {
    kps_a: Vec<Keypoint>,
    kps_b: Vec<Keypoint>,
    matches: Vec<Match>,
    truth: Vec<bool>,
}

fn planted_matches(hb: &Matrix3<f64>, seed: u64) -> Planted {
    let (w, h) = (1280.0, 1024.0);
    let mut rng = SplitMix64::new(seed);
    let kp = |x: f64, y: f64| Keypoint {
        x: x as f32,
        y: y as f32,
        level: 0,
        angle_rad: 0.0,
        response: 0.0,
        size: 31.0,
    };
    let (mut kps_a, mut kps_b, mut matches, mut truth) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    while kps_a.len() < 3000 {
        let (x, y) = (rng.next_f64() * w, rng.next_f64() * h);
        let is_true = kps_a.len() % 2 == 0;
        let (bx, by) = if is_true {
            let (bx, by) = apply_homography(hb, x, y);
            (bx + rng.next_f64() - 0.5, by + rng.next_f64() - 0.5)
        } else {
            (rng.next_f64() * w, rng.next_f64() * h)
        };
        if !(0.0..w).contains(&bx) || !(0.0..h).contains(&by) {
            continue;
        }
        let i = kps_a.len() as u32;
        kps_a.push(kp(x, y));
        kps_b.push(kp(bx, by));
        matches.push(Match {
            query: i,
            train: i,
            distance: 0,
        });
        truth.push(is_true);
    }
    Planted {
        kps_a,
        kps_b,
        matches,
        truth,
    }
}

/// Stated rates, with 2 x 1500 matches (3.75 true + 3.75 random per cell of the 20x20
/// grid, sparse as from 2000 ORB features): GMS keeps >= 75% of the true matches up to
/// 15 degrees and 0.9x without options, >= 65% at 30 degrees with the rotation and scale
/// options, and drops >= 98.5% of the random ones in every case. (Recall is limited by
/// the threshold 6 sqrt(n) at this density; the mask equals OpenCV's, see
/// features_opencv.rs.)
#[test]
fn gms_keeps_true_and_drops_random_matches() {
    let size = (1280usize, 1024usize);
    let cases = [
        (0.0f64, 1.0, false, false, 75),
        (15.0, 0.9, false, false, 75),
        (30.0, 1.0, true, true, 65),
    ];
    for (deg, scale, with_rotation, with_scale, min_true_pct) in cases {
        let hb = similarity(deg.to_radians(), scale, 640.0, 512.0, 10.0, 20.0);
        let Planted {
            kps_a,
            kps_b,
            matches,
            truth,
        } = planted_matches(&hb, 99);
        let p = GmsParams {
            with_rotation,
            with_scale,
            ..Default::default()
        };
        let mask = gms_filter(&kps_a, size, &kps_b, size, &matches, &p);
        let n_true = truth.iter().filter(|&&t| t).count();
        let n_false = truth.len() - n_true;
        let kept_true = mask.iter().zip(&truth).filter(|(m, t)| **m && **t).count();
        let kept_false = mask.iter().zip(&truth).filter(|(m, t)| **m && !**t).count();
        eprintln!(
            "{deg} deg x{scale} rot {with_rotation} scale {with_scale}: kept {kept_true}/{n_true} true, {kept_false}/{n_false} random"
        );
        assert!(
            kept_true * 100 >= n_true * min_true_pct,
            "{deg} deg: kept {kept_true}/{n_true} true"
        );
        assert!(
            kept_false * 1000 <= n_false * 15,
            "{deg} deg: kept {kept_false}/{n_false} random"
        );
    }
    // At 30 degrees the rotated neighbour patterns matter.
    let hb = similarity(30f64.to_radians(), 1.0, 640.0, 512.0, 10.0, 20.0);
    let Planted {
        kps_a,
        kps_b,
        matches,
        truth,
    } = planted_matches(&hb, 99);
    let count_true = |p: &GmsParams| {
        let mask = gms_filter(&kps_a, size, &kps_b, size, &matches, p);
        mask.iter().zip(&truth).filter(|(m, t)| **m && **t).count()
    };
    let plain = count_true(&GmsParams::default());
    let rotated = count_true(&GmsParams {
        with_rotation: true,
        ..Default::default()
    });
    assert!(
        rotated * 2 >= plain * 3,
        "rotation option: {rotated} vs {plain} true kept"
    );
    // Out-of-range indices are outliers, not panics.
    let bad = [Match {
        query: 5000,
        train: 0,
        distance: 0,
    }];
    assert_eq!(
        gms_filter(&kps_a, size, &kps_b, size, &bad, &GmsParams::default()),
        vec![false]
    );
}

#[test]
fn results_do_not_depend_on_thread_count() {
    let a = textured_image(640, 480, 21);
    let hb = similarity(0.2, 0.95, 320.0, 240.0, 4.0, 2.0);
    let b = warp_homography(&a, &hb, 640, 480, 0).expect("warp");
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool");
        pool.install(|| {
            let p = MatchImagesParams::for_method(MatchMethod::OrbGms);
            match_images(&a.view(), &b.view(), MatchMethod::OrbGms, &p).expect("match")
        })
    };
    let (r1, r2) = (run(1), run(2));
    assert_eq!(r1.features_a, r2.features_a);
    assert_eq!(r1.features_b, r2.features_b);
    assert_eq!(r1.matches, r2.matches);
    assert_eq!(r1.inliers, r2.inliers);
    let seq = match_brute_force(
        r1.features_a.descriptors.binary().unwrap_or_default(),
        r1.features_b.descriptors.binary().unwrap_or_default(),
        &MatchParams {
            parallel: false,
            ..Default::default()
        },
    );
    assert_eq!(seq, r1.matches);
}

fn shecar_dir() -> Option<std::path::PathBuf> {
    testkit::shared_data("shecar", "shecar homography matching")
}

#[test]
fn shecar_image_matches_its_homography_warp() {
    let Some(dir) = shecar_dir() else {
        return;
    };
    let full = calib::features::command::gray_from_encoded(
        &std::fs::read(dir.join("00.jpg")).expect("read"),
    )
    .expect("decode");
    let small = image::imageops::resize(&full, 1280, 720, image::imageops::FilterType::Triangle);
    let mut a = GrayBuf::default();
    a.copy_from(&GrayView::from_image(&small));
    // A mild perspective change plus rotation.
    let hb = Matrix3::new(0.95, -0.12, 60.0, 0.10, 0.97, -20.0, 2e-5, -1e-5, 1.0);
    let b = warp_homography(&a, &hb, 1280, 720, 0).expect("warp");
    let p = MatchImagesParams::for_method(MatchMethod::OrbGms);
    let r = match_images(&a.view(), &b.view(), MatchMethod::OrbGms, &p).expect("match");
    let (good, kept) = true_matches(&r, &hb, 3.0);
    eprintln!(
        "shecar 00 vs warp: {good} of {kept} GMS matches correct, {} BF matches",
        r.matches.len()
    );
    assert!(kept >= 300 && good * 100 >= kept * 90, "{good} of {kept}");
}

/// `rodlog calib match`'s library side: encoded images in, JSON and picture out.
#[test]
fn match_command_writes_json_and_picture() {
    use calib::features::command::{
        PairMatching, gray_from_encoded, match_json, match_pair, match_picture, match_summary,
    };
    let dir = std::env::temp_dir().join(format!("rodlog-features-cmd-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let a = textured_image(640, 480, 8);
    let hb = similarity(0.3, 0.9, 320.0, 240.0, 0.0, 0.0);
    let b = warp_homography(&a, &hb, 640, 480, 0).expect("warp");
    let (pa, pb, pic) = (dir.join("a.png"), dir.join("b.png"), dir.join("match.png"));
    for (img, p) in [(&a, &pa), (&b, &pb)] {
        image::GrayImage::from_raw(640, 480, img.data.clone())
            .expect("image")
            .save(p)
            .expect("png");
    }
    let how = PairMatching {
        n_features: 1000,
        ..PairMatching::default()
    };
    let decoded = |p: &std::path::Path| gray_from_encoded(&std::fs::read(p).expect("read"));
    let (ga, gb) = (decoded(&pa).expect("png a"), decoded(&pb).expect("png b"));
    let r = match_pair(&ga, &gb, &how).expect("match");
    match_picture(&ga, &gb, &r).save(&pic).expect("picture");
    assert_eq!(r.features_a.keypoints.len(), 1000);
    let json: serde_json::Value = serde_json::from_str(&match_json(&r)).expect("json");
    assert_eq!(json["method"], "orb-gms");
    assert_eq!(json["keypoints_a"], 1000);
    let pairs = json["matches"].as_array().expect("matches");
    assert_eq!(pairs.len(), r.inliers.iter().filter(|&&k| k).count());
    // Coordinates are full-size pixels that satisfy the known geometry.
    let first = pairs[0].as_array().expect("pair");
    let f = |i: usize| first[i].as_f64().expect("number");
    let (x, y) = apply_homography(&hb, f(0), f(1));
    assert!((x - f(2)).hypot(y - f(3)) < 10.0);
    for key in ["detect", "match", "filter"] {
        assert!(
            json["time_ms"][key].as_f64().is_some_and(|t| t >= 0.0),
            "{key}"
        );
    }
    let png = image::open(&pic).expect("picture").to_rgb8();
    assert_eq!(png.dimensions(), (1280, 480));
    eprintln!("{}\npicture: {}", match_summary(&r), pic.display());
    // Bytes that are no image, and a zero feature count, are errors.
    let err = gray_from_encoded(b"not an image").expect_err("garbage");
    assert!(err.to_string().contains("cannot decode"), "{err}");
    let none = PairMatching {
        n_features: 0,
        ..PairMatching::default()
    };
    assert!(match_pair(&ga, &gb, &none).is_err());
    assert!("surf".parse::<MatchMethod>().is_err());
    assert_eq!("sift".parse::<MatchMethod>().ok(), Some(MatchMethod::Sift));
}
