//! Conversions between nalgebra transforms and the `geometry_msgs` wire types.
//!
//! `TransformStamped { header.frame_id: a, child_frame_id: b, transform }` is `a_from_b`
//! (tf2 convention). Quaternions go on the wire as `(x, y, z, w)`; on the way in they are
//! accepted when `| |q|² - 1 | <= 0.01` (tf2's `validateQuaternion` tolerance) and normalised.

use msgs::builtin_interfaces::Time;
use msgs::geometry_msgs::{
    Point, Pose, PoseStamped, Quaternion, Transform, TransformStamped, Vector3 as Vector3Msg,
};
use msgs::std_msgs::Header;
use nalgebra::{Isometry3, Quaternion as NaQuaternion, Translation3, UnitQuaternion};

/// Tolerance on `| |q|² - 1 |` for incoming quaternions (tf2's).
pub const QUATERNION_NORM_SQUARED_TOLERANCE: f64 = 0.01;

/// Why a wire transform is not a rigid transform.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ConversionError {
    /// A component is NaN or infinite.
    #[error(
        "transform has non-finite components: translation ({x}, {y}, {z}) m, quaternion xyzw ({qx}, {qy}, {qz}, {qw})"
    )]
    NonFinite {
        /// Translation x.
        x: f64,
        /// Translation y.
        y: f64,
        /// Translation z.
        z: f64,
        /// Quaternion x.
        qx: f64,
        /// Quaternion y.
        qy: f64,
        /// Quaternion z.
        qz: f64,
        /// Quaternion w.
        qw: f64,
    },
    /// The quaternion is too far from unit length.
    #[error(
        "quaternion |q|^2 = {norm_squared} is not within {QUATERNION_NORM_SQUARED_TOLERANCE} of 1"
    )]
    NotUnit {
        /// Its squared norm.
        norm_squared: f64,
    },
}

/// `geometry_msgs/Transform` of an isometry.
#[must_use]
pub fn transform_msg(a_from_b: &Isometry3<f64>) -> Transform {
    let t = a_from_b.translation.vector;
    let q = a_from_b.rotation.coords; // (i, j, k, w) storage = (x, y, z, w)
    Transform {
        translation: Vector3Msg {
            x: t.x,
            y: t.y,
            z: t.z,
        },
        rotation: Quaternion {
            x: q.x,
            y: q.y,
            z: q.z,
            w: q.w,
        },
    }
}

/// The isometry of a `geometry_msgs/Transform` (quaternion normalised).
///
/// # Errors
/// [`ConversionError::NonFinite`], [`ConversionError::NotUnit`].
pub fn isometry_from_msg(t: &Transform) -> Result<Isometry3<f64>, ConversionError> {
    let (v, r) = (t.translation, t.rotation);
    if ![v.x, v.y, v.z, r.x, r.y, r.z, r.w]
        .iter()
        .all(|c| c.is_finite())
    {
        return Err(ConversionError::NonFinite {
            x: v.x,
            y: v.y,
            z: v.z,
            qx: r.x,
            qy: r.y,
            qz: r.z,
            qw: r.w,
        });
    }
    let q = NaQuaternion::new(r.w, r.x, r.y, r.z);
    let norm_squared = q.norm_squared();
    if (norm_squared - 1.0).abs() > QUATERNION_NORM_SQUARED_TOLERANCE {
        return Err(ConversionError::NotUnit { norm_squared });
    }
    Ok(Isometry3::from_parts(
        Translation3::new(v.x, v.y, v.z),
        UnitQuaternion::from_quaternion(q),
    ))
}

/// `geometry_msgs/Pose` of `frame_from_body`.
#[must_use]
pub fn pose_msg(frame_from_body: &Isometry3<f64>) -> Pose {
    let t = frame_from_body.translation.vector;
    let q = frame_from_body.rotation.coords; // (i, j, k, w) storage = (x, y, z, w)
    Pose {
        position: Point {
            x: t.x,
            y: t.y,
            z: t.z,
        },
        orientation: Quaternion {
            x: q.x,
            y: q.y,
            z: q.z,
            w: q.w,
        },
    }
}

/// `geometry_msgs/PoseStamped` of `frame_from_body` in `frame` at `stamp`.
#[must_use]
pub fn pose_stamped(frame: &str, stamp: Time, frame_from_body: &Isometry3<f64>) -> PoseStamped {
    PoseStamped {
        header: Header {
            stamp,
            frame_id: frame.to_owned(),
        },
        pose: pose_msg(frame_from_body),
    }
}

/// `frame_from_body` of a `geometry_msgs/Pose`, its quaternion normalised. For a pose that
/// may be malformed (a foreign recording), check it with [`isometry_from_msg`] first.
#[must_use]
pub fn isometry_from_pose(p: &Pose) -> Isometry3<f64> {
    let o = &p.orientation;
    Isometry3::from_parts(
        Translation3::new(p.position.x, p.position.y, p.position.z),
        UnitQuaternion::from_quaternion(NaQuaternion::new(o.w, o.x, o.y, o.z)),
    )
}

/// `TransformStamped` for the edge `parent -> child` carrying `parent_from_child`.
#[must_use]
pub fn transform_stamped(
    parent: &str,
    child: &str,
    stamp: Time,
    parent_from_child: &Isometry3<f64>,
) -> TransformStamped {
    TransformStamped {
        header: Header {
            stamp,
            frame_id: parent.to_owned(),
        },
        child_frame_id: child.to_owned(),
        transform: transform_msg(parent_from_child),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    #[test]
    fn round_trip_and_validation() {
        let iso = Isometry3::from_parts(
            Translation3::new(0.1, -0.2, 0.3),
            UnitQuaternion::from_axis_angle(&Vector3::y_axis(), 0.7),
        );
        let msg = transform_msg(&iso);
        assert!(
            (msg.rotation.y - (0.35f64).sin()).abs() < 1e-15,
            "xyzw order"
        );
        let back = isometry_from_msg(&msg).expect("valid");
        assert!((back.to_homogeneous() - iso.to_homogeneous()).amax() < 1e-15);
        let mut bad = msg;
        bad.rotation.w = 3.0;
        assert!(matches!(
            isometry_from_msg(&bad),
            Err(ConversionError::NotUnit { .. })
        ));
        bad.rotation.w = f64::NAN;
        assert!(matches!(
            isometry_from_msg(&bad),
            Err(ConversionError::NonFinite { .. })
        ));
    }
}
