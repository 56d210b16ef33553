//! The shapes of bodies (URDF links, the site's structures) as Rerun archetypes, and the
//! rotations that lay a cylinder along an axis.

use rerun::{
    AsComponents, Boxes3D, Capsules3D, CoordinateFrame, Cylinders3D, Ellipsoids3D, RecordingStream,
};

use crate::VizError;
use crate::convert::Pose;
use crate::site::Body;
use crate::urdf::Shape;

/// `q * Rx(-90 deg)`: a cylinder (axis = its z) lying along the `y` axis of `q`.
pub(super) fn along_y(q: [f64; 4]) -> [f64; 4] {
    let s = std::f64::consts::FRAC_1_SQRT_2;
    Pose { t: [0.0; 3], q }
        .compose(&Pose {
            t: [0.0; 3],
            q: [-s, 0.0, 0.0, s],
        })
        .q
}

/// `q * Ry(90 deg)`: a cylinder lying along the `x` axis of `q`.
pub(super) fn along_x(q: [f64; 4]) -> [f64; 4] {
    let s = std::f64::consts::FRAC_1_SQRT_2;
    Pose { t: [0.0; 3], q }
        .compose(&Pose {
            t: [0.0; 3],
            q: [0.0, s, 0.0, s],
        })
        .q
}

/// The axis `k` (0 = x, 1 = y, 2 = z) of a rotation `q`.
pub(super) fn axis_of(q: [f64; 4], k: usize) -> [f64; 3] {
    let mut e = [0.0; 3];
    e[k] = 1.0;
    Pose { t: [0.0; 3], q }
        .compose(&Pose {
            t: e,
            q: [0.0, 0.0, 0.0, 1.0],
        })
        .t
}

/// Whether a `/perception/target_pose` is a hook goal on the wire (its `z` up, `y` along the
/// wire: `control::tasks::poses::hook_goal`) rather than a grasp of the handle (`tool0`'s `x`
/// along the upright rod).
pub fn is_hook_goal(q: [f64; 4]) -> bool {
    axis_of(q, 2)[2] > 0.9
}

/// A shape drawn at `frame_from_shape`, in sRGBA.
pub(super) type Part = (Pose, Shape, [u8; 4]);

/// Logs the shapes of `bodies` (all in one frame) under `entity`: one `Boxes3D`, `Cylinders3D`,
/// `Ellipsoids3D`, `Capsules3D` child per kind present, each in `frame`.
pub(super) fn log_bodies(
    rec: &RecordingStream,
    entity: &str,
    frame: &str,
    bodies: &[Part],
    labels: Option<&[String]>,
    static_: bool,
) -> Result<(), VizError> {
    let coordinate_frame = CoordinateFrame::new(frame);
    let pick = |want: fn(&Shape) -> bool| -> Vec<usize> {
        (0..bodies.len()).filter(|&i| want(&bodies[i].1)).collect()
    };
    let log = |name: &str, arch: &dyn AsComponents| -> Result<(), VizError> {
        let path = format!("{entity}/{name}");
        let comps: [&dyn AsComponents; 2] = [arch, &coordinate_frame];
        if static_ {
            rec.log_static(path, &comps)?;
        } else {
            rec.log(path, &comps)?;
        }
        Ok(())
    };
    let color = |i: usize| {
        let [r, g, b, a] = bodies[i].2;
        rerun::Color::from_unmultiplied_rgba(r, g, b, a)
    };
    let label_of = |idx: &[usize]| -> Vec<String> {
        labels
            .map(|l| idx.iter().filter_map(|&i| l.get(i).cloned()).collect())
            .unwrap_or_default()
    };
    let boxes = pick(|s| matches!(s, Shape::Box { .. }));
    if !boxes.is_empty() {
        let half: Vec<[f32; 3]> = boxes
            .iter()
            .filter_map(|&i| match bodies[i].1 {
                Shape::Box { half_m } => Some(half_m),
                _ => None,
            })
            .collect();
        let mut arch =
            Boxes3D::from_centers_and_half_sizes(boxes.iter().map(|&i| bodies[i].0.t_f32()), half)
                .with_quaternions(
                    boxes
                        .iter()
                        .map(|&i| rerun::Quaternion::from_xyzw(bodies[i].0.q_f32())),
                )
                .with_colors(boxes.iter().map(|&i| color(i)))
                .with_fill_mode(rerun::FillMode::Solid);
        let l = label_of(&boxes);
        if !l.is_empty() {
            arch = arch.with_labels(l).with_show_labels(false);
        }
        log("boxes", &arch)?;
    }
    let cylinders = pick(|s| matches!(s, Shape::Cylinder { .. }));
    if !cylinders.is_empty() {
        let (lengths, radii): (Vec<f32>, Vec<f32>) = cylinders
            .iter()
            .filter_map(|&i| match bodies[i].1 {
                Shape::Cylinder { radius_m, length_m } => Some((length_m, radius_m)),
                _ => None,
            })
            .unzip();
        let mut arch = Cylinders3D::from_lengths_and_radii(lengths, radii)
            .with_centers(cylinders.iter().map(|&i| bodies[i].0.t_f32()))
            .with_quaternions(
                cylinders
                    .iter()
                    .map(|&i| rerun::Quaternion::from_xyzw(bodies[i].0.q_f32())),
            )
            .with_colors(cylinders.iter().map(|&i| color(i)))
            .with_fill_mode(rerun::FillMode::Solid);
        let l = label_of(&cylinders);
        if !l.is_empty() {
            arch = arch.with_labels(l).with_show_labels(false);
        }
        log("cylinders", &arch)?;
    }
    let spheres = pick(|s| matches!(s, Shape::Sphere { .. }));
    if !spheres.is_empty() {
        let radii: Vec<f32> = spheres
            .iter()
            .filter_map(|&i| match bodies[i].1 {
                Shape::Sphere { radius_m } => Some(radius_m),
                _ => None,
            })
            .collect();
        let arch = Ellipsoids3D::from_radii(radii)
            .with_centers(spheres.iter().map(|&i| bodies[i].0.t_f32()))
            .with_colors(spheres.iter().map(|&i| color(i)))
            .with_fill_mode(rerun::FillMode::Solid);
        log("spheres", &arch)?;
    }
    let capsules = pick(|s| matches!(s, Shape::Capsule { .. }));
    if !capsules.is_empty() {
        let (lengths, radii): (Vec<f32>, Vec<f32>) = capsules
            .iter()
            .filter_map(|&i| match bodies[i].1 {
                Shape::Capsule { radius_m, length_m } => Some((length_m, radius_m)),
                _ => None,
            })
            .unzip();
        // A URDF capsule is centred at its origin; Rerun's starts there.
        let arch = Capsules3D::from_lengths_and_radii(lengths.clone(), radii)
            .with_translations(capsules.iter().zip(&lengths).map(|(&i, len)| {
                let p = bodies[i].0;
                let a = axis_of(p.q, 2);
                let h = 0.5 * f64::from(*len);
                [
                    (p.t[0] - h * a[0]) as f32,
                    (p.t[1] - h * a[1]) as f32,
                    (p.t[2] - h * a[2]) as f32,
                ]
            }))
            .with_quaternions(
                capsules
                    .iter()
                    .map(|&i| rerun::Quaternion::from_xyzw(bodies[i].0.q_f32())),
            )
            .with_colors(capsules.iter().map(|&i| color(i)));
        log("capsules", &arch)?;
    }
    Ok(())
}

pub(super) fn body_parts(bodies: &[Body]) -> (Vec<Part>, Vec<String>) {
    (
        bodies.iter().map(|b| (b.pose, b.shape, b.rgba)).collect(),
        bodies.iter().map(|b| b.name.clone()).collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hook_goals_and_grasps_are_told_apart_by_their_axes() {
        // Hook goal: z up, y along the wire (rotated 30 deg about z).
        let (s, c) = (15f64.to_radians().sin(), 15f64.to_radians().cos());
        assert!(is_hook_goal([0.0, 0.0, s, c]));
        // Grasp: tool0 x up (the rod), z horizontal: Ry(-90 deg).
        let h = std::f64::consts::FRAC_1_SQRT_2;
        assert!(!is_hook_goal([0.0, -h, 0.0, h]));
        assert_eq!(
            axis_of([0.0, -h, 0.0, h], 0).map(|v| v.round()),
            [0.0, 0.0, 1.0]
        );
        // A wire cylinder along the goal's y, a truth cylinder along the pose's x.
        let y = axis_of(along_y([0.0, 0.0, 0.0, 1.0]), 2);
        let x = axis_of(along_x([0.0, 0.0, 0.0, 1.0]), 2);
        for (g, w) in y.iter().chain(&x).zip([0.0, 1.0, 0.0, 1.0, 0.0, 0.0]) {
            assert!((g - w).abs() < 1e-12, "{y:?} {x:?}");
        }
    }
}
