//! Brute-force Hamming matching of 486-bit M-LDB descriptors with Lowe's ratio test.
//!
//! `d(a, b) = sum_k popcount(a_k XOR b_k)` over the eight 64-bit words. For each query the
//! nearest train descriptor (ties to the lowest index, as OpenCV's `BFMatcher`) and the
//! second-nearest distance are found; the match is kept when `d1 < ratio * d2` (Lowe, IJCV
//! 2004 sec. 7.1) and `d1 <= max_distance`. Queries are independent, so splitting them over
//! rayon gives the same output for any thread count.

use rayon::prelude::*;

use super::mldb::{MldbDescriptor, hamming486};
use crate::features::Match;

/// Queries per rayon task.
const CHUNK: usize = 32;

/// Options of [`match_mldb`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MldbMatchParams {
    /// Lowe's ratio: keep `d1 < ratio * d2` (default `Some(0.8)`, the AKAZE authors'
    /// and OpenCV tutorial's value for M-LDB).
    pub ratio: Option<f32>,
    /// Drop matches farther than this many bits (default 486 = keep all).
    pub max_distance: u32,
    /// Spread queries over the rayon pool (default true; results do not depend on it).
    pub parallel: bool,
}

impl Default for MldbMatchParams {
    fn default() -> Self {
        Self {
            ratio: Some(0.8),
            max_distance: 486,
            parallel: true,
        }
    }
}

fn best_two(q: &MldbDescriptor, train: &[MldbDescriptor]) -> (u32, u32, u32) {
    let (mut i1, mut d1, mut d2) = (u32::MAX, u32::MAX, u32::MAX);
    for (j, t) in train.iter().enumerate() {
        let d = hamming486(q, t);
        if d < d1 {
            d2 = d1;
            d1 = d;
            i1 = j as u32;
        } else if d < d2 {
            d2 = d;
        }
    }
    (i1, d1, d2)
}

/// Matches each descriptor of `a` to its nearest neighbour in `b` (module docs), in query
/// order.
pub fn match_mldb(
    a: &[MldbDescriptor],
    b: &[MldbDescriptor],
    params: &MldbMatchParams,
) -> Vec<Match> {
    let keep = |qi: usize, q: &MldbDescriptor| -> Option<Match> {
        let (i1, d1, d2) = best_two(q, b);
        if i1 == u32::MAX || d1 > params.max_distance {
            return None;
        }
        if let Some(r) = params.ratio
            && (d2 == u32::MAX || (d1 as f32) >= r * d2 as f32)
        {
            return None;
        }
        Some(Match {
            query: qi as u32,
            train: i1,
            distance: d1,
        })
    };
    if params.parallel {
        a.par_chunks(CHUNK)
            .enumerate()
            .flat_map_iter(|(c, qs)| {
                qs.iter()
                    .enumerate()
                    .filter_map(move |(k, q)| keep(c * CHUNK + k, q))
            })
            .collect()
    } else {
        a.iter()
            .enumerate()
            .filter_map(|(i, q)| keep(i, q))
            .collect()
    }
}
