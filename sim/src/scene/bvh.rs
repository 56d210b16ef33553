//! Bounding volume hierarchy over analytic primitives: binned SAH build, flattened nodes,
//! allocation-free traversal.
//!
//! Build (Wald, "On fast construction of SAH-based BVHs", RT 2007): at each node the primitive
//! centroids are binned into [`SAH_BINS`] bins along each axis and the split minimising
//! `C = C_trav + (A_L N_L + A_R N_R) / A` is taken (A = surface area, N = primitive count);
//! a node becomes a leaf when no split beats `N` (the cost of testing all its primitives) or
//! it holds <= [`MAX_LEAF_PRIMS`]. Degenerate case: all centroids equal on every axis -> leaf.
//!
//! Layout: depth-first array; an interior node's left child follows it, the right child index
//! is stored. Traversal keeps a fixed stack of [`STACK_DEPTH`] node indices on the call stack
//! and visits the nearer child first.
//!
//! Culling ([`Bvh::cull`]): for a bundle of rays contained in a convex volume given as slabs
//! `lo <= n.p <= hi`, a primitive can only be hit if its box overlaps every slab (interval
//! test `|n.c| +- |n|.h`, conservative); the renderer culls once per pixel tile and per
//! tile's shadow beam, then tests each ray against the few candidates only.

use nalgebra::{Point3, Vector3};

use super::primitives::{Aabb, BoxFromOrigin, Primitive, Ray};

/// Number of SAH bins per axis.
pub const SAH_BINS: usize = 12;
/// Largest leaf.
pub const MAX_LEAF_PRIMS: usize = 4;
/// Traversal stack size (the build caps the depth below it).
pub const STACK_DEPTH: usize = 64;
/// Cost of one traversal step relative to one primitive test.
const TRAVERSAL_COST: f64 = 1.0;

/// Padding of the f32 node boxes (m): covers the f32 rounding of box corners, ray origins
/// (world coordinates up to ~1 km) and inverse directions, so a node box never misses a
/// primitive the exact f64 test would hit.
const NODE_PAD_M: f64 = 2e-4;

/// 32-byte node with f32 bounds (the exact tests are the primitives', in f64).
#[derive(Clone, Copy, Debug)]
struct Node {
    lo: [f32; 3],
    /// Leaf: first primitive; interior: right child.
    index: u32,
    hi: [f32; 3],
    /// Leaf: primitive count (> 0); interior: 0.
    count: u32,
}

impl Node {
    fn new(b: &Aabb, index: u32, count: u32) -> Self {
        let lo = [0, 1, 2].map(|k| (b.min[k] - NODE_PAD_M) as f32);
        let hi = [0, 1, 2].map(|k| (b.max[k] + NODE_PAD_M) as f32);
        Self {
            lo,
            index,
            hi,
            count,
        }
    }

    /// Slab test in f32: entry distance if the ray meets the box before `t_max`.
    ///
    /// Plain comparisons (one `minss`/`maxss` each, no NaN handling): a NaN slab distance
    /// (`0 * inf`, a ray parallel to a slab and exactly on its plane) only ever loosens the
    /// interval, so the test stays conservative: it never rejects a box the ray meets.
    #[inline]
    fn hit(&self, o: &[f32; 3], inv: &[f32; 3], t_max: f32) -> Option<f32> {
        let mut t0 = 0.0_f32;
        let mut t1 = t_max;
        for k in 0..3 {
            let a = (self.lo[k] - o[k]) * inv[k];
            let b = (self.hi[k] - o[k]) * inv[k];
            let (near, far) = if a < b { (a, b) } else { (b, a) };
            t0 = if near > t0 { near } else { t0 };
            t1 = if far < t1 { far } else { t1 };
        }
        (t0 <= t1).then_some(t0)
    }
}

/// A BVH owning its (reordered) primitives.
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    nodes: Vec<Node>,
    prims: Vec<Primitive>,
    /// Padded f32 box of each primitive (`index` = the primitive), for culling.
    prim_boxes: Vec<Node>,
    bounds: Option<Aabb>,
}

/// One slab `lo <= normal . p <= hi` of a convex culling volume (world units; `lo`/`hi` may
/// be infinite).
#[derive(Clone, Copy, Debug)]
pub struct Slab {
    /// Slab normal (any length).
    pub normal: [f64; 3],
    /// Lower bound of `normal . p`.
    pub lo: f64,
    /// Upper bound of `normal . p`.
    pub hi: f64,
}

/// Primitives that a bundle of rays may hit, found by culling the hierarchy with a convex
/// volume containing every ray of the bundle (see [`Bvh::cull`]).
#[derive(Clone, Debug, Default)]
pub struct Candidates {
    /// Candidate boxes with a lower bound of the distance along any ray of the bundle to
    /// each (the distance between the box of ray origins and the candidate's box),
    /// ascending.
    boxes: Vec<(f64, Node)>,
    /// When the bundle's rays share one origin: that origin and, per candidate, its
    /// origin-only box-test terms (`None` for non-box shapes).
    shared_origin: Option<(Point3<f64>, Vec<Option<BoxFromOrigin>>)>,
    /// When the bundle's rays share one direction (shadow rays towards the sun): that
    /// direction and its f32 reciprocal for the slab tests (see [`Self::share_direction`]).
    shared_dir: Option<(Vector3<f64>, [f32; 3])>,
    /// More than the limit passed to [`Bvh::cull`] matched: traverse the hierarchy instead.
    overflow: bool,
    /// Movable objects whose world box overlaps the volume (filled by `Scene::cull`).
    pub(crate) objects: Vec<u32>,
}

impl Candidates {
    /// Number of candidates (meaningless when [`Self::overflowed`]).
    #[must_use]
    pub fn len(&self) -> usize {
        self.boxes.len()
    }

    /// Whether there are no candidates (and no overflow).
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.boxes.is_empty() && !self.overflow
    }

    /// Whether the culling gave up (too many candidates).
    #[must_use]
    pub fn overflowed(&self) -> bool {
        self.overflow
    }

    /// Declares that the bundle's rays share the direction `dir` (until the next cull), so
    /// any-hit searches take its slab-test reciprocal from here instead of dividing per
    /// ray (same values: a ray with another direction still computes its own).
    pub fn share_direction(&mut self, dir: &Vector3<f64>) {
        self.shared_dir = Some((*dir, f32_ray_inverse(dir)));
    }
}

/// Whether a node box overlaps every slab (conservative box-vs-slab interval test).
#[inline]
fn overlaps_slabs(n: &Node, slabs: &[Slab]) -> bool {
    box_overlaps_slabs(
        [0, 1, 2].map(|k| f64::from(n.lo[k])),
        [0, 1, 2].map(|k| f64::from(n.hi[k])),
        slabs,
    )
}

/// Whether the box `[lo, hi]` overlaps every slab (interval test `n.c +- |n|.h`).
#[inline]
pub(crate) fn box_overlaps_slabs(lo: [f64; 3], hi: [f64; 3], slabs: &[Slab]) -> bool {
    let c = [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]));
    let h = [0, 1, 2].map(|k| 0.5 * (hi[k] - lo[k]));
    slabs.iter().all(|s| {
        let d = s.normal[0] * c[0] + s.normal[1] * c[1] + s.normal[2] * c[2];
        let r = s.normal[0].abs() * h[0] + s.normal[1].abs() * h[1] + s.normal[2].abs() * h[2];
        d + r >= s.lo && d - r <= s.hi
    })
}

/// Closest hit in a BVH.
#[derive(Clone, Copy, Debug)]
pub struct BvhHit {
    /// Distance along the ray (m).
    pub t_m: f64,
    /// Index into [`Bvh::primitives`].
    pub prim: u32,
}

impl Bvh {
    /// Builds the hierarchy (primitives are reordered; the order is a deterministic function
    /// of the input).
    #[must_use]
    pub fn build(prims: Vec<Primitive>) -> Self {
        if prims.is_empty() {
            return Self::default();
        }
        let bounds: Vec<Aabb> = prims.iter().map(|p| p.shape.bounds()).collect();
        let centroids: Vec<[f64; 3]> = bounds.iter().map(Aabb::centroid).collect();
        let mut order: Vec<usize> = (0..prims.len()).collect();
        let mut nodes = Vec::with_capacity(2 * prims.len());
        let n = prims.len();
        let ctx = BuildCtx {
            bounds: &bounds,
            centroids: &centroids,
        };
        ctx.build(&mut nodes, &mut order, 0, n, 0);
        let mut all = Aabb::EMPTY;
        for b in &bounds {
            all.grow(b);
        }
        let prim_boxes = order
            .iter()
            .enumerate()
            .filter_map(|(k, &i)| Some(Node::new(bounds.get(i)?, k as u32, 1)))
            .collect();
        Self {
            nodes,
            prims: reorder(prims, &order),
            prim_boxes,
            bounds: Some(all),
        }
    }

    /// The (reordered) primitives.
    #[must_use]
    pub fn primitives(&self) -> &[Primitive] {
        &self.prims
    }

    /// Bounds of everything (empty box for an empty BVH).
    #[must_use]
    pub fn bounds(&self) -> Aabb {
        self.bounds.unwrap_or(Aabb::EMPTY)
    }

    /// Number of nodes.
    #[must_use]
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Closest hit with `t` in `(t_min, t_max)`.
    #[inline]
    #[must_use]
    pub fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<BvhHit> {
        let mut best: Option<BvhHit> = None;
        let mut t_best = t_max;
        self.traverse(
            ray,
            &mut t_best,
            |prim, t_hi| {
                let p = self.prims.get(prim as usize)?;
                let t = p.shape.intersect(ray, t_min, t_hi)?;
                best = Some(BvhHit { t_m: t, prim });
                Some(t)
            },
            false,
        );
        best
    }

    /// Whether anything is hit with `t` in `(t_min, t_max)` (any-hit, for shadows).
    #[inline]
    #[must_use]
    pub fn occluded(&self, ray: &Ray, t_min: f64, t_max: f64) -> bool {
        self.occluder(ray, t_min, t_max).is_some()
    }

    /// Some primitive hit with `t` in `(t_min, t_max)` (the first found, any-hit).
    #[inline]
    #[must_use]
    pub fn occluder(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<u32> {
        let mut t = t_max;
        let mut hit = None;
        self.traverse(
            ray,
            &mut t,
            |prim, t_hi| {
                let p = self.prims.get(prim as usize)?;
                let th = p.shape.intersect(ray, t_min, t_hi)?;
                hit = Some(prim);
                Some(th)
            },
            true,
        );
        hit
    }

    /// Collects into `out` every primitive whose (padded) box overlaps all `slabs`: when the
    /// slabs bound a bundle of rays, the closest and any hit of each ray over `out` equal
    /// those over the whole hierarchy. Gives up (`out.overflowed()`) beyond `limit`
    /// candidates. `origins_lo ..= origins_hi` is a box containing every ray origin of the
    /// bundle (one point for a camera's primary rays); candidates are sorted by the distance
    /// between that box and theirs, a lower bound of any ray's entry distance (nearest
    /// first, ties by primitive index), so closest-hit searches stop at the first candidate
    /// farther than the best hit.
    pub fn cull(
        &self,
        slabs: &[Slab],
        origins_lo: [f64; 3],
        origins_hi: [f64; 3],
        limit: usize,
        out: &mut Candidates,
    ) {
        out.boxes.clear();
        // Keep the per-candidate vector for reuse below (no allocation per tile).
        let recycled = out.shared_origin.take().map(|(_, pre)| pre);
        out.shared_dir = None;
        out.overflow = false;
        if self.nodes.is_empty() {
            return;
        }
        let mut stack = [0u32; STACK_DEPTH];
        let mut sp = 1usize;
        while sp > 0 {
            sp -= 1;
            let ni = stack[sp];
            let Some(node) = self.nodes.get(ni as usize) else {
                continue;
            };
            if !overlaps_slabs(node, slabs) {
                continue;
            }
            if node.count > 0 {
                let (a, b) = (node.index as usize, (node.index + node.count) as usize);
                for pb in self.prim_boxes.get(a..b).unwrap_or(&[]) {
                    if overlaps_slabs(pb, slabs) {
                        if out.boxes.len() >= limit {
                            out.overflow = true;
                            out.boxes.clear();
                            return;
                        }
                        out.boxes.push((0.0, *pb));
                    }
                }
            } else if sp + 2 <= STACK_DEPTH {
                // The left child follows its parent; the right one is stored.
                stack[sp] = node.index;
                stack[sp + 1] = ni + 1;
                sp += 2;
            }
        }
        // Box-to-box distance: per axis the gap between the intervals (0 if they overlap).
        let gap = |n: &Node| {
            let mut d2 = 0.0;
            for k in 0..3 {
                let g = (f64::from(n.lo[k]) - origins_hi[k])
                    .max(origins_lo[k] - f64::from(n.hi[k]))
                    .max(0.0);
                d2 += g * g;
            }
            d2.sqrt()
        };
        for (t, n) in &mut out.boxes {
            *t = gap(n);
        }
        out.boxes
            .sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.index.cmp(&b.1.index)));
        // One shared origin (a camera's primary rays): evaluate each box's origin terms once.
        if origins_lo == origins_hi {
            let origin = Point3::from(origins_lo);
            let mut pre = recycled.unwrap_or_default();
            pre.clear();
            pre.extend(out.boxes.iter().map(|(_, n)| {
                self.prims
                    .get(n.index as usize)
                    .and_then(|p| p.shape.box_from_origin(&origin))
            }));
            out.shared_origin = Some((origin, pre));
        }
    }

    /// Closest hit over culled candidates (the whole hierarchy if they overflowed).
    #[inline]
    #[must_use]
    pub fn intersect_candidates(
        &self,
        cands: &Candidates,
        ray: &Ray,
        t_min: f64,
        t_max: f64,
    ) -> Option<BvhHit> {
        self.intersect_candidates_hinted(cands, ray, t_min, t_max, &mut None)
    }

    /// [`Self::intersect_candidates`] that tests candidate `*hint` (an index into `cands`,
    /// e.g. the previous ray's winner) first and stores this ray's winner there: a tight
    /// first bound lets the box tests reject the rest. The result is the same: the nearest
    /// hit and, on exact ties, the lowest candidate index (what the in-order scan keeps),
    /// since candidates ordered before the current winner are accepted at equal distance.
    #[inline]
    #[must_use]
    pub fn intersect_candidates_hinted(
        &self,
        cands: &Candidates,
        ray: &Ray,
        t_min: f64,
        t_max: f64,
        hint: &mut Option<usize>,
    ) -> Option<BvhHit> {
        if cands.overflow {
            return self.intersect(ray, t_min, t_max);
        }
        let (o, inv) = f32_ray(ray);
        // Rays from the shared origin use the candidates' precomputed box terms (same
        // arithmetic as `Shape::intersect`).
        let pre = match &cands.shared_origin {
            Some((origin, pre)) if *origin == ray.origin => pre.as_slice(),
            _ => &[],
        };
        let test = CandidateTest {
            bvh: self,
            ray,
            o,
            inv,
            pre,
            t_min,
        };
        let mut best_i = usize::MAX;
        let mut t_best = t_max;
        let first = hint.unwrap_or(usize::MAX);
        if let Some(&(t_lo, ref c)) = cands.boxes.get(first)
            && t_lo < t_best
            && let Some(t) = test.exact(first, c, t_best)
        {
            best_i = first;
            t_best = t;
        }
        for (i, &(t_lo, ref c)) in cands.boxes.iter().enumerate() {
            if i < best_i {
                // Ordered before the winner: an exact tie also wins.
                if t_lo > t_best {
                    break;
                }
                let t_hi = if best_i == usize::MAX {
                    t_best
                } else {
                    t_best.next_up()
                };
                if let Some(t) = test.exact(i, c, t_hi) {
                    best_i = i;
                    t_best = t;
                }
            } else if i > best_i {
                // Sorted by the lower bound: nothing farther can beat the best hit.
                if t_lo >= t_best {
                    break;
                }
                if let Some(t) = test.exact(i, c, t_best) {
                    best_i = i;
                    t_best = t;
                }
            }
        }
        let (_, c) = cands.boxes.get(best_i)?;
        *hint = Some(best_i);
        Some(BvhHit {
            t_m: t_best,
            prim: c.index,
        })
    }

    /// Some candidate hit with `t` in `(t_min, t_max)` (any-hit over culled candidates; the
    /// whole hierarchy if they overflowed).
    #[inline]
    #[must_use]
    pub fn occluder_candidates(
        &self,
        cands: &Candidates,
        ray: &Ray,
        t_min: f64,
        t_max: f64,
    ) -> Option<u32> {
        if cands.overflow {
            return self.occluder(ray, t_min, t_max);
        }
        let (o, inv) = match &cands.shared_dir {
            Some((dir, inv)) if *dir == ray.dir => (f32_origin(ray), *inv),
            _ => f32_ray(ray),
        };
        let t_hi = t_max as f32;
        cands.boxes.iter().find_map(|(_, c)| {
            c.hit(&o, &inv, t_hi)?;
            let p = self.prims.get(c.index as usize)?;
            p.shape.intersect(ray, t_min, t_max).map(|_| c.index)
        })
    }

    #[inline]
    fn traverse(
        &self,
        ray: &Ray,
        t_best: &mut f64,
        mut test: impl FnMut(u32, f64) -> Option<f64>,
        any_hit: bool,
    ) {
        if self.nodes.is_empty() {
            return;
        }
        let (o, inv) = f32_ray(ray);
        // Stack of (node, entry distance): nodes farther than the best hit found since they
        // were pushed are skipped when popped.
        let mut stack = [(0u32, 0.0f32); STACK_DEPTH];
        let mut sp = 0usize;
        let mut ni = 0usize;
        if self.nodes[0].hit(&o, &inv, *t_best as f32).is_none() {
            return;
        }
        loop {
            let node = self.nodes[ni];
            if node.count > 0 {
                for k in node.index..node.index + node.count {
                    if let Some(t) = test(k, *t_best) {
                        *t_best = t;
                        if any_hit {
                            return;
                        }
                    }
                }
            } else {
                let (l, r) = (ni + 1, node.index as usize);
                let hl = self.nodes[l].hit(&o, &inv, *t_best as f32);
                let hr = self.nodes[r].hit(&o, &inv, *t_best as f32);
                match (hl, hr) {
                    (Some(a), Some(b)) => {
                        let (near, far, t_far) = if a <= b { (l, r, b) } else { (r, l, a) };
                        if sp < STACK_DEPTH {
                            stack[sp] = (far as u32, t_far);
                            sp += 1;
                        }
                        ni = near;
                        continue;
                    }
                    (Some(_), None) => {
                        ni = l;
                        continue;
                    }
                    (None, Some(_)) => {
                        ni = r;
                        continue;
                    }
                    (None, None) => {}
                }
            }
            loop {
                if sp == 0 {
                    return;
                }
                sp -= 1;
                let (n, t_entry) = stack[sp];
                if f64::from(t_entry) <= *t_best {
                    ni = n as usize;
                    break;
                }
            }
        }
    }
}

/// One ray against single candidates of a [`Candidates`] list.
struct CandidateTest<'a> {
    bvh: &'a Bvh,
    ray: &'a Ray,
    o: [f32; 3],
    inv: [f32; 3],
    /// Precomputed box terms for this ray's origin (empty if none).
    pre: &'a [Option<BoxFromOrigin>],
    t_min: f64,
}

impl CandidateTest<'_> {
    /// Distance to candidate `i` (box `c`) in `(t_min, t_hi)`: the padded f32 box first,
    /// then the exact f64 test.
    #[inline(always)]
    fn exact(&self, i: usize, c: &Node, t_hi: f64) -> Option<f64> {
        c.hit(&self.o, &self.inv, t_hi as f32)?;
        match self.pre.get(i) {
            Some(Some(b)) => b.intersect(&self.ray.dir, self.t_min, t_hi),
            _ => self
                .bvh
                .prims
                .get(c.index as usize)?
                .shape
                .intersect(self.ray, self.t_min, t_hi),
        }
    }
}

/// Ray origin and inverse direction in f32 for the node slab tests.
#[inline]
fn f32_ray(ray: &Ray) -> ([f32; 3], [f32; 3]) {
    (f32_origin(ray), f32_ray_inverse(&ray.dir))
}

/// Ray origin in f32 for the node slab tests.
#[inline]
fn f32_origin(ray: &Ray) -> [f32; 3] {
    [
        ray.origin.x as f32,
        ray.origin.y as f32,
        ray.origin.z as f32,
    ]
}

/// Inverse ray direction in f32 for the node slab tests.
#[inline]
fn f32_ray_inverse(dir: &Vector3<f64>) -> [f32; 3] {
    [
        (1.0 / dir.x) as f32,
        (1.0 / dir.y) as f32,
        (1.0 / dir.z) as f32,
    ]
}

struct BuildCtx<'a> {
    bounds: &'a [Aabb],
    centroids: &'a [[f64; 3]],
}

impl BuildCtx<'_> {
    /// Builds the subtree over `order[start..end]`, returns its node index.
    fn build(
        &self,
        nodes: &mut Vec<Node>,
        order: &mut [usize],
        start: usize,
        end: usize,
        depth: usize,
    ) -> usize {
        let ni = nodes.len();
        let mut nb = Aabb::EMPTY;
        let mut cb = Aabb::EMPTY;
        for &i in &order[start..end] {
            nb.grow(&self.bounds[i]);
            cb.grow_point(self.centroids[i]);
        }
        let n = end - start;
        nodes.push(Node::new(&nb, start as u32, n as u32));
        if n <= MAX_LEAF_PRIMS || depth + 2 >= STACK_DEPTH {
            return ni;
        }
        let Some((axis, pos)) =
            best_split(&order[start..end], self.bounds, self.centroids, &cb, &nb)
        else {
            return ni;
        };
        // Stable partition by centroid, so the layout is a deterministic function of the input.
        let (mut left, mut right): (Vec<usize>, Vec<usize>) = order[start..end]
            .iter()
            .partition(|&&i| self.centroids[i][axis] < pos);
        if left.is_empty() || right.is_empty() {
            let mut all = order[start..end].to_vec();
            all.sort_by(|&a, &b| self.centroids[a][axis].total_cmp(&self.centroids[b][axis]));
            right = all.split_off(n / 2);
            left = all;
        }
        let mid = start + left.len();
        order[start..mid].copy_from_slice(&left);
        order[mid..end].copy_from_slice(&right);
        let _left = self.build(nodes, order, start, mid, depth + 1);
        let r = self.build(nodes, order, mid, end, depth + 1);
        nodes[ni].index = r as u32;
        nodes[ni].count = 0;
        ni
    }
}

fn reorder(prims: Vec<Primitive>, order: &[usize]) -> Vec<Primitive> {
    let mut slots: Vec<Option<Primitive>> = prims.into_iter().map(Some).collect();
    order
        .iter()
        .filter_map(|&i| slots.get_mut(i).and_then(Option::take))
        .collect()
}

/// Binned SAH split `(axis, position)`, or `None` when a leaf is cheaper.
// `axis` indexes several per-axis arrays at once; an iterator would obscure that.
#[allow(clippy::needless_range_loop)]
fn best_split(
    idx: &[usize],
    bounds: &[Aabb],
    centroids: &[[f64; 3]],
    cb: &Aabb,
    nb: &Aabb,
) -> Option<(usize, f64)> {
    let parent_area = nb.area().max(1e-300);
    let mut best_cost = idx.len() as f64;
    let mut best = None;
    for axis in 0..3 {
        let (lo, hi) = (cb.min[axis], cb.max[axis]);
        if hi - lo <= 1e-12 {
            continue;
        }
        let scale = SAH_BINS as f64 / (hi - lo);
        let mut bin_box = [Aabb::EMPTY; SAH_BINS];
        let mut bin_n = [0usize; SAH_BINS];
        for &i in idx {
            let b = (((centroids[i][axis] - lo) * scale) as usize).min(SAH_BINS - 1);
            bin_box[b].grow(&bounds[i]);
            bin_n[b] += 1;
        }
        let mut right_area = [0.0; SAH_BINS];
        let mut right_n = [0usize; SAH_BINS];
        let mut acc = Aabb::EMPTY;
        let mut n = 0;
        for b in (1..SAH_BINS).rev() {
            acc.grow(&bin_box[b]);
            n += bin_n[b];
            right_area[b] = acc.area();
            right_n[b] = n;
        }
        let mut acc = Aabb::EMPTY;
        let mut n = 0;
        for b in 0..SAH_BINS - 1 {
            acc.grow(&bin_box[b]);
            n += bin_n[b];
            if n == 0 || right_n[b + 1] == 0 {
                continue;
            }
            let cost = TRAVERSAL_COST
                + (acc.area() * n as f64 + right_area[b + 1] * right_n[b + 1] as f64) / parent_area;
            if cost < best_cost {
                best_cost = cost;
                best = Some((axis, lo + (b + 1) as f64 / scale));
            }
        }
    }
    best
}
