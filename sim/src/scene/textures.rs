//! Materials and seeded procedural textures.
//!
//! A texture maps surface coordinates `uv` (metres, see
//! [`LocalSurface`](super::primitives::LocalSurface)) to a linear RGB albedo. Every texture is
//! a pure function of `(uv, face, material seed)`, built from hashed value noise, fbm and
//! cellular noise ([`super::noise`]).
//!
//! Antialiasing: each call receives the pixel footprint `w` (metres on the surface), as its
//! reciprocal, the pixel density `1 / w` ([`Material::albedo_at_density`]). Features of
//! wavelength below `2 w` fade to their mean colour ([`band_weight`]) and hard edges are
//! ramps of width `w` ([`aa_step`]), so a single sample per pixel does not alias (the
//! renderer supersamples geometric edges separately).
//!
//! Cost: painted steel and bolted panels, which fill the wrist camera's view, are lane
//! kernels over many pixels at once ([`super::steel`], [`Material::albedo_lanes`]); the
//! other textures run point by point with a per-thread [`NoiseCache`]
//! ([`Material::albedo_cached`]): low-frequency fbm (finest octave >= 64 pixel footprints)
//! is interpolated from a grid of 8 samples per finest wavelength, a pure function of `uv`
//! like the rest, and cellular feature points are hashed once per cell. Band limits, ramps
//! and texture coordinates multiply by densities and reciprocal sizes instead of dividing
//! (a division takes several times a multiplication's issue slots).
//!
//! Corner content at the wrist working distance (0.3-0.6 m, one pixel ~ 0.17-0.34 mm with
//! fx = 1745 px): gravel stones (5-25 mm), bolt heads, text-like glyph blocks (2-4 mm),
//! rust-stain outlines and galvanising spangle give ORB corners; louvres, cable-tray slots,
//! conductor strands and insulator discs are the repetitive cases; `Uniform` and lightly
//! weathered paint are (nearly) textureless.

pub use super::noise::NoiseCache;
use super::noise::{aa_step, band_weight, hash_u32, hash2, unit_f32};
use super::steel::{self, SteelTexture, TexelLanes};

/// Shading class of a material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shading {
    /// Lambertian.
    Matte,
    /// Lambertian plus a Blinn-Phong highlight (paint, glaze).
    Glossy {
        /// Specular reflectance (0..1).
        specular: f32,
        /// Blinn-Phong exponent.
        exponent: f32,
    },
    /// Metallic: Blinn-Phong highlight tinted by the albedo; the depth camera loses the
    /// pattern near the mirror direction.
    Metal {
        /// Specular reflectance (0..1).
        specular: f32,
        /// Blinn-Phong exponent.
        exponent: f32,
    },
}

/// Procedural texture kinds with their size parameters (metres).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Texture {
    /// Exactly constant albedo (the textureless case; also used for SNR tests).
    Uniform,
    /// Painted steel: faint low-frequency grime, optional rust stains (`rust` 0..1).
    Painted {
        /// Grime contrast (0..0.2 typical).
        grime: f32,
        /// Rust coverage (0 = none, 1 = heavy).
        rust: f32,
    },
    /// Hot-dip galvanised steel: spangle grains and mottling.
    Galvanized,
    /// Gravel: cellular stones of the given size with dark gaps.
    Gravel {
        /// Typical stone diameter (m).
        stone_m: f32,
    },
    /// Concrete: fbm, pores and formwork seams.
    Concrete,
    /// Bolted panels: seams, bolt rows along the panel borders, rust streaks.
    BoltedPanel {
        /// Bolt spacing (m).
        pitch_m: f32,
        /// Bolt head radius (m).
        bolt_radius_m: f32,
    },
    /// Rows of text-like glyphs (accent colour) on a plate (base colour).
    Label {
        /// Glyph height (m).
        glyph_m: f32,
    },
    /// Ventilation louvres (repetitive horizontal slats).
    Louvres {
        /// Slat pitch (m).
        pitch_m: f32,
    },
    /// Perforated cable tray (repetitive slots) on galvanised steel.
    CableTray {
        /// Slot pitch (m).
        slot_pitch_m: f32,
    },
    /// Glazed porcelain.
    Porcelain,
    /// Helically stranded conductor.
    Strands {
        /// Strand width (m).
        pitch_m: f32,
    },
    /// Diagonal hazard stripes (base / accent).
    Hazard {
        /// Stripe period (m).
        pitch_m: f32,
    },
    /// Knurled rubber grip.
    Rubber {
        /// Knurl period (m).
        pitch_m: f32,
    },
}

/// A surface material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// Main linear albedo (0..1 per channel).
    pub base_rgb: [f32; 3],
    /// Secondary colour used by patterned textures (text, stripes, stones).
    pub accent_rgb: [f32; 3],
    /// Texture.
    pub texture: Texture,
    /// Shading class.
    pub shading: Shading,
    /// Texture seed.
    pub seed: u32,
}

/// Returned for an out-of-range material id (never produced by a validated scene).
pub static FALLBACK_MATERIAL: Material = Material {
    base_rgb: [0.5, 0.0, 0.5],
    accent_rgb: [0.5, 0.0, 0.5],
    texture: Texture::Uniform,
    shading: Shading::Matte,
    seed: 0,
};

impl Material {
    /// Matte material with a texture.
    #[must_use]
    pub const fn matte(base_rgb: [f32; 3], texture: Texture, seed: u32) -> Self {
        Self {
            base_rgb,
            accent_rgb: base_rgb,
            texture,
            shading: Shading::Matte,
            seed,
        }
    }

    /// Sets the accent colour.
    #[must_use]
    pub const fn with_accent(mut self, accent_rgb: [f32; 3]) -> Self {
        self.accent_rgb = accent_rgb;
        self
    }

    /// Sets the shading class.
    #[must_use]
    pub const fn with_shading(mut self, shading: Shading) -> Self {
        self.shading = shading;
        self
    }

    /// Linear albedo at surface coordinates `uv_m` of face `face`, pixel footprint
    /// `footprint_m` (metres on the surface).
    #[must_use]
    pub fn albedo(&self, uv_m: [f64; 2], face: u8, footprint_m: f32) -> [f32; 3] {
        self.albedo_cached(uv_m, face, footprint_m, &mut NoiseCache::new())
    }

    /// [`Self::albedo`] with a memo of the noise that neighbouring pixels share (one per
    /// thread, reused from pixel to pixel; the result does not depend on its contents).
    #[must_use]
    pub fn albedo_cached(
        &self,
        uv_m: [f64; 2],
        face: u8,
        footprint_m: f32,
        nc: &mut NoiseCache,
    ) -> [f32; 3] {
        self.albedo_at_density(uv_m, face, 1.0 / footprint_m.max(MIN_FOOTPRINT_M), nc)
    }

    /// The lane kernel of this material's texture, if it has one ([`steel`]): textures
    /// without one gain nothing from batching.
    #[must_use]
    pub fn steel_texture(&self) -> Option<SteelTexture> {
        match self.texture {
            Texture::Painted { grime, rust } => Some(SteelTexture::Painted { grime, rust }),
            Texture::BoltedPanel {
                pitch_m,
                bolt_radius_m,
            } => Some(SteelTexture::BoltedPanel {
                pitch_m,
                bolt_radius_m,
            }),
            _ => None,
        }
    }

    /// Whether [`Self::albedo_lanes`] evaluates this material's texture in vector lanes.
    #[must_use]
    pub fn has_lane_texture(&self) -> bool {
        self.steel_texture().is_some()
    }

    /// [`Self::albedo_at_density`] at `N` points of face `face` at once (lane `i` is the
    /// albedo of point `i`, bit for bit): one vector evaluation at `level` (or the best level
    /// below it that this CPU has) for textures with a lane kernel (see
    /// [`Self::has_lane_texture`]), point by point for the others.
    #[must_use]
    pub fn albedo_lanes<const N: usize>(
        &self,
        level: simd::Level,
        uv_m: &[[f64; 2]; N],
        face: u8,
        px_per_m: &[f32; N],
        nc: &mut NoiseCache,
    ) -> [[f32; 3]; N] {
        let Some(texture) = self.steel_texture() else {
            let mut out = [[0.0; 3]; N];
            for (i, o) in out.iter_mut().enumerate() {
                *o = self.albedo_at_density(uv_m[i], face, px_per_m[i], nc);
            }
            return out;
        };
        let mut t = TexelLanes {
            seed: self.face_seed(face),
            ..TexelLanes::default()
        };
        for i in 0..N {
            (t.u[i], t.v[i], t.px_per_m[i]) = texel(uv_m[i], px_per_m[i]);
        }
        steel::albedo_at(level, texture, &t, self.base_rgb)
    }

    /// The texture seed of face `face`.
    #[inline(always)]
    fn face_seed(&self, face: u8) -> u32 {
        hash_u32(self.seed ^ (u32::from(face) << 24))
    }

    /// [`Self::albedo_cached`] given the pixel density `px_per_m` (pixels per metre on the
    /// surface, the reciprocal of the footprint; at most `1 / 10 um`), which band limits and
    /// edge ramps multiply by.
    #[must_use]
    pub fn albedo_at_density(
        &self,
        uv_m: [f64; 2],
        face: u8,
        px_per_m: f32,
        nc: &mut NoiseCache,
    ) -> [f32; 3] {
        let (u, v, ppm) = texel(uv_m, px_per_m);
        let seed = self.face_seed(face);
        let b = self.base_rgb;
        if let Some(texture) = self.steel_texture() {
            let t = TexelLanes {
                u: [u],
                v: [v],
                px_per_m: [ppm],
                seed,
            };
            return steel::albedo(texture, &t, b)[0];
        }
        let a = self.accent_rgb;
        match self.texture {
            Texture::Uniform => b,
            Texture::Galvanized => {
                let w = band_weight(0.008, ppm);
                let c = nc.cellular2(u * (1.0 / 0.008), v * (1.0 / 0.008), seed);
                let grain = 0.88
                    + 0.24 * unit_f32(c.id) * w
                    + 0.1 * aa_step(0.06, c.f2 - c.f1, ppm * 0.008) * w;
                let mottle = 1.0 + 0.35 * nc.fbm2(u, v, 0.25, 3, ppm, seed ^ 0x55);
                scale(b, grain * mottle)
            }
            Texture::Gravel { stone_m } => gravel(nc, b, a, u, v, ppm, seed, stone_m),
            Texture::Concrete => {
                let tone = 1.0 + 0.45 * nc.fbm2(u, v, 0.35, 5, ppm, seed);
                let c = nc.cellular2(u * (1.0 / 0.004), v * (1.0 / 0.004), seed ^ 0x77);
                let pore =
                    1.0 - 0.5 * (1.0 - aa_step(0.18, c.f1, ppm * 0.004)) * band_weight(0.004, ppm);
                let seam_d = ((u * (1.0 / 1.2)).fract() - 0.5).abs() * 1.2;
                let seam = 1.0 - 0.4 * (1.0 - aa_step(0.002, 0.6 - seam_d, ppm));
                scale(b, tone * pore * seam)
            }
            // Served by the steel kernel above.
            Texture::Painted { .. } | Texture::BoltedPanel { .. } => b,
            Texture::Label { glyph_m } => label(nc, b, a, u, v, ppm, seed, glyph_m),
            Texture::Louvres { pitch_m } => {
                let f = fract01(v / pitch_m);
                let w = band_weight(pitch_m, ppm);
                let slat = 0.7 + 0.45 * f / 0.75;
                let gap = aa_step(0.75, f, ppm * pitch_m);
                let detail = slat * (1.0 - gap) + 0.12 * gap;
                let mean = 0.72;
                let g = 1.0 + 0.15 * nc.fbm2(u, v, 0.3, 3, ppm, seed);
                scale(b, (w * detail + (1.0 - w) * mean) * g)
            }
            Texture::CableTray { slot_pitch_m } => {
                let p = slot_pitch_m;
                let fu = fract01(u / p);
                let fv = fract01(v / (0.5 * p));
                // Rounded slot: |x| < 0.3, |y| < 0.2 in cell units.
                let dx = ((fu - 0.5).abs() - 0.3).max(0.0);
                let dy = ((fv - 0.5).abs() - 0.15).max(0.0);
                let d_m = ((dx * dx + dy * dy).sqrt() - 0.06) * p * 0.5;
                let hole = 1.0 - aa_step(0.0, d_m, ppm);
                let w = band_weight(0.5 * p, ppm);
                let m = 1.0 + 0.25 * nc.fbm2(u, v, 0.2, 3, ppm, seed);
                let c = scale(b, m);
                mix(c, scale(c, 0.08), hole * w + 0.15 * (1.0 - w))
            }
            Texture::Porcelain => {
                let g = 1.0 + 0.12 * nc.fbm2(u, v, 0.05, 4, ppm, seed);
                let dirt =
                    1.0 - 0.25 * (nc.fbm2(u, v, 0.3, 3, ppm, seed ^ 9) + 0.5).clamp(0.0, 1.0);
                scale(b, g * dirt)
            }
            Texture::Strands { pitch_m } => {
                let (s, c) = 0.26_f32.sin_cos();
                let f = fract01((u * c + v * s) / pitch_m);
                let w = band_weight(pitch_m, ppm);
                let round = 0.55 + 0.5 * (std::f32::consts::PI * f).sin();
                let strand = w * round + (1.0 - w) * 0.87;
                let grime = 1.0 + 0.5 * nc.fbm2(u * 0.3, v, 0.15, 5, ppm, seed);
                scale(b, strand * grime)
            }
            Texture::Hazard { pitch_m } => {
                let f = fract01((u + v) / pitch_m);
                let t = aa_step(0.5, f, ppm * pitch_m) * (1.0 - aa_step(0.98, f, ppm * pitch_m));
                let w = band_weight(pitch_m, ppm);
                let wear = 1.0 + 0.3 * nc.fbm2(u, v, 0.05, 4, ppm, seed);
                scale(mix(b, a, w * t + (1.0 - w) * 0.5), wear)
            }
            Texture::Rubber { pitch_m } => {
                let fa = fract01((u + v) / pitch_m);
                let fb = fract01((u - v) / pitch_m);
                let d = fa.min(1.0 - fa).min(fb).min(1.0 - fb) * pitch_m;
                let w = band_weight(pitch_m, ppm);
                let groove =
                    1.0 - 0.55 * (1.0 - aa_step(0.12 * pitch_m, d, ppm)) * w - 0.1 * (1.0 - w);
                scale(b, groove)
            }
        }
    }
}

/// A texture lookup point: wrapped f32 coordinates and the clamped pixel density.
#[inline(always)]
fn texel(uv_m: [f64; 2], px_per_m: f32) -> (f32, f32, f32) {
    // Keep f32 precision: textures repeat every 4096 m, far beyond the scene.
    let u = wrap(uv_m[0], TEXTURE_PERIOD_M) as f32;
    let v = wrap(uv_m[1], TEXTURE_PERIOD_M) as f32;
    // (A NaN density becomes the finest.)
    (u, v, px_per_m.min(1.0 / MIN_FOOTPRINT_M))
}

/// Smallest pixel footprint textures resolve (m).
pub const MIN_FOOTPRINT_M: f32 = 1e-5;

/// Period of all textures (m): coordinates are wrapped to keep f32 precision.
const TEXTURE_PERIOD_M: f64 = 4096.0;

/// `x` modulo `period` in `[0, period]` by floor (no `fmod` call).
#[inline]
fn wrap(x: f64, period: f64) -> f64 {
    x - (x / period).floor() * period
}

/// `x - floor(x)`: the position within a unit period (no `fmodf` call).
#[inline]
fn fract01(x: f32) -> f32 {
    x - x.floor()
}

#[inline]
fn scale(c: [f32; 3], k: f32) -> [f32; 3] {
    [
        (c[0] * k).clamp(0.0, 1.0),
        (c[1] * k).clamp(0.0, 1.0),
        (c[2] * k).clamp(0.0, 1.0),
    ]
}

#[inline]
fn mix(a: [f32; 3], b: [f32; 3], t: f32) -> [f32; 3] {
    [
        a[0] + (b[0] - a[0]) * t,
        a[1] + (b[1] - a[1]) * t,
        a[2] + (b[2] - a[2]) * t,
    ]
}

// Texture parameters are plain scalars next to the memo; a struct would only rename them.
#[allow(clippy::too_many_arguments)]
fn gravel(
    nc: &mut NoiseCache,
    b: [f32; 3],
    a: [f32; 3],
    u: f32,
    v: f32,
    ppm: f32,
    seed: u32,
    stone_m: f32,
) -> [f32; 3] {
    let w = band_weight(stone_m, ppm);
    let mean = scale(mix(b, a, 0.5), 0.85);
    if w <= 0.0 {
        let t = 1.0 + 0.3 * nc.fbm2(u, v, 1.5, 3, ppm, seed);
        return scale(mean, t);
    }
    let c = nc.cellular2(u / stone_m, v / stone_m, seed);
    let h = c.id;
    let tone = 0.6 + 0.8 * unit_f32(hash_u32(h));
    let stone = scale(mix(b, a, unit_f32(h)), tone);
    let gap = 1.0 - aa_step(0.1, c.f2 - c.f1, ppm * stone_m);
    let speck = 1.0 + 0.4 * nc.fbm2(u, v, stone_m * 0.3, 3, ppm, seed ^ 3);
    let detail = scale(mix(stone, scale(stone, 0.25), gap), speck);
    let large = 1.0 + 0.25 * nc.fbm2(u, v, 1.5, 3, ppm, seed ^ 5);
    scale(mix(mean, detail, w), large)
}

// Texture parameters are plain scalars next to the memo; a struct would only rename them.
#[allow(clippy::too_many_arguments)]
fn label(
    nc: &mut NoiseCache,
    b: [f32; 3],
    a: [f32; 3],
    u: f32,
    v: f32,
    ppm: f32,
    seed: u32,
    glyph: f32,
) -> [f32; 3] {
    let row_h = glyph * 1.6;
    let cell_w = glyph * 0.75;
    let row = (v / row_h).floor() as i32;
    let col = (u / cell_w).floor() as i32;
    let (fu, fv) = (u / cell_w - col as f32, v / row_h - row as f32);
    let rh = hash2(row, 0x51, seed);
    // Line length in glyphs, some rows blank, words separated by spaces.
    let len = (12 + rh % 40) as i32;
    let blank_row = rh.is_multiple_of(5);
    let gh = hash2(col, row, seed ^ 0xfeed);
    let space = gh.is_multiple_of(6);
    let w = band_weight(glyph * 0.2, ppm);
    let base_tone = 1.0 + 0.08 * nc.fbm2(u, v, 0.1, 3, ppm, seed);
    let plate = scale(b, base_tone);
    if blank_row || space || col < 1 || col > len {
        return plate;
    }
    // Glyph area within the cell: x in [0.1, 0.85], y in [0.2, 0.9] of the row.
    let gx = (fu - 0.1) / 0.75;
    let gy = (fv - 0.2) / 0.7;
    if !(0.0..1.0).contains(&gx) || !(0.0..1.0).contains(&gy) {
        return mix(plate, a, 0.0);
    }
    let (bi, bj) = ((gx * 3.0) as i32, (gy * 5.0) as i32);
    let bits = gh >> 3;
    let on = |i: i32, j: i32| {
        (0..3).contains(&i) && (0..5).contains(&j) && (bits >> (i + 3 * j)) & 1 == 1
    };
    if !on(bi, bj) {
        return mix(plate, a, 0.3 * (1.0 - w));
    }
    let (bx, by) = (gx * 3.0 - bi as f32, gy * 5.0 - bj as f32);
    let (bw, bh) = (0.75 * cell_w / 3.0, 0.7 * row_h / 5.0);
    let mut d = f32::MAX;
    if !on(bi - 1, bj) {
        d = d.min(bx * bw);
    }
    if !on(bi + 1, bj) {
        d = d.min((1.0 - bx) * bw);
    }
    if !on(bi, bj - 1) {
        d = d.min(by * bh);
    }
    if !on(bi, bj + 1) {
        d = d.min((1.0 - by) * bh);
    }
    let ink = aa_step(0.0, d, ppm);
    mix(plate, a, w * ink + 0.3 * (1.0 - w))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn textures_are_deterministic_and_in_range() {
        let kinds = [
            Texture::Uniform,
            Texture::Painted {
                grime: 0.1,
                rust: 0.8,
            },
            Texture::Galvanized,
            Texture::Gravel { stone_m: 0.02 },
            Texture::Concrete,
            Texture::BoltedPanel {
                pitch_m: 0.08,
                bolt_radius_m: 0.008,
            },
            Texture::Label { glyph_m: 0.012 },
            Texture::Louvres { pitch_m: 0.02 },
            Texture::CableTray { slot_pitch_m: 0.05 },
            Texture::Porcelain,
            Texture::Strands { pitch_m: 0.004 },
            Texture::Hazard { pitch_m: 0.1 },
            Texture::Rubber { pitch_m: 0.004 },
        ];
        for (k, t) in kinds.iter().enumerate() {
            let m = Material::matte([0.5, 0.4, 0.3], *t, k as u32).with_accent([0.05, 0.05, 0.05]);
            let first = m.albedo([0.0, 0.0], 1, 0.0003);
            let mut spread = 0.0_f32;
            for i in 0..2000 {
                let uv = [i as f64 * 0.00123, (i * 7 % 113) as f64 * 0.0017];
                let c = m.albedo(uv, 1, 0.0003);
                assert_eq!(c, m.albedo(uv, 1, 0.0003));
                for (x, f) in c.iter().zip(first) {
                    assert!((0.0..=1.0).contains(x), "{t:?} {x}");
                    spread = spread.max((x - f).abs());
                }
            }
            if *t == Texture::Uniform {
                assert!(spread < 1e-6);
            } else {
                assert!(spread > 0.02, "{t:?} has no contrast");
            }
        }
    }
}
