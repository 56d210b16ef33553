//! Evaluates one material's albedo over a 1280x1024 grid of surface points 0.26 mm apart
//! (the wrist camera's pixel footprint at 0.45 m), in the renderer's 16x16-tile order and
//! with one reused noise memo: a target for instruction counts of the texture code alone.
//!
//! `valgrind --tool=callgrind target/release/examples/texture_profile [KIND] [lanes]` with
//! KIND 0 bolted panel (default), 1 painted with rust, 2 label, 3 gravel, 4 concrete, 5
//! galvanised; `lanes` evaluates 8 points per call as the renderer's tiles do below AVX-512.

use std::hint::black_box;

use sim::scene::textures::NoiseCache;
use sim::scene::{Material, Texture};

fn main() {
    let kind: u32 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    let texture = match kind {
        0 => Texture::BoltedPanel {
            pitch_m: 0.075,
            bolt_radius_m: 0.0075,
        },
        1 => Texture::Painted {
            grime: 0.08,
            rust: 0.5,
        },
        2 => Texture::Label { glyph_m: 0.011 },
        3 => Texture::Gravel { stone_m: 0.022 },
        4 => Texture::Concrete,
        _ => Texture::Galvanized,
    };
    let material = Material::matte([0.4, 0.42, 0.37], texture, 12345);
    let mut memo = NoiseCache::new();
    let footprint_m = 0.000_26_f32;
    let mut sum = 0.0_f32;
    if std::env::args().nth(2).as_deref() == Some("lanes") {
        // The renderer's batched path: 8 points of a tile row at once.
        let px_per_m = 1.0 / footprint_m;
        for tile_row in 0..64 {
            for tile_col in 0..80 {
                for r in 0..16 {
                    for c0 in [0, 8] {
                        let uv: [[f64; 2]; 8] = std::array::from_fn(|i| {
                            [
                                0.3 + f64::from(tile_col * 16 + c0 + i as u32)
                                    * f64::from(footprint_m),
                                0.2 + f64::from(tile_row * 16 + r) * f64::from(footprint_m),
                            ]
                        });
                        let a = material.albedo_lanes(
                            simd::max_level(),
                            black_box(&uv),
                            1,
                            &[px_per_m; 8],
                            &mut memo,
                        );
                        sum += a.iter().map(|c| c[0] + c[1] + c[2]).sum::<f32>();
                    }
                }
            }
        }
        println!("mean albedo {}", sum / (3.0 * 1280.0 * 1024.0));
        return;
    }
    for tile_row in 0..64 {
        for tile_col in 0..80 {
            for r in 0..16 {
                for c in 0..16 {
                    let u = 0.3 + f64::from(tile_col * 16 + c) * f64::from(footprint_m);
                    let v = 0.2 + f64::from(tile_row * 16 + r) * f64::from(footprint_m);
                    let a = material.albedo_cached(black_box([u, v]), 1, footprint_m, &mut memo);
                    sum += a[0] + a[1] + a[2];
                }
            }
        }
    }
    println!("mean albedo {}", sum / (3.0 * 1280.0 * 1024.0));
}
