//! ORB: oriented FAST and rotated BRIEF (Rublee, Rabaud, Konolige & Bradski, "ORB: an
//! efficient alternative to SIFT or SURF", ICCV 2011), with the keypoint distribution of
//! ORB-SLAM (Mur-Artal et al., T-RO 2015/2017).
//!
//! Per pyramid level `l` (image scaled by `1 / s^l`, `s` = [`OrbParams::scale_factor`]):
//! 1. FAST-9 ([`super::fast`]) at [`OrbParams::fast_threshold`] over the region at least
//!    [`OrbParams::edge_threshold`] pixels from the border, with non-maximum suppression;
//!    every `cell_size` cell (30 px) left empty is searched again at
//!    [`OrbParams::min_fast_threshold`] (ORB-SLAM's 20 -> 7 fallback, for low-texture areas).
//!    Both come from one scan at the lower threshold: a FAST score does not depend on the
//!    threshold, so the corners at 20 are those scoring above 20 (see
//!    [`FastDetector::detect`]); the result is the same as two scans, in the same order.
//! 2. Ranking by the Harris measure `R = det(M) - k tr(M)^2` (k = 0.04) of the 7x7 Sobel
//!    structure tensor `M` (Harris & Stephens 1988; ORB section 3.1), scaled as OpenCV does
//!    by `(4 * 7 * 255)^-4`. As in OpenCV, FAST is first thinned by its own score to twice the
//!    level's quota (here with the quadtree, so the thinning keeps the spread).
//! 3. The quadtree ([`super::quadtree`]) keeps the level's quota, best Harris per node.
//!    [`KeypointDistribution::RetainBest`] replaces the quadtree in steps 2-3 by OpenCV's
//!    choice, the strongest wherever they are: more GMS matches on strong texture and far
//!    more robust to image noise, less coverage (figures in `rodlog experiment matchers` and
//!    `rodlog experiment noise --orb-distribution retain-best`).
//!    Quotas follow ORB-SLAM, `n_l = N (1 - 1/s) s^-l / (1 - s^-L)`, processed from the
//!    coarsest level down; a level short of its quota passes the shortfall to the next finer.
//! 4. Orientation by the intensity centroid (ORB eq. 1-3): `m_pq = sum x^p y^q I(x, y)`
//!    over the disc of radius `patch_size / 2`, `theta = atan2(m01, m10)`.
//! 5. Steered BRIEF: for each test `(p_i, q_i)` of [`super::brief_pattern::BRIEF_PATTERN`],
//!    rotated by `theta`, bit `i = [I_s(R p_i) < I_s(R q_i)]` on the image smoothed by
//!    [`super::gray::gaussian_blur7`], pixel positions rounded (ORB section 4). The 256
//!    tests were learned as in ORB section 4.3 (greedy, mean near 0.5, low correlation) by
//!    `calib/examples/learn_brief_pattern.rs` on seeded synthetic scenes; see
//!    [`super::brief_pattern`].
//!
//! All per-image buffers (pyramid, smoothed level, FAST scores, quadtree nodes) live in
//! [`OrbExtractor`] and are reused, so a warm extractor allocates only its output.
//!
//! Keypoints are reported in full-resolution pixels: `x = x_l * s^l`.

use super::brief_pattern::BRIEF_PATTERN;
use super::fast::{Corner, FastDetector, Rect};
use super::gray::{BlurScratch, GrayBuf, GrayView, ResizeScratch, gaussian_blur7, resize_bilinear};
use super::quadtree::Quadtree;
use super::{Descriptor, FeatureError, Features, Keypoint};

/// Harris constant `k` of `det(M) - k tr(M)^2`.
pub const HARRIS_K: f32 = 0.04;
/// Side of the Harris window (pixels).
pub const HARRIS_BLOCK: usize = 7;
/// Largest coordinate of a test point in [`BRIEF_PATTERN`] (rotated, it reaches
/// `13 * sqrt(2) < 19`, hence the minimum edge threshold).
pub const PATTERN_RADIUS: i32 = 13;
/// The smallest usable [`OrbParams::edge_threshold`]: a rotated test point and the
/// orientation disc of a 31-pixel patch stay inside the image.
pub const MIN_EDGE_THRESHOLD: usize = 19;

/// How a pyramid level's corners are cut down to its quota (module docs, steps 2-3).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum KeypointDistribution {
    /// ORB-SLAM's quadtree: the best corner of each node, so the keypoints cover every
    /// textured part of the image evenly (the paper's front end).
    #[default]
    Quadtree,
    /// The strongest corners wherever they are, as OpenCV's ORB
    /// (`KeyPointsFilter::retainBest`, which also keeps every corner tied with the last one
    /// kept, so a level may keep a few more than its quota): dense on strong texture, none
    /// on weak texture.
    /// GMS scores a match by the matches around it, so dense keypoints give it more support:
    /// more matches survive, at the cost of coverage (see `rodlog experiment matchers`).
    RetainBest,
}

impl KeypointDistribution {
    /// The name used by the CLI and in results files.
    pub fn name(self) -> &'static str {
        match self {
            Self::Quadtree => "quadtree",
            Self::RetainBest => "retain-best",
        }
    }
}

/// Indices (ascending) of the corners `xy` with responses `response` chosen by
/// `distribution`: at most `n` for the quadtree; for
/// [`KeypointDistribution::RetainBest`] the `n` strongest plus every corner tied with the
/// `n`-th (as OpenCV; cutting a tie by index would favour the top of the image, since FAST
/// scores are small integers and corners come in raster order).
fn select(
    distribution: KeypointDistribution,
    quad: &mut Quadtree,
    xy: &[[f32; 2]],
    response: &[f32],
    bounds: (f32, f32, f32, f32),
    n: usize,
    out: &mut Vec<u32>,
) {
    match distribution {
        KeypointDistribution::Quadtree => quad.distribute(xy, response, bounds, n, out),
        KeypointDistribution::RetainBest => {
            out.clear();
            let count = xy.len().min(response.len());
            out.extend(0..count as u32);
            if count > n && n > 0 {
                out.sort_unstable_by(|&a, &b| {
                    response[b as usize]
                        .total_cmp(&response[a as usize])
                        .then(a.cmp(&b))
                });
                let cut = response[out[n - 1] as usize];
                let keep = n + out[n..]
                    .iter()
                    .take_while(|&&i| response[i as usize].total_cmp(&cut).is_eq())
                    .count();
                out.truncate(keep);
                out.sort_unstable();
            } else if n == 0 {
                out.clear();
            }
        }
    }
}

/// ORB parameters. `Default` is the paper's front end (ARCHITECTURE.md section 6).
#[derive(Clone, Debug, PartialEq)]
pub struct OrbParams {
    /// Number of features to keep over all levels (default 2000).
    pub n_features: usize,
    /// Ratio between consecutive pyramid levels (default 1.2).
    pub scale_factor: f32,
    /// Number of pyramid levels (default 8).
    pub n_levels: usize,
    /// FAST threshold (intensity difference) tried first (default 20).
    pub fast_threshold: u8,
    /// FAST threshold for cells where the first found nothing (default 7).
    pub min_fast_threshold: u8,
    /// Keypoints are at least this far from the border of their level, pixels (default 19).
    pub edge_threshold: usize,
    /// Diameter of the orientation patch, pixels (default 31).
    pub patch_size: usize,
    /// Side of the cells of the FAST fallback, pixels (default 30).
    pub cell_size: usize,
    /// How each level keeps its quota (default the quadtree).
    pub distribution: KeypointDistribution,
}

impl Default for OrbParams {
    fn default() -> Self {
        Self {
            n_features: 2000,
            scale_factor: 1.2,
            n_levels: 8,
            fast_threshold: 20,
            min_fast_threshold: 7,
            edge_threshold: 19,
            patch_size: 31,
            cell_size: 30,
            distribution: KeypointDistribution::Quadtree,
        }
    }
}

impl OrbParams {
    /// Checks the parameters.
    ///
    /// # Errors
    /// [`FeatureError::InvalidParam`] naming the offending field and value.
    pub fn validate(&self) -> Result<(), FeatureError> {
        let bad = |name: &'static str, value: f64| Err(FeatureError::InvalidParam { name, value });
        if !(self.scale_factor > 1.0 && self.scale_factor.is_finite()) {
            return bad("scale_factor", f64::from(self.scale_factor));
        }
        if self.n_levels == 0 || self.n_levels > 32 {
            return bad("n_levels", self.n_levels as f64);
        }
        if self.edge_threshold < MIN_EDGE_THRESHOLD || self.edge_threshold < self.patch_size / 2 + 1
        {
            return bad("edge_threshold", self.edge_threshold as f64);
        }
        if self.patch_size < 3 {
            return bad("patch_size", self.patch_size as f64);
        }
        if self.cell_size < 8 {
            return bad("cell_size", self.cell_size as f64);
        }
        if self.min_fast_threshold == 0 || self.min_fast_threshold > self.fast_threshold {
            return bad("min_fast_threshold", f64::from(self.min_fast_threshold));
        }
        Ok(())
    }

    /// Size of pyramid level `level` of a `width` x `height` image:
    /// `round(size_0 / s^level)` per axis (computed in `f32`, as the pyramid is built).
    /// Rounding makes each axis' true ratio `size_0 / size_l` differ from `s^level` by up to
    /// 0.3 %, differently in x and y ([`Self::full_res_position`]).
    #[must_use]
    pub fn level_size(&self, level: u8, width: u32, height: u32) -> (usize, usize) {
        let s = self.scale_factor.powi(i32::from(level));
        (
            (width as f32 / s).round() as usize,
            (height as f32 / s).round() as usize,
        )
    }

    /// The full-resolution position of a keypoint of a `width` x `height` image.
    ///
    /// ORB reports `x_l * s^l` for the level-`l` pixel `x_l` (as OpenCV does), but the
    /// pyramid is resampled pixel-centre aligned ([`super::gray::resize_bilinear`], chained
    /// maps compose), so that pixel is centred at `(x_l + 0.5) width / width_l - 0.5` in the
    /// full image, and likewise in y. Taking `x_l * s^l` instead is off by
    /// `0.5 (s^l - 1)` pixels (1.3 px at level 7), plus up to 0.7 px more at the image's far
    /// side where `width / width_l` differs from `s^l` by rounding (tested against the
    /// pyramid itself). Both views of a pair see a similar offset at the same level, so the
    /// hand-eye estimates of rendered trials moved by less than 0.01 deg with the exact map.
    #[must_use]
    pub fn full_res_position(&self, k: &Keypoint, width: u32, height: u32) -> (f32, f32) {
        if k.level == 0 {
            return (k.x, k.y);
        }
        let s = self.scale_factor.powi(i32::from(k.level));
        let (wl, hl) = self.level_size(k.level, width, height);
        let map = |p: f32, full: u32, size_l: usize| -> f32 {
            let ratio = f64::from(full) / size_l.max(1) as f64;
            ((f64::from(p) / f64::from(s) + 0.5) * ratio - 0.5) as f32
        };
        (map(k.x, width, wl), map(k.y, height, hl))
    }

    /// The per-level quotas `n_l` (module docs, step 3), summing to `n_features`.
    pub fn level_quotas(&self) -> Vec<usize> {
        let inv = 1.0 / f64::from(self.scale_factor);
        let l = self.n_levels;
        let first = self.n_features as f64 * (1.0 - inv) / (1.0 - inv.powi(l as i32));
        let mut q: Vec<usize> = (0..l)
            .map(|i| (first * inv.powi(i as i32)).round() as usize)
            .collect();
        let head: usize = q[..l - 1].iter().sum();
        q[l - 1] = self.n_features.saturating_sub(head);
        q
    }
}

/// Reusable ORB state: pyramid, smoothed images and scratch buffers.
#[derive(Clone, Debug)]
pub struct OrbExtractor {
    params: OrbParams,
    quotas: Vec<usize>,
    scales: Vec<f32>,
    levels: Vec<GrayBuf>,
    blurred: GrayBuf,
    resize_scratch: ResizeScratch,
    blur_scratch: BlurScratch,
    fast: FastDetector,
    quad: Quadtree,
    corners: Vec<Corner>,
    low: Vec<Corner>,
    cell_count: Vec<u32>,
    fallback: Vec<(usize, Corner)>,
    xy: Vec<[f32; 2]>,
    resp: Vec<f32>,
    sub_xy: Vec<[f32; 2]>,
    sub_resp: Vec<f32>,
    chosen: Vec<u32>,
    chosen2: Vec<u32>,
    umax: Vec<i32>,
    pattern: Box<SoaPattern>,
}

impl OrbExtractor {
    /// An extractor for `params`.
    ///
    /// # Errors
    /// [`FeatureError::InvalidParam`] from [`OrbParams::validate`].
    pub fn new(params: OrbParams) -> Result<Self, FeatureError> {
        params.validate()?;
        let quotas = params.level_quotas();
        let scales = (0..params.n_levels)
            .map(|l| params.scale_factor.powi(l as i32))
            .collect();
        let half = (params.patch_size / 2) as i32;
        let umax = (0..=half)
            .map(|v| (f64::from(half * half - v * v)).sqrt().round() as i32)
            .collect();
        let pattern = soa_pattern();
        Ok(Self {
            params,
            quotas,
            scales,
            levels: Vec::new(),
            blurred: GrayBuf::default(),
            resize_scratch: ResizeScratch::default(),
            blur_scratch: BlurScratch::default(),
            fast: FastDetector::new(),
            quad: Quadtree::new(),
            corners: Vec::new(),
            low: Vec::new(),
            cell_count: Vec::new(),
            fallback: Vec::new(),
            xy: Vec::new(),
            resp: Vec::new(),
            sub_xy: Vec::new(),
            sub_resp: Vec::new(),
            chosen: Vec::new(),
            chosen2: Vec::new(),
            umax,
            pattern,
        })
    }

    /// The parameters.
    pub fn params(&self) -> &OrbParams {
        &self.params
    }

    /// Detects and describes ORB features of `img` into `out` (cleared first), grouped by
    /// level (finest first). Levels smaller than the border are skipped.
    ///
    /// # Errors
    /// [`FeatureError::ImageTooSmall`] when level 0 has no room for a keypoint.
    pub fn detect_and_describe(
        &mut self,
        img: &GrayView<'_>,
        out: &mut Features,
    ) -> Result<(), FeatureError> {
        out.keypoints.clear();
        out.descriptors.clear();
        let edge = self.params.edge_threshold;
        let min = 2 * edge + 1;
        if img.width() < min || img.height() < min {
            return Err(FeatureError::ImageTooSmall {
                width: img.width(),
                height: img.height(),
                min,
            });
        }
        self.build_pyramid(img);
        let n_levels = self.levels.len();
        // Coarsest level first (shortfalls carry down), appended straight into `out`; the
        // level blocks are put back finest-first by two reversals, without allocating.
        let mut counts = [0usize; 32];
        let mut carry = 0usize;
        for l in (0..n_levels).rev() {
            let quota = self.quotas.get(l).copied().unwrap_or(0) + carry;
            let before = out.keypoints.len();
            self.process_level(l, quota, &mut out.keypoints, &mut out.descriptors);
            let got = out.keypoints.len() - before;
            if let Some(c) = counts.get_mut(l) {
                *c = got;
            }
            carry = quota.saturating_sub(got);
        }
        out.keypoints.reverse();
        out.descriptors.reverse();
        let mut start = 0;
        for &c in counts.iter().take(n_levels) {
            out.keypoints[start..start + c].reverse();
            out.descriptors[start..start + c].reverse();
            start += c;
        }
        Ok(())
    }

    /// Level 0 = a copy of the input; level l = bilinear resize of level l - 1 to
    /// `round(size_0 / s^l)`. Levels too small for the border are dropped.
    fn build_pyramid(&mut self, img: &GrayView<'_>) {
        let n = self.params.n_levels;
        self.levels.resize_with(n, GrayBuf::default);
        self.levels[0].copy_from(img);
        let min = 2 * self.params.edge_threshold + 1;
        let mut used = 1;
        for l in 1..n {
            let (w, h) = self
                .params
                .level_size(l as u8, img.width() as u32, img.height() as u32);
            if w < min || h < min {
                break;
            }
            let (done, rest) = self.levels.split_at_mut(l);
            let dst = &mut rest[0];
            dst.reshape(w, h);
            resize_bilinear(&done[l - 1].view(), dst, &mut self.resize_scratch);
            used = l + 1;
        }
        self.levels.truncate(used);
    }

    fn process_level(
        &mut self,
        l: usize,
        quota: usize,
        kps: &mut Vec<Keypoint>,
        descs: &mut Vec<Descriptor>,
    ) {
        let p = &self.params;
        let edge = p.edge_threshold;
        let level = &self.levels[l];
        let (w, h) = (level.width, level.height);
        let view = level.view();
        let region = Rect {
            x0: edge,
            y0: edge,
            x1: w - edge,
            y1: h - edge,
        };
        // 1. FAST with the per-cell fallback, from one scan at the lower threshold: scores
        //    do not depend on the threshold, so the corners at `fast_threshold` are those
        //    with a higher score, suppression included ([`FastDetector::detect`]). The
        //    order is that of a scan at `fast_threshold` followed by one per empty cell.
        self.low.clear();
        self.fast
            .detect(&view, region, p.min_fast_threshold, true, &mut self.low);
        self.corners.clear();
        self.corners
            .extend(self.low.iter().filter(|c| c.score > p.fast_threshold));
        let (rw, rh) = (region.x1 - region.x0, region.y1 - region.y0);
        let ncols = (rw / p.cell_size).max(1);
        let nrows = (rh / p.cell_size).max(1);
        let cw = rw.div_ceil(ncols);
        let ch = rh.div_ceil(nrows);
        let cell_of = |c: &Corner| {
            let cx = ((c.x as usize - region.x0) / cw).min(ncols - 1);
            let cy = ((c.y as usize - region.y0) / ch).min(nrows - 1);
            cy * ncols + cx
        };
        self.cell_count.clear();
        self.cell_count.resize(ncols * nrows, 0);
        for c in &self.corners {
            self.cell_count[cell_of(c)] += 1;
        }
        // The empty cells' low-threshold corners, cell by cell (a stable sort keeps each
        // cell's raster order).
        self.fallback.clear();
        self.fallback.extend(
            self.low
                .iter()
                .map(|c| (cell_of(c), *c))
                .filter(|&(cell, _)| self.cell_count[cell] == 0),
        );
        self.fallback.sort_by_key(|&(cell, _)| cell);
        self.corners.extend(self.fallback.iter().map(|&(_, c)| c));
        if self.corners.is_empty() || quota == 0 {
            return;
        }
        let bounds = (
            region.x0 as f32,
            region.y0 as f32,
            region.x1 as f32,
            region.y1 as f32,
        );
        self.xy.clear();
        self.xy
            .extend(self.corners.iter().map(|c| [c.x as f32, c.y as f32]));
        // 2. Thin by FAST score (spread kept), then rank by Harris.
        self.resp.clear();
        self.resp
            .extend(self.corners.iter().map(|c| f32::from(c.score)));
        let keep_fast = 2 * quota;
        let distribution = p.distribution;
        if self.corners.len() <= keep_fast {
            self.chosen.clear();
            self.chosen.extend(0..self.corners.len() as u32);
        } else {
            select(
                distribution,
                &mut self.quad,
                &self.xy,
                &self.resp,
                bounds,
                keep_fast,
                &mut self.chosen,
            );
        }
        let (sub_xy, sub_resp) = (&mut self.sub_xy, &mut self.sub_resp);
        sub_xy.clear();
        sub_resp.clear();
        for &i in &self.chosen {
            let c = self.corners[i as usize];
            sub_xy.push([c.x as f32, c.y as f32]);
            sub_resp.push(harris_response(&view, c.x as usize, c.y as usize));
        }
        // 3. To the quota by Harris (quadtree: best per node).
        select(
            distribution,
            &mut self.quad,
            sub_xy,
            sub_resp,
            bounds,
            quota,
            &mut self.chosen2,
        );
        // 4-5. Orientation and descriptor.
        self.blurred.reshape(w, h);
        gaussian_blur7(&view, &mut self.blurred, &mut self.blur_scratch);
        simd::dispatch(DescribeAll {
            img: &view,
            blurred: &self.blurred.view(),
            umax: &self.umax,
            pattern: &self.pattern,
            chosen: &self.chosen2,
            xy: sub_xy,
            response: sub_resp,
            level: l as u8,
            scale: self.scales[l],
            size: p.patch_size as f32 * self.scales[l],
            kps,
            descs,
        });
    }
}

/// Steps 4-5 for the chosen keypoints of one level, as a [`simd::Kernel`] (the rotated
/// test offsets of [`describe`] vectorise).
struct DescribeAll<'a, 'b> {
    img: &'a GrayView<'b>,
    blurred: &'a GrayView<'b>,
    umax: &'a [i32],
    pattern: &'a SoaPattern,
    chosen: &'a [u32],
    xy: &'a [[f32; 2]],
    response: &'a [f32],
    level: u8,
    scale: f32,
    size: f32,
    kps: &'a mut Vec<Keypoint>,
    descs: &'a mut Vec<Descriptor>,
}

impl simd::Kernel for DescribeAll<'_, '_> {
    type Output = ();
    #[inline(always)]
    fn run(self) {
        for &j in self.chosen {
            let (Some(&[x, y]), Some(&response)) =
                (self.xy.get(j as usize), self.response.get(j as usize))
            else {
                continue;
            };
            let (xi, yi) = (x as usize, y as usize);
            let angle = ic_angle(self.img, xi, yi, self.umax);
            self.descs
                .push(describe(self.blurred, xi, yi, angle, self.pattern));
            self.kps.push(Keypoint {
                x: x * self.scale,
                y: y * self.scale,
                level: self.level,
                angle_rad: angle,
                response,
                size: self.size,
            });
        }
    }
}

/// Harris response at `(x, y)` over a [`HARRIS_BLOCK`]-square window of 3x3 Sobel
/// gradients, `(a b - c^2 - k (a + b)^2) / (4 * 7 * 255)^4` with `a = sum Ix^2`,
/// `b = sum Iy^2`, `c = sum Ix Iy` (OpenCV's scaling). The caller keeps the window
/// (radius 4 with the Sobel taps) inside the image; pixels outside read as 0.
pub fn harris_response(img: &GrayView<'_>, x: usize, y: usize) -> f32 {
    match harris_window(img, x, y) {
        Some(win) => harris_from_window(&win),
        None => harris_response_clamped(img, x, y),
    }
}

/// Side of the pixel window the Harris response reads: the block plus the Sobel taps.
const HARRIS_WIN: usize = HARRIS_BLOCK + 2;

/// The [`HARRIS_WIN`]-square window centred on `(x, y)`, or `None` when it leaves the image.
fn harris_window(
    img: &GrayView<'_>,
    x: usize,
    y: usize,
) -> Option<[[i32; HARRIS_WIN]; HARRIS_WIN]> {
    let r = HARRIS_WIN / 2;
    let (x0, y0) = (x.checked_sub(r)?, y.checked_sub(r)?);
    let mut win = [[0i32; HARRIS_WIN]; HARRIS_WIN];
    for (j, w) in win.iter_mut().enumerate() {
        let px: &[u8; HARRIS_WIN] = img.row(y0 + j)?.get(x0..x0 + HARRIS_WIN)?.try_into().ok()?;
        *w = px.map(i32::from);
    }
    Some(win)
}

/// [`harris_response`] on a window held in registers (no per-pixel bounds checks); the
/// same integer sums, hence the same result, as [`harris_response_clamped`].
fn harris_from_window(w: &[[i32; HARRIS_WIN]; HARRIS_WIN]) -> f32 {
    let (mut a, mut b, mut c) = (0i64, 0i64, 0i64);
    for j in 1..HARRIS_WIN - 1 {
        let (up, mid, dn) = (&w[j - 1], &w[j], &w[j + 1]);
        let (mut sa, mut sb, mut sc) = (0i32, 0i32, 0i32);
        for i in 1..HARRIS_WIN - 1 {
            let ix =
                (mid[i + 1] - mid[i - 1]) * 2 + (up[i + 1] - up[i - 1]) + (dn[i + 1] - dn[i - 1]);
            let iy = (dn[i] - up[i]) * 2 + (dn[i - 1] - up[i - 1]) + (dn[i + 1] - up[i + 1]);
            sa += ix * ix;
            sb += iy * iy;
            sc += ix * iy;
        }
        a += i64::from(sa);
        b += i64::from(sb);
        c += i64::from(sc);
    }
    harris_scale(a, b, c)
}

/// `(a b - c^2 - k (a + b)^2) / (4 * 7 * 255)^4` (OpenCV's scaling).
fn harris_scale(a: i64, b: i64, c: i64) -> f32 {
    let scale = 1.0 / (4.0 * HARRIS_BLOCK as f64 * 255.0);
    let s4 = scale * scale * scale * scale;
    let (a, b, c) = (a as f64, b as f64, c as f64);
    ((a * b - c * c - f64::from(HARRIS_K) * (a + b) * (a + b)) * s4) as f32
}

/// [`harris_response`] near the border: pixels outside the data read as 0.
fn harris_response_clamped(img: &GrayView<'_>, x: usize, y: usize) -> f32 {
    let r = (HARRIS_BLOCK / 2) as isize;
    let stride = img.stride() as isize;
    let data = img.data();
    let px = |o: isize| -> i32 { data.get(o as usize).map_or(0, |&v| i32::from(v)) };
    let (mut a, mut b, mut c) = (0i64, 0i64, 0i64);
    for dy in -r..=r {
        for dx in -r..=r {
            let o = (y as isize + dy) * stride + x as isize + dx;
            let ix = (px(o + 1) - px(o - 1)) * 2
                + (px(o - stride + 1) - px(o - stride - 1))
                + (px(o + stride + 1) - px(o + stride - 1));
            let iy = (px(o + stride) - px(o - stride)) * 2
                + (px(o + stride - 1) - px(o - stride - 1))
                + (px(o + stride + 1) - px(o - stride + 1));
            a += i64::from(ix * ix);
            b += i64::from(iy * iy);
            c += i64::from(ix * iy);
        }
    }
    harris_scale(a, b, c)
}

/// Intensity-centroid orientation (ORB eq. 1-3) over the disc `|v| <= r`,
/// `|u| <= umax[|v|]`, `r = umax.len() - 1`: `atan2(m01, m10)` in radians, `(-pi, pi]`,
/// in image axes (x right, y down). The caller keeps the disc inside the image.
#[inline(always)]
pub fn ic_angle(img: &GrayView<'_>, x: usize, y: usize, umax: &[i32]) -> f32 {
    let (mut m01, mut m10) = (0i64, 0i64);
    let r = umax.len() as isize - 1;
    for v in -r..=r {
        let Some(row) = img.row((y as isize + v) as usize) else {
            continue;
        };
        let d = umax.get(v.unsigned_abs()).copied().unwrap_or(0) as isize;
        let lo = (x as isize - d).max(0) as usize;
        let hi = ((x as isize + d) as usize).min(row.len().saturating_sub(1));
        let Some(seg) = row.get(lo..=hi) else {
            continue;
        };
        let mut sum = 0i64;
        let mut wsum = 0i64;
        for (k, &p) in seg.iter().enumerate() {
            let u = lo as i64 + k as i64 - x as i64;
            sum += i64::from(p);
            wsum += u * i64::from(p);
        }
        m10 += wsum;
        m01 += v as i64 * sum;
    }
    (m01 as f64).atan2(m10 as f64) as f32
}

/// `x.round() as i32` (half away from zero) for `|x| < 2^22`, written with truncation so the
/// 256 offsets of [`describe`] are plain lane operations: the fraction `x - trunc(x)` is
/// exact, and rounds away from zero when it reaches one half.
#[inline(always)]
fn round_half_away(x: f32) -> i32 {
    let t = x as i32;
    let frac = x - t as f32;
    t + i32::from(frac >= 0.5) - i32::from(frac <= -0.5)
}

/// The test pattern as four coordinate arrays (`x1`, `y1`, `x2`, `y2`), the layout
/// [`describe`] rotates with vector instructions.
pub type SoaPattern = [[f32; 256]; 4];

/// [`BRIEF_PATTERN`] as a [`SoaPattern`].
pub fn soa_pattern() -> Box<SoaPattern> {
    let mut p = Box::new([[0f32; 256]; 4]);
    for (i, t) in BRIEF_PATTERN.iter().enumerate() {
        for c in 0..4 {
            p[c][i] = f32::from(t[c]);
        }
    }
    p
}

/// Steered BRIEF descriptor of the keypoint `(x, y)` on the smoothed image (module docs,
/// step 5): test points rotated by `angle`, rounded to the nearest pixel, then compared;
/// bit `i` is bit `i % 64` of word `i / 64`. Points outside the image read as 0 (the
/// caller keeps keypoints [`MIN_EDGE_THRESHOLD`] from the border, so none are).
#[inline(always)]
pub fn describe(
    blurred: &GrayView<'_>,
    x: usize,
    y: usize,
    angle: f32,
    pattern: &SoaPattern,
) -> Descriptor {
    let (s, c) = angle.sin_cos();
    let stride = blurred.stride() as i32;
    let data = blurred.data();
    let centre = (y * blurred.stride() + x) as isize;
    // Rotated offsets, computed for all tests at once (vectorised: SoA, no branches).
    let mut off1 = [0i32; 256];
    let mut off2 = [0i32; 256];
    for i in 0..256 {
        let (x1, y1, x2, y2) = (pattern[0][i], pattern[1][i], pattern[2][i], pattern[3][i]);
        off1[i] = round_half_away(x1 * c - y1 * s) + round_half_away(x1 * s + y1 * c) * stride;
        off2[i] = round_half_away(x2 * c - y2 * s) + round_half_away(x2 * s + y2 * c) * stride;
    }
    let at = |o: i32| {
        data.get((centre + o as isize) as usize)
            .copied()
            .unwrap_or(0)
    };
    let mut words = [0u64; 4];
    for (w, word) in words.iter_mut().enumerate() {
        let mut bits = 0u64;
        for k in 0..64 {
            let i = w * 64 + k;
            bits |= u64::from(at(off1[i]) < at(off2[i])) << k;
        }
        *word = bits;
    }
    Descriptor(words)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::features::synth::textured_image;

    /// Intensity centroid of `img` above its background `floor`, in its pixel coordinates.
    fn centroid(img: &GrayBuf, floor: f64) -> (f64, f64) {
        let (mut m, mut mx, mut my) = (0.0, 0.0, 0.0);
        for (i, &v) in img.data.iter().enumerate() {
            let w = (f64::from(v) - floor).max(0.0);
            m += w;
            mx += w * (i % img.width) as f64;
            my += w * (i / img.width) as f64;
        }
        (mx / m, my / m)
    }

    #[test]
    fn full_res_position_follows_the_pyramid_resampling() {
        // A smooth blob far from the image centre (where each level's rounded size matters
        // most): the centroid of its resampled copy on every level, mapped back, is its
        // centre.
        let (w, h) = (640_usize, 512_usize);
        let (bx, by, sigma) = (503.3_f64, 397.6_f64, 9.0_f64);
        let data: Vec<u8> = (0..w * h)
            .map(|i| {
                let (dx, dy) = ((i % w) as f64 - bx, (i / w) as f64 - by);
                let g = (-(dx * dx + dy * dy) / (2.0 * sigma * sigma)).exp();
                (20.0 + 220.0 * g).round() as u8
            })
            .collect();
        let Ok(view) = GrayView::new(&data, w, h) else {
            panic!("view");
        };
        let params = OrbParams::default();
        let Ok(mut ex) = OrbExtractor::new(params.clone()) else {
            panic!("extractor");
        };
        ex.build_pyramid(&view);
        assert_eq!(ex.levels.len(), params.n_levels);
        let mut worst_old = 0.0_f64;
        for (l, level) in ex.levels.iter().enumerate().skip(1) {
            assert_eq!(
                (level.width, level.height),
                params.level_size(l as u8, w as u32, h as u32)
            );
            let (cx, cy) = centroid(level, 20.5);
            let s = params.scale_factor.powi(l as i32);
            let k = Keypoint {
                x: (cx * f64::from(s)) as f32,
                y: (cy * f64::from(s)) as f32,
                level: l as u8,
                angle_rad: 0.0,
                response: 0.0,
                size: 31.0 * s,
            };
            let (x, y) = params.full_res_position(&k, w as u32, h as u32);
            let err = (f64::from(x) - bx).hypot(f64::from(y) - by);
            assert!(
                err < 0.05,
                "level {l}: ({x}, {y}) is {err} px from the blob"
            );
            // The same-scale shift alone (`0.5 (s^l - 1)`) misses by a tenth of a pixel or more.
            let shift = 0.5 * (f64::from(s) - 1.0);
            let old = (f64::from(k.x) + shift - bx).hypot(f64::from(k.y) + shift - by);
            worst_old = worst_old.max(old);
        }
        assert!(
            worst_old > 0.3,
            "the rounding of level sizes moved nothing: {worst_old}"
        );
    }

    #[test]
    fn features_are_the_same_bits_on_every_simd_level() {
        use simd::{Level, with_max_level};
        // Odd sizes: row tails that are not multiples of any vector width.
        let img = textured_image(421, 317, 9);
        let params = OrbParams {
            n_features: 500,
            ..OrbParams::default()
        };
        let run = |level| {
            with_max_level(level, || {
                crate::features::detect_and_describe(&img.view(), &params)
            })
        };
        let Ok(base) = run(Level::Baseline) else {
            panic!("ORB failed on the synthetic image");
        };
        assert!(
            base.keypoints.len() > 400,
            "{} keypoints",
            base.keypoints.len()
        );
        for level in [Level::Avx2, Level::Avx512] {
            let Ok(f) = run(level) else {
                panic!("ORB failed at {level:?}");
            };
            assert_eq!(f, base, "{level:?}");
        }
    }

    #[test]
    fn quadtree_covers_weak_texture_retain_best_does_not() {
        // Left half at full contrast, right half at a fifth of it (measured: the quadtree
        // puts 24 % of its keypoints on the weak half, retain-best none).
        let (w, h) = (640, 480);
        let mut img = textured_image(w, h, 4);
        for row in img.data.chunks_exact_mut(w) {
            for v in &mut row[w / 2..] {
                *v = (128.0 + (f32::from(*v) - 128.0) * 0.2).round() as u8;
            }
        }
        let right_share = |distribution| {
            let params = OrbParams {
                n_features: 400,
                distribution,
                ..OrbParams::default()
            };
            let Ok(f) = crate::features::detect_and_describe(&img.view(), &params) else {
                panic!("ORB failed on the synthetic image");
            };
            assert!(
                f.keypoints.len() > 350,
                "{distribution:?}: {}",
                f.keypoints.len()
            );
            let right = f.keypoints.iter().filter(|k| k.x >= (w / 2) as f32).count();
            right as f64 / f.keypoints.len() as f64
        };
        let quad = right_share(KeypointDistribution::Quadtree);
        let best = right_share(KeypointDistribution::RetainBest);
        eprintln!("weak-half share: quadtree {quad:.3}, retain-best {best:.3}");
        assert!(quad > 0.15, "quadtree puts {quad:.2} on the weak half");
        assert!(
            best < 0.25 * quad,
            "retain-best {best:.2} vs quadtree {quad:.2}"
        );
    }

    #[test]
    fn round_half_away_equals_f32_round() {
        // Ties, values next to ties, negatives and the rotated-pattern range.
        let mut xs = vec![0.5f32, -0.5, 1.5, -1.5, 2.5, -2.5, 0.0, -0.0, 13.0, -13.0];
        for k in -40..=40 {
            let tie = k as f32 + 0.5;
            xs.extend([tie, tie.next_up(), tie.next_down()]);
        }
        for i in 0..20_000 {
            let a = i as f32 * 0.001_37;
            xs.extend([13.0 * a.sin() - 7.0 * a.cos(), -(a % 19.0)]);
        }
        for x in xs {
            assert_eq!(round_half_away(x), x.round() as i32, "{x}");
        }
    }

    #[test]
    fn harris_window_path_equals_clamped_path() {
        let img = textured_image(64, 48, 3);
        let view = img.view();
        let mut nonzero = 0;
        for y in 4..44 {
            for x in 4..60 {
                let fast = harris_response(&view, x, y);
                assert!(harris_window(&view, x, y).is_some(), "({x}, {y}) inside");
                assert_eq!(
                    fast.to_bits(),
                    harris_response_clamped(&view, x, y).to_bits()
                );
                nonzero += usize::from(fast != 0.0);
            }
        }
        assert!(
            nonzero > 1000,
            "textured image gave {nonzero} non-zero responses"
        );
        // At the border the window leaves the image and the clamped path answers.
        assert!(harris_window(&view, 3, 10).is_none());
        assert_eq!(
            harris_response(&view, 3, 10).to_bits(),
            harris_response_clamped(&view, 3, 10).to_bits()
        );
    }
    /// Correct GMS matches (within 3 px of the warp) between a textured image and its warp,
    /// both with Gaussian noise of `sigma` levels, with `distribution`.
    fn correct_gms_matches(distribution: KeypointDistribution, sigma: f64) -> (usize, usize) {
        use crate::features::synth::{apply_homography, similarity, warp_homography};
        use crate::features::{GmsParams, MatchParams, gms_filter, match_brute_force};
        let (w, h) = (640, 512);
        let a = textured_image(w, h, 11);
        let hom = similarity(8f64.to_radians(), 0.95, 320.0, 256.0, 6.0, -4.0);
        let Some(b) = warp_homography(&a, &hom, w, h, 128) else {
            panic!("singular warp");
        };
        let mut rng = rng::SplitMix64::new(21);
        let noisy = |img: &GrayBuf, rng: &mut rng::SplitMix64| {
            let mut out = img.clone();
            for v in &mut out.data {
                *v = (f64::from(*v) + sigma * rng.normal())
                    .round()
                    .clamp(0.0, 255.0) as u8;
            }
            out
        };
        let (a, b) = (noisy(&a, &mut rng), noisy(&b, &mut rng));
        let params = OrbParams {
            distribution,
            ..OrbParams::default()
        };
        let detect = |img: &GrayBuf| {
            crate::features::detect_and_describe(&img.view(), &params)
                .unwrap_or_else(|e| panic!("{e}"))
        };
        let (fa, fb) = (detect(&a), detect(&b));
        let matches = match_brute_force(&fa.descriptors, &fb.descriptors, &MatchParams::default());
        let keep = gms_filter(
            &fa.keypoints,
            (w, h),
            &fb.keypoints,
            (w, h),
            &matches,
            &GmsParams::default(),
        );
        let (mut kept, mut correct) = (0, 0);
        for (m, k) in matches.iter().zip(keep) {
            if k {
                let (ka, kb) = (
                    fa.keypoints[m.query as usize],
                    fb.keypoints[m.train as usize],
                );
                let (x, y) = apply_homography(&hom, f64::from(ka.x), f64::from(ka.y));
                kept += 1;
                correct += usize::from((x - f64::from(kb.x)).hypot(y - f64::from(kb.y)) < 3.0);
            }
        }
        (kept, correct)
    }

    #[test]
    fn retain_best_keeps_more_true_matches_under_noise() {
        // Measured (correct GMS matches, quadtree / retain-best): 1000 / 1537 clean, 131 / 486
        // at sigma 0.20 and 11 / 235 at 0.30 of the intensity range: the quadtree's nodes
        // on weak texture hold corners that noise does not let repeat.
        for (sigma, factor) in [(0.0, 1.2), (0.20 * 255.0, 2.5), (0.30 * 255.0, 5.0)] {
            let (_, quad) = correct_gms_matches(KeypointDistribution::Quadtree, sigma);
            let (kept, best) = correct_gms_matches(KeypointDistribution::RetainBest, sigma);
            eprintln!("sigma {sigma:5.1}: correct quadtree {quad}, retain-best {best} of {kept}");
            assert!(
                best as f64 >= factor * quad as f64,
                "sigma {sigma}: retain-best {best} vs quadtree {quad}"
            );
            assert!(best * 2 > kept, "sigma {sigma}: {best} of {kept} correct");
        }
    }
}
