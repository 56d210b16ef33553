//! URDF of the robot, generated from the same numbers as the kinematics ([`RobotModel`]), so the
//! drawn robot cannot drift from the computed one.
//!
//! Published on `/robot_description` (std_msgs/String) and attached to recordings; Rerun and
//! Foxglove draw it, placing each link at the TF frame of the same name (link names = TF frame
//! names of ARCHITECTURE.md section 3, joint names = its joint list).
//!
//! Contents: links `base_link`, `lift_link`, `arm_base_link`, the six arm links, `tool0` and
//! `panoramic_optical_frame`; joints `lift_joint` (prismatic), the six revolute arm joints, and
//! the fixed `arm_mount_joint`, `tool0_joint`, `panoramic_joint`. A URDF joint's origin is the
//! child's pose in the parent at position 0 and its axis is z (see [`crate::dh`]); `rpy` is the
//! URDF fixed-axis roll-pitch-yaw, `R = Rz(yaw) Ry(pitch) Rx(roll)`.
//!
//! Deliberately absent: `map` (the base's odometry is a `/tf` edge, not a joint);
//! `camera_color_optical_frame` (its edge from `tool0` is the hand-eye calibration, published
//! on `/tf` by the calibration stage, ARCHITECTURE.md section 3; a fixed URDF joint would hide a
//! recalibration); `rod_link` (the rod is a free body). Geometry is primitive (boxes and
//! cylinders), for display, not for collision checking:
//!
//! | link | visuals |
//! |---|---|
//! | `base_link` | chassis 1.2 x 0.8 x 0.35 m (the planner's chassis box), four wheels, the lift's sleeve up to its zero height |
//! | `lift_link` | platform 0.4 x 0.4 m and the mast below it, [`LIFT_TRAVEL_M`] long (when the lift is low its foot is in the well under the chassis) |
//! | arm links | a joint housing on each joint axis and a tube to the next DH origin |
//! | `tool0` | flange adapter, the end effector's palm and motor, the two clamp jaws around the handle of a held rod (its axis 60 mm in front of the flange), and the wrist camera (Mech-Eye NANO class, 145 x 51 x 85 mm) at the *nominal* mount, its colour lens at the optical origin |
//!
//! The camera housing sits where the bracket puts it by design; the frame the robot
//! believes in (`camera_color_optical_frame`, from the calibration) may differ after a bump.

use crate::camera_mount::nominal_tool0_from_camera;
use crate::kinematics::{JointKind, LIFT_TRAVEL_M, LIFT_ZERO_HEIGHT_M, RobotModel};
use crate::names;
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use std::f64::consts::FRAC_PI_2;
use std::fmt::Write;

/// Name of the `<robot>` element.
pub const ROBOT_NAME: &str = "rodlog_aubo_i10";

/// Height of the base chassis' top deck above `base_link` (m), display only.
const CHASSIS_TOP_M: f64 = 0.45;
/// Wheel radius and width (m), display only.
const WHEEL: (f64, f64) = (0.16, 0.12);
/// Mech-Eye NANO class housing (m): width along the camera's x, height along its y, depth
/// along its z.
const CAMERA_HOUSING_M: [f64; 3] = [0.145, 0.051, 0.085];
/// The colour lens' distance from the housing's +x end (m).
const CAMERA_LENS_INSET_M: f64 = 0.012;

#[derive(Clone, Copy)]
enum Shape {
    Box([f64; 3]),
    Cylinder { radius_m: f64, length_m: f64 },
}

struct Visual {
    link_from_shape: Isometry3<f64>,
    shape: Shape,
    material: &'static str,
}

/// Formats a float for XML: shortest round-trip decimal, `-0` and |v| < 1e-15 as `0`.
fn num(v: f64) -> String {
    if v.abs() < 1e-15 {
        "0".to_owned()
    } else {
        format!("{v}")
    }
}

fn origin(pose: &Isometry3<f64>) -> String {
    let t = pose.translation.vector;
    let (roll, pitch, yaw) = pose.rotation.euler_angles();
    format!(
        "<origin xyz=\"{} {} {}\" rpy=\"{} {} {}\"/>",
        num(t.x),
        num(t.y),
        num(t.z),
        num(roll),
        num(pitch),
        num(yaw)
    )
}

/// A cylinder joining `from` to `to` (link coordinates).
fn segment(
    from: Vector3<f64>,
    to: Vector3<f64>,
    radius_m: f64,
    material: &'static str,
) -> Option<Visual> {
    let d = to - from;
    let length_m = d.norm();
    if length_m < 1e-6 {
        return None;
    }
    let rotation = UnitQuaternion::rotation_between(&Vector3::z(), &d).unwrap_or_else(|| {
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
    });
    Some(Visual {
        link_from_shape: Isometry3::from_parts(Translation3::from(from + 0.5 * d), rotation),
        shape: Shape::Cylinder { radius_m, length_m },
        material,
    })
}

fn at(x: f64, y: f64, z: f64, shape: Shape, material: &'static str) -> Visual {
    Visual {
        link_from_shape: Isometry3::translation(x, y, z),
        shape,
        material,
    }
}

/// The visuals of `tool0` (module docs): the end effector, its clamp jaws and the wrist
/// camera at the nominal mount.
fn tool0_visuals() -> Vec<Visual> {
    // A held rod's axis runs along tool0 x at z = 60 mm (robot::grounding_rod's grasp); the
    // handle's radius is 21 mm, so the palm stops at 36 mm and the jaws stand either side.
    let mut v = vec![
        at(
            0.0,
            0.0,
            0.006,
            Shape::Cylinder {
                radius_m: 0.045,
                length_m: 0.012,
            },
            "tool",
        ),
        at(0.0, 0.0, 0.024, Shape::Box([0.1, 0.09, 0.024]), "tool"),
        at(0.0, 0.028, 0.061, Shape::Box([0.06, 0.012, 0.05]), "jaw"),
        at(0.0, -0.028, 0.061, Shape::Box([0.06, 0.012, 0.05]), "jaw"),
    ];
    // The geared motor beside the palm, along the rod.
    v.extend(segment(
        Vector3::new(-0.06, 0.07, 0.03),
        Vector3::new(0.06, 0.07, 0.03),
        0.03,
        "tool",
    ));
    // The camera: housing behind the lens, extending along the camera's -x (away from the
    // rod), and the lens.
    let tool0_from_camera = nominal_tool0_from_camera();
    let [w, h, d] = CAMERA_HOUSING_M;
    v.push(Visual {
        link_from_shape: tool0_from_camera
            * Isometry3::translation(-(0.5 * w - CAMERA_LENS_INSET_M), 0.0, -0.5 * d),
        shape: Shape::Box([w, h, d]),
        material: "camera",
    });
    v.push(Visual {
        link_from_shape: tool0_from_camera * Isometry3::translation(0.0, 0.0, 0.002),
        shape: Shape::Cylinder {
            radius_m: 0.009,
            length_m: 0.004,
        },
        material: "lens",
    });
    v
}

fn write_link(out: &mut String, name: &str, visuals: &[Visual]) {
    let _ = writeln!(out, "  <link name=\"{name}\">");
    for v in visuals {
        let geometry = match v.shape {
            Shape::Box([x, y, z]) => format!("<box size=\"{} {} {}\"/>", num(x), num(y), num(z)),
            Shape::Cylinder { radius_m, length_m } => {
                format!(
                    "<cylinder radius=\"{}\" length=\"{}\"/>",
                    num(radius_m),
                    num(length_m)
                )
            }
        };
        let _ = writeln!(
            out,
            "    <visual>{}<geometry>{geometry}</geometry><material name=\"{}\"/></visual>",
            origin(&v.link_from_shape),
            v.material
        );
    }
    let _ = writeln!(out, "  </link>");
}

struct JointSpec<'a> {
    name: &'a str,
    kind: &'a str,
    parent: &'a str,
    child: &'a str,
    parent_from_child_zero: Isometry3<f64>,
    limit: Option<crate::limits::JointLimit>,
    effort: f64,
}

fn write_joint(out: &mut String, j: &JointSpec<'_>) {
    let _ = writeln!(out, "  <joint name=\"{}\" type=\"{}\">", j.name, j.kind);
    let _ = writeln!(out, "    <parent link=\"{}\"/>", j.parent);
    let _ = writeln!(out, "    <child link=\"{}\"/>", j.child);
    let _ = writeln!(out, "    {}", origin(&j.parent_from_child_zero));
    if let Some(l) = j.limit {
        let _ = writeln!(out, "    <axis xyz=\"0 0 1\"/>");
        let _ = writeln!(
            out,
            "    <limit lower=\"{}\" upper=\"{}\" effort=\"{}\" velocity=\"{}\"/>",
            num(l.position_min),
            num(l.position_max),
            num(j.effort),
            num(l.velocity_max)
        );
    }
    let _ = writeln!(out, "  </joint>");
}

/// The URDF XML text of `model`.
///
/// Arm joint `i` has origin `Tz(d_{i-1}) Tx(a_{i-1}) Rx(alpha_{i-1}) Rz(offset_i)` in the
/// previous link (identity-plus-offset for joint 1), axis z; `lift_joint` has origin
/// `base_from_lift_zero`, axis z. Efforts are nominal display values (N m, N).
#[must_use]
pub fn robot_urdf(model: &RobotModel) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "<?xml version=\"1.0\"?>");
    let _ = writeln!(
        out,
        "<!-- Generated by the rodlog `robot` crate from its kinematic model; do not edit. -->"
    );
    let _ = writeln!(out, "<robot name=\"{ROBOT_NAME}\">");
    for (name, rgba) in [
        ("chassis", "0.25 0.27 0.3 1"),
        ("lift", "0.95 0.75 0.1 1"),
        ("arm", "0.85 0.86 0.88 1"),
        ("joint", "0.12 0.35 0.7 1"),
        ("tool", "0.9 0.45 0.1 1"),
        ("jaw", "0.35 0.36 0.38 1"),
        ("camera", "0.16 0.17 0.19 1"),
        ("lens", "0.2 0.45 0.8 1"),
        ("wheel", "0.08 0.08 0.08 1"),
    ] {
        let _ = writeln!(
            out,
            "  <material name=\"{name}\"><color rgba=\"{rgba}\"/></material>"
        );
    }

    // Base and lift.
    let wheel_axis = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), FRAC_PI_2);
    let mut base = vec![at(
        0.0,
        0.0,
        0.5 * (CHASSIS_TOP_M + 0.1),
        Shape::Box([1.2, 0.8, CHASSIS_TOP_M - 0.1]),
        "chassis",
    )];
    for (x, y) in [(0.4, 0.46), (0.4, -0.46), (-0.4, 0.46), (-0.4, -0.46)] {
        base.push(Visual {
            link_from_shape: Isometry3::from_parts(Translation3::new(x, y, WHEEL.0), wheel_axis),
            shape: Shape::Cylinder {
                radius_m: WHEEL.0,
                length_m: WHEEL.1,
            },
            material: "wheel",
        });
    }
    let sleeve_m = (LIFT_ZERO_HEIGHT_M - CHASSIS_TOP_M - 0.03).max(0.01);
    base.push(at(
        0.0,
        0.0,
        CHASSIS_TOP_M + 0.5 * sleeve_m,
        Shape::Box([0.28, 0.28, sleeve_m]),
        "chassis",
    ));
    write_link(&mut out, names::BASE_LINK, &base);
    write_link(
        &mut out,
        names::LIFT_LINK,
        &[
            at(0.0, 0.0, -0.015, Shape::Box([0.4, 0.4, 0.03]), "lift"),
            at(
                0.0,
                0.0,
                -0.03 - 0.5 * LIFT_TRAVEL_M,
                Shape::Box([0.22, 0.22, LIFT_TRAVEL_M]),
                "lift",
            ),
        ],
    );
    write_link(
        &mut out,
        names::ARM_BASE_LINK,
        &[at(
            0.0,
            0.0,
            0.025,
            Shape::Cylinder {
                radius_m: 0.09,
                length_m: 0.05,
            },
            "arm",
        )],
    );

    // Arm links: a joint housing on the link's axis and a body to the next joint's origin.
    let rows = model.dh.rows;
    for (i, link) in names::ARM_LINKS.iter().enumerate() {
        let proximal = i < 3;
        let (housing_r, body_r) = if proximal {
            (0.075, 0.055)
        } else {
            (0.055, 0.045)
        };
        let mut visuals = vec![at(
            0.0,
            0.0,
            0.0,
            Shape::Cylinder {
                radius_m: housing_r,
                length_m: 2.0 * housing_r,
            },
            "joint",
        )];
        if let Some(row) = rows.get(i) {
            let next = Vector3::new(row.a_m, 0.0, row.d_m);
            visuals.extend(segment(Vector3::zeros(), next, body_r, "arm"));
        }
        write_link(&mut out, link, &visuals);
    }
    // tool0: the end effector, its clamp jaws and the wrist camera.
    write_link(&mut out, names::TOOL0, &tool0_visuals());
    write_link(
        &mut out,
        names::PANORAMIC_OPTICAL_FRAME,
        &[at(
            0.0,
            0.0,
            -0.02,
            Shape::Box([0.08, 0.06, 0.04]),
            "camera",
        )],
    );

    // Joints.
    if let Some(origin) = model.joint_origin(JointKind::Lift) {
        write_joint(
            &mut out,
            &JointSpec {
                name: names::LIFT_JOINT,
                kind: "prismatic",
                parent: names::BASE_LINK,
                child: names::LIFT_LINK,
                parent_from_child_zero: origin,
                limit: Some(model.lift_limit),
                effort: 2000.0,
            },
        );
    }
    write_joint(
        &mut out,
        &JointSpec {
            name: names::ARM_MOUNT_JOINT,
            kind: "fixed",
            parent: names::LIFT_LINK,
            child: names::ARM_BASE_LINK,
            parent_from_child_zero: model.lift_from_arm_base,
            limit: None,
            effort: 0.0,
        },
    );
    for i in 0..6 {
        let Some(edge) = model.joint_edge(JointKind::Arm(i), 0.0) else {
            continue;
        };
        write_joint(
            &mut out,
            &JointSpec {
                name: names::ARM_JOINTS[i],
                kind: "revolute",
                parent: edge.parent,
                child: edge.child,
                parent_from_child_zero: edge.parent_from_child,
                limit: Some(model.arm_limits[i]),
                effort: if i < 3 { 207.0 } else { 34.0 },
            },
        );
    }
    write_joint(
        &mut out,
        &JointSpec {
            name: names::TOOL0_JOINT,
            kind: "fixed",
            parent: names::ARM_WRIST3_LINK,
            child: names::TOOL0,
            parent_from_child_zero: model.wrist3_from_tool0(),
            limit: None,
            effort: 0.0,
        },
    );
    write_joint(
        &mut out,
        &JointSpec {
            name: names::PANORAMIC_JOINT,
            kind: "fixed",
            parent: names::BASE_LINK,
            child: names::PANORAMIC_OPTICAL_FRAME,
            parent_from_child_zero: model.base_from_panoramic_optical,
            limit: None,
            effort: 0.0,
        },
    );
    let _ = writeln!(out, "</robot>");
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    /// Minimal reader for the generated text: joint name -> (parent, child, parent_from_child).
    fn parse_joints(urdf: &str) -> BTreeMap<String, (String, String, Isometry3<f64>)> {
        let attr = |s: &str, key: &str| -> String {
            let start = s
                .find(&format!("{key}=\""))
                .map(|i| i + key.len() + 2)
                .expect("attribute");
            let end = s[start..].find('"').expect("closing quote") + start;
            s[start..end].to_owned()
        };
        let nums = |s: String| -> Vec<f64> {
            s.split_whitespace()
                .map(|v| v.parse().expect("number"))
                .collect()
        };
        let mut joints = BTreeMap::new();
        for block in urdf.split("<joint ").skip(1) {
            let block = &block[..block.find("</joint>").expect("closed")];
            let name = attr(block, "name");
            let parent = attr(&block[block.find("<parent").expect("parent")..], "link");
            let child = attr(&block[block.find("<child").expect("child")..], "link");
            let origin = &block[block.find("<origin").expect("origin")..];
            let xyz = nums(attr(origin, "xyz"));
            let rpy = nums(attr(origin, "rpy"));
            let pose = Isometry3::from_parts(
                Translation3::new(xyz[0], xyz[1], xyz[2]),
                UnitQuaternion::from_euler_angles(rpy[0], rpy[1], rpy[2]),
            );
            joints.insert(name, (parent, child, pose));
        }
        joints
    }

    #[test]
    fn urdf_chain_reproduces_the_kinematics_at_zero() {
        let model = RobotModel::nominal();
        let urdf = robot_urdf(&model);
        let joints = parse_joints(&urdf);
        let chain = [
            names::LIFT_JOINT,
            names::ARM_MOUNT_JOINT,
            names::ARM_SHOULDER_JOINT,
            names::ARM_UPPERARM_JOINT,
            names::ARM_FOREARM_JOINT,
            names::ARM_WRIST1_JOINT,
            names::ARM_WRIST2_JOINT,
            names::ARM_WRIST3_JOINT,
            names::TOOL0_JOINT,
        ];
        let mut base_from_frame = Isometry3::identity();
        let mut frame = names::BASE_LINK.to_owned();
        for name in chain {
            let (parent, child, pose) = joints.get(name).unwrap_or_else(|| panic!("joint {name}"));
            assert_eq!(*parent, frame, "joint {name} hangs below the previous link");
            base_from_frame *= pose;
            frame = child.clone();
        }
        assert_eq!(frame, names::TOOL0);
        let expected = model.base_from_tool0(0.0, &[0.0; 6]);
        let dt = (base_from_frame.translation.vector - expected.translation.vector).norm();
        let dr =
            crate::se3::rotation_angle_between_rad(&base_from_frame.rotation, &expected.rotation);
        assert!(dt < 1e-12 && dr < 1e-12, "{dt:e} m {dr:e} rad");
    }

    #[test]
    fn urdf_has_the_design_names_and_not_the_camera_edge() {
        let urdf = robot_urdf(&RobotModel::nominal());
        for link in names::ARM_LINKS.iter().chain(&[
            names::BASE_LINK,
            names::LIFT_LINK,
            names::ARM_BASE_LINK,
            names::TOOL0,
            names::PANORAMIC_OPTICAL_FRAME,
        ]) {
            assert!(
                urdf.contains(&format!("<link name=\"{link}\">")),
                "link {link}"
            );
        }
        for joint in names::ARM_JOINTS.iter().chain(&[names::LIFT_JOINT]) {
            assert!(
                urdf.contains(&format!("<joint name=\"{joint}\"")),
                "joint {joint}"
            );
        }
        assert!(!urdf.contains(names::CAMERA_COLOR_OPTICAL_FRAME));
        assert!(urdf.contains("type=\"prismatic\""));
        assert_eq!(urdf.matches("<joint ").count(), 10);
        assert_eq!(urdf.matches("<link ").count(), 11);
        // Deterministic text.
        assert_eq!(urdf, robot_urdf(&RobotModel::nominal()));
    }
}
