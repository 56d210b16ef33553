//! The YAML calibration file of `rodlog calib self --yaml FILE`, and the `--json` object
//! ([`result_json`]).
//!
//! It names the parent `tool0`, the child `camera_color_optical_frame` and the direction
//! explicitly (`tool0_from_camera`: maps camera coordinates to tool0 coordinates, the
//! transform a URDF joint `tool0 -> camera_color_optical_frame` or a ROS static transform
//! publisher with parent `tool0` expects), and also writes the inverse, labelled
//! `camera_from_tool0`, because using the inverse by mistake is the classic user error.

use std::fmt::Write as _;

use nalgebra::Isometry3;

use super::SelfCalResult;

/// A YAML float: round-trip exact, `.nan` / `.inf` for non-finite values.
fn num(v: f64) -> String {
    if v.is_nan() {
        ".nan".to_owned()
    } else if v.is_infinite() {
        if v > 0.0 {
            ".inf".to_owned()
        } else {
            "-.inf".to_owned()
        }
    } else {
        format!("{v:?}")
    }
}

fn block(
    out: &mut String,
    name: &str,
    parent: &str,
    child: &str,
    t: &Isometry3<f64>,
    comment: &str,
) {
    let v = t.translation.vector;
    let q = t.rotation.coords;
    let m = t.to_homogeneous();
    let _ = writeln!(out, "{name}:");
    let _ = writeln!(out, "  # {comment}");
    let _ = writeln!(out, "  parent_frame: {parent}");
    let _ = writeln!(out, "  child_frame: {child}");
    let _ = writeln!(
        out,
        "  translation_m: [{}, {}, {}]",
        num(v.x),
        num(v.y),
        num(v.z)
    );
    let _ = writeln!(
        out,
        "  quaternion_xyzw: [{}, {}, {}, {}]",
        num(q.x),
        num(q.y),
        num(q.z),
        num(q.w)
    );
    let _ = writeln!(out, "  matrix:");
    for r in 0..4 {
        let _ = writeln!(
            out,
            "    - [{}, {}, {}, {}]",
            num(m[(r, 0)]),
            num(m[(r, 1)]),
            num(m[(r, 2)]),
            num(m[(r, 3)])
        );
    }
}

/// The calibration YAML of a self-calibration result (module docs). `child_frame` is normally
/// `camera_color_optical_frame`. Floats are printed round-trip exact.
pub fn calibration_yaml(result: &SelfCalResult, method: &str, child_frame: &str) -> String {
    let s = &result.solution;
    let mut out = String::new();
    let _ = writeln!(out, "# rodlog hand-eye self-calibration (eye-in-hand)");
    let _ = writeln!(out, "method: {method}");
    let _ = writeln!(out, "mode: {}", result.mode.name());
    let _ = writeln!(out, "frame: tool0");
    let _ = writeln!(out, "child_frame: {child_frame}");
    let _ = writeln!(out, "direction: tool0_from_camera");
    block(
        &mut out,
        "tool0_from_camera",
        "tool0",
        child_frame,
        &s.tool0_from_camera,
        "X: p_in_tool0 = X * p_in_camera. Use THIS one for the tool0 -> camera TF edge.",
    );
    block(
        &mut out,
        "camera_from_tool0",
        child_frame,
        "tool0",
        &s.tool0_from_camera.inverse(),
        "the INVERSE of X (the paper's X_p), for reference only: not the tool0 -> camera edge.",
    );
    let _ = writeln!(out, "views: {}", s.views);
    let _ = writeln!(out, "pairs: {}", s.pairs);
    let _ = writeln!(out, "residual_rot_deg: {}", num(s.residual_rot_deg));
    let _ = writeln!(out, "residual_trans_mm: {}", num(s.residual_trans_mm));
    let _ = writeln!(out, "sigma_rot_deg: {}", num(s.sigma_rot_deg));
    let _ = writeln!(out, "sigma_trans_mm: {}", num(s.sigma_trans_mm));
    let _ = writeln!(out, "condition: {}", num(s.condition));
    let _ = writeln!(out, "scale: {}", num(s.scale));
    out
}

/// The `--json` object of `rodlog calib self`: the calibration JSON of ARCHITECTURE.md section 4
/// ([`crate::handeye::calibration_json`], mode `rgbd`/`mono`, transform `tool0_from_camera`)
/// plus `features_per_view`, the linear initialisation (`linear_translation_m`,
/// `linear_quaternion_xyzw`) and `pair_reports`: one object per pair `i < j` with
/// `i, j, hand_rotation_deg, raw_matches, matches, inliers, scale, residual_rot_deg,
/// residual_trans_mm, eq15_rms_mm, used, rejected` (the reason text or `null`), `steps` (the
/// [`super::Steps`] that ran, by name) and, when eq. 15 ran, `eq15`: `{"world_points"
/// (fixed_from_start | alternated | retriangulated | joint), "points", "views", "observations", "iterations",
/// "initial_cost", "final_cost"` (m^2), `"rms_mm"}`. Non-finite figures become `null`.
pub fn result_json(result: &SelfCalResult, method: &str, child_frame: &str) -> serde_json::Value {
    let mut v =
        crate::handeye::calibration_json(&result.solution, method, result.mode.name(), child_frame);
    let lin = &result.linear_tool0_from_camera;
    let (lt, lq) = (lin.translation.vector, lin.rotation.coords);
    let pairs: Vec<serde_json::Value> = result
        .pairs
        .iter()
        .map(|p| {
            serde_json::json!({
                "i": p.i,
                "j": p.j,
                "hand_rotation_deg": p.hand_rotation_deg,
                "raw_matches": p.raw_matches,
                "matches": p.matches,
                "inliers": p.inliers,
                "scale": p.scale,
                "residual_rot_deg": p.residual_rot_deg,
                "residual_trans_mm": p.residual_trans_mm,
                "eq15_rms_mm": p.eq15_rms_mm,
                "used": p.rejected.is_none(),
                "rejected": p.rejected.as_ref().map(ToString::to_string),
            })
        })
        .collect();
    if let Some(obj) = v.as_object_mut() {
        obj.insert(
            "features_per_view".to_owned(),
            serde_json::json!(result.features_per_view),
        );
        obj.insert(
            "linear_translation_m".to_owned(),
            serde_json::json!([lt.x, lt.y, lt.z]),
        );
        obj.insert(
            "linear_quaternion_xyzw".to_owned(),
            serde_json::json!([lq.x, lq.y, lq.z, lq.w]),
        );
        obj.insert("pair_reports".to_owned(), serde_json::Value::Array(pairs));
        let st = &result.steps;
        obj.insert(
            "steps".to_owned(),
            serde_json::json!({
                "rigid_ransac": st.rigid_ransac,
                "depth_weighted_motion": st.depth_weighted_motion,
                "image_motion": st.image_motion,
                "pose_refinement": st.pose_refinement,
                "pair_rejection": st.pair_rejection,
                "final_refinement": st.final_refinement.name(),
                "angle_prior": st.angle_prior,
                "guided_round": st.guided_round,
                "epipolar_refinement": st.epipolar_refinement,
                "consistency": st.consistency,
            }),
        );
        if let Some(e) = &result.eq15 {
            obj.insert(
                "eq15".to_owned(),
                serde_json::json!({
                    "world_points": e.world_points.name(),
                    "points": e.points,
                    "views": e.views,
                    "observations": e.observations,
                    "iterations": e.iterations,
                    "initial_cost": e.initial_cost,
                    "final_cost": e.final_cost,
                    "rms_mm": e.rms_m * 1e3,
                }),
            );
        }
    }
    v
}
