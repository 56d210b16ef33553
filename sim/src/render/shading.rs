//! Radiance of a surface point under sun and sky.
//!
//! `L = rho / pi (E_sun max(0, n.l) V c_sun + E_sky (1 + n_z) / 2 c_sky(n) + E_gnd (1 - n_z) / 2 c_gnd)
//!      + k_s (e + 8) / (8 pi) (n.h)^e E_sun max(0, n.l) V c_sun`
//!
//! plus, when the lamp beside the lens is lit ([`super::light::Lamp`]), its illuminance
//! `E_lamp = I(theta) max(0, n.l_lamp) / r^2` in both terms, diffuse and the specular lobe
//! (with `h` halfway between the lamp and the viewer: the lamp's glare on metal).
//!
//! Lambertian diffuse (albedo `rho`) lit by the sun (visibility `V` from one shadow ray), the
//! sky dome as the cosine-weighted hemisphere term `(1 + n_z) / 2` (isotropic sky) and light
//! bounced off the ground (albedo [`GROUND_BOUNCE_ALBEDO`]) from below; glossy and metallic
//! materials add an energy-normalised Blinn-Phong lobe (Akenine-Moller et al., *Real-Time
//! Rendering* 4th ed., eq. 9.xx family) and a mirror reflection of the sky. Units: the output
//! is luminance-like radiance in cd/m^2 per linear RGB channel, illuminance in lux.

use nalgebra::{Isometry3, Point3, Vector3};

use super::depth_sensor::DepthSample;
use super::light::{LightConditions, luminance};
use crate::scene::textures::NoiseCache;
use crate::scene::{Candidates, Hit, MaterialId, Ray, Scene, Shading};

/// Albedo of the surroundings bouncing light up onto downward-facing surfaces.
pub const GROUND_BOUNCE_ALBEDO: f64 = 0.2;
/// Offset of shadow-ray origins along the normal (m).
pub const SHADOW_BIAS_M: f64 = 2e-5;

/// Per-capture lighting constants.
#[derive(Clone, Copy, Debug)]
pub struct LightSetup {
    /// Conditions.
    pub light: LightConditions,
    sun_dir: Vector3<f64>,
    sun_rgb: [f64; 3],
    e_sun: f64,
    e_sky: f64,
    e_ground: f64,
    shadows: bool,
    lamp: Option<LampSetup>,
}

/// The lamp of a capture, in the world frame.
#[derive(Clone, Copy, Debug)]
struct LampSetup {
    position: Point3<f64>,
    /// Unit beam axis (the camera's optical axis).
    axis: Vector3<f64>,
    /// `I_0 b` (cd).
    intensity_cd: f64,
    /// Beam exponent `m`.
    exponent: f64,
    rgb: [f64; 3],
}

impl LightSetup {
    /// Precomputes the constants; `shadows` enables shadow rays.
    #[must_use]
    pub fn new(light: &LightConditions, shadows: bool) -> Self {
        // A sun contributing under 0.1 % of the global illuminance (at the horizon) casts no
        // shadow rays: they would be long, grazing and pointless.
        let e_sun = if light.sun_direction.z > 0.0
            && light.sun_normal_lux > 1e-3 * light.horizontal_lux()
        {
            light.sun_normal_lux
        } else {
            0.0
        };
        Self {
            light: *light,
            sun_dir: light.sun_direction,
            sun_rgb: light.sun_rgb,
            e_sun,
            e_sky: light.sky_horizontal_lux,
            e_ground: GROUND_BOUNCE_ALBEDO * light.horizontal_lux(),
            shadows,
            lamp: None,
        }
    }

    /// Places the conditions' lamp (if lit) beside the lens of the camera at
    /// `world_from_camera` (optical frame, z forward).
    #[must_use]
    pub fn with_camera(mut self, world_from_camera: &Isometry3<f64>) -> Self {
        self.lamp = self.light.lamp.map(|l| LampSetup {
            position: world_from_camera * Point3::from(l.offset_m),
            axis: world_from_camera.rotation * Vector3::z(),
            intensity_cd: l.intensity_cd * l.brightness,
            exponent: l.beam_exponent(),
            rgb: l.rgb,
        });
        self
    }
}

impl LampSetup {
    /// The lamp's illuminance at `point` with normal `n` (lx) and the unit direction towards
    /// the lamp (module docs).
    fn illuminance(&self, point: &Point3<f64>, n: &Vector3<f64>) -> (f64, Vector3<f64>) {
        let to_lamp = self.position - point;
        let r2 = to_lamp.norm_squared().max(1e-6);
        let l = to_lamp / r2.sqrt();
        let ndl = n.dot(&l);
        let cos_beam = -l.dot(&self.axis);
        if ndl <= 0.0 || cos_beam <= 0.0 {
            return (0.0, l);
        }
        (
            self.intensity_cd * cos_beam.powf(self.exponent) * ndl / r2,
            l,
        )
    }
}

/// Result of shading one ray.
#[derive(Clone, Copy, Debug)]
pub struct Shaded {
    /// Radiance (cd/m^2, linear RGB).
    pub radiance: [f32; 3],
    /// Hashed primitive key (edge detection); `u32::MAX` for the sky.
    pub key: u32,
    /// Depth-relevant attributes (`z_m` filled by the caller).
    pub depth: Option<DepthSample>,
    /// Distance along the ray (m), infinite for the sky.
    pub t_m: f64,
}

const INV_PI: f64 = std::f64::consts::FRAC_1_PI;

/// Primitives hit by the previous primary and shadow rays of a run of neighbouring pixels
/// (see [`Scene::intersect_hinted`]) and the texture noise they shared; they speed tracing
/// up without changing its result.
#[derive(Clone, Debug, Default)]
pub struct TraceHints {
    primary: Option<Hit>,
    /// Winning entry of the candidate list of [`trace_culled`].
    candidate: Option<usize>,
    shadow: Option<Hit>,
    noise: NoiseCache,
}

/// Traces and shades one ray. `footprint_per_m` is the pixel footprint per metre of distance
/// (radians per pixel).
#[must_use]
pub fn trace(
    scene: &Scene,
    setup: &LightSetup,
    ray: &Ray,
    footprint_per_m: f64,
    hints: &mut TraceHints,
) -> Shaded {
    let found = scene.intersect_hinted(ray, 0.0, f64::INFINITY, hints.primary);
    if found.is_some() {
        hints.primary = found;
    }
    let Some(hit) = found else {
        return shade_sky(setup, ray);
    };
    let TraceHints { shadow, noise, .. } = hints;
    shade_hit(scene, setup, ray, &hit, footprint_per_m, noise, |r| {
        scene.occluded_hinted(r, 0.0, f64::INFINITY, shadow)
    })
}

/// [`trace`] for a ray inside the volume `statics` was culled with (see
/// [`Scene::intersect_culled`]): the same result, the primary ray tested against the
/// candidates only.
#[must_use]
pub fn trace_culled(
    scene: &Scene,
    setup: &LightSetup,
    ray: &Ray,
    footprint_per_m: f64,
    hints: &mut TraceHints,
    statics: &Candidates,
) -> Shaded {
    let found =
        scene.intersect_culled_hinted(ray, 0.0, f64::INFINITY, statics, &mut hints.candidate);
    let Some(hit) = found else {
        return shade_sky(setup, ray);
    };
    let TraceHints { shadow, noise, .. } = hints;
    shade_hit(scene, setup, ray, &hit, footprint_per_m, noise, |r| {
        scene.occluded_hinted(r, 0.0, f64::INFINITY, shadow)
    })
}

/// Radiance of the sky seen along a ray that hit nothing.
#[must_use]
pub fn shade_sky(setup: &LightSetup, ray: &Ray) -> Shaded {
    let s = setup.light.sky_radiance(&ray.dir);
    Shaded {
        radiance: [s[0] as f32, s[1] as f32, s[2] as f32],
        key: u32::MAX,
        depth: None,
        t_m: f64::INFINITY,
    }
}

impl LightSetup {
    /// Whether shading casts shadow rays towards the sun (enabled and the sun is up).
    #[must_use]
    pub fn casts_shadows(&self) -> bool {
        self.shadows && self.e_sun > 0.0
    }

    /// Unit direction towards the sun.
    #[must_use]
    pub fn sun_direction(&self) -> Vector3<f64> {
        self.sun_dir
    }
}

/// Shades a hit of `ray`; `occluded` answers shadow rays (origin offset by
/// [`SHADOW_BIAS_M`] along the normal, direction to the sun, `t` in `(0, inf)`), `noise`
/// memoises texture noise between neighbouring calls (it never changes the result).
pub fn shade_hit(
    scene: &Scene,
    setup: &LightSetup,
    ray: &Ray,
    hit: &Hit,
    footprint_per_m: f64,
    noise: &mut NoiseCache,
    occluded: impl FnMut(&Ray) -> bool,
) -> Shaded {
    match SurfaceHit::new(scene, ray, hit, footprint_per_m) {
        Some(s) => {
            let albedo = s.albedo(scene, noise);
            s.shade(setup, ray, albedo, scene, occluded)
        }
        None => shade_without_surface(hit),
    }
}

/// Shading of a hit whose primitive has no surface (not produced by a valid scene):
/// black, without depth.
#[must_use]
pub fn shade_without_surface(hit: &Hit) -> Shaded {
    Shaded {
        radiance: [0.0; 3],
        key: primitive_key(hit),
        depth: None,
        t_m: hit.t_m,
    }
}

/// The hashed primitive key of a hit (never the sky's `u32::MAX`).
#[inline]
fn primitive_key(hit: &Hit) -> u32 {
    crate::scene::noise::hash_u32((hit.key() ^ (hit.key() >> 29)) as u32).min(u32::MAX - 1)
}

/// A primary hit between intersection and shading: its surface point, the normal turned
/// towards the ray, the cosine of incidence and the pixel density on the surface (the
/// texture lookup's inputs), so a tile can look its textures up in batches
/// ([`AlbedoBatch`]) before lighting each pixel ([`SurfaceHit::shade`]).
#[derive(Clone, Copy, Debug)]
pub struct SurfaceHit {
    point: Point3<f64>,
    /// Unit normal turned towards the ray.
    normal: Vector3<f64>,
    uv_m: [f64; 2],
    cos_i: f64,
    t_m: f64,
    px_per_m: f32,
    key: u32,
    material: MaterialId,
    face: u8,
}

impl SurfaceHit {
    /// The surface of `hit` (`None` for a primitive without one: see
    /// [`shade_without_surface`]).
    #[inline]
    #[must_use]
    pub fn new(scene: &Scene, ray: &Ray, hit: &Hit, footprint_per_m: f64) -> Option<Self> {
        let sp = scene.surface(ray, hit)?;
        let mut normal = sp.normal;
        let mut cos_i = -normal.dot(&ray.dir);
        if cos_i < 0.0 {
            normal = -normal;
            cos_i = -cos_i;
        }
        // Pixels per metre on the surface (the footprint's reciprocal: one division).
        let px_per_m = (cos_i.max(0.2) / (hit.t_m * footprint_per_m)) as f32;
        Some(Self {
            point: sp.point,
            normal,
            uv_m: sp.uv_m,
            cos_i,
            t_m: hit.t_m,
            px_per_m,
            key: primitive_key(hit),
            material: sp.material,
            face: sp.face,
        })
    }

    /// The texture's albedo here (one lookup; [`AlbedoBatch`] looks many up at once).
    pub fn albedo(&self, scene: &Scene, noise: &mut NoiseCache) -> [f32; 3] {
        scene
            .material(self.material)
            .albedo_at_density(self.uv_m, self.face, self.px_per_m, noise)
    }

    /// Radiance of this hit of `ray` with the given texture albedo (module docs);
    /// `occluded` answers the shadow ray.
    pub fn shade(
        &self,
        setup: &LightSetup,
        ray: &Ray,
        albedo: [f32; 3],
        scene: &Scene,
        mut occluded: impl FnMut(&Ray) -> bool,
    ) -> Shaded {
        let (n, cos_i, key) = (self.normal, self.cos_i, self.key);
        let mat = scene.material(self.material);
        let a = [
            f64::from(albedo[0]),
            f64::from(albedo[1]),
            f64::from(albedo[2]),
        ];

        let ndl = n.dot(&setup.sun_dir);
        let mut e_direct = 0.0;
        if ndl > 0.0 && setup.e_sun > 0.0 {
            let visible = !setup.shadows || {
                let origin: Point3<f64> = self.point + n * SHADOW_BIAS_M;
                !occluded(&Ray {
                    origin,
                    dir: setup.sun_dir,
                })
            };
            if visible {
                e_direct = setup.e_sun * ndl;
            }
        }
        let (e_lamp, to_lamp, lamp_rgb) = setup.lamp.map_or((0.0, n, [0.0; 3]), |lp| {
            let (e, l) = lp.illuminance(&self.point, &n);
            (e, l, lp.rgb)
        });
        let up = n.z.clamp(-1.0, 1.0);
        let sky_w = 0.5 + 0.5 * up;
        let e_sky = setup.e_sky * sky_w;
        let e_gnd = setup.e_ground * (1.0 - sky_w);
        let t = 1.0 - up.max(0.0);
        let l = &setup.light;
        let mut rad = [0.0; 3];
        for c in 0..3 {
            let sky_c = l.sky_zenith_rgb[c] + (l.sky_horizon_rgb[c] - l.sky_zenith_rgb[c]) * t;
            let irr = e_direct * setup.sun_rgb[c]
                + e_sky * sky_c
                + e_gnd * l.sky_horizon_rgb[c]
                + e_lamp * lamp_rgb[c];
            rad[c] = a[c] * INV_PI * irr;
        }
        let mut metal = false;
        if let Shading::Glossy { specular, exponent } | Shading::Metal { specular, exponent } =
            mat.shading
        {
            let (ks, e) = (f64::from(specular), f64::from(exponent));
            let is_metal = matches!(mat.shading, Shading::Metal { .. });
            metal = is_metal && ks >= 0.15;
            let tint = |c: usize| {
                if is_metal {
                    a[c] / luminance(a).max(1e-3)
                } else {
                    1.0
                }
            };
            let v = -ray.dir;
            let refl = ray.dir + n * (2.0 * cos_i);
            let sky = l.sky_radiance(&refl);
            let lobe = |to_light: Vector3<f64>, e_light: f64| {
                let hv = to_light + v;
                if e_light > 0.0 && hv.norm_squared() > 1e-12 {
                    let nh = n.dot(&hv.normalize()).max(0.0);
                    ks * (e + 8.0) / (8.0 * std::f64::consts::PI) * nh.powf(e) * e_light
                } else {
                    0.0
                }
            };
            let spec = lobe(setup.sun_dir, e_direct);
            let glare = lobe(to_lamp, e_lamp);
            for c in 0..3 {
                rad[c] += tint(c) * (spec * setup.sun_rgb[c] + ks * sky[c] + glare * lamp_rgb[c]);
            }
        }
        Shaded {
            radiance: [rad[0] as f32, rad[1] as f32, rad[2] as f32],
            key,
            depth: Some(DepthSample {
                z_m: 0.0,
                cos_incidence: cos_i,
                albedo: luminance(a),
                sun_lux: e_direct,
                metal,
            }),
            t_m: self.t_m,
        }
    }
}

/// Points waiting per material and face before a batched texture lookup (one AVX-512
/// vector of f32; two batches of 8 below AVX-512).
const ALBEDO_LANES: usize = 16;

/// Texture lookups of a tile's hits, batched per material and face: textures with a lane
/// kernel ([`crate::scene::Material::has_lane_texture`]) are evaluated [`ALBEDO_LANES`]
/// points at a time at a fixed vector level, the others point by point. Every albedo
/// equals [`SurfaceHit::albedo`] bit for bit, so batching changes only the speed.
#[derive(Clone, Debug)]
pub struct AlbedoBatch {
    level: simd::Level,
    /// Per (material, face) with points waiting: the indices of its waiting hits (a face
    /// has its own texture seed, and one seed per batch keeps the noise in lanes).
    pending: Vec<((MaterialId, u8), Vec<usize>)>,
}

impl Default for AlbedoBatch {
    fn default() -> Self {
        Self::new(simd::max_level())
    }
}

impl AlbedoBatch {
    /// Batches run at `level` (or the best level below it that this CPU has); hand a
    /// rendering's worker threads the caller's [`simd::max_level`].
    #[must_use]
    pub fn new(level: simd::Level) -> Self {
        Self {
            level,
            pending: Vec::new(),
        }
    }

    /// The albedo of every hit of `hits` into `out` (same length; `[0; 3]` where `None`).
    pub fn run(
        &mut self,
        scene: &Scene,
        hits: &[Option<SurfaceHit>],
        noise: &mut NoiseCache,
        out: &mut Vec<[f32; 3]>,
    ) {
        out.clear();
        out.resize(hits.len(), [0.0; 3]);
        for (_, waiting) in &mut self.pending {
            waiting.clear();
        }
        for (i, h) in hits.iter().enumerate() {
            let Some(h) = h else { continue };
            if !scene.material(h.material).has_lane_texture() {
                if let Some(o) = out.get_mut(i) {
                    *o = h.albedo(scene, noise);
                }
                continue;
            }
            let key = (h.material, h.face);
            let slot = match self.pending.iter().position(|(k, _)| *k == key) {
                Some(k) => k,
                None => {
                    self.pending.push((key, Vec::with_capacity(ALBEDO_LANES)));
                    self.pending.len() - 1
                }
            };
            let Some((_, waiting)) = self.pending.get_mut(slot) else {
                continue;
            };
            waiting.push(i);
            if waiting.len() == ALBEDO_LANES {
                flush(self.level, scene, key, waiting, hits, noise, out);
            }
        }
        for (key, waiting) in &mut self.pending {
            if !waiting.is_empty() {
                flush(self.level, scene, *key, waiting, hits, noise, out);
            }
        }
    }
}

/// Looks up the albedo of the (at most [`ALBEDO_LANES`]) hits `waiting` on face `key.1` of
/// material `key.0` at `level` and empties `waiting`: one batch of 16 with AVX-512,
/// batches of 8 otherwise.
fn flush(
    level: simd::Level,
    scene: &Scene,
    (id, face): (MaterialId, u8),
    waiting: &mut Vec<usize>,
    hits: &[Option<SurfaceHit>],
    noise: &mut NoiseCache,
    out: &mut [[f32; 3]],
) {
    let material = scene.material(id);
    let level = level.min(simd::detected());
    let step = if level == simd::Level::Avx512 {
        ALBEDO_LANES
    } else {
        ALBEDO_LANES / 2
    };
    for first in (0..waiting.len()).step_by(step) {
        if step == ALBEDO_LANES {
            lookup::<ALBEDO_LANES>(level, material, face, waiting, first, hits, noise, out);
        } else {
            lookup::<{ ALBEDO_LANES / 2 }>(level, material, face, waiting, first, hits, noise, out);
        }
    }
    waiting.clear();
}

/// One lane batch: the albedo of the hits `waiting[first..first + N]` on face `face`
/// (spare lanes repeat the last point; only the real lanes are written to `out`).
#[allow(clippy::too_many_arguments)]
fn lookup<const N: usize>(
    level: simd::Level,
    material: &crate::scene::Material,
    face: u8,
    waiting: &[usize],
    first: usize,
    hits: &[Option<SurfaceHit>],
    noise: &mut NoiseCache,
    out: &mut [[f32; 3]],
) {
    let (uv, ppm) = gather::<N>(waiting, first, hits);
    let albedo = material.albedo_lanes(level, &uv, face, &ppm, noise);
    for (&i, a) in waiting.iter().skip(first).zip(albedo) {
        if let Some(o) = out.get_mut(i) {
            *o = a;
        }
    }
}

/// Texture inputs of the hits `waiting[first..first + N]`, the last one repeated into
/// spare lanes.
fn gather<const N: usize>(
    waiting: &[usize],
    first: usize,
    hits: &[Option<SurfaceHit>],
) -> ([[f64; 2]; N], [f32; N]) {
    let mut uv = [[0.0; 2]; N];
    let mut ppm = [0.0_f32; N];
    let mut last = None;
    for k in 0..N {
        if let Some(h) = waiting
            .get(first + k)
            .and_then(|&i| hits.get(i))
            .and_then(Option::as_ref)
        {
            last = Some(h);
        }
        if let Some(h) = last {
            (uv[k], ppm[k]) = (h.uv_m, h.px_per_m);
        }
    }
    (uv, ppm)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::light::Lamp;

    #[test]
    fn the_lamp_falls_off_with_the_square_of_distance_and_across_its_beam() {
        let lamp = Lamp::wrist(0.5);
        let light = LightConditions::from_hour(20.0).with_lamp(Some(lamp));
        // Camera at the origin looking along +z; the lamp 4 cm above the lens.
        let setup = LightSetup::new(&light, false).with_camera(&Isometry3::identity());
        let lp = setup.lamp.expect("lit");
        let at = |p: [f64; 3], n: Vector3<f64>| lp.illuminance(&Point3::from(p), &n).0;
        let facing = -Vector3::z();
        let (x0, y0) = (lamp.offset_m[0], lamp.offset_m[1]);
        let e1 = at([x0, y0, 1.0], facing);
        assert!((e1 - 500.0).abs() < 1e-9, "{e1}");
        let e2 = at([x0, y0, 2.0], facing);
        assert!((e2 / e1 - 0.25).abs() < 1e-12, "{e2}");
        // At the half-intensity angle, on a surface facing the lamp: half the intensity.
        let h = lamp.half_angle_deg.to_radians();
        let p = [x0 + h.sin(), y0, h.cos()];
        let towards_lamp = -Vector3::new(p[0] - x0, 0.0, p[2]).normalize();
        assert!((at(p, towards_lamp) - 250.0).abs() < 1e-9);
        // Surfaces facing away and points behind the lamp get nothing.
        assert_eq!(at([x0, y0, 1.0], Vector3::z()), 0.0);
        assert_eq!(at([x0, y0, -1.0], Vector3::z()), 0.0);
        // Off, there is no lamp at all.
        let dark = LightConditions::from_hour(20.0).with_lamp(Some(Lamp::wrist(0.0)));
        assert!(dark.lamp.is_none());
        assert!((Lamp::wrist(1.0).flux_lm() - 1405.0).abs() < 5.0);
    }
}
