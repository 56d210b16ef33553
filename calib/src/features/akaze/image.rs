//! Float images and the separable filters of the AKAZE scale space.
//!
//! Borders follow OpenCV so the pyramid matches the reference implementation: Gaussian
//! smoothing replicates the edge pixel, derivative filters mirror without repeating it
//! (`reflect101`: `-1 -> 1`, `n -> n - 2`). Filters take their taps as `(offset, weight)`
//! lists so the sparse scale-`s` derivative kernels (three non-zero taps `s` apart) cost
//! three multiply-adds per pixel and pass.

/// A row-major single-channel `f32` image.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ImageF32 {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// `width * height` values, row after row.
    pub data: Vec<f32>,
}

impl ImageF32 {
    /// A zero image.
    pub fn zeros(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            data: vec![0.0; width * height],
        }
    }

    /// Resizes to `width x height` (contents unspecified afterwards).
    pub fn reshape(&mut self, width: usize, height: usize) {
        self.width = width;
        self.height = height;
        self.data.resize(width * height, 0.0);
    }

    /// Row `y`.
    #[inline]
    pub fn row(&self, y: usize) -> &[f32] {
        &self.data[y * self.width..(y + 1) * self.width]
    }

    /// Value at `(x, y)`, `None` outside.
    #[inline]
    pub fn get(&self, x: usize, y: usize) -> Option<f32> {
        if x < self.width && y < self.height {
            self.data.get(y * self.width + x).copied()
        } else {
            None
        }
    }
}

/// How a filter reads beyond the image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Border {
    /// `aaa|abcd|ddd` (OpenCV `BORDER_REPLICATE`).
    Replicate,
    /// `cb|abcd|cb` (OpenCV `BORDER_REFLECT_101`, its `BORDER_DEFAULT`).
    Reflect101,
}

#[inline]
fn border_index(i: isize, n: usize, border: Border) -> usize {
    let n = n as isize;
    if n <= 1 {
        return 0;
    }
    let r = match border {
        Border::Replicate => i.clamp(0, n - 1),
        Border::Reflect101 => {
            let mut i = i;
            // Loop for offsets larger than the image (tiny levels).
            loop {
                if i < 0 {
                    i = -i;
                } else if i >= n {
                    i = 2 * n - 2 - i;
                } else {
                    break i;
                }
            }
        }
    };
    r as usize
}

/// A 1D kernel as non-zero `(offset, weight)` taps.
#[derive(Clone, Debug, PartialEq)]
pub struct Kernel1 {
    taps: Vec<(isize, f32)>,
    radius: usize,
}

impl Kernel1 {
    /// A dense, centred kernel of odd length (zero weights dropped).
    pub fn dense(weights: &[f32]) -> Self {
        let r = weights.len() / 2;
        let taps = weights
            .iter()
            .enumerate()
            .filter(|(_, w)| **w != 0.0)
            .map(|(i, w)| (i as isize - r as isize, *w))
            .collect();
        Self { taps, radius: r }
    }

    /// OpenCV's `getGaussianKernel(ksize, sigma)`: `exp(-(i - r)^2 / (2 sigma^2))`,
    /// normalised to sum 1.
    pub fn gaussian(ksize: usize, sigma: f32) -> Self {
        let r = ksize / 2;
        let s2 = 2.0 * f64::from(sigma) * f64::from(sigma);
        let w: Vec<f64> = (0..2 * r + 1)
            .map(|i| {
                let d = i as f64 - r as f64;
                (-d * d / s2).exp()
            })
            .collect();
        let sum: f64 = w.iter().sum();
        let w: Vec<f32> = w.iter().map(|v| (v / sum) as f32).collect();
        Self::dense(&w)
    }

    /// The scale-`s` first-derivative kernel `[-1, 0 x (2s-1), 1]`: the difference over
    /// `2s` pixels (Alcantarilla et al. 2013 sec. 4.1, OpenCV `compute_derivative_kernels`).
    pub fn derivative(s: usize) -> Self {
        let s = s.max(1) as isize;
        Self {
            taps: vec![(-s, -1.0), (s, 1.0)],
            radius: s as usize,
        }
    }

    /// The scale-`s` Scharr smoothing kernel `[3, 0.., 10, 0.., 3] / (32 s)`: with
    /// [`Kernel1::derivative`] it yields the true derivative of a ramp (gain 1), and for
    /// `s = 1` it is Scharr's normalised 3x3 operator.
    pub fn scharr_smooth(s: usize) -> Self {
        let sf = s.max(1) as f32;
        let si = s.max(1) as isize;
        let norm = 1.0 / (2.0 * sf * (10.0 / 3.0 + 2.0));
        Self {
            taps: vec![(-si, norm), (0, 10.0 / 3.0 * norm), (si, norm)],
            radius: s.max(1),
        }
    }
}

/// OpenCV's Gaussian kernel size for `sigma`: `ceil(2 (1 + (sigma - 0.8) / 0.3))`, made odd.
pub fn gaussian_ksize(sigma: f32) -> usize {
    let k = (2.0 * (1.0 + (sigma - 0.8) / 0.3)).ceil().max(1.0) as usize;
    k | 1
}

/// Scratch of [`sep_filter`].
#[derive(Clone, Debug, Default)]
pub struct FilterScratch {
    padded: Vec<f32>,
    tmp: Vec<f32>,
}

/// `dst = ky (vertical) * (kx (horizontal) * src)` with `border` on both axes.
pub fn sep_filter(
    src: &ImageF32,
    kx: &Kernel1,
    ky: &Kernel1,
    border: Border,
    dst: &mut ImageF32,
    scratch: &mut FilterScratch,
) {
    let (w, h) = (src.width, src.height);
    dst.reshape(w, h);
    if w == 0 || h == 0 {
        return;
    }
    let r = kx.radius;
    scratch.padded.resize(w + 2 * r, 0.0);
    scratch.tmp.resize(w * h, 0.0);
    // Horizontal pass into tmp.
    for y in 0..h {
        let row = src.row(y);
        let pad = &mut scratch.padded;
        pad[r..r + w].copy_from_slice(row);
        for i in 0..r {
            pad[r - 1 - i] = row[border_index(-(i as isize) - 1, w, border)];
            pad[r + w + i] = row[border_index((w + i) as isize, w, border)];
        }
        let out = &mut scratch.tmp[y * w..(y + 1) * w];
        out.fill(0.0);
        for &(o, k) in &kx.taps {
            let start = (r as isize + o) as usize;
            let seg = &pad[start..start + w];
            for (d, s) in out.iter_mut().zip(seg) {
                *d += k * *s;
            }
        }
    }
    // Vertical pass into dst.
    for y in 0..h {
        let out = &mut dst.data[y * w..(y + 1) * w];
        out.fill(0.0);
        for &(o, k) in &ky.taps {
            let sy = border_index(y as isize + o, h, border);
            let seg = &scratch.tmp[sy * w..(sy + 1) * w];
            for (d, s) in out.iter_mut().zip(seg) {
                *d += k * *s;
            }
        }
    }
}

/// Gaussian smoothing with OpenCV's kernel (`ksize` odd) and replicated borders.
pub fn gaussian_blur(
    src: &ImageF32,
    ksize: usize,
    sigma: f32,
    dst: &mut ImageF32,
    scratch: &mut FilterScratch,
) {
    let k = Kernel1::gaussian(ksize, sigma);
    sep_filter(src, &k, &k, Border::Replicate, dst, scratch);
}

/// Halves an image by 2x2 averaging: `dst` is `(w / 2) x (h / 2)` (OpenCV `INTER_AREA` at
/// an exact factor of two; an odd last row or column is dropped).
pub fn half_sample(src: &ImageF32, dst: &mut ImageF32) {
    let (w, h) = (src.width / 2, src.height / 2);
    dst.reshape(w, h);
    for y in 0..h {
        let r0 = src.row(2 * y);
        let r1 = src.row(2 * y + 1);
        let out = &mut dst.data[y * w..(y + 1) * w];
        for (x, o) in out.iter_mut().enumerate() {
            *o = 0.25 * (r0[2 * x] + r0[2 * x + 1] + r1[2 * x] + r1[2 * x + 1]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn borders_match_opencv() {
        let idx: Vec<usize> = (-3..8)
            .map(|i| border_index(i, 5, Border::Reflect101))
            .collect();
        assert_eq!(idx, vec![3, 2, 1, 0, 1, 2, 3, 4, 3, 2, 1]);
        let idx: Vec<usize> = (-2..7)
            .map(|i| border_index(i, 5, Border::Replicate))
            .collect();
        assert_eq!(idx, vec![0, 0, 0, 1, 2, 3, 4, 4, 4]);
    }

    #[test]
    fn derivative_kernels_give_the_slope_of_a_ramp() {
        // f(x, y) = 0.3 x - 0.2 y: every scale returns the slope inside the image.
        let (w, h) = (40, 30);
        let mut img = ImageF32::zeros(w, h);
        for y in 0..h {
            for x in 0..w {
                img.data[y * w + x] = 0.3 * x as f32 - 0.2 * y as f32;
            }
        }
        let mut s = FilterScratch::default();
        let mut lx = ImageF32::default();
        let mut ly = ImageF32::default();
        for scale in 1..5 {
            let (d, m) = (Kernel1::derivative(scale), Kernel1::scharr_smooth(scale));
            sep_filter(&img, &d, &m, Border::Reflect101, &mut lx, &mut s);
            sep_filter(&img, &m, &d, Border::Reflect101, &mut ly, &mut s);
            let (cx, cy) = (w / 2, h / 2);
            assert!((lx.data[cy * w + cx] - 0.3).abs() < 1e-5);
            assert!((ly.data[cy * w + cx] + 0.2).abs() < 1e-5);
        }
        let g = Kernel1::gaussian(9, 1.6);
        let sum: f32 = g.taps.iter().map(|t| t.1).sum();
        assert!((sum - 1.0).abs() < 1e-6);
        assert_eq!(gaussian_ksize(1.6), 9);
        assert_eq!(gaussian_ksize(1.0), 5);
    }
}
