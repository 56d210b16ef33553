//! Learns the 256 rBRIEF tests of `calib/src/features/brief_pattern.rs` the way the ORB
//! paper does (Rublee et al., ICCV 2011, section 4.3), on synthetic images regenerated here
//! from fixed seeds (no external data, so the table carries no data licence):
//!
//! 1. Training keypoints: ORB keypoints (FAST + Harris + quadtree, intensity-centroid angle)
//!    of 16 seeded textured scenes plus seeded noise, at full and half size.
//! 2. Candidates: 12000 seeded random pairs of 5x5 sub-windows inside the 31x31 patch
//!    (window centres in [-13, 13]^2, the two windows not overlapping). A test compares the
//!    smoothed image (7x7 Gaussian, standing in for the 5x5 window mean) at the two centres
//!    rotated by the keypoint angle, exactly as the descriptor does.
//! 3. Each test is run on every keypoint; tests are ordered by |mean - 0.5|.
//! 4. Greedy search: keep a test if its |Pearson correlation| with every kept test is below
//!    a threshold; if fewer than 256 are kept, raise the threshold by 0.02 and start again.
//!
//! Run: `cargo run -p calib --example learn_brief_pattern -- calib/src/features/brief_pattern.rs`

use calib::features::gray::{BlurScratch, GrayBuf, ResizeScratch, gaussian_blur7, resize_bilinear};
use calib::features::synth::{SplitMix64, textured_image};
use calib::features::{OrbParams, detect_and_describe};

const N_CANDIDATES: usize = 12_000;
const N_TESTS: usize = 256;
const R: i64 = 13;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out_path = std::env::args().nth(1);
    // 1. Training keypoints and their smoothed images.
    let mut samples: Vec<(usize, usize, usize, f32)> = Vec::new(); // image, x, y, angle
    let mut blurred: Vec<GrayBuf> = Vec::new();
    let params = OrbParams {
        n_features: 800,
        n_levels: 1,
        ..OrbParams::default()
    };
    for seed in 0..16u64 {
        let mut full = textured_image(640, 480, 1000 + seed);
        // Sensor-like noise (sum of three uniforms, sigma ~4.5 gray levels): real images
        // have no perfectly flat areas, where `<` would bias tests towards 0.
        let mut noise = SplitMix64::new(2000 + seed);
        for p in &mut full.data {
            let n = (noise.next_f64() + noise.next_f64() + noise.next_f64() - 1.5) * 9.0;
            *p = (f64::from(*p) + n).round().clamp(0.0, 255.0) as u8;
        }
        let mut half = GrayBuf::default();
        half.reshape(320, 240);
        resize_bilinear(&full.view(), &mut half, &mut ResizeScratch::default());
        for img in [full, half] {
            let f = detect_and_describe(&img.view(), &params)?;
            let mut b = GrayBuf::default();
            gaussian_blur7(&img.view(), &mut b, &mut BlurScratch::default());
            let id = blurred.len();
            for k in &f.keypoints {
                samples.push((id, k.x as usize, k.y as usize, k.angle_rad));
            }
            blurred.push(b);
        }
    }
    let n = samples.len();
    let words = n.div_ceil(64);
    eprintln!("{n} training keypoints from {} images", blurred.len());
    // 2. Candidate tests.
    let mut rng = SplitMix64::new(0x0B5E_ED01);
    let mut cands: Vec<[i64; 4]> = Vec::new();
    let mut seen = std::collections::BTreeSet::new();
    while cands.len() < N_CANDIDATES {
        let mut c = || (rng.next_u64() % (2 * R + 1) as u64) as i64 - R; // modulo: the committed pattern was drawn so
        let t = [c(), c(), c(), c()];
        if (t[0] - t[2]).abs() < 5 && (t[1] - t[3]).abs() < 5 {
            continue;
        }
        if seen.insert(t) {
            cands.push(t);
        }
    }
    // 3. Run every test on every keypoint (bit sets), order by |mean - 0.5|.
    let mut bits = vec![0u64; N_CANDIDATES * words];
    for (s, &(id, x, y, angle)) in samples.iter().enumerate() {
        let img = &blurred[id];
        let (sn, cs) = (f64::from(angle).sin(), f64::from(angle).cos());
        let at = |px: i64, py: i64| -> u8 {
            let (px, py) = (px as f64, py as f64);
            let ix = x as i64 + (px * cs - py * sn).round() as i64;
            let iy = y as i64 + (px * sn + py * cs).round() as i64;
            img.data
                .get(iy as usize * img.width + ix as usize)
                .copied()
                .unwrap_or(0)
        };
        for (c, t) in cands.iter().enumerate() {
            if at(t[0], t[1]) < at(t[2], t[3]) {
                bits[c * words + s / 64] |= 1 << (s % 64);
            }
        }
    }
    let ones: Vec<u32> = (0..N_CANDIDATES)
        .map(|c| {
            bits[c * words..(c + 1) * words]
                .iter()
                .map(|w| w.count_ones())
                .sum()
        })
        .collect();
    let mean = |c: usize| f64::from(ones[c]) / n as f64;
    let mut order: Vec<usize> = (0..N_CANDIDATES)
        .filter(|&c| ones[c] > 0 && ones[c] < n as u32)
        .collect();
    order.sort_by(|&a, &b| {
        (mean(a) - 0.5)
            .abs()
            .total_cmp(&(mean(b) - 0.5).abs())
            .then(a.cmp(&b))
    });
    let corr = |a: usize, b: usize| -> f64 {
        let both: u32 = bits[a * words..(a + 1) * words]
            .iter()
            .zip(&bits[b * words..(b + 1) * words])
            .map(|(x, y)| (x & y).count_ones())
            .sum();
        let (ma, mb) = (mean(a), mean(b));
        (f64::from(both) / n as f64 - ma * mb) / (ma * (1.0 - ma) * mb * (1.0 - mb)).sqrt()
    };
    // 4. Greedy decorrelated selection.
    let mut threshold = 0.2;
    let chosen = loop {
        let mut kept: Vec<usize> = Vec::with_capacity(N_TESTS);
        for &c in &order {
            if kept.iter().all(|&k| corr(c, k).abs() < threshold) {
                kept.push(c);
                if kept.len() == N_TESTS {
                    break;
                }
            }
        }
        if kept.len() == N_TESTS {
            break kept;
        }
        eprintln!(
            "threshold {threshold:.2}: only {} tests, raising",
            kept.len()
        );
        threshold += 0.02;
    };
    let worst_mean = chosen
        .iter()
        .map(|&c| (mean(c) - 0.5).abs())
        .fold(0.0, f64::max);
    let mut table = String::new();
    table.push_str(&format!(
        "//! The 256 steered-BRIEF tests, learned as in Rublee et al., ICCV 2011, section 4.3.\n\
//!\n\
//! GENERATED by `cargo run -p calib --example learn_brief_pattern -- \\\n\
//! calib/src/features/brief_pattern.rs`; do not edit. Training: {n} ORB keypoints of 32\n\
//! seeded synthetic scenes (`features::synth::textured_image`, seeds 1000..1015, 640x480\n\
//! and half size, plus seeded noise); {N_CANDIDATES} seeded candidate pairs of non-overlapping 5x5 windows in\n\
//! the 31x31 patch; ordered by |mean - 0.5|; greedily kept when |correlation| with every\n\
//! kept test < {threshold:.2}. Largest |mean - 0.5| kept: {worst_mean:.3}. Being learned\n\
//! from generated images, the table is original to rodlog (no third-party data or code).\n\n\
/// Test `i` is `[x1, y1, x2, y2]`: bit `i` = `I(R (x1, y1)) < I(R (x2, y2))` on the\n\
/// smoothed image, `R` the keypoint's rotation. Coordinates are within `[-13, 13]`.\n\
pub const BRIEF_PATTERN: [[i8; 4]; 256] = [\n"
    ));
    for &c in &chosen {
        let t = cands[c];
        table.push_str(&format!(
            "    [{}, {}, {}, {}], // mean {:.3}\n",
            t[0],
            t[1],
            t[2],
            t[3],
            mean(c)
        ));
    }
    table.push_str("];\n");
    match out_path {
        Some(p) => std::fs::write(&p, table)?,
        None => print!("{table}"),
    }
    eprintln!(
        "kept {N_TESTS} tests at |corr| < {threshold:.2}, worst |mean - 0.5| {worst_mean:.3}"
    );
    Ok(())
}
