//! RGB-D ray casting of a [`Scene`]: distorted pinhole cameras, daylight shading,
//! antialiasing, colour-sensor and structured-light depth models.
//!
//! # Pipeline of [`render_rgbd`]
//! 1. **Primary rays** (bands of 16 rows in parallel, 16x16 tiles within a band): each
//!    pixel's undistorted direction comes from the camera's [`RayTable`] (the inverse
//!    plumb_bob model), is rotated into the world by `world_from_camera`, intersected with the
//!    scene and shaded ([`shading`]: surfaces, then the tile's textures in lane batches per
//!    material, then lighting); depth `z = t d_z` (optical axis) goes through the
//!    [`depth_sensor`] model, 8 pixels at a time. Per tile, the static BVH is culled once with the tile's frustum
//!    (the x/z, y/z ranges of its rays: four planes through the camera centre) and the
//!    tile's rays test only those candidates; shadow rays likewise test only the primitives
//!    overlapping the beam swept from the box of the tile's hit points towards the sun
//!    (separating axes: two perpendiculars of the sun direction, the sun direction and the
//!    world axes). Both volumes contain every ray, so hits are exactly those of a full
//!    traversal (a tile with more than [`CULL_LIMIT`] candidates traverses the BVH per ray).
//!    Candidates are sorted by a lower bound of their distance (box of ray origins to their
//!    box), so a ray stops at the first candidate beyond its best hit; each primary ray
//!    tests the previous ray's winner first (a tight bound for the box tests; exact ties
//!    keep the lowest candidate index, as the in-order scan does), and boxes' origin-only
//!    slab terms are evaluated once per tile (primary rays share the camera centre).
//! 2. **Antialiasing**: pixels whose primitive differs from a 4-neighbour are re-sampled with
//!    a rotated-grid pattern (4 sub-samples at (+-1/8, +-3/8) px, Akeley 1993) and averaged
//!    with the centre; textures are band-limited by the ray footprint (analytic AA). Depth
//!    stays the centre sample's, and a pixel whose sub-samples straddle a depth step is
//!    dropped (flying pixel). Sub-sample rays are culled per tile too, with the frustum of
//!    the tile's pixel centres grown by one pixel (a sub-sample's direction interpolates
//!    between neighbouring centres, so it lies inside).
//! 3. **Exposure**: a luminance histogram drives auto-exposure, then per-pixel noise,
//!    gain and sRGB quantisation ([`rgb_sensor`]).
//!
//! # Determinism
//! Every pixel is a pure function of (scene, pose, camera, light, parameters, seed, pixel
//! index): noise comes from counter-based hashes keyed by the pixel index, and the only
//! reduction (the histogram) sums integers. Tiles and their culled candidate lists are a
//! fixed function of the image geometry; tracing hints (the previous sample's primitive,
//! tested first to tighten the bound) and the texture-noise memo
//! ([`crate::scene::textures::NoiseCache`], keyed by all its inputs) live per band and never
//! change a result. The output bytes are therefore identical for any rayon thread count
//! (tested for the renderer with 1, 2 and 3 threads). The lane kernels (steel textures,
//! colour and depth sensors) run at the vector level [`simd::max_level`] gives on the
//! calling thread, in element-wise IEEE arithmetic, so every level and batch width gives
//! the same bytes too (tested for a whole capture at each level).
//!
//! # Conventions
//! Camera frame = OpenCV optical axes (x right, y down, z forward); `world_from_camera` maps
//! camera coordinates to `map`. Depth is metres along z (NaN = no data).

pub mod camera_model;
pub mod depth_sensor;
pub mod light;
pub mod photo;
pub mod rgb_sensor;
pub mod shading;

use nalgebra::{Isometry3, Matrix3, Point3, Vector3};
use rayon::prelude::*;

pub use camera_model::{
    CameraError, CameraModel, RAY_TILE, RayTable, RayTile, panoramic_camera, unit_direction,
    world_from_camera_looking_at, wrist_camera,
};
pub use depth_sensor::{DepthSensorParams, depth_to_mm};
pub use light::{Lamp, LightConditions};
pub use rgb_sensor::{Exposure, RgbSensorParams};

use crate::scene::textures::NoiseCache;
use crate::scene::{Candidates, Hit, Ray, Scene, Slab};
use camera_model::grow;
use depth_sensor::{DepthLanes, DepthSample};
use rgb_sensor::{HISTOGRAM_BINS, histogram_bin};
use shading::{
    AlbedoBatch, LightSetup, SHADOW_BIAS_M, Shaded, SurfaceHit, TraceHints, shade_sky,
    shade_without_surface, trace_culled,
};

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
    intrinsics: &CameraModel,
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
/// Edge of the square pixel tiles whose rays share culled candidate lists (px); a band of
/// `TILE` rows is one parallel work item.
const TILE: usize = RAY_TILE;
/// Most candidate primitives a tile keeps before falling back to BVH traversal per ray.
pub const CULL_LIMIT: usize = 48;
/// Widening of tile frustums (normalised image coordinates, ~1e-4 px).
const FRUSTUM_MARGIN: f64 = 1e-7;
/// Widening of shadow beams (m), beyond the shadow-ray bias.
const BEAM_MARGIN_M: f64 = 1e-6;
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
    /// The world ray through undistorted image coordinates `xy` and the `d_z` of its unit
    /// camera-frame direction ([`unit_direction`]).
    #[inline(always)]
    fn ray(&self, xy: [f64; 2]) -> (Ray, f64) {
        self.ray_along(unit_direction(xy))
    }

    /// The world ray along the unit camera-frame direction `d` (rotated by `r` in plain
    /// arithmetic in nalgebra's order, matrix rows `(m0 d0 + m1 d1) + m2 d2`, so a
    /// per-pixel loop keeps the matrix in registers) and its `d_z`.
    #[inline(always)]
    fn ray_along(&self, d: [f64; 3]) -> (Ray, f64) {
        let r = &self.r;
        let row = |m0: f64, m1: f64, m2: f64| (m0 * d[0] + m1 * d[1]) + m2 * d[2];
        (
            Ray {
                origin: self.origin,
                dir: Vector3::new(
                    row(r.m11, r.m12, r.m13),
                    row(r.m21, r.m22, r.m23),
                    row(r.m31, r.m32, r.m33),
                ),
            },
            d[2],
        )
    }
}

/// Undistorted direction `(x, y)` at the sub-pixel position `(col, row) + off` (|off| < 1/2),
/// interpolated bilinearly between the ray table's pixel centres (the inverse distortion is
/// smooth: the error is ~1e-10 of the ray angle at 3/8 px, far below a pixel), instead of
/// a Newton undistortion per sub-sample. `None` for a 1-pixel-wide or -high image.
fn interpolate_rays(
    table: &[[f64; 2]],
    w: usize,
    h: usize,
    col: usize,
    row: usize,
    off: [f64; 2],
) -> Option<[f64; 2]> {
    if w < 2 || h < 2 {
        return None;
    }
    // Cell whose corners bracket the sample (extrapolating at the image border).
    let c0 = if off[0] < 0.0 {
        col.max(1) - 1
    } else {
        col.min(w - 2)
    };
    let r0 = if off[1] < 0.0 {
        row.max(1) - 1
    } else {
        row.min(h - 2)
    };
    let fx = col as f64 + off[0] - c0 as f64;
    let fy = row as f64 + off[1] - r0 as f64;
    let at = |c: usize, r: usize| table.get(r * w + c).copied();
    let (p00, p10) = (at(c0, r0)?, at(c0 + 1, r0)?);
    let (p01, p11) = (at(c0, r0 + 1)?, at(c0 + 1, r0 + 1)?);
    let lerp =
        |a: [f64; 2], b: [f64; 2], t: f64| [a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t];
    Some(lerp(lerp(p00, p10, fx), lerp(p01, p11, fx), fy))
}

/// Whether pixel `(col, row)` of a `w` x `h` key image sees another primitive than one of
/// its 4-neighbours.
#[inline(always)]
fn primitive_edge(keys: &[u32], w: usize, h: usize, col: usize, row: usize) -> bool {
    let p = row * w + col;
    let Some(&kc) = keys.get(p) else {
        return false;
    };
    let differs = |q: usize| keys.get(q).is_some_and(|&k| k != kc);
    (col > 0 && differs(p - 1))
        || (col + 1 < w && differs(p + 1))
        || (row > 0 && differs(p - w))
        || (row + 1 < h && differs(p + w))
}

/// The band of tile rows from `row0` of a `width`-pixel image.
struct Band {
    row0: usize,
    width: usize,
}

/// One primary ray of a tile: index in the band, pixel column and row, ray, `d_z` of its
/// unit camera-frame direction (depth = `t d_z`) and closest hit.
#[derive(Clone, Copy)]
struct TileRay {
    j: usize,
    col: u32,
    row: u32,
    ray: Ray,
    dz: f64,
    hit: Option<Hit>,
}

/// Per-thread buffers of [`render_tile`].
#[derive(Default)]
struct TileScratch {
    rays: Vec<TileRay>,
    primary: Candidates,
    shadow: Candidates,
    noise: NoiseCache,
    /// Per ray: the surface it hit, if any.
    hits: Vec<Option<SurfaceHit>>,
    albedo: Vec<[f32; 3]>,
    batch: AlbedoBatch,
}

/// Half-spaces `n_cam . p_cam >= 0` through the camera centre bounding the rays whose
/// undistorted coordinates lie in `[x0, x1] x [y0, y1]` (widened by [`FRUSTUM_MARGIN`]),
/// in the world frame, plus the half-space in front of the camera.
fn frustum(cam: &Cam, x: [f64; 2], y: [f64; 2]) -> [Slab; 5] {
    let (x0, x1) = (x[0] - FRUSTUM_MARGIN, x[1] + FRUSTUM_MARGIN);
    let (y0, y1) = (y[0] - FRUSTUM_MARGIN, y[1] + FRUSTUM_MARGIN);
    let o = cam.origin;
    let planes = [
        Vector3::new(1.0, 0.0, -x0),
        Vector3::new(-1.0, 0.0, x1),
        Vector3::new(0.0, 1.0, -y0),
        Vector3::new(0.0, -1.0, y1),
        Vector3::new(0.0, 0.0, 1.0),
    ];
    planes.map(|n| {
        let nw = cam.r * n;
        Slab {
            normal: [nw.x, nw.y, nw.z],
            lo: nw.dot(&o.coords),
            hi: f64::INFINITY,
        }
    })
}

/// The beam swept from the box `[lo, hi]` of shadow-ray origins along the unit sun
/// direction `s` (separating axes: two perpendiculars of `s`, `s` itself, the world axes),
/// widened by [`BEAM_MARGIN_M`].
fn shadow_beam(lo: [f64; 3], hi: [f64; 3], s: &Vector3<f64>) -> [Slab; 6] {
    let e1 = crate::scene::primitives::perpendicular(s);
    let e2 = s.cross(&e1);
    let c = Vector3::new(
        0.5 * (lo[0] + hi[0]),
        0.5 * (lo[1] + hi[1]),
        0.5 * (lo[2] + hi[2]),
    );
    let h = Vector3::new(
        0.5 * (hi[0] - lo[0]),
        0.5 * (hi[1] - lo[1]),
        0.5 * (hi[2] - lo[2]),
    );
    let span = |a: &Vector3<f64>| {
        let d = a.dot(&c);
        let r = a.abs().dot(&h) + BEAM_MARGIN_M;
        (d - r, d + r)
    };
    let (e1_lo, e1_hi) = span(&e1);
    let (e2_lo, e2_hi) = span(&e2);
    let (s_lo, _) = span(s);
    let axis = |k: usize| {
        let mut n = [0.0; 3];
        n[k] = 1.0;
        if s[k] >= 0.0 {
            Slab {
                normal: n,
                lo: lo[k],
                hi: f64::INFINITY,
            }
        } else {
            Slab {
                normal: n,
                lo: f64::NEG_INFINITY,
                hi: hi[k],
            }
        }
    };
    [
        Slab {
            normal: [e1.x, e1.y, e1.z],
            lo: e1_lo,
            hi: e1_hi,
        },
        Slab {
            normal: [e2.x, e2.y, e2.z],
            lo: e2_lo,
            hi: e2_hi,
        },
        Slab {
            normal: [s.x, s.y, s.z],
            lo: s_lo,
            hi: f64::INFINITY,
        },
        axis(0),
        axis(1),
        axis(2),
    ]
}

/// Box of the hit points of `rays` (empty, `lo > hi`, if none hit), padded by the shadow
/// bias and [`BEAM_MARGIN_M`] so it contains every shadow-ray origin.
fn shadow_origins(rays: &[TileRay]) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for r in rays {
        if let Some(h) = &r.hit {
            let p = r.ray.at(h.t_m);
            for k in 0..3 {
                [lo[k], hi[k]] = grow([lo[k], hi[k]], p[k]);
            }
        }
    }
    let pad = SHADOW_BIAS_M + BEAM_MARGIN_M;
    (lo.map(|x| x - pad), hi.map(|x| x + pad))
}

/// The depth sensor of one capture: its parameters, grazing threshold and seed.
struct DepthMeasure<'a> {
    params: &'a DepthSensorParams,
    max_incidence_cos: f64,
    seed: u64,
    level: simd::Level,
}

/// Pixels per depth measurement batch (one AVX-512 vector of f64).
const DEPTH_LANES: usize = 8;

/// Depth samples of a band waiting to be measured [`DEPTH_LANES`] at a time
/// ([`DepthSensorParams::measure_lanes`] under [`simd::dispatch_at`]); each pixel's value is
/// the one [`DepthSensorParams::measure_with`] gives it.
#[derive(Default)]
struct DepthBatch {
    lanes: DepthLanes<DEPTH_LANES>,
    /// Index in the band of each waiting pixel.
    slots: [usize; DEPTH_LANES],
    len: usize,
}

impl DepthBatch {
    fn push(&mut self, j: usize, s: &DepthSample, pixel: u64, col: u32, row: u32) {
        if let Some(slot) = self.slots.get_mut(self.len) {
            *slot = j;
            self.lanes.set(self.len, s, pixel, col, row);
            self.len += 1;
        }
    }

    fn is_full(&self) -> bool {
        self.len == DEPTH_LANES
    }

    /// Measures the waiting pixels into `dep` (indexed by band index; spare lanes hold
    /// earlier pixels, whose results are dropped).
    fn flush(&mut self, sensor: &DepthMeasure<'_>, dep: &mut [f32]) {
        if self.len == 0 {
            return;
        }
        let z = simd::dispatch_at(
            sensor.level,
            MeasureDepth {
                sensor,
                lanes: &self.lanes,
            },
        );
        for (&j, &z) in self.slots.iter().zip(&z).take(self.len) {
            if let Some(d) = dep.get_mut(j) {
                *d = z;
            }
        }
        self.len = 0;
    }
}

/// [`DepthSensorParams::measure_lanes`] as a [`simd::Kernel`].
struct MeasureDepth<'a, 'b> {
    sensor: &'a DepthMeasure<'b>,
    lanes: &'a DepthLanes<DEPTH_LANES>,
}

impl simd::Kernel for MeasureDepth<'_, '_> {
    type Output = [f32; DEPTH_LANES];
    #[inline(always)]
    fn run(self) -> Self::Output {
        let s = self.sensor;
        s.params
            .measure_lanes(s.max_incidence_cos, self.lanes, s.seed)
    }
}

/// Traces and shades the centre samples of `tile` in `band`, calling
/// `out(index in band, column, row, shaded)` per pixel (with the sample's depth along the
/// optical axis in `shaded.depth`). Primary rays are tested only against the
/// static primitives inside the tile's frustum, shadow rays only against those inside the
/// beam swept by the tile's hit points towards the sun (both exact: the volumes contain
/// every ray).
#[allow(clippy::too_many_arguments)]
fn render_tile(
    scene: &Scene,
    cam: &Cam,
    setup: &LightSetup,
    tile: &RayTile<'_>,
    band: &Band,
    sc: &mut TileScratch,
    mut out: impl FnMut(usize, u32, u32, &Shaded),
) {
    let w = band.width;
    let o = [cam.origin.x, cam.origin.y, cam.origin.z];
    sc.rays.clear();
    for (r, row_dirs) in tile.dirs.chunks(tile.cols.len().max(1)).enumerate() {
        for (c, &d) in tile.cols.clone().zip(row_dirs) {
            let (ray, dz) = cam.ray_along(d);
            sc.rays.push(TileRay {
                j: r * w + c,
                col: c as u32,
                row: (band.row0 + r) as u32,
                ray,
                dz,
                hit: None,
            });
        }
    }
    let frustum = frustum(cam, tile.x_range, tile.y_range);
    scene.cull(&frustum, o, o, CULL_LIMIT, &mut sc.primary);
    // The previous ray's winner is tested first (neighbours mostly hit the same primitive).
    let mut hint = None;
    for r in &mut sc.rays {
        r.hit = scene.intersect_culled_hinted(&r.ray, 0.0, f64::INFINITY, &sc.primary, &mut hint);
    }
    if setup.casts_shadows() {
        let (lo, hi) = shadow_origins(&sc.rays);
        if lo[0] <= hi[0] {
            let sun = setup.sun_direction();
            let beam = shadow_beam(lo, hi, &sun);
            scene.cull(&beam, lo, hi, CULL_LIMIT, &mut sc.shadow);
            sc.shadow.share_direction(&sun);
        }
        // Without a hit in the tile no shadow ray is cast (the candidates go unused).
    }
    // Surfaces, then the textures of the whole tile in batches, then lighting.
    sc.hits.clear();
    sc.hits.extend(sc.rays.iter().map(|r| {
        r.hit
            .as_ref()
            .and_then(|h| SurfaceHit::new(scene, &r.ray, h, cam.footprint_per_m))
    }));
    sc.batch.run(scene, &sc.hits, &mut sc.noise, &mut sc.albedo);
    let shadow = &sc.shadow;
    for ((r, surface), &albedo) in sc.rays.iter().zip(&sc.hits).zip(&sc.albedo) {
        let mut s = match (surface, &r.hit) {
            (Some(h), _) => h.shade(setup, &r.ray, albedo, scene, |sr| {
                scene.occluded_culled(sr, 0.0, f64::INFINITY, shadow)
            }),
            (None, None) => shade_sky(setup, &r.ray),
            (None, Some(h)) => shade_without_surface(h),
        };
        // Depth along the optical axis, set in place: the sensor then reads the sample where
        // shading wrote it (copying it out would reload fields just stored).
        let z_m = s.t_m * r.dz;
        if let Some(ds) = s.depth.as_mut() {
            ds.z_m = z_m;
        }
        out(r.j, r.col, r.row, &s);
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
    let setup = LightSetup::new(light, sensor.shadows).with_camera(world_from_camera);
    let table = rays.normalized();
    let mut radiance = vec![[0.0_f32; 3]; n];
    let mut keys = vec![0_u32; n];
    let mut depth = vec![f32::NAN; n];
    let chunk = TILE * w;

    // The vector level of the lane kernels, taken on the calling thread (a cap set there
    // with `simd::with_max_level` then holds on the workers too).
    let level = simd::max_level();
    let depth_sensor = DepthMeasure {
        params: &sensor.depth,
        max_incidence_cos: sensor.depth.max_incidence_cos(),
        seed,
        level,
    };
    // Pass 1: centre samples, tile by tile (bands of TILE rows in parallel).
    radiance
        .par_chunks_mut(chunk)
        .zip(keys.par_chunks_mut(chunk))
        .zip(depth.par_chunks_mut(chunk))
        .enumerate()
        .for_each(|(ci, ((rad, key), dep))| {
            let mut scratch = TileScratch {
                batch: AlbedoBatch::new(level),
                ..TileScratch::default()
            };
            let mut depth_batch = DepthBatch::default();
            let band = Band {
                row0: ci * TILE,
                width: w,
            };
            for col0 in (0..w).step_by(TILE) {
                let Some(tile) = rays.tile(col0, band.row0) else {
                    continue;
                };
                render_tile(
                    scene,
                    &cam,
                    &setup,
                    &tile,
                    &band,
                    &mut scratch,
                    |j, col, row, s: &Shaded| {
                        let p = band.row0 * w + j;
                        if let Some(r) = rad.get_mut(j) {
                            *r = s.radiance;
                        }
                        if let Some(kk) = key.get_mut(j) {
                            *kk = s.key;
                        }
                        if let Some(sample) = &s.depth {
                            depth_batch.push(j, sample, p as u64, col, row);
                            if depth_batch.is_full() {
                                depth_batch.flush(&depth_sensor, dep);
                            }
                        }
                    },
                );
            }
            depth_batch.flush(&depth_sensor, dep);
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
                let row0 = ci * TILE;
                let rows = rad.len() / w.max(1);
                let mut hints = TraceHints::default();
                let mut cands = Candidates::default();
                let mut edges: Vec<(usize, usize)> = Vec::with_capacity(TILE * TILE);
                let mut count = 0;
                for col0 in (0..w).step_by(TILE) {
                    let col1 = (col0 + TILE).min(w);
                    edges.clear();
                    for row in row0..row0 + rows {
                        for col in col0..col1 {
                            if primitive_edge(keys, w, h, col, row) {
                                edges.push((col, row));
                            }
                        }
                    }
                    if edges.is_empty() {
                        continue;
                    }
                    // Sub-samples interpolate between neighbouring pixel centres, so the
                    // tile's pixels grown by one on each side bound all their rays.
                    let (mut xr, mut yr) = (
                        [f64::INFINITY, f64::NEG_INFINITY],
                        [f64::INFINITY, f64::NEG_INFINITY],
                    );
                    for row in row0.saturating_sub(1)..(row0 + rows + 1).min(h) {
                        for xy in table
                            .get(row * w + col0.saturating_sub(1)..row * w + (col1 + 1).min(w))
                            .unwrap_or(&[])
                        {
                            xr = grow(xr, xy[0]);
                            yr = grow(yr, xy[1]);
                        }
                    }
                    let o = [cam.origin.x, cam.origin.y, cam.origin.z];
                    scene.cull(&frustum(&cam, xr, yr), o, o, CULL_LIMIT, &mut cands);
                    for &(col, row) in &edges {
                        let (Some(r), Some(d)) = (
                            rad.get_mut((row - row0) * w + col),
                            dep.get_mut((row - row0) * w + col),
                        ) else {
                            continue;
                        };
                        count += 1;
                        let p = row * w + col;
                        let guess = table.get(p).copied().unwrap_or([0.0; 2]);
                        let mut acc = *r;
                        let mut z_min = f64::INFINITY;
                        let mut z_max = 0.0_f64;
                        for off in RGSS {
                            let xy = interpolate_rays(table, w, h, col, row, off).unwrap_or(guess);
                            let (ray, dz) = cam.ray(xy);
                            let s: Shaded = trace_culled(
                                scene,
                                &setup,
                                &ray,
                                cam.footprint_per_m,
                                &mut hints,
                                &cands,
                            );
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
    let rgb_seed = rng::splitmix64(seed ^ RGB_SALT);
    let mut rgb = vec![0u8; 3 * n];
    rgb.par_chunks_mut(3 * chunk)
        .zip(radiance.par_chunks(chunk))
        .enumerate()
        .for_each(|(ci, (out, rad))| {
            let p0 = (ci * chunk) as u64;
            sensor
                .rgb
                .expose_run(level, rad, wb, &exposure, rgb_seed, p0, out);
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
    intrinsics: &CameraModel,
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
    let xy = intrinsics.undistort_pixel(&nalgebra::Point2::new(u, v))?;
    let xy = [xy.x, xy.y];
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

#[cfg(test)]
mod tests {
    use super::shading::trace;
    use super::*;
    use crate::scene::SubstationBuilder;

    /// The antialiasing sub-sample directions interpolated from the ray table agree with the
    /// exact undistortion to far below a pixel, including at the image border.
    #[test]
    fn interpolated_subsample_rays_match_undistortion() {
        let k = wrist_camera();
        let Ok(rays) = RayTable::new(&k) else {
            panic!("ray table");
        };
        let (w, h) = (k.width as usize, k.height as usize);
        let mut worst = 0.0_f64;
        for (col, row) in [
            (0, 0),
            (w - 1, h - 1),
            (0, h - 1),
            (640, 512),
            (1200, 77),
            (3, 1000),
        ] {
            for off in RGSS {
                let Some(xy) = interpolate_rays(rays.normalized(), w, h, col, row, off) else {
                    panic!("interpolation");
                };
                let px = nalgebra::Point2::new(col as f64 + off[0], row as f64 + off[1]);
                let Ok(exact) = k.undistort_pixel(&px) else {
                    panic!("undistort");
                };
                worst = worst.max((xy[0] - exact.x).abs() * k.fx);
                worst = worst.max((xy[1] - exact.y).abs() * k.fy);
            }
        }
        assert!(worst < 1e-3, "worst error {worst} px");
        assert!(interpolate_rays(rays.normalized(), 1, h, 0, 0, RGSS[0]).is_none());
    }

    /// The whole capture (steel textures, colour and depth sensors) has the same bytes at
    /// every vector level: the calibration cabinet at noon, with sun wash-out and dark
    /// surfaces in view.
    #[test]
    fn captures_are_identical_at_every_simd_level() {
        let Ok((scene, layout)) = SubstationBuilder::new(1).build() else {
            panic!("substation builds");
        };
        let Ok(k) = wrist_camera().scaled(0.25) else {
            panic!("scaled camera");
        };
        let Some(pose) = layout.cabinet_wrist_view() else {
            panic!("pose");
        };
        let light = LightConditions::from_hour(12.0);
        let frames: Vec<(Vec<u8>, Vec<u32>)> = [
            simd::Level::Baseline,
            simd::Level::Avx2,
            simd::Level::Avx512,
        ]
        .into_iter()
        .map(|level| {
            let f = simd::with_max_level(level, || {
                render_rgbd(&scene, &pose, &k, &light, &SensorParams::wrist(), 5)
            });
            let Ok(f) = f else { panic!("render") };
            (f.rgb, f.depth_m.iter().map(|z| z.to_bits()).collect())
        })
        .collect();
        let holes = frames[0]
            .1
            .iter()
            .filter(|&&z| f32::from_bits(z).is_nan())
            .count();
        assert!(holes > 0 && holes < frames[0].1.len() / 2, "{holes} holes");
        for f in &frames[1..] {
            assert!(f.0 == frames[0].0, "colour bytes differ between levels");
            assert!(f.1 == frames[0].1, "depth bits differ between levels");
        }
    }

    /// Tile culling must not change any pixel: compare every centre sample of the tiled
    /// path with the per-ray full-hierarchy [`trace`], bit for bit, for views with shadows
    /// cast by other structures (low sun) and with sky and far ground in the image.
    #[test]
    fn tile_culling_matches_full_traversal() {
        let Ok((scene, layout)) = SubstationBuilder::new(3).build() else {
            panic!("substation builds");
        };
        let Ok(k) = wrist_camera().scaled(0.125) else {
            panic!("scaled camera");
        };
        let Ok(rays) = RayTable::new(&k) else {
            panic!("ray table");
        };
        let target = layout.calibration_target_center;
        let spot = layout.world_from_robot_spot.translation.vector;
        // Views of the calibration cabinet, the yard, and each movable object (wire, rod)
        // from 0.6 m and from 3 m.
        let mut views = vec![
            (
                target + layout.calibration_target_normal * 0.45 + Vector3::new(0.0, 0.08, 0.12),
                target,
            ),
            (Point3::new(spot.x, spot.y, 1.4), Point3::new(0.0, 0.0, 3.0)),
            (Point3::new(spot.x + 2.0, spot.y - 3.0, 0.6), target),
        ];
        for obj in scene.objects() {
            let c = Point3::from(obj.world_from_object().translation.vector);
            for d in [0.6, 3.0] {
                views.push((c + Vector3::new(d * 0.8, -d * 0.6, 0.2), c));
            }
        }
        assert!(views.len() > 3, "the substation has movable objects");
        let (w, h) = (k.width as usize, k.height as usize);
        let table = rays.normalized();
        let mut compared = 0;
        let views_count = views.len();
        for (eye, look) in views {
            let Some(pose) = world_from_camera_looking_at(&eye, &look, &Vector3::z()) else {
                panic!("pose");
            };
            let cam = Cam {
                r: pose.rotation.to_rotation_matrix().into_inner(),
                origin: Point3::from(pose.translation.vector),
                footprint_per_m: 1.0 / k.fx.min(k.fy),
            };
            for hour in [7.5, 12.0, 16.5] {
                let setup = LightSetup::new(&LightConditions::from_hour(hour), true);
                let mut scratch = TileScratch::default();
                for row0 in (0..h).step_by(TILE) {
                    let band = Band { row0, width: w };
                    for col0 in (0..w).step_by(TILE) {
                        let Some(tile) = rays.tile(col0, row0) else {
                            panic!("tile {col0} {row0}");
                        };
                        render_tile(
                            &scene,
                            &cam,
                            &setup,
                            &tile,
                            &band,
                            &mut scratch,
                            |j, _, _, s| {
                                let p = row0 * w + j;
                                let (ray, _) = cam.ray(table[p]);
                                let mut hints = TraceHints::default();
                                let r =
                                    trace(&scene, &setup, &ray, cam.footprint_per_m, &mut hints);
                                assert_eq!(s.radiance, r.radiance, "pixel {p} hour {hour}");
                                assert_eq!(s.key, r.key);
                                assert_eq!(s.t_m.to_bits(), r.t_m.to_bits());
                                compared += 1;
                            },
                        );
                    }
                }
            }
        }
        assert_eq!(compared, views_count * 3 * w * h);
    }
}
