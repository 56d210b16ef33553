//! The visual geometry of a URDF, as ROS tools draw it: each link's `<visual>` shapes at
//! their `<origin>` in the link's frame, the link placed at the TF frame of the same name
//! (RViz's RobotModel display, Foxglove's URDF layer). The joints are not used: `/tf` and
//! `/tf_static` place the links, so a recalibrated or moving frame is drawn where the robot
//! says it is.
//!
//! Parsed with `urdf-rs` (the parser of Rerun's own URDF importer). Boxes, cylinders,
//! spheres and capsules are drawn; meshes are counted in [`RobotVisuals::skipped_meshes`]
//! (rodlog's URDF has none).
//!
//! # Conventions
//! A visual's `<origin xyz rpy>` is `link_from_shape` with `R = Rz(yaw) Ry(pitch) Rx(roll)`
//! (URDF's fixed-axis roll-pitch-yaw); a URDF cylinder's axis is its local `z`, centred at the
//! origin (as Rerun's `Cylinders3D`). Colours are the URDF `rgba` in `[0, 1]`, read as sRGB
//! (what RViz shows); a `<material>` without a colour takes the robot-level material of the
//! same name; none at all is light grey.

use crate::VizError;
use crate::convert::Pose;

/// A drawable URDF shape.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// Box of half extents (m) along the shape's x, y, z.
    Box {
        /// Half sizes (m).
        half_m: [f32; 3],
    },
    /// Cylinder along the shape's z, centred at its origin.
    Cylinder {
        /// Radius (m).
        radius_m: f32,
        /// Length (m).
        length_m: f32,
    },
    /// Sphere.
    Sphere {
        /// Radius (m).
        radius_m: f32,
    },
    /// Capsule along the shape's z (`length_m` between the hemisphere centres).
    Capsule {
        /// Radius (m).
        radius_m: f32,
        /// Length of the cylindrical part (m).
        length_m: f32,
    },
}

/// One `<visual>` of a link.
#[derive(Debug, Clone, PartialEq)]
pub struct LinkVisual {
    /// The link (= TF frame) it belongs to.
    pub link: String,
    /// `link_from_shape`.
    pub pose: Pose,
    /// Geometry.
    pub shape: Shape,
    /// sRGBA.
    pub rgba: [u8; 4],
}

/// A joint of a URDF: `parent_from_child` at joint position 0 (its `<origin>`).
#[derive(Debug, Clone, PartialEq)]
pub struct Joint {
    /// `<joint name>`.
    pub name: String,
    /// Parent link.
    pub parent: String,
    /// Child link.
    pub child: String,
    /// `parent_from_child` at position 0.
    pub origin: Pose,
}

/// The visuals of a URDF.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RobotVisuals {
    /// `<robot name>`.
    pub name: String,
    /// Every drawable visual, in link order then visual order.
    pub visuals: Vec<LinkVisual>,
    /// Link names, in document order.
    pub links: Vec<String>,
    /// Joints, in document order.
    pub joints: Vec<Joint>,
    /// Mesh visuals not drawn.
    pub skipped_meshes: usize,
}

/// Light grey, for visuals without a colour.
const DEFAULT_RGBA: [u8; 4] = [200, 200, 200, 255];

/// `R = Rz(yaw) Ry(pitch) Rx(roll)` as a quaternion `(x, y, z, w)`.
pub fn quaternion_from_rpy(rpy: [f64; 3]) -> [f64; 4] {
    let (sr, cr) = (0.5 * rpy[0]).sin_cos();
    let (sp, cp) = (0.5 * rpy[1]).sin_cos();
    let (sy, cy) = (0.5 * rpy[2]).sin_cos();
    [
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    ]
}

fn rgba(c: &urdf_rs::Color) -> [u8; 4] {
    let q = |v: f64| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
    let [r, g, b, a] = c.rgba.0;
    [q(r), q(g), q(b), q(a)]
}

/// The visuals of the URDF text `urdf`.
///
/// # Errors
/// [`VizError::Urdf`] when the text is not a URDF `urdf-rs` can read.
pub fn robot_visuals(urdf: &str) -> Result<RobotVisuals, VizError> {
    let robot = urdf_rs::read_from_string(urdf).map_err(|e| VizError::Urdf {
        reason: e.to_string(),
    })?;
    let named_colour = |name: &str| {
        robot
            .materials
            .iter()
            .find(|m| m.name == name)
            .and_then(|m| m.color.as_ref())
            .map(rgba)
    };
    let mut out = RobotVisuals {
        name: robot.name.clone(),
        ..RobotVisuals::default()
    };
    for link in &robot.links {
        out.links.push(link.name.clone());
        for v in &link.visual {
            let shape = match &v.geometry {
                urdf_rs::Geometry::Box { size } => Shape::Box {
                    half_m: size.0.map(|s| (0.5 * s) as f32),
                },
                urdf_rs::Geometry::Cylinder { radius, length } => Shape::Cylinder {
                    radius_m: *radius as f32,
                    length_m: *length as f32,
                },
                urdf_rs::Geometry::Sphere { radius } => Shape::Sphere {
                    radius_m: *radius as f32,
                },
                urdf_rs::Geometry::Capsule { radius, length } => Shape::Capsule {
                    radius_m: *radius as f32,
                    length_m: *length as f32,
                },
                urdf_rs::Geometry::Mesh { .. } => {
                    out.skipped_meshes += 1;
                    continue;
                }
            };
            let colour = v
                .material
                .as_ref()
                .and_then(|m| m.color.as_ref().map(rgba).or_else(|| named_colour(&m.name)));
            out.visuals.push(LinkVisual {
                link: link.name.clone(),
                pose: Pose {
                    t: v.origin.xyz.0,
                    q: quaternion_from_rpy(v.origin.rpy.0),
                },
                shape,
                rgba: colour.unwrap_or(DEFAULT_RGBA),
            });
        }
    }
    for j in &robot.joints {
        out.joints.push(Joint {
            name: j.name.clone(),
            parent: j.parent.link.clone(),
            child: j.child.link.clone(),
            origin: Pose {
                t: j.origin.xyz.0,
                q: quaternion_from_rpy(j.origin.rpy.0),
            },
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    const URDF: &str = r#"<?xml version="1.0"?>
<robot name="two">
  <material name="red"><color rgba="1 0 0 1"/></material>
  <link name="base_link">
    <visual><origin xyz="0 0 0.5" rpy="0 0 0"/><geometry><box size="1 0.5 0.2"/></geometry><material name="red"/></visual>
  </link>
  <link name="arm">
    <visual><origin xyz="0.1 0 0" rpy="0 1.5707963267948966 0"/><geometry><cylinder radius="0.05" length="0.4"/></geometry></visual>
    <visual><geometry><mesh filename="package://x/arm.stl"/></geometry></visual>
  </link>
  <joint name="j" type="revolute">
    <parent link="base_link"/><child link="arm"/><origin xyz="0 0 1" rpy="0 0 0"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
</robot>"#;

    #[test]
    fn visuals_keep_their_link_pose_size_and_material() -> Result<(), VizError> {
        let r = robot_visuals(URDF)?;
        assert_eq!(r.name, "two");
        assert_eq!(r.links, vec!["base_link", "arm"]);
        assert_eq!(r.visuals.len(), 2);
        assert_eq!(r.skipped_meshes, 1);
        let b = &r.visuals[0];
        assert_eq!(b.link, "base_link");
        assert_eq!(
            b.shape,
            Shape::Box {
                half_m: [0.5, 0.25, 0.1]
            }
        );
        assert_eq!(b.pose.t, [0.0, 0.0, 0.5]);
        assert_eq!(b.rgba, [255, 0, 0, 255]);
        let c = &r.visuals[1];
        assert_eq!(c.link, "arm");
        assert_eq!(
            c.shape,
            Shape::Cylinder {
                radius_m: 0.05,
                length_m: 0.4
            }
        );
        assert_eq!(c.rgba, DEFAULT_RGBA);
        assert_eq!(r.joints.len(), 1);
        let j = &r.joints[0];
        assert_eq!((j.parent.as_str(), j.child.as_str()), ("base_link", "arm"));
        assert_eq!(j.origin.t, [0.0, 0.0, 1.0]);
        // Pitch +90 deg: the cylinder's z axis lies along the link's -x... R_y(90) z = +x.
        let s = std::f64::consts::FRAC_1_SQRT_2;
        for (got, want) in c.pose.q.iter().zip([0.0, s, 0.0, s]) {
            assert!((got - want).abs() < 1e-12, "{:?}", c.pose.q);
        }
        Ok(())
    }

    #[test]
    fn rpy_is_fixed_axis_roll_then_pitch_then_yaw() {
        // Roll 90 then yaw 90: y -> z (roll) stays z (yaw); x -> x (roll) -> y (yaw).
        let q = quaternion_from_rpy([
            std::f64::consts::FRAC_PI_2,
            0.0,
            std::f64::consts::FRAC_PI_2,
        ]);
        let p = Pose { t: [0.0; 3], q };
        let x = p.compose(&Pose {
            t: [1.0, 0.0, 0.0],
            q: [0.0, 0.0, 0.0, 1.0],
        });
        let y = p.compose(&Pose {
            t: [0.0, 1.0, 0.0],
            q: [0.0, 0.0, 0.0, 1.0],
        });
        for (got, want) in x.t.iter().chain(&y.t).zip([0.0, 1.0, 0.0, 0.0, 0.0, 1.0]) {
            assert!((got - want).abs() < 1e-12, "{:?} {:?}", x.t, y.t);
        }
    }

    #[test]
    fn text_that_is_not_a_urdf_is_an_error() {
        assert!(matches!(
            robot_visuals("<robot><link></robot>"),
            Err(VizError::Urdf { .. })
        ));
    }
}
