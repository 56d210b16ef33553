//! Calibration views from decoded messages: pairing images, depth, camera_info and /tf, and
//! the refusals (missing TF, stamps outside the TF range, depth/colour stamp mismatch).

mod selfcal_support;

use calib::handeye::pose_error;
use calib::relpose::CameraModel;
use calib::selfcal::{CalibView, SelfCalError, SelfCalParams, self_calibrate, views_from_messages};
use msgs::builtin_interfaces::Time;
use msgs::frames::{BASE_LINK, CAMERA_COLOR_OPTICAL_FRAME, TOOL0};
use msgs::sensor_msgs::{CameraInfo, Image, image_encodings};
use msgs::std_msgs::Header;
use msgs::tf2_msgs::TfMessage;
use msgs::{Msg, RobotTime, topics};
use selfcal_support as sup;

fn ros(stamp_ns: u64) -> Time {
    RobotTime::from_nanos(stamp_ns).to_ros().expect("stamp")
}

fn camera_info(cam: &CameraModel) -> CameraInfo {
    CameraInfo {
        header: Header {
            stamp: ros(1),
            frame_id: CAMERA_COLOR_OPTICAL_FRAME.to_owned(),
        },
        width: cam.width,
        height: cam.height,
        distortion_model: "plumb_bob".to_owned(),
        d: vec![cam.k1, cam.k2, cam.p1, cam.p2, cam.k3],
        k: [cam.fx, 0.0, cam.cx, 0.0, cam.fy, cam.cy, 0.0, 0.0, 1.0],
        ..CameraInfo::default()
    }
}

fn tf(v: &CalibView, stamp_ns: u64) -> Msg {
    Msg::from(TfMessage {
        transforms: vec![robot::conversions::transform_stamped(
            BASE_LINK,
            TOOL0,
            ros(stamp_ns),
            &v.base_from_tool0,
        )],
    })
}

fn rgb8(v: &CalibView) -> Msg {
    let (w, h) = v.gray.dimensions();
    Msg::from(Image {
        header: Header {
            stamp: ros(v.stamp_ns),
            frame_id: CAMERA_COLOR_OPTICAL_FRAME.to_owned(),
        },
        width: w,
        height: h,
        encoding: image_encodings::RGB8.to_owned(),
        is_bigendian: 0,
        step: 3 * w,
        data: v.gray.as_raw().iter().flat_map(|&g| [g, g, g]).collect(),
    })
}

fn depth_16uc1(v: &CalibView, stamp_ns: u64) -> Msg {
    let (w, h) = v.gray.dimensions();
    let d = v.depth_m.as_deref().unwrap_or(&[]);
    Msg::from(Image {
        header: Header {
            stamp: ros(stamp_ns),
            frame_id: CAMERA_COLOR_OPTICAL_FRAME.to_owned(),
        },
        width: w,
        height: h,
        encoding: image_encodings::TYPE_16UC1.to_owned(),
        is_bigendian: 0,
        step: 2 * w,
        data: d
            .iter()
            .flat_map(|&m| ((m * 1000.0).round() as u16).to_le_bytes())
            .collect(),
    })
}

/// A recording's messages for the views: camera_info, then per view /tf, image, depth.
fn messages(views: &[CalibView], cam: &CameraModel, depth: bool) -> Vec<(String, Msg)> {
    let mut out = vec![(
        topics::CAMERA_COLOR_INFO.to_owned(),
        Msg::from(camera_info(cam)),
    )];
    for v in views {
        out.push((topics::TF.to_owned(), tf(v, v.stamp_ns)));
        out.push((topics::CAMERA_COLOR_IMAGE.to_owned(), rgb8(v)));
        if depth {
            out.push((
                topics::CAMERA_DEPTH_IMAGE.to_owned(),
                depth_16uc1(v, v.stamp_ns),
            ));
        }
    }
    out
}

#[test]
fn selfcal_messages_roundtrip_and_calibrate() {
    let x_true = sup::true_x();
    let (views, cam) = sup::views(&sup::camera_poses(8), &x_true, true);
    let msgs = messages(&views, &cam, true);
    let (got, got_cam) = views_from_messages(&msgs).expect("views");
    assert_eq!(got.len(), views.len());
    assert_eq!(got_cam, cam);
    for (a, b) in got.iter().zip(&views) {
        assert_eq!(a.stamp_ns, b.stamp_ns);
        assert_eq!(a.gray, b.gray);
        let (r, t) = pose_error(&a.base_from_tool0, &b.base_from_tool0);
        assert!(r < 1e-6 && t < 1e-9, "{r} {t}");
        let (da, db) = (
            a.depth_m.as_deref().unwrap_or(&[]),
            b.depth_m.as_deref().unwrap_or(&[]),
        );
        assert_eq!(da.len(), db.len());
        assert!(
            da.iter()
                .zip(db)
                .all(|(x, y)| (x - y).abs() <= 0.0005 + 1e-6)
        );
    }
    // 16UC1 millimetre depth is coarser than the rendered depth, and still gives X well.
    let res = self_calibrate(&got, &got_cam, &SelfCalParams::default()).expect("calibration");
    let (r, t) = pose_error(&res.solution.tool0_from_camera, &x_true);
    eprintln!(
        "from messages (16UC1 mm depth): {r:.4} deg, {:.3} mm",
        t * 1e3
    );
    assert!(r < 0.1 && t < 1e-3, "{r} deg {t} m");
}

#[test]
fn selfcal_messages_refuse_missing_tf_even_with_sim_truth() {
    let (views, cam) = sup::views(&sup::camera_poses(4), &sup::true_x(), false);
    let mut msgs: Vec<(String, Msg)> = messages(&views, &cam, false)
        .into_iter()
        .filter(|(t, _)| t != topics::TF)
        .collect();
    // Ground truth on a /sim/ topic must not be read.
    for v in &views {
        msgs.push(("/sim/tf".to_owned(), tf(v, v.stamp_ns)));
    }
    let err = views_from_messages(&msgs).expect_err("must be refused");
    assert!(
        matches!(&err, SelfCalError::MissingTf { index: 0, .. }),
        "{err:?}"
    );
    assert!(err.to_string().contains("tool0"), "{err}");
}

#[test]
fn selfcal_messages_refuse_stamp_outside_tf_range() {
    let (views, cam) = sup::views(&sup::camera_poses(4), &sup::true_x(), false);
    let last = views[3].stamp_ns;
    let msgs: Vec<(String, Msg)> = messages(&views, &cam, false)
        .into_iter()
        .filter(|(t, m)| {
            !(t == topics::TF
                && matches!(m, Msg::TfMessage(tf) if tf.transforms[0].header.stamp == ros(last)))
        })
        .collect();
    let err = views_from_messages(&msgs).expect_err("must be refused");
    match &err {
        SelfCalError::MissingTf {
            index,
            stamp_ns,
            reason,
            ..
        } => {
            assert_eq!((*index, *stamp_ns), (3, last));
            assert!(reason.contains("outside the buffered range"), "{reason}");
        }
        other => panic!("expected MissingTf, got {other:?}"),
    }
}

#[test]
fn selfcal_messages_refuse_depth_stamp_mismatch() {
    let (views, cam) = sup::views(&sup::camera_poses(4), &sup::true_x(), true);
    let mut msgs = messages(&views, &cam, false);
    for (k, v) in views.iter().enumerate() {
        let late = if k == 2 { 5_000_000 } else { 0 }; // 5 ms late on view 2
        msgs.push((
            topics::CAMERA_DEPTH_IMAGE.to_owned(),
            depth_16uc1(v, v.stamp_ns + late),
        ));
    }
    let err = views_from_messages(&msgs).expect_err("must be refused");
    assert_eq!(
        err,
        SelfCalError::StampMismatch {
            what: "depth image",
            stamp_ns: views[2].stamp_ns + 5_000_000,
            nearest_ns: Some(views[2].stamp_ns),
            tolerance_ns: 1_000_000,
        }
    );
}

#[test]
fn selfcal_messages_refuse_bad_inputs() {
    let (views, cam) = sup::views(&sup::camera_poses(3), &sup::true_x(), false);
    // No camera_info.
    let msgs: Vec<(String, Msg)> = messages(&views, &cam, false)
        .into_iter()
        .filter(|(t, _)| t != topics::CAMERA_COLOR_INFO)
        .collect();
    assert!(matches!(
        views_from_messages(&msgs),
        Err(SelfCalError::NoCameraInfo { .. })
    ));
    // A fisheye model.
    let mut msgs = messages(&views, &cam, false);
    if let Some((_, Msg::CameraInfo(ci))) = msgs.first_mut() {
        ci.distortion_model = "equidistant".to_owned();
    }
    assert!(matches!(
        views_from_messages(&msgs),
        Err(SelfCalError::BadCameraInfo { .. })
    ));
    // A truncated image buffer.
    let mut msgs = messages(&views, &cam, false);
    if let Some((_, Msg::Image(img))) = msgs.get_mut(2) {
        img.data.truncate(100);
    }
    assert!(matches!(
        views_from_messages(&msgs),
        Err(SelfCalError::BadImageBuffer { len: 100, .. })
    ));
    // No images at all.
    let msgs = vec![(
        topics::CAMERA_COLOR_INFO.to_owned(),
        Msg::from(camera_info(&cam)),
    )];
    assert!(matches!(
        views_from_messages(&msgs),
        Err(SelfCalError::NoImages { .. })
    ));
}
