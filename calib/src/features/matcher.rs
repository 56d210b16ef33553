//! Brute-force Hamming matching of binary descriptors.
//!
//! The distance of two 256-bit descriptors is `d(a, b) = sum_k popcount(a_k XOR b_k)` over
//! their four 64-bit words (`u64::count_ones`, one `popcnt` with the workspace's
//! `target-cpu=x86-64-v2`). Every query is compared with every train descriptor; its best
//! match is the smallest distance, ties going to the lowest train index (as OpenCV's
//! `BFMatcher`). Options: Lowe's ratio test `d1 < ratio * d2` (Lowe, IJCV 2004), a maximum
//! distance, and the cross check (keep `i -> j` only when `j`'s best match in `a` is `i`).
//! Queries are processed in blocks of four (each train descriptor is loaded once per
//! block); with `parallel`, blocks of queries go to rayon, and since each query's result
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

/// Nearest and second-nearest train descriptor for each query of `queries`.
fn best_two(queries: &[Descriptor], train: &[Descriptor], out: &mut [Best]) {
    let mut qi = 0;
    while qi + 4 <= queries.len() {
        let (q0, q1, q2, q3) = (
            queries[qi].0,
            queries[qi + 1].0,
            queries[qi + 2].0,
            queries[qi + 3].0,
        );
        let mut b = [NONE; 4];
        for (j, t) in train.iter().enumerate() {
            let t = t.0;
            let d = |q: [u64; 4]| {
                (q[0] ^ t[0]).count_ones()
                    + (q[1] ^ t[1]).count_ones()
                    + (q[2] ^ t[2]).count_ones()
                    + (q[3] ^ t[3]).count_ones()
            };
            let j = j as u32;
            update(&mut b[0], d(q0), j);
            update(&mut b[1], d(q1), j);
            update(&mut b[2], d(q2), j);
            update(&mut b[3], d(q3), j);
        }
        out[qi..qi + 4].copy_from_slice(&b);
        qi += 4;
    }
    for (q, o) in queries[qi..].iter().zip(out[qi..].iter_mut()) {
        let mut b = NONE;
        for (j, t) in train.iter().enumerate() {
            update(&mut b, hamming(q, t), j as u32);
        }
        *o = b;
    }
}

fn all_best(queries: &[Descriptor], train: &[Descriptor], parallel: bool) -> Vec<Best> {
    let mut out = vec![NONE; queries.len()];
    if parallel {
        out.par_chunks_mut(CHUNK)
            .zip(queries.par_chunks(CHUNK))
            .for_each(|(o, q)| best_two(q, train, o));
    } else {
        for (o, q) in out.chunks_mut(CHUNK).zip(queries.chunks(CHUNK)) {
            best_two(q, train, o);
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
    let ab = all_best(a, b, params.parallel);
    let ba = if params.cross_check {
        all_best(b, a, params.parallel)
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
