//! Brute-force Hamming matching of binary descriptors.
//!
//! The distance of two 256-bit descriptors is `d(a, b) = sum_k popcount(a_k XOR b_k)` over
//! their four 64-bit words (`u64::count_ones`, one `popcnt` with the workspace's
//! `target-cpu=x86-64-v2`). Every query is compared with every train descriptor; its best
//! match is the smallest distance, ties going to the lowest train index (as OpenCV's
//! `BFMatcher`). Options: Lowe's ratio test `d1 < ratio * d2` (Lowe, IJCV 2004), a maximum
//! distance, and the cross check (keep `i -> j` only when `j`'s best match in `a` is `i`).
//! The train set is transposed so the distances of one query to a block of train
//! descriptors vectorise, run at the CPU's best vector level ([`super::simd`]); with
//! `parallel`, blocks of queries go to rayon, and since each query's result
//! depends only on that query, the output is the same for any thread count.

use rayon::prelude::*;

use super::Descriptor;

/// Queries per rayon task.
const CHUNK: usize = 64;

/// Hamming distance of two descriptors.
#[inline]
pub fn hamming(a: &Descriptor, b: &Descriptor) -> u32 {
    (a.0[0] ^ b.0[0]).count_ones()
        + (a.0[1] ^ b.0[1]).count_ones()
        + (a.0[2] ^ b.0[2]).count_ones()
        + (a.0[3] ^ b.0[3]).count_ones()
}

/// A match `a[query] <-> b[train]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Match {
    /// Index into the first (query) set.
    pub query: u32,
    /// Index into the second (train) set.
    pub train: u32,
    /// Hamming distance, bits.
    pub distance: u32,
}

/// Options of [`match_brute_force`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MatchParams {
    /// Keep only mutual best matches (default false; GMS wants all nearest neighbours).
    pub cross_check: bool,
    /// Lowe's ratio: keep `d1 < ratio * d2` (default `None`).
    pub ratio: Option<f32>,
    /// Drop matches farther than this many bits (default 256 = keep all).
    pub max_distance: u32,
    /// Spread queries over the rayon pool (default true; results do not depend on it).
    pub parallel: bool,
}

impl Default for MatchParams {
    fn default() -> Self {
        Self {
            cross_check: false,
            ratio: None,
            max_distance: 256,
            parallel: true,
        }
    }
}

/// Best and second-best distances of one query.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Best {
    index: u32,
    d1: u32,
    d2: u32,
}

const NONE: Best = Best {
    index: u32::MAX,
    d1: u32::MAX,
    d2: u32::MAX,
};

#[inline]
fn update(best: &mut Best, d: u32, j: u32) {
    if d < best.d1 {
        best.d2 = best.d1;
        best.d1 = d;
        best.index = j;
    } else if d < best.d2 {
        best.d2 = d;
    }
}

/// Train descriptors per [`TRAIN_CHUNK`] block of the kernel.
const TRAIN_CHUNK: usize = 64;

/// Train descriptors transposed (structure of arrays): `words[k][j]` is word `k` of train
/// descriptor `j`, so the distances of one query to consecutive train descriptors are
/// lane-wise XOR + popcount + add over contiguous words (vectorised: `vpopcntq` on
/// AVX-512, a nibble-table popcount on AVX2/SSSE3).
struct SoaTrain {
    words: [Vec<u64>; 4],
}

impl SoaTrain {
    fn new(train: &[Descriptor]) -> Self {
        Self {
            words: std::array::from_fn(|k| train.iter().map(|d| d.0[k]).collect()),
        }
    }
}

/// Nearest and second-nearest train descriptor for each query of `queries`. The train set
/// is scanned in blocks of [`TRAIN_CHUNK`]: the block's distances are computed lane-wise,
/// and only a block whose minimum beats the current second-best distance is walked in
/// index order by [`update`], so the result (ties to the lowest index) is exactly the one
/// of the plain sequential scan.
#[inline(always)]
fn best_two(queries: &[Descriptor], train: &SoaTrain, out: &mut [Best]) {
    let [w0, w1, w2, w3] = &train.words;
    let n = w0.len().min(w1.len()).min(w2.len()).min(w3.len());
    let mut dist = [0u32; TRAIN_CHUNK];
    for (q, o) in queries.iter().zip(out.iter_mut()) {
        let [q0, q1, q2, q3] = q.0;
        let mut b = NONE;
        let mut start = 0;
        while start < n {
            let end = (start + TRAIN_CHUNK).min(n);
            let (a0, a1, a2, a3) = (
                &w0[start..end],
                &w1[start..end],
                &w2[start..end],
                &w3[start..end],
            );
            let dist = &mut dist[..end - start];
            for (i, d) in dist.iter_mut().enumerate() {
                *d = (q0 ^ a0[i]).count_ones()
                    + (q1 ^ a1[i]).count_ones()
                    + (q2 ^ a2[i]).count_ones()
                    + (q3 ^ a3[i]).count_ones();
            }
            let min = dist.iter().copied().fold(u32::MAX, u32::min);
            if min < b.d2 {
                for (i, &d) in dist.iter().enumerate() {
                    update(&mut b, d, (start + i) as u32);
                }
            }
            start = end;
        }
        *o = b;
    }
}

/// [`best_two`] as a [`simd::Kernel`].
struct BestTwo<'a> {
    queries: &'a [Descriptor],
    train: &'a SoaTrain,
    out: &'a mut [Best],
}

impl simd::Kernel for BestTwo<'_> {
    type Output = ();
    #[inline(always)]
    fn run(self) {
        best_two(self.queries, self.train, self.out);
    }
}

fn all_best(
    queries: &[Descriptor],
    train: &[Descriptor],
    parallel: bool,
    level: simd::Level,
) -> Vec<Best> {
    let mut out = vec![NONE; queries.len()];
    let soa = SoaTrain::new(train);
    let run = |o: &mut [Best], q: &[Descriptor]| {
        simd::dispatch_at(
            level,
            BestTwo {
                queries: q,
                train: &soa,
                out: o,
            },
        );
    };
    if parallel {
        out.par_chunks_mut(CHUNK)
            .zip(queries.par_chunks(CHUNK))
            .for_each(|(o, q)| run(o, q));
    } else {
        for (o, q) in out.chunks_mut(CHUNK).zip(queries.chunks(CHUNK)) {
            run(o, q);
        }
    }
    out
}

/// Matches every descriptor of `a` to its nearest neighbour in `b` (module docs), in
/// ascending query order; queries failing an option are left out.
pub fn match_brute_force(a: &[Descriptor], b: &[Descriptor], params: &MatchParams) -> Vec<Match> {
    if a.is_empty() || b.is_empty() {
        return Vec::new();
    }
    let level = simd::max_level();
    let ab = all_best(a, b, params.parallel, level);
    let ba = if params.cross_check {
        all_best(b, a, params.parallel, level)
    } else {
        Vec::new()
    };
    ab.iter()
        .enumerate()
        .filter_map(|(i, best)| {
            if best.index == u32::MAX || best.d1 > params.max_distance {
                return None;
            }
            if let Some(r) = params.ratio {
                // With a single train descriptor there is no second one: d2 = MAX passes.
                if best.d2 != u32::MAX && (best.d1 as f32) >= r * best.d2 as f32 {
                    return None;
                }
            }
            if params.cross_check && ba.get(best.index as usize).map(|x| x.index) != Some(i as u32)
            {
                return None;
            }
            Some(Match {
                query: i as u32,
                train: best.index,
                distance: best.d1,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg_descs(n: usize, seed: u64) -> Vec<Descriptor> {
        let mut s = seed;
        (0..n)
            .map(|_| {
                Descriptor(std::array::from_fn(|_| {
                    s = s
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    s
                }))
            })
            .collect()
    }

    #[test]
    fn hamming_counts_bits() {
        let a = Descriptor([0, 0, 0, 0]);
        let b = Descriptor([1, 3, 0, u64::MAX]);
        assert_eq!(hamming(&a, &b), 1 + 2 + 64);
    }

    #[test]
    fn finds_exact_copies_and_matches_naive() {
        let a = lcg_descs(37, 1);
        let mut b = lcg_descs(50, 2);
        b[17] = a[5];
        let m = match_brute_force(&a, &b, &MatchParams::default());
        assert_eq!(m.len(), 37);
        assert_eq!(
            m[5],
            Match {
                query: 5,
                train: 17,
                distance: 0
            }
        );
        for mm in &m {
            let q = &a[mm.query as usize];
            let naive = b
                .iter()
                .enumerate()
                .min_by_key(|(j, t)| (hamming(q, t), *j))
                .map(|(j, _)| j as u32);
            assert_eq!(Some(mm.train), naive);
        }
        let seq = match_brute_force(
            &a,
            &b,
            &MatchParams {
                parallel: false,
                ..Default::default()
            },
        );
        assert_eq!(m, seq);
    }

    #[test]
    fn every_simd_level_equals_the_naive_scan_with_ties() {
        // Few distinct descriptors, so distances tie often; sizes not multiples of the block.
        let base = lcg_descs(7, 5);
        let pick = |n: usize, seed: u64| -> Vec<Descriptor> {
            let idx = lcg_descs(n, seed);
            idx.iter().map(|d| base[(d.0[0] % 7) as usize]).collect()
        };
        let a = pick(131, 6);
        let mut b = pick(197, 7);
        b.extend(lcg_descs(70, 8));
        let want: Vec<Best> = a
            .iter()
            .map(|q| {
                let mut best = NONE;
                for (j, t) in b.iter().enumerate() {
                    update(&mut best, hamming(q, t), j as u32);
                }
                best
            })
            .collect();
        for level in [
            simd::Level::Baseline,
            simd::Level::Avx2,
            simd::Level::Avx512,
        ] {
            assert_eq!(all_best(&a, &b, false, level), want, "{level:?}");
            assert_eq!(all_best(&a, &b, true, level), want, "{level:?}");
        }
    }

    #[test]
    fn cross_check_and_ratio_filter() {
        let a = lcg_descs(40, 3);
        let mut b = lcg_descs(40, 4);
        b[0] = a[0];
        let cc = match_brute_force(
            &a,
            &b,
            &MatchParams {
                cross_check: true,
                ..Default::default()
            },
        );
        assert!(cc.contains(&Match {
            query: 0,
            train: 0,
            distance: 0
        }));
        for m in &cc {
            let back = match_brute_force(
                &b[m.train as usize..=m.train as usize],
                &a,
                &MatchParams::default(),
            );
            assert_eq!(back[0].train, m.query);
        }
        let r = match_brute_force(
            &a,
            &b,
            &MatchParams {
                ratio: Some(0.5),
                ..Default::default()
            },
        );
        assert_eq!(
            r,
            vec![Match {
                query: 0,
                train: 0,
                distance: 0
            }]
        );
    }
}
