//! Even spreading of keypoints with the ORB-SLAM quadtree (Mur-Artal, Montiel & Tardós,
//! "ORB-SLAM: a versatile and accurate monocular SLAM system", IEEE T-RO 2015, and
//! ORB-SLAM2, T-RO 2017: `ORBextractor::DistributeOctTree`).
//!
//! The detection rectangle starts as `round(width / height)` square-ish nodes. Every node
//! holding more than one keypoint is split into four quadrants (empty children are dropped)
//! while the node count stays below the requested `n`; once a full round of splits could
//! overshoot `n` (`nodes + 3 * expandable > n`), nodes are split one at a time, the most
//! populated first, until there are `n` nodes. Each node then keeps its keypoint with the
//! highest response. A split adds at most three nodes, so the node count can exceed `n` by
//! up to 3; unlike ORB-SLAM we then keep the `n` strongest, so the result never has more
//! than `n` keypoints. Ties (equal size or response) go to the lower index, so the result is
//! deterministic (ORB-SLAM sorts node pointers, which is not).

/// One node: a rectangle and a range of the shared index array.
#[derive(Clone, Copy, Debug)]
struct Node {
    x0: f32,
    y0: f32,
    x1: f32,
    y1: f32,
    start: usize,
    end: usize,
    alive: bool,
}

impl Node {
    fn len(&self) -> usize {
        self.end - self.start
    }
    /// Splittable: more than one keypoint and still wider than a pixel.
    fn expandable(&self) -> bool {
        self.alive && self.len() > 1 && (self.x1 - self.x0 > 0.5 || self.y1 - self.y0 > 0.5)
    }
}

/// Reusable buffers for [`Quadtree::distribute`].
#[derive(Clone, Debug, Default)]
pub struct Quadtree {
    nodes: Vec<Node>,
    idx: Vec<u32>,
    tmp: Vec<u32>,
    order: Vec<usize>,
}

impl Quadtree {
    /// Empty buffers.
    pub fn new() -> Self {
        Self::default()
    }

    /// Selects at most `n` well-spread keypoints. `xy[i]` and `response[i]` describe
    /// keypoint `i`; `bounds = (x0, y0, x1, y1)` is the detection rectangle (points outside
    /// are clamped into it). Writes the chosen indices, ascending, into `out`.
    pub fn distribute(
        &mut self,
        xy: &[[f32; 2]],
        response: &[f32],
        bounds: (f32, f32, f32, f32),
        n: usize,
        out: &mut Vec<u32>,
    ) {
        out.clear();
        let count = xy.len().min(response.len());
        if n == 0 || count == 0 {
            return;
        }
        let (bx0, by0, bx1, by1) = bounds;
        let (bw, bh) = ((bx1 - bx0).max(1.0), (by1 - by0).max(1.0));
        let n_ini = ((bw / bh).round() as usize).max(1);
        let hx = bw / n_ini as f32;
        // Initial nodes: counting sort of the keypoints by column strip.
        self.idx.clear();
        self.idx.resize(count, 0);
        let strip = |p: &[f32; 2]| (((p[0] - bx0) / hx).floor().max(0.0) as usize).min(n_ini - 1);
        let mut starts = vec![0usize; n_ini + 1];
        for p in &xy[..count] {
            starts[strip(p) + 1] += 1;
        }
        for i in 0..n_ini {
            starts[i + 1] += starts[i];
        }
        let mut fill = starts.clone();
        for (i, p) in xy[..count].iter().enumerate() {
            let s = strip(p);
            self.idx[fill[s]] = i as u32;
            fill[s] += 1;
        }
        self.nodes.clear();
        for i in 0..n_ini {
            if starts[i + 1] > starts[i] {
                self.nodes.push(Node {
                    x0: bx0 + hx * i as f32,
                    y0: by0,
                    x1: bx0 + hx * (i + 1) as f32,
                    y1: by0 + bh,
                    start: starts[i],
                    end: starts[i + 1],
                    alive: true,
                });
            }
        }
        let mut live = self.nodes.len();
        loop {
            if live >= n {
                break;
            }
            self.order.clear();
            self.order
                .extend((0..self.nodes.len()).filter(|&i| self.nodes[i].expandable()));
            if self.order.is_empty() {
                break;
            }
            let before = live;
            if live + 3 * self.order.len() <= n {
                // A full round cannot overshoot: split everything.
                let order = std::mem::take(&mut self.order);
                for &i in &order {
                    live = live - 1 + self.split(xy, i);
                }
                self.order = order;
            } else {
                // Most populated first, until n nodes.
                let nodes = &self.nodes;
                self.order
                    .sort_by(|&a, &b| nodes[b].len().cmp(&nodes[a].len()).then(a.cmp(&b)));
                let order = std::mem::take(&mut self.order);
                for &i in &order {
                    live = live - 1 + self.split(xy, i);
                    if live >= n {
                        break;
                    }
                }
                self.order = order;
            }
            if live == before && self.nodes.iter().all(|nd| !nd.expandable()) {
                break;
            }
        }
        // Best response per live node.
        let mut winners: Vec<u32> = self
            .nodes
            .iter()
            .filter(|nd| nd.alive)
            .filter_map(|nd| {
                self.idx[nd.start..nd.end].iter().copied().reduce(|a, b| {
                    let (ra, rb) = (response[a as usize], response[b as usize]);
                    if rb > ra || (rb == ra && b < a) { b } else { a }
                })
            })
            .collect();
        if winners.len() > n {
            winners.sort_by(|&a, &b| {
                response[b as usize]
                    .total_cmp(&response[a as usize])
                    .then(a.cmp(&b))
            });
            winners.truncate(n);
        }
        winners.sort_unstable();
        out.extend(winners);
    }

    /// Splits node `i` into its non-empty quadrants; returns how many children were made.
    fn split(&mut self, xy: &[[f32; 2]], i: usize) -> usize {
        let nd = self.nodes[i];
        let (mx, my) = (0.5 * (nd.x0 + nd.x1), 0.5 * (nd.y0 + nd.y1));
        let quad = |p: &[f32; 2]| usize::from(p[0] >= mx) + 2 * usize::from(p[1] >= my);
        let mut counts = [0usize; 4];
        for &k in &self.idx[nd.start..nd.end] {
            counts[quad(&xy[k as usize])] += 1;
        }
        let mut pos = [0usize; 4];
        for q in 1..4 {
            pos[q] = pos[q - 1] + counts[q - 1];
        }
        self.tmp.clear();
        self.tmp.resize(nd.len(), 0);
        for &k in &self.idx[nd.start..nd.end] {
            let q = quad(&xy[k as usize]);
            self.tmp[pos[q]] = k;
            pos[q] += 1;
        }
        self.idx[nd.start..nd.end].copy_from_slice(&self.tmp);
        self.nodes[i].alive = false;
        let rects = [
            (nd.x0, nd.y0, mx, my),
            (mx, nd.y0, nd.x1, my),
            (nd.x0, my, mx, nd.y1),
            (mx, my, nd.x1, nd.y1),
        ];
        let mut start = nd.start;
        let mut made = 0;
        for (q, &(x0, y0, x1, y1)) in rects.iter().enumerate() {
            if counts[q] > 0 {
                self.nodes.push(Node {
                    x0,
                    y0,
                    x1,
                    y1,
                    start,
                    end: start + counts[q],
                    alive: true,
                });
                made += 1;
            }
            start += counts[q];
        }
        made
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_best_per_cluster() {
        // Two far clusters; asking for 2 gives the best of each.
        let xy = [[1.0, 1.0], [2.0, 1.0], [90.0, 90.0], [91.0, 91.0]];
        let resp = [1.0, 5.0, 7.0, 3.0];
        let mut out = Vec::new();
        Quadtree::new().distribute(&xy, &resp, (0.0, 0.0, 100.0, 100.0), 2, &mut out);
        assert_eq!(out, vec![1, 2]);
    }

    #[test]
    fn identical_points_terminate() {
        let xy = [[5.0, 5.0]; 10];
        let resp = [1.0; 10];
        let mut out = Vec::new();
        Quadtree::new().distribute(&xy, &resp, (0.0, 0.0, 10.0, 10.0), 5, &mut out);
        assert_eq!(out, vec![0]);
    }
}
