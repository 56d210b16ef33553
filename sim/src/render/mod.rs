//! RGB-D ray casting of a [`Scene`]: distorted pinhole cameras, daylight shading,
//! antialiasing, colour-sensor and structured-light depth models.
//!
//! # Pipeline of [`render_rgbd`]
//! 1. **Primary rays** (rows in parallel): each pixel's undistorted direction comes from the
//!    camera's [`RayTable`] (the inverse plumb_bob model), is rotated into the world by
//!    `world_from_camera`, intersected with the scene BVHs and shaded ([`shading`]); depth
//!    `z = t d_z` (optical axis) goes through the [`depth_sensor`] model.
//! 2. **Antialiasing**: pixels whose primitive differs from a 4-neighbour are re-sampled with
//!    a rotated-grid pattern (4 sub-samples at (+-1/8, +-3/8) px, Akeley 1993) and averaged
//!    with the centre; textures are band-limited by the ray footprint (analytic AA). Depth
//!    stays the centre sample's, and a pixel whose sub-samples straddle a depth step is
//!    dropped (flying pixel).
//! 3. **Exposure**: a luminance histogram drives auto-exposure, then per-pixel noise,
//!    gain and sRGB quantisation ([`rgb_sensor`]).
//!
//! # Determinism
//! Every pixel is a pure function of (scene, pose, camera, light, parameters, seed, pixel
//! index): noise comes from counter-based hashes keyed by the pixel index, and the only
//! reduction (the histogram) sums integers. Tracing hints (the previous pixel's primitive,
//! tested first to tighten the BVH bound) are reset at the start of each fixed block of
//! rows and never change which hit is closest. The output bytes are therefore identical for
//! any rayon thread count.
//!
//! # Conventions
//! Camera frame = OpenCV optical axes (x right, y down, z forward); `world_from_camera` maps
//! camera coordinates to `map`. Depth is metres along z (NaN = no data).

pub mod camera_model;
pub mod depth_sensor;
pub mod light;
pub mod rgb_sensor;
pub mod shading;

use nalgebra::{Isometry3, Matrix3, Point3, Vector3};
use rayon::prelude::*;

pub use camera_model::{CameraError, CameraIntrinsics, RayTable, world_from_camera_looking_at};
pub use depth_sensor::{DepthSensorParams, depth_to_mm};
pub use light::LightConditions;
pub use rgb_sensor::{Exposure, RgbSensorParams};

use crate::scene::{Ray, Scene};
use depth_sensor::DepthSample;
use rgb_sensor::{HISTOGRAM_BINS, histogram_bin, srgb_lut};
use shading::{LightSetup, Shaded, TraceHints, trace};

/// Errors of rendering.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum RenderError {
    /// Invalid camera.
    #[error(transparent)]
    Camera(#[from] CameraError),
    /// A pixel outside the image was requested.
    #[error("pixel ({u}, {v}) is outside the {width}x{height} image")]
    PixelOutside {
        /// Column.
        u: f64,
        /// Row.
        v: f64,
        /// Image width.
        width: u32,
        /// Image height.
        height: u32,
    },
}

/// Everything about the sensors of one camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorParams {
    /// Colour sensor.
    pub rgb: RgbSensorParams,
    /// Depth sensor.
    pub depth: DepthSensorParams,
    /// Supersample geometric edges. Default true.
    pub antialias: bool,
    /// Cast shadow rays towards the sun. Default true.
    pub shadows: bool,
}

impl Default for SensorParams {
    fn default() -> Self {
        Self {
            rgb: RgbSensorParams::default(),
            depth: DepthSensorParams::default(),
            antialias: true,
            shadows: true,
        }
    }
}

impl SensorParams {
    /// Wrist RGB-D camera defaults.
    #[must_use]
    pub fn wrist() -> Self {
        Self::default()
    }

    /// Panoramic camera: RGB-only in practice (depth range 0 disables depth), a more
    /// sensitive sensor with longer exposures (it streams at <= 1 Hz).
    #[must_use]
    pub fn panoramic() -> Self {
        let mut s = Self::default();
        s.rgb.max_exposure_s = 0.25;
        s.rgb.sensitivity_e_per_nit_s = 120.0;
        s.depth.max_range_m = 0.0;
        s
    }

    /// Everything noise-free and hole-free (ground truth rendering, tests).
    #[must_use]
    pub fn ideal() -> Self {
        let mut s = Self::default();
        s.rgb.noise_enabled = false;
        s.depth.noise_enabled = false;
        s.depth.holes_enabled = false;
        s.depth.max_range_m = 1e6;
        s.depth.min_range_m = 0.0;
        s
    }
}

/// One RGB-D capture.
#[derive(Clone, Debug, PartialEq)]
pub struct RgbdFrame {
    /// Width (px).
    pub width: u32,
    /// Height (px).
    pub height: u32,
    /// sRGB colour, 8 bits per channel, RGB order, row-major (`3 * width * height` bytes).
    pub rgb: Vec<u8>,
    /// Depth along the optical axis (m), NaN = no data, registered to `rgb`.
    pub depth_m: Vec<f32>,
    /// Exposure chosen by auto-exposure.
    pub exposure: Exposure,
    /// Number of supersampled (edge) pixels.
    pub antialiased_pixels: usize,
}

impl RgbdFrame {
    /// Depth as 16UC1 millimetres (0 = no data).
    #[must_use]
    pub fn depth_mm(&self) -> Vec<u16> {
        depth_to_mm(&self.depth_m)
    }

    /// RGB of pixel `(u, v)`.
    #[must_use]
    pub fn rgb_at(&self, u: u32, v: u32) -> Option<[u8; 3]> {
        let i = 3 * (v as usize * self.width as usize + u as usize);
        if u >= self.width {
            return None;
        }
        self.rgb
            .get(i..i + 3)
            .and_then(|s| <[u8; 3]>::try_from(s).ok())
    }

    /// Depth of pixel `(u, v)` (m, NaN = no data).
    #[must_use]
    pub fn depth_at(&self, u: u32, v: u32) -> Option<f32> {
        if u >= self.width {
            return None;
        }
        self.depth_m
            .get(v as usize * self.width as usize + u as usize)
            .copied()
    }
}

/// Renders one capture; builds the camera's [`RayTable`] first (tens of milliseconds at
/// 1280x1024: keep a table and call [`render_rgbd_with_rays`] for repeated captures).
///
/// # Errors
/// [`RenderError::Camera`] for invalid intrinsics.
pub fn render_rgbd(
    scene: &Scene,
    world_from_camera: &Isometry3<f64>,
    intrinsics: &CameraIntrinsics,
    light: &LightConditions,
    sensor: &SensorParams,
    seed: u64,
) -> Result<RgbdFrame, RenderError> {
    let rays = RayTable::new(intrinsics)?;
    Ok(render_rgbd_with_rays(
        scene,
        world_from_camera,
        &rays,
        light,
        sensor,
        seed,
    ))
}

/// Salt of the colour noise stream.
const RGB_SALT: u64 = 0x5eed_c0de_0000_0001;
/// Rows per parallel work item.
const ROWS_PER_CHUNK: usize = 4;
/// Rotated-grid sub-sample offsets (px).
const RGSS: [[f64; 2]; 4] = [
    [-0.375, -0.125],
    [0.125, -0.375],
    [0.375, 0.125],
    [-0.125, 0.375],
];

struct Cam {
    r: Matrix3<f64>,
    origin: Point3<f64>,
    footprint_per_m: f64,
}

impl Cam {
    #[inline]
    fn ray(&self, xy: [f64; 2]) -> (Ray, f64) {
        let d = Vector3::new(xy[0], xy[1], 1.0);
        let inv = 1.0 / d.norm();
        let dc = d * inv;
        (
            Ray {
                origin: self.origin,
                dir: self.r * dc,
            },
            dc.z,
        )
    }
}

/// Renders one capture with a precomputed ray table (pure function; see the module docs).
#[must_use]
pub fn render_rgbd_with_rays(
    scene: &Scene,
    world_from_camera: &Isometry3<f64>,
    rays: &RayTable,
    light: &LightConditions,
    sensor: &SensorParams,
    seed: u64,
) -> RgbdFrame {
    let k = *rays.intrinsics();
    let w = k.width as usize;
    let h = k.height as usize;
    let n = w * h;
    let cam = Cam {
        r: world_from_camera.rotation.to_rotation_matrix().into_inner(),
        origin: Point3::from(world_from_camera.translation.vector),
        footprint_per_m: 1.0 / k.fx.min(k.fy),
    };
    let setup = LightSetup::new(light, sensor.shadows);
    let table = rays.normalized();
    let mut radiance = vec![[0.0_f32; 3]; n];
    let mut keys = vec![0_u32; n];
    let mut depth = vec![f32::NAN; n];
    let chunk = ROWS_PER_CHUNK * w;

    // Pass 1: centre samples.
    radiance
        .par_chunks_mut(chunk)
        .zip(keys.par_chunks_mut(chunk))
        .zip(depth.par_chunks_mut(chunk))
        .enumerate()
        .for_each(|(ci, ((rad, key), dep))| {
            let p0 = ci * chunk;
            let mut hints = TraceHints::default();
            for (j, ((r, kk), d)) in rad
                .iter_mut()
                .zip(key.iter_mut())
                .zip(dep.iter_mut())
                .enumerate()
            {
                let p = p0 + j;
                let xy = table.get(p).copied().unwrap_or([0.0; 2]);
                let (ray, dz) = cam.ray(xy);
                let s = trace(scene, &setup, &ray, cam.footprint_per_m, &mut hints);
                *r = s.radiance;
                *kk = s.key;
                if let Some(ds) = s.depth {
                    let sample = DepthSample {
                        z_m: s.t_m * dz,
                        ..ds
                    };
                    *d = sensor.depth.measure(
                        &sample,
                        seed,
                        p as u64,
                        (p % w) as u32,
                        (p / w) as u32,
                    );
                }
            }
        });

    // Pass 2: supersample pixels on primitive boundaries.
    let mut antialiased_pixels = 0;
    if sensor.antialias {
        let keys = &keys;
        antialiased_pixels = radiance
            .par_chunks_mut(chunk)
            .zip(depth.par_chunks_mut(chunk))
            .enumerate()
            .map(|(ci, (rad, dep))| {
                let p0 = ci * chunk;
                let mut hints = TraceHints::default();
                let mut count = 0;
                for (j, (r, d)) in rad.iter_mut().zip(dep.iter_mut()).enumerate() {
                    let p = p0 + j;
                    let (col, row) = (p % w, p / w);
                    let kc = keys[p];
                    let edge = (col > 0 && keys[p - 1] != kc)
                        || (col + 1 < w && keys[p + 1] != kc)
                        || (row > 0 && keys[p - w] != kc)
                        || (row + 1 < h && keys[p + w] != kc);
                    if !edge {
                        continue;
                    }
                    count += 1;
                    let guess = table.get(p).copied().unwrap_or([0.0; 2]);
                    let mut acc = *r;
                    let mut z_min = f64::INFINITY;
                    let mut z_max = 0.0_f64;
                    for off in RGSS {
                        let xy = k
                            .undistort_from(col as f64 + off[0], row as f64 + off[1], guess)
                            .unwrap_or(guess);
                        let (ray, dz) = cam.ray(xy);
                        let s: Shaded = trace(scene, &setup, &ray, cam.footprint_per_m, &mut hints);
                        for (a, x) in acc.iter_mut().zip(s.radiance) {
                            *a += x;
                        }
                        let z = s.t_m * dz;
                        z_min = z_min.min(z);
                        z_max = z_max.max(z);
                    }
                    *r = acc.map(|x| x * 0.2);
                    if sensor.depth.holes_enabled
                        && d.is_finite()
                        && (z_max - z_min) > sensor.depth.flying_pixel_ratio * z_min
                    {
                        *d = f32::NAN;
                    }
                }
                count
            })
            .sum();
    }

    // White balance and auto-exposure.
    let illum = light.illuminant_rgb();
    let s = sensor.rgb.white_balance_strength.clamp(0.0, 1.0);
    let mut wb = [0.0; 3];
    for c in 0..3 {
        wb[c] = illum[c].max(1e-6).powf(-s);
    }
    let norm = light::luminance([wb[0] * illum[0], wb[1] * illum[1], wb[2] * illum[2]]).max(1e-12);
    let wb = [
        (wb[0] / norm) as f32,
        (wb[1] / norm) as f32,
        (wb[2] / norm) as f32,
    ];
    let histogram = radiance
        .par_chunks(chunk)
        .map(|rad| {
            let mut hist = vec![0u64; HISTOGRAM_BINS];
            for r in rad {
                let y = 0.2126 * r[0] * wb[0] + 0.7152 * r[1] * wb[1] + 0.0722 * r[2] * wb[2];
                if let Some(b) = hist.get_mut(histogram_bin(y)) {
                    *b += 1;
                }
            }
            hist
        })
        .reduce(
            || vec![0u64; HISTOGRAM_BINS],
            |mut a, b| {
                for (x, y) in a.iter_mut().zip(b) {
                    *x += y;
                }
                a
            },
        );
    let exposure = sensor.rgb.auto_exposure(&histogram);

    // Pass 3: sensor noise and quantisation.
    let lut = srgb_lut();
    let rgb_seed = crate::scene::noise::splitmix64(seed ^ RGB_SALT);
    let mut rgb = vec![0u8; 3 * n];
    rgb.par_chunks_mut(3 * chunk)
        .zip(radiance.par_chunks(chunk))
        .enumerate()
        .for_each(|(ci, (out, rad))| {
            let p0 = ci * chunk;
            for (j, (o, r)) in out.chunks_exact_mut(3).zip(rad).enumerate() {
                let l = [r[0] * wb[0], r[1] * wb[1], r[2] * wb[2]];
                sensor
                    .rgb
                    .expose_pixel(l, &exposure, rgb_seed, (p0 + j) as u64, &lut, o);
            }
        });

    RgbdFrame {
        width: k.width,
        height: k.height,
        rgb,
        depth_m: depth,
        exposure,
        antialiased_pixels,
    }
}

/// Exact (noise-free, hole-free) depth along the optical axis seen by pixel `(u, v)`, or
/// `None` when the ray escapes to the sky.
///
/// # Errors
/// [`RenderError::PixelOutside`] outside the image; [`RenderError::Camera`] if the pixel
/// cannot be undistorted.
pub fn raycast_depth(
    scene: &Scene,
    world_from_camera: &Isometry3<f64>,
    intrinsics: &CameraIntrinsics,
    u: f64,
    v: f64,
) -> Result<Option<f64>, RenderError> {
    let (wf, hf) = (f64::from(intrinsics.width), f64::from(intrinsics.height));
    if !(u >= -0.5 && u < wf - 0.5 && v >= -0.5 && v < hf - 0.5) {
        return Err(RenderError::PixelOutside {
            u,
            v,
            width: intrinsics.width,
            height: intrinsics.height,
        });
    }
    let xy = intrinsics.undistort(u, v)?;
    let cam = Cam {
        r: world_from_camera.rotation.to_rotation_matrix().into_inner(),
        origin: Point3::from(world_from_camera.translation.vector),
        footprint_per_m: 0.0,
    };
    let (ray, dz) = cam.ray(xy);
    Ok(scene
        .intersect(&ray, 0.0, f64::INFINITY)
        .map(|hit| hit.t_m * dz))
}
