//! The bay's materials (galvanised and rusty steel, porcelain, glass, concrete, labelled and
//! bolted panels), and the seeded dice that vary them.

use crate::scene::noise::{hash_u32, unit_f32};
use crate::scene::textures::{Material, Shading, Texture};
use crate::scene::{MaterialId, SceneBuilder};

/// Deterministic stream of uniforms from the seed.
pub(super) struct Dice {
    state: u32,
}

impl Dice {
    /// The stream of `seed` (both halves of it mixed in).
    pub(super) fn new(seed: u64) -> Self {
        Self {
            state: hash_u32((seed as u32) ^ hash_u32((seed >> 32) as u32)),
        }
    }

    pub(super) fn next(&mut self) -> f64 {
        self.state = hash_u32(self.state.wrapping_add(0x9e37_79b9));
        f64::from(unit_f32(self.state))
    }
    pub(super) fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }
    pub(super) fn seed(&mut self) -> u32 {
        self.state = hash_u32(self.state.wrapping_add(0x7f4a_7c15));
        self.state
    }
}

/// The bay's materials, one of each kind, textured from the seed.
pub(super) struct Mats {
    pub(super) steel: MaterialId,
    pub(super) porcelain: MaterialId,
    pub(super) glass: MaterialId,
    pub(super) cap: MaterialId,
    pub(super) conductor: MaterialId,
    pub(super) concrete: MaterialId,
    pub(super) road: MaterialId,
    pub(super) pedestal: MaterialId,
    pub(super) kiosk: MaterialId,
    pub(super) plain_box: MaterialId,
    pub(super) label_white: MaterialId,
    pub(super) label_yellow: MaterialId,
    pub(super) louvres: MaterialId,
    pub(super) bolted: MaterialId,
    pub(super) cabinet: MaterialId,
    pub(super) door: MaterialId,
    pub(super) tray: MaterialId,
    pub(super) dark: MaterialId,
    pub(super) hazard: MaterialId,
    pub(super) rusty: MaterialId,
}

impl Mats {
    /// Adds the materials to `b`, their textures' seeds drawn from `d`.
    pub(super) fn new(b: &mut SceneBuilder, d: &mut Dice) -> Self {
        let gloss = |s: f32, e: f32| Shading::Glossy {
            specular: s,
            exponent: e,
        };
        Mats {
            steel: b.material(
                Material::matte([0.42, 0.43, 0.42], Texture::Galvanized, d.seed()).with_shading(
                    Shading::Metal {
                        specular: 0.12,
                        exponent: 12.0,
                    },
                ),
            ),
            porcelain: b.material(
                Material::matte([0.28, 0.12, 0.05], Texture::Porcelain, d.seed())
                    .with_shading(gloss(0.25, 60.0)),
            ),
            glass: b.material(
                Material::matte([0.16, 0.26, 0.2], Texture::Porcelain, d.seed())
                    .with_shading(gloss(0.35, 90.0)),
            ),
            cap: b.material(Material::matte(
                [0.5, 0.5, 0.48],
                Texture::Galvanized,
                d.seed(),
            )),
            conductor: b.material(
                Material::matte(
                    [0.5, 0.5, 0.5],
                    Texture::Strands { pitch_m: 0.0045 },
                    d.seed(),
                )
                .with_shading(Shading::Metal {
                    specular: 0.2,
                    exponent: 18.0,
                }),
            ),
            concrete: b.material(Material::matte(
                [0.45, 0.44, 0.41],
                Texture::Concrete,
                d.seed(),
            )),
            road: b.material(Material::matte(
                [0.36, 0.35, 0.33],
                Texture::Concrete,
                d.seed(),
            )),
            pedestal: b.material(Material::matte(
                [0.47, 0.48, 0.47],
                Texture::Galvanized,
                d.seed(),
            )),
            kiosk: b.material(
                Material::matte(
                    [0.42, 0.46, 0.4],
                    Texture::Painted {
                        grime: 0.06,
                        rust: d.range(0.1, 0.5) as f32,
                    },
                    d.seed(),
                )
                .with_shading(gloss(0.05, 25.0)),
            ),
            plain_box: b.material(
                Material::matte(
                    [0.5, 0.52, 0.5],
                    Texture::Painted {
                        grime: 0.015,
                        rust: 0.0,
                    },
                    d.seed(),
                )
                .with_shading(gloss(0.04, 20.0)),
            ),
            label_white: b.material(
                Material::matte(
                    [0.75, 0.75, 0.72],
                    Texture::Label { glyph_m: 0.011 },
                    d.seed(),
                )
                .with_accent([0.03, 0.03, 0.04]),
            ),
            label_yellow: b.material(
                Material::matte(
                    [0.75, 0.6, 0.03],
                    Texture::Label { glyph_m: 0.016 },
                    d.seed(),
                )
                .with_accent([0.02, 0.02, 0.02]),
            ),
            louvres: b.material(Material::matte(
                [0.4, 0.43, 0.38],
                Texture::Louvres { pitch_m: 0.018 },
                d.seed(),
            )),
            bolted: b.material(Material::matte(
                [0.4, 0.42, 0.37],
                Texture::BoltedPanel {
                    pitch_m: 0.075,
                    bolt_radius_m: 0.0075,
                },
                d.seed(),
            )),
            cabinet: b.material(
                Material::matte(
                    [0.38, 0.42, 0.36],
                    Texture::Painted {
                        grime: 0.08,
                        rust: d.range(0.3, 0.6) as f32,
                    },
                    d.seed(),
                )
                .with_shading(gloss(0.05, 25.0)),
            ),
            door: b.material(Material::matte(
                [0.45, 0.47, 0.42],
                Texture::BoltedPanel {
                    pitch_m: 0.09,
                    bolt_radius_m: 0.006,
                },
                d.seed(),
            )),
            tray: b.material(Material::matte(
                [0.5, 0.5, 0.48],
                Texture::CableTray { slot_pitch_m: 0.05 },
                d.seed(),
            )),
            dark: b.material(Material::matte(
                [0.04, 0.04, 0.045],
                Texture::Rubber { pitch_m: 0.01 },
                d.seed(),
            )),
            hazard: b.material(
                Material::matte(
                    [0.75, 0.55, 0.02],
                    Texture::Hazard { pitch_m: 0.12 },
                    d.seed(),
                )
                .with_accent([0.03, 0.03, 0.03]),
            ),
            rusty: b.material(Material::matte(
                [0.35, 0.33, 0.3],
                Texture::Painted {
                    grime: 0.1,
                    rust: 0.9,
                },
                d.seed(),
            )),
        }
    }
}
