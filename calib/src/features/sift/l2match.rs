//! Brute-force L2 matching of SIFT descriptors with Lowe's ratio test (Lowe 2004, sec. 7.1:
//! keep a match when its distance is below 0.8 times the second nearest).
//!
//! Distances are squared L2, `d^2(a, b) = sum_k (a_k - b_k)^2` over the 128 entries, summed
//! in `f32` in eight lanes (a loop the compiler vectorises). Descriptor entries are integers
//! in `0..=255`, so every partial sum is an integer below `2^24` and exact in `f32`: the
//! distance does not depend on the summation order and is returned exactly as a `u32` in
//! [`Match::distance`]. The ratio test on squared distances is `d1^2 < ratio^2 d2^2`. The
//! best train index is the smallest distance, ties to the lower index (OpenCV's
//! `BFMatcher`). Queries are split into blocks for rayon and each query's result depends
//! only on that query, so the output does not depend on the thread count.

use rayon::prelude::*;

use super::SiftDescriptor;
use crate::features::Match;

/// Queries per rayon task.
const CHUNK: usize = 32;

/// Options of [`match_l2_ratio`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SiftMatchParams {
    /// Lowe's ratio on (unsquared) L2 distances: keep `d1 < ratio * d2` (default `Some(0.8)`,
    /// Lowe sec. 7.1; OpenCV's tutorials use 0.7-0.75). A query with a single train
    /// candidate passes.
    pub ratio: Option<f32>,
    /// Keep only mutual nearest neighbours (default false).
    pub cross_check: bool,
    /// Spread queries over the rayon pool (default true; results do not depend on it).
    pub parallel: bool,
}

impl Default for SiftMatchParams {
    fn default() -> Self {
        Self {
            ratio: Some(0.8),
            cross_check: false,
            parallel: true,
        }
    }
}

/// Squared L2 distance of two descriptors (exact for integer-valued descriptors).
#[inline]
pub fn l2_squared(a: &SiftDescriptor, b: &SiftDescriptor) -> f32 {
    let mut acc = [0.0f32; 8];
    for (ca, cb) in a.chunks_exact(8).zip(b.chunks_exact(8)) {
        for k in 0..8 {
            let d = ca[k] - cb[k];
            acc[k] += d * d;
        }
    }
    ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7]))
}

/// Nearest and second-nearest squared distances of one query.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Best {
    index: u32,
    d1: f32,
    d2: f32,
}

/// The nearest and second-nearest train descriptors of one query.
fn nearest(q: &SiftDescriptor, train: &[SiftDescriptor]) -> Best {
    let mut best = Best {
        index: u32::MAX,
        d1: f32::INFINITY,
        d2: f32::INFINITY,
    };
    for (j, t) in train.iter().enumerate() {
        let d = l2_squared(q, t);
        if d < best.d1 {
            best.d2 = best.d1;
            best.d1 = d;
            best.index = j as u32;
        } else if d < best.d2 {
            best.d2 = d;
        }
    }
    best
}

fn all_nearest(a: &[SiftDescriptor], b: &[SiftDescriptor], parallel: bool) -> Vec<Best> {
    if parallel {
        a.par_chunks(CHUNK)
            .flat_map_iter(|chunk| chunk.iter().map(|q| nearest(q, b)))
            .collect()
    } else {
        a.iter().map(|q| nearest(q, b)).collect()
    }
}

/// Matches every descriptor of `a` (query) to its nearest neighbour in `b` (train), keeping
/// those passing the ratio test and, when asked, the cross check (module docs).
/// `Match::distance` is the squared L2 distance.
pub fn match_l2_ratio(
    a: &[SiftDescriptor],
    b: &[SiftDescriptor],
    params: &SiftMatchParams,
) -> Vec<Match> {
    if a.is_empty() || b.is_empty() {
        return Vec::new();
    }
    let fwd = all_nearest(a, b, params.parallel);
    let back = if params.cross_check {
        Some(all_nearest(b, a, params.parallel))
    } else {
        None
    };
    let r2 = params.ratio.map(|r| r * r);
    fwd.iter()
        .enumerate()
        .filter(|(_, best)| match r2 {
            Some(r2) => best.d2.is_infinite() || best.d1 < r2 * best.d2,
            None => true,
        })
        .filter(|(i, best)| match &back {
            Some(back) => back
                .get(best.index as usize)
                .is_some_and(|bb| bb.index as usize == *i),
            None => true,
        })
        .map(|(i, best)| Match {
            query: i as u32,
            train: best.index,
            distance: best.d1 as u32,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn desc(seed: u64) -> SiftDescriptor {
        let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        let mut d = [0.0f32; 128];
        for v in d.iter_mut() {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            *v = (s % 256) as f32;
        }
        d
    }

    #[test]
    fn distance_is_exact_integer() {
        let (a, b) = (desc(1), desc(2));
        let exact: i64 = a
            .iter()
            .zip(&b)
            .map(|(x, y)| {
                let d = *x as i64 - *y as i64;
                d * d
            })
            .sum();
        assert_eq!(l2_squared(&a, &b) as i64, exact);
    }

    #[test]
    fn ratio_test_keeps_distinct_and_drops_ambiguous() {
        let train: Vec<SiftDescriptor> = (0..50).map(desc).collect();
        // Query 0: a slightly perturbed copy of train 7 (distinct). Query 1: midway between
        // train 3 and 4 (ambiguous).
        let mut q0 = train[7];
        q0[0] = (q0[0] + 3.0).min(255.0);
        let mut q1 = [0.0f32; 128];
        for (k, v) in q1.iter_mut().enumerate() {
            *v = ((train[3][k] + train[4][k]) * 0.5).round();
        }
        let m = match_l2_ratio(&[q0, q1], &train, &SiftMatchParams::default());
        assert_eq!(m.len(), 1);
        assert_eq!((m[0].query, m[0].train), (0, 7));
        let none = SiftMatchParams {
            ratio: None,
            ..Default::default()
        };
        assert_eq!(match_l2_ratio(&[q0, q1], &train, &none).len(), 2);
    }

    #[test]
    fn parallel_equals_sequential_and_cross_check_is_mutual() {
        let a: Vec<SiftDescriptor> = (0..300).map(desc).collect();
        let b: Vec<SiftDescriptor> = (150..500).map(desc).collect();
        let p = SiftMatchParams {
            ratio: None,
            cross_check: true,
            parallel: true,
        };
        let par = match_l2_ratio(&a, &b, &p);
        let seq = match_l2_ratio(
            &a,
            &b,
            &SiftMatchParams {
                parallel: false,
                ..p
            },
        );
        assert_eq!(par, seq);
        // Identical descriptors a[150..300] == b[0..150] are mutual nearest (distance 0).
        let zero = par.iter().filter(|m| m.distance == 0).count();
        assert_eq!(zero, 150);
        assert!(
            par.iter()
                .all(|m| m.distance != 0 || m.query == m.train + 150)
        );
    }
}
