//! Colour confirmation of a depth fit: can the registered colour image tell the fitted
//! cylinder's silhouette from what lies beside it?
//!
//! The wire and the handle are found in depth alone, and structured-light depth does not care
//! about ambient light. The colour image, registered to the depth image, is an independent
//! witness: in daylight the conductor's silhouette stands out from the sky or structure
//! behind it; at dusk the camera's gain is high and its shot and read noise bury the same
//! edge (ARCHITECTURE.md section 6: dusk = lower SNR, not simply a darker image). A fit that the colour
//! image cannot confirm is a fit the robot has only one sensor's word for, so the confidence
//! drops ([`super::confidence`], factor `colour_contrast`). This is the "feature validity" the
//! task needs; it is measured in the image, never read from the illuminance sensor.
//!
//! # The measure
//! At `N` stations along the axis (the extent of the fit's inliers), with `P` the axis point,
//! `a` the axis and `e = normalize(a × P)` the direction across the line of sight, samples are
//! taken at `P + j a + k r e` (nearest pixel, no interpolation, so the noise is not smoothed),
//! on each side of the silhouette (the limb is at `|k| ≈ 1`):
//! - just inside the limb: `0.55 <= |k| <= 0.9`;
//! - just outside it: `1.15 <= |k| <= 1.6` (both clear of the antialiased limb pixels).
//!
//! A side's contrast is the step across the limb over the background's pixel spread,
//! `c = |m_in - m_out| / s_out`: what a per-pixel edge detector (the paper's LA-Net
//! segmentation) sees. The spread of the background side holds its noise and its texture;
//! the wire's own strand texture, which is detail rather than noise, averages out of `m_in`.
//! A station takes its better side (the other may fall on a structure of the wire's
//! brightness); the measure is the median over the stations that have enough samples.
//! In daylight the step stands tens of spreads above the sky; at the end of civil twilight
//! (~3 lx) the gain's noise brings it down to about one.
//!
//! # Under the wrist light
//! The lamp beside the lens (`crate::tasks::lighting`) changes what the measure sees, not the
//! measure: it is taken in the image, so the light enters through the image itself. Its
//! inverse-square falloff makes the wire at 0.45 m brighter than whatever lies behind it,
//! and the gain drops back to daylight values, so the step rises above the spread again
//! (`tests/perception_sim.rs`: at 19:00, 0.4 lx, the wire's and the handle's confirmation
//! come back with the lamp). Its glare on the metal does not reach the bands: a lamp at the
//! lens mirrors off where the normal faces the camera, the cylinder's centre line, while
//! the inside band starts at `|k| = 0.55`, where the normal is 33 deg off the line of sight
//! and a specular lobe of exponent 200 has fallen to 1e-15 of its peak.

use super::PerceptionError;
use super::cylinder::Cylinder;
use super::point_cloud::{CameraModel, image_rows};
use msgs::sensor_msgs::Image;
use nalgebra::Point3;

/// Stations along the axis.
pub const STATIONS: usize = 24;
/// Band just inside the limb, in radii from the axis (each side).
pub const INSIDE_BAND: (f64, f64) = (0.55, 0.9);
/// Band just outside the limb, in radii from the axis (each side).
pub const OUTSIDE_BAND: (f64, f64) = (1.15, 1.6);
/// Fewest samples per band for a station to count.
pub const MIN_BAND_SAMPLES: usize = 8;
/// Fewest stations for a measure at all.
pub const MIN_STATIONS: usize = 6;

/// A colour image reduced to luma (Rec. 601, 8-bit units), row-major. The default is the
/// empty image, in which nothing can be confirmed.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LumaImage {
    /// Width (px).
    pub width: usize,
    /// Height (px).
    pub height: usize,
    /// `width * height` values in `[0, 255]`.
    pub luma: Vec<f32>,
}

impl LumaImage {
    /// From a `sensor_msgs/Image` in `rgb8`, `bgr8`, `rgba8`, `bgra8` or `mono8`.
    ///
    /// # Errors
    /// [`PerceptionError::BadImage`] for another encoding or a short buffer.
    pub fn from_image(image: &Image) -> Result<Self, PerceptionError> {
        let bad = |reason| PerceptionError::bad_image("colour", image, reason);
        // (bytes per pixel, offsets of R, G, B)
        let (bpp, [r, g, b]) = match image.encoding.as_str() {
            "rgb8" => (3, [0, 1, 2]),
            "bgr8" => (3, [2, 1, 0]),
            "rgba8" => (4, [0, 1, 2]),
            "bgra8" => (4, [2, 1, 0]),
            "mono8" => (1, [0, 0, 0]),
            _ => return Err(bad("encoding must be rgb8, bgr8, rgba8, bgra8 or mono8")),
        };
        let (width, height) = (image.width as usize, image.height as usize);
        let mut luma = Vec::with_capacity(width * height);
        for row in image_rows(image, bpp).map_err(bad)? {
            luma.extend(row.chunks_exact(bpp).map(|p| {
                0.299 * f32::from(p[r]) + 0.587 * f32::from(p[g]) + 0.114 * f32::from(p[b])
            }));
        }
        Ok(Self {
            width,
            height,
            luma,
        })
    }

    /// Luma at the pixel nearest `(u, v)`, `None` outside the image.
    #[must_use]
    pub fn nearest(&self, u: f64, v: f64) -> Option<f32> {
        let (u, v) = (u.round(), v.round());
        if !(u >= 0.0 && v >= 0.0 && u < self.width as f64 && v < self.height as f64) {
            return None;
        }
        self.luma.get(v as usize * self.width + u as usize).copied()
    }
}

/// The wrist colour image of the capture in progress, kept for the depth image of the same
/// stamp that follows it: the runtime publishes a `CameraCapture` colour first
/// (`msgs::drivers::CameraCapture`). Shared by the stages that confirm depth fits in colour.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PendingColour {
    latest: Option<(u64, LumaImage)>,
}

impl PendingColour {
    /// Keeps `image` (stamp `stamp_ns`). An image that cannot be read confirms nothing: it is
    /// kept as the empty image, whose contrast counts as 0.
    pub fn keep(&mut self, stamp_ns: u64, image: &Image) {
        let luma = LumaImage::from_image(image).unwrap_or_default();
        self.latest = Some((stamp_ns, luma));
    }

    /// The kept image when its stamp is `stamp_ns`; what was kept is dropped either way.
    pub fn take_for(&mut self, stamp_ns: u64) -> Option<LumaImage> {
        self.latest
            .take()
            .filter(|(stamp, _)| *stamp == stamp_ns)
            .map(|(_, luma)| luma)
    }
}

/// How well the colour image shows a fitted cylinder's silhouette (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LimbContrast {
    /// Median step-over-spread `c` over the stations.
    pub contrast: f64,
    /// Stations that had enough samples.
    pub stations: usize,
}

/// Running mean and variance (Welford).
#[derive(Debug, Clone, Copy, Default)]
struct Moments {
    n: usize,
    mean: f64,
    m2: f64,
}

impl Moments {
    fn push(&mut self, x: f64) {
        self.n += 1;
        let d = x - self.mean;
        self.mean += d / self.n as f64;
        self.m2 += d * (x - self.mean);
    }

    fn variance(&self) -> f64 {
        if self.n < 2 {
            0.0
        } else {
            self.m2 / (self.n - 1) as f64
        }
    }
}

/// The step between the bands over the outside band's spread, floored at the 8-bit
/// quantisation's `1/sqrt(12)` so a flat synthetic image does not divide by zero.
fn step_over_spread(inside: &Moments, outside: &Moments) -> f64 {
    let spread = outside.variance().sqrt().max(1.0 / 12f64.sqrt());
    (inside.mean - outside.mean).abs() / spread
}

/// The axis extent `[s_lo, s_hi]` (parameter along `cylinder.direction` from
/// `cylinder.point`) covered by `points`, trimmed to the 5th-95th percentile.
#[must_use]
pub fn axis_extent(cylinder: &Cylinder, points: &[Point3<f64>]) -> Option<(f64, f64)> {
    let mut s: Vec<f64> = points
        .iter()
        .map(|p| (p - cylinder.point).dot(&cylinder.direction))
        .filter(|s| s.is_finite())
        .collect();
    if s.len() < 2 {
        return None;
    }
    s.sort_by(f64::total_cmp);
    let at = |q: f64| s[((s.len() - 1) as f64 * q).round() as usize];
    Some((at(0.05), at(0.95)))
}

/// Measures the silhouette contrast of `cylinder` (camera frame) over the axis extent
/// `extent` in `image`, registered to `camera` (module docs). `None` when fewer than
/// [`MIN_STATIONS`] stations see both bands (e.g. the silhouette leaves the image).
#[must_use]
pub fn limb_contrast(
    image: &LumaImage,
    camera: &CameraModel,
    cylinder: &Cylinder,
    extent: (f64, f64),
) -> Option<LimbContrast> {
    let a = cylinder.direction.try_normalize(1e-12)?;
    let r = cylinder.radius_m;
    let (s_lo, s_hi) = extent;
    if !(s_lo.is_finite() && s_hi.is_finite() && s_hi > s_lo) {
        return None;
    }
    let mut per_station = Vec::with_capacity(STATIONS);
    for i in 0..STATIONS {
        let s = s_lo + (s_hi - s_lo) * (i as f64 + 0.5) / STATIONS as f64;
        let p = cylinder.point + a * s;
        let Some(e) = a.cross(&p.coords).try_normalize(1e-9) else {
            continue;
        };
        // Pixel pitch at this station, so each band is sampled about once per pixel.
        let px_per_m = camera.fx / p.z.max(1e-3);
        let step_m = (1.0 / px_per_m).max(1e-5);
        let half_length_m = 0.25 * (s_hi - s_lo) / STATIONS as f64;
        let sample = |k_lo: f64, k_hi: f64| {
            let mut m = Moments::default();
            let mut j = -half_length_m;
            while j <= half_length_m {
                let mut k = k_lo * r;
                while k <= k_hi * r {
                    let q: Point3<f64> = p + a * j + e * k;
                    if let Some(value) = camera.project(&q).and_then(|px| image.nearest(px.x, px.y))
                    {
                        m.push(f64::from(value));
                    }
                    k += step_m;
                }
                j += step_m;
            }
            m
        };
        let mut best: Option<f64> = None;
        for sign in [-1.0, 1.0] {
            let band = |(lo, hi): (f64, f64)| {
                if sign > 0.0 {
                    sample(lo, hi)
                } else {
                    sample(-hi, -lo)
                }
            };
            let (inside, outside) = (band(INSIDE_BAND), band(OUTSIDE_BAND));
            if inside.n >= MIN_BAND_SAMPLES && outside.n >= MIN_BAND_SAMPLES {
                let c = step_over_spread(&inside, &outside);
                best = Some(best.map_or(c, |b| b.max(c)));
            }
        }
        if let Some(d) = best {
            per_station.push(d);
        }
    }
    if per_station.len() < MIN_STATIONS {
        return None;
    }
    per_station.sort_by(f64::total_cmp);
    Some(LimbContrast {
        contrast: per_station[per_station.len() / 2],
        stations: per_station.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;
    use rng::SplitMix64;

    /// A `mono8` image of a horizontal bar (the cylinder at z = 0.5 m seen side-on) of
    /// intensity `wire` on `background`, with uniform noise of amplitude `noise`.
    fn bar_image(camera: &CameraModel, wire: f64, background: f64, noise: f64) -> Image {
        let (w, h) = (camera.width as usize, camera.height as usize);
        let half_px = camera.fx * 0.0134 / 0.5;
        let mut rng = SplitMix64::new(7);
        let data = (0..w * h)
            .map(|i| {
                let v = (i / w) as f64;
                let base = if (v - camera.cy).abs() < half_px {
                    wire
                } else {
                    background
                };
                (base + rng.uniform(-noise, noise))
                    .round()
                    .clamp(0.0, 255.0) as u8
            })
            .collect();
        Image {
            height: h as u32,
            width: w as u32,
            encoding: "mono8".to_owned(),
            step: w as u32,
            data,
            ..Image::default()
        }
    }

    fn camera() -> CameraModel {
        CameraModel::pinhole(320, 256, 436.0, 436.0, 160.0, 128.0).with_distortion([0.0; 5])
    }

    fn bar() -> Cylinder {
        Cylinder {
            point: Point3::new(0.0, 0.0, 0.5),
            direction: Vector3::x(),
            radius_m: 0.0134,
        }
    }

    #[test]
    fn a_clean_silhouette_has_high_contrast_and_noise_lowers_it() {
        let cam = camera();
        let measure = |noise| {
            let image =
                LumaImage::from_image(&bar_image(&cam, 60.0, 180.0, noise)).expect("mono8 image");
            limb_contrast(&image, &cam, &bar(), (-0.1, 0.1)).expect("silhouette in view")
        };
        let clean = measure(4.0);
        let noisy = measure(120.0);
        assert!(clean.stations >= MIN_STATIONS);
        // Uniform noise of amplitude A has s = A / sqrt(3): 120 DN of contrast over 2.3 DN.
        assert!(clean.contrast > 30.0, "{clean:?}");
        assert!(noisy.contrast < 3.0, "{noisy:?}");
    }

    #[test]
    fn a_cylinder_where_the_image_shows_nothing_has_no_contrast() {
        let cam = camera();
        let image =
            LumaImage::from_image(&bar_image(&cam, 120.0, 120.0, 10.0)).expect("mono8 image");
        let c = limb_contrast(&image, &cam, &bar(), (-0.1, 0.1)).expect("silhouette in view");
        assert!(c.contrast < 0.5, "{c:?}");
    }

    #[test]
    fn a_silhouette_outside_the_image_gives_no_measure() {
        let cam = camera();
        let image = LumaImage::from_image(&bar_image(&cam, 60.0, 180.0, 4.0)).expect("mono8 image");
        let mut far_left = bar();
        far_left.point.y = 5.0;
        assert!(limb_contrast(&image, &cam, &far_left, (-0.1, 0.1)).is_none());
        assert!(limb_contrast(&image, &cam, &bar(), (0.1, 0.1)).is_none());
    }

    #[test]
    fn colour_encodings_reduce_to_the_same_luma_and_bad_buffers_are_refused() {
        let rgb = Image {
            height: 1,
            width: 2,
            encoding: "rgb8".to_owned(),
            step: 6,
            data: vec![255, 0, 0, 0, 0, 255],
            ..Image::default()
        };
        let mut bgr = rgb.clone();
        bgr.encoding = "bgr8".to_owned();
        bgr.data = vec![0, 0, 255, 255, 0, 0];
        let a = LumaImage::from_image(&rgb).expect("mono8 image");
        let b = LumaImage::from_image(&bgr).expect("mono8 image");
        assert_eq!(a, b);
        assert!((a.luma[0] - 0.299 * 255.0).abs() < 1e-3);
        let mut short = rgb.clone();
        short.data.pop();
        assert!(matches!(
            LumaImage::from_image(&short),
            Err(PerceptionError::BadImage {
                image: "colour",
                ..
            })
        ));
        let mut depth = rgb;
        depth.encoding = "32FC1".to_owned();
        assert!(LumaImage::from_image(&depth).is_err());
    }

    #[test]
    fn a_kept_colour_image_goes_only_to_the_depth_image_of_its_stamp() {
        let image = bar_image(&camera(), 60.0, 180.0, 4.0);
        let mut pending = PendingColour::default();
        pending.keep(5, &image);
        assert!(pending.take_for(6).is_none());
        assert!(pending.take_for(5).is_none(), "a mismatch drops it");
        pending.keep(5, &image);
        assert_eq!(pending.take_for(5).map(|l| l.width), Some(320));
        let mut bad = image;
        bad.encoding = "32FC1".to_owned();
        pending.keep(7, &bad);
        assert_eq!(pending.take_for(7), Some(LumaImage::default()));
    }

    #[test]
    fn the_extent_is_the_trimmed_span_of_the_points() {
        let points: Vec<Point3<f64>> = (0..=100)
            .map(|i| Point3::new(f64::from(i) * 0.001, 0.0134, 0.5))
            .collect();
        let (lo, hi) = axis_extent(&bar(), &points).expect("points");
        assert!(
            (lo - 0.005).abs() < 1e-9 && (hi - 0.095).abs() < 1e-9,
            "{lo} {hi}"
        );
        assert!(axis_extent(&bar(), &points[..1]).is_none());
    }
}
