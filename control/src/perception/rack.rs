//! The empty rack's pose from wrist depth: where the rod goes back when the robot has not
//! seen it stored (a remove on its own). A crew's survey places the rack to a few cm, and the
//! rod seats only within 1 cm of its stored pose; the rack's post measures the rest.
//!
//! # Method
//! The post is a vertical bar of square section (half width `h`) at a known place in the rack
//! frame ([`PostModel`]). In the prior rack frame (the survey's), the depth points between
//! the holders' heights and within [`SEARCH_RADIUS_M`] of the post's axis are its faces seen
//! from the camera. Their horizontal positions `q_i` are fitted by the square's centre `c`
//! (the yaw is the survey's: 1 deg moves the holders 1.4 mm about the post) in rounds of
//! closest faces, as in iterated closest points (Besl and McKay 1992): each point goes to
//! the nearest side of the current square; the points on the side across an axis that faces
//! the camera (at most [`MIN_FACE_COS`] off) give the centre on it (their mean, less `h`),
//! and an axis with no such side takes the middle of the points' extent along it (the seen
//! face's width; its ends are points with [`EDGE_SUPPORT`] others close inside). Points farther from the square than [`TRIM_FACTOR`] times the RMS, and than
//! [`TRIM_FLOOR_M`], are dropped after the first rounds. The start is the points' centroid pushed `h` away from the camera (the
//! visible faces are the near ones). The height comes from the rack's base plate, a
//! horizontal face around the post: first the most populated height slice over the plate
//! (before the post's band is chosen, so that a survey's height error cannot put the plate
//! in it), then the median height of the points over the plate away from the post, which
//! depth outliers cannot move.

use nalgebra::{Isometry3, Point3, Translation3, Vector2, Vector3};

/// Search radius around the prior post axis (m): a survey's error (3 sigma of 2 cm per axis, 6 cm)
/// plus the post's half diagonal and a margin.
pub const SEARCH_RADIUS_M: f64 = 0.1;
/// Residuals above this multiple of the RMS (and above [`TRIM_FLOOR_M`]) are dropped.
pub const TRIM_FACTOR: f64 = 3.0;
/// Residuals below this are always kept (m): the points past a face's end are what fixes
/// the position along the face, and they sit a few mm off a wrong fit.
pub const TRIM_FLOOR_M: f64 = 0.01;
/// Post points needed for a fit.
pub const MIN_POST_POINTS: usize = 20;
/// Points on a face for it to give the centre across it.
pub const MIN_FACE_POINTS: usize = 10;
/// A side is seen squarely enough to give the centre across it when the cosine between its
/// normal and the direction to the camera is at least this (66 deg).
pub const MIN_FACE_COS: f64 = 0.4;
/// A face's end is the outermost point with this many others within [`EDGE_SUPPORT_M`]
/// inside it (a lone depth outlier is no end).
pub const EDGE_SUPPORT: usize = 5;
/// See [`EDGE_SUPPORT`] (m).
pub const EDGE_SUPPORT_M: f64 = 0.001;
/// Residuals above this are always dropped after the first rounds (m).
pub const TRIM_CAP_M: f64 = 0.02;
/// Half the height window searched for the plate around the prior (m): 4 sigma of a
/// survey's 2 cm.
pub const PLATE_SEARCH_M: f64 = 0.08;
/// Rounds of the fit at most.
pub const FIT_ROUNDS: usize = 30;
/// Largest RMS distance of the kept points to the square (m).
pub const MAX_RMS_M: f64 = 0.003;
/// Plate points needed for the height.
pub const MIN_PLATE_POINTS: usize = 20;
/// Half the height window around the plate's model height (m).
pub const PLATE_WINDOW_M: f64 = 0.04;

/// The rack's post in the rack frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PostModel {
    /// Centre of the square section (m).
    pub centre_xy_m: [f64; 2],
    /// Half the side of the square (m).
    pub half_width_m: f64,
    /// Heights of the post fitted for the section (m): above the plate, in view of the
    /// camera on the stored rod's handle.
    pub band_z_m: [f64; 2],
    /// Centre of the base plate's top face (m).
    pub plate_centre_m: [f64; 3],
    /// Half extents of the plate's top face (m).
    pub plate_half_xy_m: [f64; 2],
}

/// A measured rack.
#[derive(Debug, Clone, PartialEq)]
pub struct RackFit {
    /// The rack frame measured (`frame_from_rack`, the points' frame).
    pub frame_from_rack: Isometry3<f64>,
    /// Its shift from the prior, in the prior rack frame (m).
    pub shift_m: Vector3<f64>,
    /// Post points kept in the fit.
    pub post_points: usize,
    /// Their RMS distance to the square (m).
    pub rms_m: f64,
}

/// Why the rack was not measured.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RackFitError {
    /// Too few depth points on the post.
    #[error("{found} depth points on the rack's post, {needed} needed: the post is not in view")]
    TooFewPoints {
        /// Points found.
        found: usize,
        /// Points needed.
        needed: usize,
    },
    /// The points do not lie on the post's square.
    #[error(
        "the post's points are {rms_mm:.1} mm RMS off its square section (at most {max_mm:.1} mm)"
    )]
    Residual {
        /// RMS (mm).
        rms_mm: f64,
        /// Limit (mm).
        max_mm: f64,
    },
    /// Too few points on the base plate for the height.
    #[error("{found} depth points on the rack's base plate, {needed} needed")]
    NoPlate {
        /// Points found.
        found: usize,
        /// Points needed.
        needed: usize,
    },
}

/// The closest point of the boundary of the square `[-h, h]^2` to `p`.
fn closest_on_square(p: Vector2<f64>, h: f64) -> Vector2<f64> {
    let c = Vector2::new(p.x.clamp(-h, h), p.y.clamp(-h, h));
    if c != p {
        return c;
    }
    // Inside: the nearest edge.
    if h - p.x.abs() < h - p.y.abs() {
        Vector2::new(h * p.x.signum(), p.y)
    } else {
        Vector2::new(p.x, h * p.y.signum())
    }
}

/// The plate's height in the prior rack frame: the most populated 1 cm slice of the points
/// over the plate's inner part (a survey's xy error away from its rim) within
/// [`PLATE_SEARCH_M`] of the model, refined by the median of the points within 1 cm of it.
/// The post's faces spread over every slice; the plate fills one.
fn plate_height_mode(local: &[Point3<f64>], model: &PostModel) -> Result<f64, RackFitError> {
    let inner = |q: &&Point3<f64>| {
        let l = q.xy().coords - Vector2::new(model.plate_centre_m[0], model.plate_centre_m[1]);
        l.x.abs() <= model.plate_half_xy_m[0] - 0.06
            && l.y.abs() <= model.plate_half_xy_m[1] - 0.06
            && (q.z - model.plate_centre_m[2]).abs() <= PLATE_SEARCH_M
    };
    let heights: Vec<f64> = local.iter().filter(inner).map(|q| q.z).collect();
    let slices = (2.0 * PLATE_SEARCH_M / 0.01).round() as usize;
    let mut count = vec![0usize; slices + 1];
    let low = model.plate_centre_m[2] - PLATE_SEARCH_M;
    for z in &heights {
        let k = ((z - low) / 0.01).floor().clamp(0.0, slices as f64) as usize;
        count[k] += 1;
    }
    let (best, n) = count
        .iter()
        .enumerate()
        .max_by_key(|(k, n)| (**n, usize::MAX - k))
        .map_or((0, 0), |(k, n)| (k, *n));
    if n < MIN_PLATE_POINTS {
        return Err(RackFitError::NoPlate {
            found: n,
            needed: MIN_PLATE_POINTS,
        });
    }
    let mode = low + (best as f64 + 0.5) * 0.01;
    let mut near: Vec<f64> = heights
        .into_iter()
        .filter(|z| (z - mode).abs() <= 0.01)
        .collect();
    near.sort_by(f64::total_cmp);
    Ok(near[near.len() / 2])
}

/// Measures the rack (module docs) from `points` (any frame), the prior `frame_from_rack`
/// and the camera's position `eye` in the same frame.
///
/// # Errors
/// [`RackFitError`].
pub fn fit_rack(
    points: &[Point3<f64>],
    prior: &Isometry3<f64>,
    eye: &Point3<f64>,
    model: &PostModel,
) -> Result<RackFit, RackFitError> {
    let rack_from_frame = prior.inverse();
    let axis = Vector2::from(model.centre_xy_m);
    let h = model.half_width_m;
    let mut local: Vec<Point3<f64>> = points.iter().map(|p| rack_from_frame * p).collect();
    // A first height from the plate, so that a survey's height error does not bring the
    // plate into the post's band.
    let dz0 = plate_height_mode(&local, model)? - model.plate_centre_m[2];
    for q in &mut local {
        q.z -= dz0;
    }
    let band: Vec<Vector2<f64>> = local
        .iter()
        .filter(|q| {
            (q.xy().coords - axis).norm() <= SEARCH_RADIUS_M
                && (model.band_z_m[0]..=model.band_z_m[1]).contains(&q.z)
        })
        .map(|q| q.xy().coords)
        .collect();
    if band.len() < MIN_POST_POINTS {
        return Err(RackFitError::TooFewPoints {
            found: band.len(),
            needed: MIN_POST_POINTS,
        });
    }
    let centroid = band.iter().sum::<Vector2<f64>>() / band.len() as f64;
    let eye_xy = (rack_from_frame * eye).xy().coords;
    let away = (centroid - eye_xy).try_normalize(1e-9).unwrap_or_default();
    let mut c = centroid + away * h;
    let mut keep = vec![true; band.len()];
    let mut rms = f64::INFINITY;
    for round in 0..FIT_ROUNDS {
        let residual = |q: &Vector2<f64>, c: Vector2<f64>| {
            let l = q - c;
            l - closest_on_square(l, h)
        };
        if round >= 2 {
            let limit = (TRIM_FACTOR * rms).clamp(TRIM_FLOOR_M, TRIM_CAP_M);
            for (k, q) in band.iter().enumerate() {
                keep[k] = residual(q, c).norm() <= limit;
            }
        }
        // Each kept point on its nearest face: a face across axis `a` gives `c_a` directly;
        // an axis with no face in view takes the middle of the other faces' extent.
        let mut next = c;
        for a in 0..2 {
            let b = 1 - a;
            // The side across `a` facing the camera, if the camera sees it at all squarely.
            let sign = (eye_xy[a] - c[a]).signum();
            let mut normal = Vector2::zeros();
            normal[a] = sign;
            let to_eye = eye_xy - (c + normal * h);
            let seen = to_eye
                .try_normalize(1e-9)
                .is_some_and(|v| v.dot(&normal) >= MIN_FACE_COS);
            let (mut across, mut all) = (Vec::new(), Vec::new());
            for (q, _) in band.iter().zip(&keep).filter(|(_, k)| **k) {
                let l = q - c;
                if seen && l[a] * sign > 0.0 && h - l[a].abs() <= h - l[b].abs() {
                    across.push(q[a] - h * sign);
                }
                all.push(q[a]);
            }
            if across.len() >= MIN_FACE_POINTS {
                next[a] = across.iter().sum::<f64>() / across.len() as f64;
            } else if all.len() >= MIN_FACE_POINTS {
                all.sort_by(f64::total_cmp);
                let supported = |k: &usize| {
                    all.get(k + EDGE_SUPPORT)
                        .is_some_and(|w| w - all[*k] <= EDGE_SUPPORT_M)
                };
                let lo = (0..all.len()).find(supported);
                let hi = (EDGE_SUPPORT..all.len())
                    .rev()
                    .find(|k| all[*k] - all[k - EDGE_SUPPORT] <= EDGE_SUPPORT_M);
                if let (Some(lo), Some(hi)) = (lo, hi) {
                    next[a] = 0.5 * (all[lo] + all[hi]);
                }
            }
        }
        let step = (next - c).norm();
        c = next;
        let kept: Vec<f64> = band
            .iter()
            .zip(&keep)
            .filter(|(_, k)| **k)
            .map(|(q, _)| residual(q, c).norm_squared())
            .collect();
        if kept.len() < MIN_POST_POINTS {
            return Err(RackFitError::TooFewPoints {
                found: kept.len(),
                needed: MIN_POST_POINTS,
            });
        }
        rms = (kept.iter().sum::<f64>() / kept.len() as f64).sqrt();
        if step < 1e-7 && round >= 3 {
            break;
        }
    }
    let kept = keep.iter().filter(|k| **k).count();
    if rms > MAX_RMS_M {
        return Err(RackFitError::Residual {
            rms_mm: rms * 1e3,
            max_mm: MAX_RMS_M * 1e3,
        });
    }
    // The height: the plate's points, the post's neighbourhood and the plate's rim left out.
    let plate = Vector2::new(model.plate_centre_m[0], model.plate_centre_m[1]) + (c - axis);
    let mut heights: Vec<f64> = local
        .iter()
        .filter(|q| {
            let l = q.xy().coords - plate;
            let to_post = q.xy().coords - c;
            l.x.abs() <= model.plate_half_xy_m[0] - 0.02
                && l.y.abs() <= model.plate_half_xy_m[1] - 0.02
                && (to_post.x.abs() > h + 0.01 || to_post.y.abs() > h + 0.01)
                && (q.z - model.plate_centre_m[2]).abs() <= PLATE_WINDOW_M
        })
        .map(|q| q.z)
        .collect();
    if heights.len() < MIN_PLATE_POINTS {
        return Err(RackFitError::NoPlate {
            found: heights.len(),
            needed: MIN_PLATE_POINTS,
        });
    }
    heights.sort_by(f64::total_cmp);
    let plate_z = heights[heights.len() / 2];
    let shift_m = Vector3::new(
        c.x - axis.x,
        c.y - axis.y,
        dz0 + plate_z - model.plate_centre_m[2],
    );
    Ok(RackFit {
        frame_from_rack: prior * Translation3::from(shift_m),
        shift_m,
        post_points: kept,
        rms_m: rms,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::perception::synthetic::{BoxShape, NoiseModel, Scene, render_depth, wrist_rays};
    use rng::SplitMix64;

    const POST: PostModel = PostModel {
        centre_xy_m: [0.0, 0.13],
        half_width_m: 0.025,
        band_z_m: [0.05, 0.45],
        plate_centre_m: [0.0, 0.05, 0.02],
        plate_half_xy_m: [0.2, 0.2],
    };

    /// A synthetic wrist capture of a rack (post and plate) 2.6 cm / -2.8 cm / +1.2 cm off the
    /// prior (a survey's error), seen as the remove looks at it (at the stored handle's
    /// centre from 0.45 m, 20 deg above): the fit finds the shift to a millimetre, and a
    /// view without the post refuses.
    #[test]
    fn the_post_gives_the_racks_shift_from_its_prior() -> Result<(), Box<dyn std::error::Error>> {
        let prior = Isometry3::translation(10.0, -1.5, 0.6)
            * nalgebra::UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.4);
        let truth_shift = Vector3::new(0.026, -0.028, 0.012);
        let map_from_rack = prior * Translation3::from(truth_shift);
        let look_at = map_from_rack * Point3::new(0.0, 0.0, 0.245);
        let towards = (prior.rotation * Vector3::new(0.3, -0.85, 0.0)).normalize();
        let e = 20f64.to_radians();
        let eye = look_at + (towards * e.cos() + Vector3::z() * e.sin()) * 0.45;
        let map_from_camera =
            robot::se3::world_from_camera_looking_at(&eye, &look_at, &Vector3::z())
                .ok_or("view")?;
        let camera_from_map = map_from_camera.inverse();
        let part = |c: [f64; 3], h: [f64; 3]| BoxShape {
            camera_from_box: camera_from_map
                * map_from_rack
                * Isometry3::translation(c[0], c[1], c[2]),
            half_extents_m: Vector3::from(h),
        };
        let scene = Scene {
            boxes: vec![
                part([0.0, 0.05, 0.01], [0.2, 0.2, 0.01]),
                part([0.0, 0.05, -0.3], [0.22, 0.22, 0.3]),
                part([0.0, 0.13, 0.6], [0.025, 0.025, 0.6]),
                part([0.0, 0.05, 0.75], [0.04, 0.085, 0.015]),
            ],
            ..Scene::default()
        };
        let rays = wrist_rays()?;
        let depth = render_depth(
            &scene,
            &rays,
            &NoiseModel::default(),
            &mut SplitMix64::new(7),
        );
        let points: Vec<Point3<f64>> = (0..depth.height)
            .step_by(2)
            .flat_map(|v| (0..depth.width).step_by(2).map(move |u| (u, v)))
            .filter_map(|(u, v)| depth.point(&rays, u, v))
            .map(|p| map_from_camera * p)
            .collect();
        let fit = fit_rack(&points, &prior, &eye, &POST)?;
        let error = fit.shift_m - truth_shift;
        eprintln!(
            "shift {:?} vs {truth_shift:?}: {:.2} mm, {} points, rms {:.2} mm",
            fit.shift_m,
            error.norm() * 1e3,
            fit.post_points,
            fit.rms_m * 1e3
        );
        assert!(error.xy().norm() < 1e-3, "{error}");
        assert!(error.z.abs() < 1e-3, "{error}");
        // A prior 5 cm too low (2.5 sigma of a survey) still finds the plate before it
        // chooses the post's band.
        let low = Isometry3::translation(0.0, 0.0, -0.05) * prior;
        let fit = fit_rack(&points, &low, &eye, &POST)?;
        let error = fit.shift_m - (truth_shift + Vector3::new(0.0, 0.0, 0.05));
        assert!(error.norm() < 1e-3, "{error}");
        let far = Isometry3::translation(0.5, 0.0, 0.0) * prior;
        assert!(matches!(
            fit_rack(&points, &far, &eye, &POST),
            Err(RackFitError::TooFewPoints { .. } | RackFitError::NoPlate { .. })
        ));
        Ok(())
    }

    #[test]
    fn closest_points_of_the_square() {
        let h = 1.0;
        assert_eq!(
            closest_on_square(Vector2::new(2.0, 0.5), h),
            Vector2::new(1.0, 0.5)
        );
        assert_eq!(
            closest_on_square(Vector2::new(0.2, 0.9), h),
            Vector2::new(0.2, 1.0)
        );
        assert_eq!(
            closest_on_square(Vector2::new(-3.0, -3.0), h),
            Vector2::new(-1.0, -1.0)
        );
    }
}
