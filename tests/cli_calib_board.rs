//! `rodlog calib board` on the shecar sample (the paper's dataset 2) imported with
//! `rodlog import shecar`: the 6x8 board is found in all 18 images and the board-based X
//! has the README reference's quality (median AX=XB rotation residual ~0.87 deg over the 153
//! pairs with Park; rotation within ~0.4 deg of identity, t ~ (-2.4, -6.4, -10.1) mm).

#[path = "support/cli.rs"]
mod cli;
use cli::rodlog;

#[test]
fn board_calibration_of_imported_shecar_matches_the_reference() {
    let Some(data) = testkit::shared_data("shecar", "board calibration of shecar") else {
        return;
    };
    let tmp = tempfile::tempdir().expect("tempdir");
    let rec = tmp.path().join("shecar.mcap").display().to_string();
    let import = rodlog(&[
        "import",
        "shecar",
        &data.display().to_string(),
        "-o",
        &rec,
        "--scale",
        "0.5",
    ]);
    assert!(
        import.status.success(),
        "{}",
        String::from_utf8_lossy(&import.stderr)
    );

    let out = rodlog(&[
        "calib", "board", &rec, "--board", "6x8", "--square", "0.0283", "--method", "park",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    assert_eq!(json["views"], 18);
    assert_eq!(json["pairs"], 153);
    let residual = json["residual_rot_deg"].as_f64().expect("residual");
    assert!(residual < 0.9, "median rotation residual {residual} deg");
    let t: Vec<f64> = (0..3)
        .map(|i| json["translation_m"][i].as_f64().expect("t"))
        .collect();
    let reference = [-0.0024, -0.0064, -0.0101];
    let dt = t
        .iter()
        .zip(reference)
        .map(|(a, b)| (a - b).powi(2))
        .sum::<f64>()
        .sqrt();
    assert!(dt < 0.02, "translation {t:?} is {dt} m from the reference");
    let w = json["quaternion_xyzw"][3].as_f64().expect("w").abs();
    let angle_deg = 2.0 * w.min(1.0).acos().to_degrees();
    assert!(angle_deg < 1.0, "rotation {angle_deg} deg from identity");

    // Refusal: a board size that is not there.
    let out = rodlog(&[
        "calib", "board", &rec, "--board", "5x5", "--square", "0.0283",
    ]);
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("not found"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
