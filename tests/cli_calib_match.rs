//! `rodlog calib match` on a synthetic textured image and a known warp of it: both keypoint
//! distributions give matches the warp confirms, and a wrong `--distribution` is refused
//! with the list of choices.

#[path = "support/cli.rs"]
mod cli;
use cli::rodlog;

use calib::features::synth::{apply_homography, similarity, textured_image, warp_homography};

#[test]
fn match_with_each_distribution_finds_true_matches() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let (w, h) = (640usize, 480usize);
    let a = textured_image(w, h, 11);
    let hb = similarity(12f64.to_radians(), 0.95, 320.0, 240.0, 8.0, -5.0);
    let b = warp_homography(&a, &hb, w, h, 0).expect("warp");
    let paths: Vec<String> = [("a.png", &a), ("b.png", &b)]
        .iter()
        .map(|(name, img)| {
            let path = tmp.path().join(name);
            image::GrayImage::from_raw(w as u32, h as u32, img.data.clone())
                .expect("buffer")
                .save(&path)
                .expect("save");
            path.display().to_string()
        })
        .collect();
    let mut all_matches = Vec::new();
    for distribution in ["quadtree", "retain-best"] {
        let out = rodlog(&[
            "calib",
            "match",
            &paths[0],
            &paths[1],
            "--json",
            "--features",
            "800",
            "--distribution",
            distribution,
        ]);
        assert!(
            out.status.success(),
            "{distribution}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let json: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
        let matches = json["matches"].as_array().expect("matches");
        let good = matches
            .iter()
            .filter(|m| {
                let v: Vec<f64> = (0..4).filter_map(|i| m[i].as_f64()).collect();
                v.len() == 4 && {
                    let (x, y) = apply_homography(&hb, v[0], v[1]);
                    (x - v[2]).hypot(y - v[3]) < 3.0
                }
            })
            .count();
        eprintln!("{distribution}: {good} of {} matches true", matches.len());
        assert!(
            matches.len() > 100 && good * 100 >= matches.len() * 90,
            "{distribution}: {good} of {} matches true",
            matches.len()
        );
        all_matches.push(matches.clone());
    }
    assert_ne!(
        all_matches[0], all_matches[1],
        "--distribution changed nothing"
    );
    let bad = rodlog(&[
        "calib",
        "match",
        &paths[0],
        &paths[1],
        "--distribution",
        "best",
    ]);
    assert!(!bad.status.success());
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(
        err.contains("retain-best") && err.contains("quadtree"),
        "{err}"
    );
}
