//! Tests of the remap files and conversions.
use super::*;
use msgs::sensor_msgs::{Image, JointState};
use msgs::std_msgs::Header;

const AUBO: &str = r#"
producer = "aubo_driver"
[[topic]]
vendor = "/joint_states"
rodlog = "/joint_states"
type = "sensor_msgs/msg/JointState"
[joints]
shoulder_joint = "arm_shoulder_joint"
lift_mm = { name = "lift_joint", scale = 0.001, offset = 0.1 }
[tool0]
flange = "wrist3_Link"
rpy_deg = [0.0, 0.0, 90.0]
[command.arm]
mode = "action"
name = "/joint_trajectory_controller/follow_joint_trajectory"
"#;

const CAMERA: &str = r#"
producer = "camera_driver"
[[topic]]
vendor = "/mechmind/color_image"
rodlog = "/camera/color/image_raw"
type = "sensor_msgs/msg/Image"
encoding = "rgb8"
[[topic]]
vendor = "/mechmind/depth_map"
rodlog = "/camera/depth/image_raw"
type = "sensor_msgs/msg/Image"
depth_scale = 0.001
[frames]
"mechmind_camera/color_map" = "camera_color_optical_frame"
[command.camera_trigger]
mode = "service"
services = ["/capture_color_image"]
types = ["mecheye_ros_interface/srv/CaptureColorImage"]
"#;

fn err_text(text: &str) -> String {
    Remap::parse(text, "t.toml")
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default()
}

#[test]
fn joint_names_and_units_are_converted() -> Result<(), Box<dyn std::error::Error>> {
    let remap = Remap::parse(AUBO, "aubo.toml")?;
    let route = remap.routes.first().ok_or("no route")?.clone();
    assert_eq!(route.producer, "aubo_driver");
    let js = JointState {
        header: Header::default(),
        name: vec!["shoulder_joint".into(), "lift_mm".into(), "other".into()],
        position: vec![0.5, 200.0, 1.0],
        velocity: vec![0.1, 10.0, 0.0],
        effort: vec![],
    };
    let cdr = Msg::JointState(js).encode()?;
    let (msg, bytes) = remap.convert(&route, &cdr)?;
    let Msg::JointState(out) = msg else {
        return Err("not a JointState".into());
    };
    assert_eq!(out.name, ["arm_shoulder_joint", "lift_joint", "other"]);
    assert!((out.position[1] - 0.3).abs() < 1e-12);
    assert!((out.velocity[1] - 0.01).abs() < 1e-12);
    assert!(bytes.is_some_and(|b| b != cdr));
    let t = remap.tool0.ok_or("no tool0")?;
    let s = std::f64::consts::FRAC_1_SQRT_2;
    assert!((t.quaternion_xyzw[2] - s).abs() < 1e-12 && (t.quaternion_xyzw[3] - s).abs() < 1e-12);
    assert_eq!(
        remap.commands.arm,
        Some(ArmCommand::Action(
            "/joint_trajectory_controller/follow_joint_trajectory".into()
        ))
    );
    Ok(())
}

#[test]
fn unchanged_messages_keep_their_bytes() -> Result<(), Box<dyn std::error::Error>> {
    let remap = Remap::default();
    let routes = remap.routes_with_identity(&[msgs::topics::JOINT_STATES], "graph");
    let route = routes.first().ok_or("no identity route")?;
    assert_eq!(route.origin, IDENTITY_ORIGIN);
    let mut cdr = Msg::JointState(JointState::default()).encode()?;
    cdr.extend_from_slice(&[0, 0]); // RTPS padding a decoder accepts
    let (_, bytes) = remap.convert(route, &cdr)?;
    assert_eq!(bytes, None);
    Ok(())
}

#[test]
fn images_swap_channels_scale_depth_and_rename_frames() -> Result<(), Box<dyn std::error::Error>> {
    let remap = Remap::parse(CAMERA, "cam.toml")?;
    let color = remap.routes.first().ok_or("no route")?.clone();
    let depth = remap.routes.get(1).ok_or("no route")?.clone();
    let img = Image {
        header: Header {
            frame_id: "mechmind_camera/color_map".into(),
            ..Header::default()
        },
        height: 1,
        width: 2,
        encoding: "bgr8".into(),
        is_bigendian: 0,
        step: 7,
        data: vec![1, 2, 3, 4, 5, 6, 99],
    };
    let (msg, _) = remap.convert(&color, &Msg::Image(img).encode()?)?;
    let Msg::Image(out) = msg else {
        return Err("not an image".into());
    };
    assert_eq!(out.data, [3, 2, 1, 6, 5, 4, 99]);
    assert_eq!(out.encoding, "rgb8");
    assert_eq!(out.header.frame_id, "camera_color_optical_frame");
    let mm: Vec<u8> = [1500.0_f32, 0.0]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let d = Image {
        height: 1,
        width: 2,
        encoding: "32FC1".into(),
        step: 8,
        data: mm,
        ..Image::default()
    };
    let (msg, _) = remap.convert(&depth, &Msg::Image(d).encode()?)?;
    let Msg::Image(out) = msg else {
        return Err("not an image".into());
    };
    let first = f32::from_le_bytes([out.data[0], out.data[1], out.data[2], out.data[3]]);
    assert!((first - 1.5).abs() < 1e-6);
    let short = Image {
        height: 2,
        width: 2,
        encoding: "bgr8".into(),
        step: 6,
        data: vec![0; 7],
        ..Image::default()
    };
    let err = remap.convert(&color, &Msg::Image(short).encode()?).err();
    assert!(matches!(err, Some(RemapError::Convert { .. })), "{err:?}");
    Ok(())
}

#[test]
fn bad_files_are_refused_naming_the_key() {
    assert!(err_text("[[topic]]\nvendor = \"/a\"\nrodlog = \"/joint_states\"\ntype = \"sensor_msgs/msg/JointState\"\nunits = 3\n").contains("units"));
    assert!(
        err_text("[[topic]]\nvendor = \"/a\"\nrodlog = \"/nope\"\ntype = \"x/msg/Y\"\n")
            .contains("not a rodlog topic")
    );
    assert!(err_text("[[topic]]\nvendor = \"/a\"\nrodlog = \"/joint_states\"\ntype = \"sensor_msgs/msg/Image\"\n").contains("carries sensor_msgs/msg/JointState"));
    assert!(err_text("[[topic]]\nvendor = \"a\"\nrodlog = \"/joint_states\"\ntype = \"sensor_msgs/msg/JointState\"\n").contains("absolute"));
    assert!(err_text("[[topic]]\nvendor = \"/a\"\nrodlog = \"/arm/joint_trajectory\"\ntype = \"trajectory_msgs/msg/JointTrajectory\"\n").contains("command topic"));
    assert!(err_text("[joints]\nj1 = \"elbow\"\n").contains("not a rodlog joint"));
    assert!(
        err_text("[joints]\nj1 = { name = \"lift_joint\", scale = 0.0 }\n").contains("non-zero")
    );
    assert!(err_text("[joints]\nj1 = \"lift_joint\"\nj2 = \"lift_joint\"\n").contains("already"));
    assert!(err_text("[tool0]\nflange = \"f\"\nxyz_m = [2.0, 0.0, 0.0]\n").contains("at most 1 m"));
    assert!(err_text("[command.arm]\nmode = \"teleport\"\nname = \"/x\"\n").contains("teleport"));
    assert!(
        err_text("[command.camera_trigger]\nmode = \"service\"\nservices = [\"/c\"]\n")
            .contains("as many types")
    );
    assert!(
        err_text("[[status]]\ntopic = \"/s\"\ntype = \"p/msg/S\"\nfield = \"uint8\"\nok = []\n")
            .contains("no value")
    );
}

#[test]
fn merging_refuses_two_owners_of_one_thing() -> Result<(), Box<dyn std::error::Error>> {
    let mut a = Remap::parse(AUBO, "a.toml")?;
    a.merge(Remap::parse(CAMERA, "c.toml")?, "c.toml")?;
    assert_eq!(a.routes.len(), 3);
    assert_eq!(a.files.len(), 2);
    let err = a.merge(Remap::parse(AUBO, "b.toml")?, "b.toml").err();
    assert!(matches!(err, Some(RemapError::Conflict { .. })), "{err:?}");
    Ok(())
}

#[test]
fn status_values_decode_and_gate() -> Result<(), Box<dyn std::error::Error>> {
    let s = StatusTopic {
        topic: "/safety".into(),
        type_name: "p/msg/SafetyMode".into(),
        field: StatusField::Int8,
        ok: vec![1, 2],
    };
    assert_eq!(s.value(&[0, 1, 0, 0, 0xff])?, -1);
    assert!(!s.allows(-1));
    assert!(s.allows(2));
    assert!(s.value(&[0, 1, 0, 0]).is_err());
    Ok(())
}

#[test]
fn the_shipped_remap_files_parse() -> Result<(), Box<dyn std::error::Error>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let paths: Vec<PathBuf> = SHIPPED.iter().map(|p| root.join(p)).collect();
    let remap = Remap::load(&paths)?;
    assert!(remap.tool0.is_some());
    assert!(matches!(remap.commands.arm, Some(ArmCommand::Action(_))));
    assert!(matches!(
        remap.commands.camera_trigger,
        Some(TriggerCommand::Services { .. })
    ));
    assert_eq!(remap.joints.len(), 6);
    Ok(())
}
