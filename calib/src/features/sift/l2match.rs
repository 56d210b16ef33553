//! Brute-force L2 matching of SIFT descriptors with Lowe's ratio test (Lowe 2004, sec. 7.1:
//! keep a match when its distance is below 0.8 times the second nearest).
//!
//! Distances are squared L2, `d^2(a, b) = |a|^2 + |b|^2 - 2 a.b` over the 128 entries.
//! Descriptor entries are integers in `0..=255`, so `a.b <= 128 * 255^2 < 2^23` and
//! `|a|^2 + |b|^2 < 2^24`: every partial sum and the result are integers exact in `f32`, the
//! distance does not depend on the summation order (or on the vector width the kernel runs
//! at) and equals [`l2_squared`]'s `sum_k (a_k - b_k)^2` exactly; it is returned as a `u32`
//! in [`Match::distance`]. The ratio test on squared distances is `d1^2 < ratio^2 d2^2`. The
//! best train index is the smallest distance, ties to the lower index (OpenCV's
//! `BFMatcher`).
//!
//! Kernel ([`BlockedTrain`], [`best_two`]): the dot-product form makes the scan a small
//! matrix product. Train descriptors are stored in blocks of [`BLOCK`], dimension-major
//! within a block, and [`QUERY_TILE`] queries share each block: for every entry `k`, each
//! query adds `q_k` times the block's row `k` to its row of dot products, a contiguous loop
//! the compiler vectorises (run with AVX-512 or AVX2 by [`simd::dispatch_at`]; the
//! `QUERY_TILE` x `BLOCK` accumulators stay in L1, each loaded train row serves every query
//! of the tile). A block whose minimum does not beat a query's second-best distance is
//! skipped, the others are walked in index order, so the result is exactly the plain
//! sequential scan's. Queries are split into blocks for rayon and each query's result
//! depends only on that query, so the output does not depend on the thread count.

use rayon::prelude::*;

use super::{SIFT_DESCRIPTOR_LEN, SiftDescriptor};
use crate::features::Match;

/// Queries per rayon task.
const CHUNK: usize = 32;
/// Train descriptors per block of the kernel.
const BLOCK: usize = 256;
/// Queries that share each loaded train block.
const QUERY_TILE: usize = 8;

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

const NONE: Best = Best {
    index: u32::MAX,
    d1: f32::INFINITY,
    d2: f32::INFINITY,
};

/// Books train descriptor `j` at squared distance `d` (a strict `<`: ties keep the lower
/// index, which was seen first).
#[inline(always)]
fn update(best: &mut Best, d: f32, j: u32) {
    if d < best.d1 {
        best.d2 = best.d1;
        best.d1 = d;
        best.index = j;
    } else if d < best.d2 {
        best.d2 = d;
    }
}

/// Squared norm `|a|^2` (exact, module docs).
#[inline(always)]
fn norm_squared(a: &SiftDescriptor) -> f32 {
    let mut acc = [0.0f32; 8];
    for c in a.chunks_exact(8) {
        for k in 0..8 {
            acc[k] += c[k] * c[k];
        }
    }
    ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7]))
}

/// Train descriptors in blocks of [`BLOCK`], dimension-major within a block:
/// `values[(b * 128 + k) * BLOCK + i]` is entry `k` of descriptor `b * BLOCK + i`, and
/// `norms[b * BLOCK + i]` its squared norm. The last block is padded with zero descriptors
/// of infinite norm, which are never nearest.
struct BlockedTrain {
    values: Vec<f32>,
    norms: Vec<f32>,
}

impl BlockedTrain {
    fn new(train: &[SiftDescriptor]) -> Self {
        let n = train.len().div_ceil(BLOCK);
        let mut values = vec![0.0f32; n * SIFT_DESCRIPTOR_LEN * BLOCK];
        let mut norms = vec![f32::INFINITY; n * BLOCK];
        let blocks = values.chunks_exact_mut(SIFT_DESCRIPTOR_LEN * BLOCK);
        for ((chunk, block), norm) in train
            .chunks(BLOCK)
            .zip(blocks)
            .zip(norms.chunks_exact_mut(BLOCK))
        {
            for (i, (d, nm)) in chunk.iter().zip(norm.iter_mut()).enumerate() {
                for (row, &v) in block.chunks_exact_mut(BLOCK).zip(d) {
                    if let Some(slot) = row.get_mut(i) {
                        *slot = v;
                    }
                }
                *nm = norm_squared(d);
            }
        }
        Self { values, norms }
    }
}

/// Nearest and second-nearest train descriptors of each query (module docs), written to
/// `out[q]`. The inner loops run over the lanes of a block (contiguous, vectorised); the
/// [`QUERY_TILE`] accumulator rows stay in L1.
#[inline(always)]
fn best_two(queries: &[SiftDescriptor], train: &BlockedTrain, out: &mut [Best]) {
    let mut dot = [[0.0f32; BLOCK]; QUERY_TILE];
    for (qs, os) in queries.chunks(QUERY_TILE).zip(out.chunks_mut(QUERY_TILE)) {
        let Some(first) = qs.first() else { continue };
        // A short last tile repeats its first query in the unused rows.
        let q: [&SiftDescriptor; QUERY_TILE] = std::array::from_fn(|r| qs.get(r).unwrap_or(first));
        let qn = q.map(norm_squared);
        let mut best = [NONE; QUERY_TILE];
        let blocks = train
            .values
            .chunks_exact(SIFT_DESCRIPTOR_LEN * BLOCK)
            .zip(train.norms.chunks_exact(BLOCK));
        for (b, (block, norms)) in blocks.enumerate() {
            for row in &mut dot {
                row.fill(0.0);
            }
            for (k, t) in block.chunks_exact(BLOCK).enumerate() {
                for (acc, qr) in dot.iter_mut().zip(&q) {
                    let x = qr[k];
                    for (a, &t) in acc.iter_mut().zip(t) {
                        *a += x * t;
                    }
                }
            }
            for ((best, acc), qn) in best.iter_mut().zip(&mut dot).zip(qn) {
                let mut min = f32::INFINITY;
                for (a, &nt) in acc.iter_mut().zip(norms) {
                    *a = (qn + nt) - 2.0 * *a;
                    min = min.min(*a);
                }
                if min < best.d2 {
                    for (i, &d) in acc.iter().enumerate() {
                        update(best, d, (b * BLOCK + i) as u32);
                    }
                }
            }
        }
        for (o, b) in os.iter_mut().zip(best) {
            *o = b;
        }
    }
}

/// [`best_two`] as a [`simd::Kernel`].
struct BestTwo<'a> {
    queries: &'a [SiftDescriptor],
    train: &'a BlockedTrain,
    out: &'a mut [Best],
}

impl simd::Kernel for BestTwo<'_> {
    type Output = ();
    #[inline(always)]
    fn run(self) {
        best_two(self.queries, self.train, self.out);
    }
}

fn all_nearest(a: &[SiftDescriptor], b: &[SiftDescriptor], parallel: bool) -> Vec<Best> {
    let level = simd::max_level();
    let train = BlockedTrain::new(b);
    let mut out = vec![NONE; a.len()];
    let run = |o: &mut [Best], q: &[SiftDescriptor]| {
        simd::dispatch_at(
            level,
            BestTwo {
                queries: q,
                train: &train,
                out: o,
            },
        );
    };
    if parallel {
        out.par_chunks_mut(CHUNK)
            .zip(a.par_chunks(CHUNK))
            .for_each(|(o, q)| run(o, q));
    } else {
        for (o, q) in out.chunks_mut(CHUNK).zip(a.chunks(CHUNK)) {
            run(o, q);
        }
    }
    out
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

    /// The plain sequential scan the kernel must reproduce exactly.
    fn naive_nearest(q: &SiftDescriptor, train: &[SiftDescriptor]) -> Best {
        let mut best = NONE;
        for (j, t) in train.iter().enumerate() {
            update(&mut best, l2_squared(q, t), j as u32);
        }
        best
    }

    /// The blocked kernel equals the sequential scan bit for bit at every vector level, for
    /// train sets that fill their last block exactly, by one, or leave it short, query
    /// counts that do not fill their last tile, and duplicates across blocks (ties go to
    /// the lower index).
    #[test]
    fn blocked_kernel_equals_the_sequential_scan_at_every_level() {
        let mut train: Vec<SiftDescriptor> =
            (0..2 * BLOCK as u64 + 1).map(|i| desc(1000 + i)).collect();
        // Duplicates in a later block than their originals.
        train[BLOCK + 3] = train[5];
        train[2 * BLOCK] = train[20];
        // Extreme entries: the norm bound of the module docs is reached.
        train[BLOCK - 1] = [255.0; 128];
        train[BLOCK] = [0.0; 128];
        let mut queries: Vec<SiftDescriptor> =
            (0..QUERY_TILE as u64 + 3).map(|i| desc(5000 + i)).collect();
        queries.push(train[20]);
        queries.push(train[5]);
        queries.push([0.0; 128]);
        queries.push([255.0; 128]);
        assert_ne!(queries.len() % QUERY_TILE, 0, "a short last tile");
        let dup = naive_nearest(&train[20], &train);
        assert_eq!(
            (dup.index, dup.d1),
            (20, 0.0),
            "a duplicate keeps the lower index"
        );
        for level in [
            simd::Level::Baseline,
            simd::Level::Avx2,
            simd::Level::Avx512,
        ] {
            for n_train in [1, 17, BLOCK - 1, BLOCK, BLOCK + 1, train.len()] {
                let t = &train[..n_train];
                let blocked = BlockedTrain::new(t);
                let mut out = vec![NONE; queries.len()];
                simd::dispatch_at(
                    level,
                    BestTwo {
                        queries: &queries,
                        train: &blocked,
                        out: &mut out,
                    },
                );
                let want: Vec<Best> = queries.iter().map(|q| naive_nearest(q, t)).collect();
                assert_eq!(out, want, "{level:?}, {n_train} train descriptors");
            }
        }
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
