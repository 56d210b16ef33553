//! The panoramic wire-region finder: from one low-resolution panoramic colour frame and the
//! site map's prior of the target conductor, the plane through the panoramic camera that
//! contains the wire, the corrected wire prior, and the wrist camera's look pose.
//!
//! # Method
//! 1. **Search band.** The map prior (a segment of the target conductor: point `p0`,
//!    direction `d0`, half-length `L`) is projected into the image at [`PanoramicParams::samples`]
//!    points (plumb_bob distortion included). Around each projected sample the search runs
//!    along the image normal of the projected curve over `±band_px`.
//! 2. **Thin ridge.** A 26.8 mm conductor at 2-6 m is 0.5-2 px wide in the panoramic
//!    image, darker than the sky behind it or, lit by the sun, brighter (aluminium strands;
//!    the simulator renders both). On the luminance `Y = 0.299 R + 0.587 G + 0.114 B`
//!    (bilinear), the ridge response at offset `s` along the normal `n` is
//!    `r(s) = max(min(Y(s - w), Y(s + w)) - Y(s), Y(s) - max(Y(s - w), Y(s + w)))` with
//!    `w` = [`PanoramicParams::ridge_halfwidth_px`] (a line detector of either polarity:
//!    non-zero only when both sides differ from the centre the same way, so edges of large
//!    objects do not respond; Steger, *An unbiased detector of curvilinear structures*, PAMI
//!    1998, uses the same second-derivative idea). The best `s` per sample, refined by a
//!    parabola through its neighbours, is a candidate when `r >= min_contrast`.
//! 3. **Plane of the wire.** Candidates are undistorted to normalised rays `m_i = (x, y, 1)`;
//!    a line in the undistorted image is a plane through the camera centre with normal
//!    `n_c ∝ m_a × m_b`. RANSAC over candidate pairs (seeded, deterministic) keeps the plane
//!    with most candidates within `inlier_px` (angular distance `|n_c · m| / |m|` times the
//!    focal length), then least squares: `n_c` = the right singular vector of the smallest
//!    singular value of the stacked unit rays of the inliers.
//! 4. **Corrected prior.** One view constrains the wire to that plane only (its depth along
//!    the viewing rays is unobservable), so the corrected point is the orthogonal projection
//!    of the map prior onto the plane, `p = p0 - n (n · (p0 - c))`, and the direction is the
//!    prior direction projected onto the plane: the error across the viewing rays (the
//!    sway and the sag seen from the base) is removed, the error along them stays.
//! 5. **Quality, refusal.** Refused ([`PerceptionError::PanoramicNoWire`]) when fewer than
//!    `min_inlier_fraction` of the samples that fall in the image are inliers (dusk sky as
//!    dark as the wire, occlusion, wire out of view), or the prior is not in view
//!    ([`PerceptionError::PanoramicNotInView`]).
//!
//! The look pose of the wrist camera is then [`super::roi::wrist_look_pose`] of the corrected
//! prior ([`look_pose`]).
//!
//! # Degenerate cases
//! A wire seen end-on (its projection shorter than a few pixels) or a viewing plane that
//! contains the prior direction's normal: refused (too few samples in view). The panoramic
//! camera sits on the base, 0.9 m high and pitched up 30 deg; its view ends ~65 deg above the
//! horizontal, so a conductor 4.4 m above and less than ~2 m ahead of it is out of view: the
//! robot takes the panoramic fix a few metres before its working spot.

use nalgebra::{Isometry3, Matrix3, Point2, Point3, Vector3};

use super::PerceptionError;
use super::point_cloud::CameraModel;
use rng::SplitMix64;

/// Samples along the projected prior that fall inside the image must number at least this.
pub const MIN_SAMPLES_IN_VIEW: usize = 8;

/// A prior of the wire (from the site map), in some fixed frame (`map` or `base_link`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WirePrior {
    /// A point on the wire axis near the hanging location (m).
    pub point: Point3<f64>,
    /// Direction of the wire (any sign, non-zero).
    pub direction: Vector3<f64>,
    /// Half-length of the prior segment searched (m).
    pub half_length_m: f64,
}

/// Settings of the finder.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PanoramicParams {
    /// Samples along the prior segment. Default 64.
    pub samples: usize,
    /// Half-width of the search band along the image normal (px at the image's scale).
    /// Default 24 px (~0.35 m at 4 m with the 320x180 panoramic image).
    pub band_px: f64,
    /// Half-width of the ridge's comparison offset (px). Default 2.
    pub ridge_halfwidth_px: f64,
    /// Smallest ridge response accepted (luminance levels of 255). Default 6.
    pub min_contrast: f64,
    /// RANSAC inlier distance (px). Default 1.5.
    pub inlier_px: f64,
    /// RANSAC iterations. Default 200.
    pub iterations: usize,
    /// Inliers / samples in view below this: refused. Default 0.5.
    pub min_inlier_fraction: f64,
    /// RANSAC seed. Default 0x9A40.
    pub seed: u64,
}

impl Default for PanoramicParams {
    fn default() -> Self {
        Self {
            samples: 64,
            band_px: 24.0,
            ridge_halfwidth_px: 2.0,
            min_contrast: 6.0,
            inlier_px: 1.5,
            iterations: 200,
            min_inlier_fraction: 0.5,
            seed: 0x9A40,
        }
    }
}

/// A borrowed `rgb8` image.
#[derive(Debug, Clone, Copy)]
pub struct RgbView<'a> {
    /// Width (px).
    pub width: usize,
    /// Height (px).
    pub height: usize,
    /// Row stride (bytes).
    pub step: usize,
    /// Pixel bytes, `R G B` per pixel.
    pub data: &'a [u8],
}

impl<'a> RgbView<'a> {
    /// A view of a `sensor_msgs/Image` with encoding `rgb8` or `bgr8`; `bgr8` is accepted
    /// only through [`RgbView::luminance_weights`], which the caller takes from the encoding.
    ///
    /// # Errors
    /// [`PerceptionError::BadImage`] when the stride or length does not fit.
    pub fn new(
        width: usize,
        height: usize,
        step: usize,
        data: &'a [u8],
    ) -> Result<Self, PerceptionError> {
        if width == 0
            || height == 0
            || step < 3 * width
            || data.len() < step * (height - 1) + 3 * width
        {
            return Err(PerceptionError::BadImage {
                image: "colour",
                reason: "size, stride and data length disagree",
                encoding: "rgb8".to_owned(),
                width: u32::try_from(width).unwrap_or(u32::MAX),
                height: u32::try_from(height).unwrap_or(u32::MAX),
                step: u32::try_from(step).unwrap_or(u32::MAX),
                bytes: data.len(),
            });
        }
        Ok(Self {
            width,
            height,
            step,
            data,
        })
    }

    /// Rec. 601 luma weights for `rgb8`, reversed for `bgr8`.
    #[must_use]
    pub fn luminance_weights(bgr: bool) -> [f64; 3] {
        if bgr {
            [0.114, 0.587, 0.299]
        } else {
            [0.299, 0.587, 0.114]
        }
    }

    fn luma_at(&self, u: usize, v: usize, w: &[f64; 3]) -> f64 {
        let i = v * self.step + 3 * u;
        match self.data.get(i..i + 3) {
            Some(p) => w[0] * f64::from(p[0]) + w[1] * f64::from(p[1]) + w[2] * f64::from(p[2]),
            None => f64::NAN,
        }
    }

    /// Bilinear luminance at `(u, v)` (pixel centres at integers); NaN outside.
    #[must_use]
    pub fn luma(&self, u: f64, v: f64, w: &[f64; 3]) -> f64 {
        if !(u >= 0.0 && v >= 0.0) {
            return f64::NAN;
        }
        let (u0, v0) = (u.floor() as usize, v.floor() as usize);
        if u0 + 1 >= self.width || v0 + 1 >= self.height {
            return f64::NAN;
        }
        let (fu, fv) = (u - u0 as f64, v - v0 as f64);
        let top = self.luma_at(u0, v0, w) * (1.0 - fu) + self.luma_at(u0 + 1, v0, w) * fu;
        let bottom =
            self.luma_at(u0, v0 + 1, w) * (1.0 - fu) + self.luma_at(u0 + 1, v0 + 1, w) * fu;
        top * (1.0 - fv) + bottom * fv
    }
}

/// What the finder measured.
#[derive(Debug, Clone, PartialEq)]
pub struct PanoramicWire {
    /// Unit normal of the plane through the camera centre containing the wire, in the
    /// prior's frame.
    pub plane_normal: Vector3<f64>,
    /// The camera centre in the prior's frame.
    pub camera_centre: Point3<f64>,
    /// Corrected wire point (the prior projected onto the plane).
    pub point: Point3<f64>,
    /// Corrected unit direction (in the plane).
    pub direction: Vector3<f64>,
    /// Distance the prior point moved (m).
    pub correction_m: f64,
    /// Inlier pixels (distorted image coordinates), for drawing.
    pub inliers_px: Vec<(f64, f64)>,
    /// Samples of the prior that fell in the image.
    pub samples_in_view: usize,
    /// RMS distance of the inliers to the fitted line (px).
    pub rms_px: f64,
    /// Median ridge response of the inliers (luminance levels).
    pub median_contrast: f64,
}

/// Finds the wire near `prior` in a panoramic frame (module docs).
///
/// `frame_from_camera` maps the panoramic optical frame to the prior's frame.
///
/// # Errors
/// [`PerceptionError::PanoramicNotInView`], [`PerceptionError::PanoramicNoWire`],
/// [`PerceptionError::Degenerate`] for a zero prior direction.
pub fn find_wire_region(
    image: &RgbView<'_>,
    luma_weights: &[f64; 3],
    camera: &CameraModel,
    frame_from_camera: &Isometry3<f64>,
    prior: &WirePrior,
    params: &PanoramicParams,
) -> Result<PanoramicWire, PerceptionError> {
    let d0 = prior
        .direction
        .try_normalize(1e-12)
        .ok_or(PerceptionError::Degenerate {
            what: "prior wire direction",
        })?;
    let camera_from_frame = frame_from_camera.inverse();
    let n = params.samples.max(2);
    let (w, h) = (f64::from(camera.width), f64::from(camera.height));
    let project = |t: f64| {
        let p = prior.point + d0 * t;
        camera
            .project(&(camera_from_frame * p))
            .map(|px| (px.x, px.y))
    };
    let mut in_view = 0usize;
    let mut candidates: Vec<((f64, f64), f64)> = Vec::new();
    let dt = 2.0 * prior.half_length_m / (n - 1) as f64;
    for k in 0..n {
        let t = -prior.half_length_m + dt * k as f64;
        let (Some(c), Some(a), Some(b)) =
            (project(t), project(t - 0.5 * dt), project(t + 0.5 * dt))
        else {
            continue;
        };
        if !(c.0 >= 0.0 && c.1 >= 0.0 && c.0 <= w - 1.0 && c.1 <= h - 1.0) {
            continue;
        }
        in_view += 1;
        let (tu, tv) = (b.0 - a.0, b.1 - a.1);
        let len = tu.hypot(tv);
        if len < 1e-9 {
            continue;
        }
        let (nu, nv) = (-tv / len, tu / len);
        if let Some(found) = ridge_along(image, luma_weights, c, (nu, nv), params) {
            candidates.push(found);
        }
    }
    if in_view < MIN_SAMPLES_IN_VIEW {
        return Err(PerceptionError::PanoramicNotInView {
            samples_in_view: in_view,
            needed: MIN_SAMPLES_IN_VIEW,
        });
    }
    let rays: Vec<Vector3<f64>> = candidates
        .iter()
        .map(|((u, v), _)| {
            let x = camera.undistort_pixel(&Point2::new(*u, *v))?;
            Ok(Vector3::new(x.x, x.y, 1.0).normalize())
        })
        .collect::<Result<_, PerceptionError>>()?;
    let needed = ((params.min_inlier_fraction * in_view as f64).ceil() as usize).max(2);
    let no_wire = |inliers: usize| PerceptionError::PanoramicNoWire {
        inliers,
        samples_in_view: in_view,
        needed,
    };
    // Angular tolerance: inlier_px at the focal length.
    let tol = params.inlier_px / camera.fx.max(camera.fy);
    let mut rng = SplitMix64::new(params.seed);
    let mut best: Option<(usize, Vector3<f64>)> = None;
    if rays.len() >= 2 {
        for _ in 0..params.iterations.max(1) {
            let i = rng.below(rays.len());
            let j = rng.below(rays.len());
            if i == j {
                continue;
            }
            let Some(normal) = rays[i].cross(&rays[j]).try_normalize(1e-9) else {
                continue;
            };
            let count = rays.iter().filter(|m| normal.dot(m).abs() <= tol).count();
            if best.is_none_or(|(c, _)| count > c) {
                best = Some((count, normal));
            }
        }
    }
    let Some((count, normal)) = best else {
        return Err(no_wire(0));
    };
    if count < needed {
        return Err(no_wire(count));
    }
    // Least squares on the inliers: the smallest right singular vector of the stacked rays
    // (the smallest eigenvector of sum m m^T).
    let inlier_idx: Vec<usize> = (0..rays.len())
        .filter(|&k| normal.dot(&rays[k]).abs() <= tol)
        .collect();
    let mut scatter = Matrix3::zeros();
    for &k in &inlier_idx {
        scatter += rays[k] * rays[k].transpose();
    }
    let eig = scatter.symmetric_eigen();
    let mut min_k = 0;
    for k in 1..3 {
        if eig.eigenvalues[k] < eig.eigenvalues[min_k] {
            min_k = k;
        }
    }
    let mut n_c: Vector3<f64> = eig.eigenvectors.column(min_k).into_owned();
    if n_c.dot(&normal) < 0.0 {
        n_c = -n_c;
    }
    let sq: f64 = inlier_idx
        .iter()
        .map(|&k| (n_c.dot(&rays[k]) * camera.fx).powi(2))
        .sum();
    let rms_px = (sq / inlier_idx.len().max(1) as f64).sqrt();
    let mut contrasts: Vec<f64> = inlier_idx.iter().map(|&k| candidates[k].1).collect();
    contrasts.sort_by(f64::total_cmp);
    let median_contrast = contrasts.get(contrasts.len() / 2).copied().unwrap_or(0.0);
    let plane_normal = frame_from_camera.rotation * n_c;
    let camera_centre = Point3::from(frame_from_camera.translation.vector);
    let offset = plane_normal.dot(&(prior.point - camera_centre));
    let point = prior.point - plane_normal * offset;
    let direction = (d0 - plane_normal * plane_normal.dot(&d0))
        .try_normalize(1e-9)
        .ok_or(PerceptionError::Degenerate {
            what: "prior direction perpendicular to the wire plane",
        })?;
    Ok(PanoramicWire {
        plane_normal,
        camera_centre,
        point,
        direction,
        correction_m: offset.abs(),
        inliers_px: inlier_idx.iter().map(|&k| candidates[k].0).collect(),
        samples_in_view: in_view,
        rms_px,
        median_contrast,
    })
}

/// The strongest thin ridge (dark or bright) along the normal `(nu, nv)` through `c` within the band:
/// `((u, v), response)` or `None` below the contrast threshold.
fn ridge_along(
    image: &RgbView<'_>,
    weights: &[f64; 3],
    c: (f64, f64),
    (nu, nv): (f64, f64),
    params: &PanoramicParams,
) -> Option<((f64, f64), f64)> {
    let half = params.band_px.max(1.0).round() as i64;
    let wd = params.ridge_halfwidth_px;
    let response = |s: f64| {
        let at = |o: f64| image.luma(c.0 + nu * (s + o), c.1 + nv * (s + o), weights);
        let (centre, lo, hi) = (at(0.0), at(-wd), at(wd));
        let r = (lo.min(hi) - centre).max(centre - lo.max(hi));
        if r.is_nan() { f64::NEG_INFINITY } else { r }
    };
    let mut best = (f64::NEG_INFINITY, 0i64);
    for s in -half..=half {
        let r = response(s as f64);
        if r > best.0 {
            best = (r, s);
        }
    }
    if best.0 < params.min_contrast {
        return None;
    }
    let s = best.1 as f64;
    let (rm, rp) = (response(s - 1.0), response(s + 1.0));
    let denom = rm - 2.0 * best.0 + rp;
    let ds = if rm.is_finite() && rp.is_finite() && denom < -1e-12 {
        (0.5 * (rm - rp) / denom).clamp(-0.5, 0.5)
    } else {
        0.0
    };
    let s = s + ds;
    Some(((c.0 + nu * s, c.1 + nv * s), best.0))
}

/// The wrist camera's look pose at the corrected wire (see [`super::roi::wrist_look_pose`]).
///
/// # Errors
/// As [`super::roi::wrist_look_pose`].
pub fn look_pose(
    wire: &PanoramicWire,
    robot_point: &Point3<f64>,
    standoff_m: f64,
) -> Result<Isometry3<f64>, PerceptionError> {
    super::roi::wrist_look_pose(&wire.point, &wire.direction, robot_point, standoff_m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Translation3, UnitQuaternion};

    /// A 320x180 panoramic camera looking north (frame: x east, y north, z up), pitched up
    /// 30 deg, at the origin 0.9 m high.
    fn setup() -> (CameraModel, Isometry3<f64>) {
        let camera = CameraModel::pinhole(320, 180, 130.0, 130.0, 159.5, 89.5)
            .with_distortion([-0.12, 0.01, 0.0, 0.0, 0.0]);
        let pitch = 30f64.to_radians();
        let z = Vector3::new(0.0, pitch.cos(), pitch.sin());
        let x = Vector3::x();
        let y = z.cross(&x);
        let r = nalgebra::Rotation3::from_basis_unchecked(&[x, y, z]);
        let pose = Isometry3::from_parts(
            Translation3::new(0.0, 0.0, 0.9),
            UnitQuaternion::from_rotation_matrix(&r),
        );
        (camera, pose)
    }

    /// Renders a sky gradient with a dark wire (a straight line along x at `(y, z)`, drawn
    /// with its true projected width, antialiased by supersampling) and a dark box.
    fn render(camera: &CameraModel, pose: &Isometry3<f64>, wire_y: f64, wire_z: f64) -> Vec<u8> {
        let (w, h) = (camera.width as usize, camera.height as usize);
        let mut data = vec![0u8; w * h * 3];
        let cam_from_world = pose.inverse();
        for v in 0..h {
            for u in 0..w {
                let mut cover = 0.0;
                for (su, sv) in [(0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75)] {
                    let px = Point2::new(u as f64 - 0.5 + su, v as f64 - 0.5 + sv);
                    let Ok(x) = camera.undistort_pixel(&px) else {
                        continue;
                    };
                    let dir = pose.rotation * Vector3::new(x.x, x.y, 1.0);
                    let o = pose.translation.vector;
                    // Distance of the ray to the wire line (along x).
                    let wire_o = Vector3::new(0.0, wire_y, wire_z);
                    let ax = Vector3::x();
                    let nrm = dir.cross(&ax);
                    let dist = if nrm.norm() > 1e-9 {
                        ((wire_o - o).dot(&nrm) / nrm.norm()).abs()
                    } else {
                        f64::INFINITY
                    };
                    if dist <= 0.0134 * 1.0 {
                        cover += 0.25;
                    }
                }
                let _ = cam_from_world;
                let sky = 200.0 - 40.0 * v as f64 / h as f64;
                let val = sky * (1.0 - cover) + 40.0 * cover;
                let i = (v * w + u) * 3;
                let (r, g, b) = if u > 250 && v > 120 {
                    (30.0, 30.0, 30.0)
                } else {
                    (val * 0.9, val * 0.95, val)
                };
                data[i] = r as u8;
                data[i + 1] = g as u8;
                data[i + 2] = b as u8;
            }
        }
        data
    }

    #[test]
    fn corrects_the_prior_across_the_viewing_rays() -> Result<(), PerceptionError> {
        let (camera, pose) = setup();
        // True wire 3.0 m north, 5.3 m high; the map says 3.2 m north, 5.45 m high.
        let data = render(&camera, &pose, 3.0, 5.3);
        let image = RgbView::new(320, 180, 960, &data)?;
        let prior = WirePrior {
            point: Point3::new(0.3, 3.2, 5.45),
            direction: Vector3::new(1.0, 0.02, 0.0),
            half_length_m: 1.5,
        };
        let found = find_wire_region(
            &image,
            &RgbView::luminance_weights(false),
            &camera,
            &pose,
            &prior,
            &PanoramicParams::default(),
        )?;
        // The true wire lies in the plane.
        for x in [-1.0, 0.0, 1.0] {
            let p = Point3::new(x, 3.0, 5.3);
            let d = found.plane_normal.dot(&(p - found.camera_centre));
            assert!(d.abs() < 0.02, "true wire {d} m off the plane");
        }
        // In the y-z plane, the prior error (0.2, 0.15) m splits into a part along the viewing
        // ray to the wire (unobservable, kept) and a part across it (removed).
        let ray = Vector3::new(0.0, 3.0, 5.3 - 0.9).normalize();
        let across = Vector3::x().cross(&ray);
        let error_before: Vector3<f64> = Vector3::new(0.0, 0.2, 0.15);
        let error_after: Vector3<f64> = Vector3::new(0.0, found.point.y - 3.0, found.point.z - 5.3);
        assert!(error_before.dot(&across).abs() > 0.07);
        assert!(
            error_after.dot(&across).abs() < 0.005,
            "across the ray: {} m",
            error_after.dot(&across)
        );
        assert!((error_after.dot(&ray) - error_before.dot(&ray)).abs() < 0.01);
        assert!(found.direction.x.abs() > 0.999);
        assert!(found.rms_px < 1.0, "rms {}", found.rms_px);
        Ok(())
    }

    #[test]
    fn finds_a_sunlit_wire_brighter_than_the_sky() -> Result<(), PerceptionError> {
        let (camera, pose) = setup();
        let mut data = render(&camera, &pose, 3.0, 5.3);
        // Invert the wire's contrast: dark wire pixels (value < 120) become bright.
        for px in data.chunks_exact_mut(3) {
            if px[2] < 150 && px[0] > 35 {
                for c in px.iter_mut() {
                    *c = 255 - *c / 2;
                }
            }
        }
        let image = RgbView::new(320, 180, 960, &data)?;
        let prior = WirePrior {
            point: Point3::new(0.0, 3.1, 5.4),
            direction: Vector3::x(),
            half_length_m: 1.5,
        };
        let found = find_wire_region(
            &image,
            &RgbView::luminance_weights(false),
            &camera,
            &pose,
            &prior,
            &PanoramicParams::default(),
        )?;
        let d = found
            .plane_normal
            .dot(&(Point3::new(0.0, 3.0, 5.3) - found.camera_centre));
        assert!(d.abs() < 0.02, "true wire {d} m off the plane");
        Ok(())
    }

    #[test]
    fn refuses_when_no_wire_is_visible() -> Result<(), PerceptionError> {
        let (camera, pose) = setup();
        // No wire in view (drawn far behind the camera).
        let data = render(&camera, &pose, -30.0, 5.3);
        let image = RgbView::new(320, 180, 960, &data)?;
        let prior = WirePrior {
            point: Point3::new(0.0, 3.0, 5.3),
            direction: Vector3::x(),
            half_length_m: 1.5,
        };
        let r = find_wire_region(
            &image,
            &RgbView::luminance_weights(false),
            &camera,
            &pose,
            &prior,
            &PanoramicParams::default(),
        );
        assert!(
            matches!(r, Err(PerceptionError::PanoramicNoWire { .. })),
            "{r:?}"
        );
        // Out of view: a prior behind the camera.
        let behind = WirePrior {
            point: Point3::new(0.0, -3.0, 5.3),
            ..prior
        };
        let r = find_wire_region(
            &image,
            &RgbView::luminance_weights(false),
            &camera,
            &pose,
            &behind,
            &PanoramicParams::default(),
        );
        assert!(
            matches!(r, Err(PerceptionError::PanoramicNotInView { .. })),
            "{r:?}"
        );
        Ok(())
    }
}
