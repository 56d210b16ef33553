//! Match pictures: the two images side by side (A left, B right, top-aligned), a line per
//! match, GMS inliers green (thick, opaque) drawn over rejected matches in red (thin,
//! translucent, so that thousands of them do not hide the inliers), keypoints as small cyan
//! crosses.

use image::{Rgb, RgbImage};

use super::Keypoint;
use super::gray::GrayView;
use super::matcher::Match;

/// Colour of inlier lines.
pub const INLIER: Rgb<u8> = Rgb([0, 220, 0]);
/// Colour of rejected lines.
pub const REJECTED: Rgb<u8> = Rgb([230, 0, 0]);
/// Colour of keypoint marks.
pub const KEYPOINT: Rgb<u8> = Rgb([0, 200, 255]);

fn put(img: &mut RgbImage, x: i64, y: i64, c: Rgb<u8>) {
    if x >= 0 && y >= 0 && x < i64::from(img.width()) && y < i64::from(img.height()) {
        img.put_pixel(x as u32, y as u32, c);
    }
}

/// Opacity of rejected-match lines.
const REJECTED_ALPHA: f32 = 0.25;

fn blend(img: &mut RgbImage, x: i64, y: i64, c: Rgb<u8>, alpha: f32) {
    if x >= 0 && y >= 0 && x < i64::from(img.width()) && y < i64::from(img.height()) {
        let p = img.get_pixel_mut(x as u32, y as u32);
        for k in 0..3 {
            let v = f32::from(p.0[k]) * (1.0 - alpha) + f32::from(c.0[k]) * alpha;
            p.0[k] = v.round().clamp(0.0, 255.0) as u8;
        }
    }
}

/// Points of the Bresenham line from `(x0, y0)` to `(x1, y1)`.
fn line_points((x0, y0): (i64, i64), (x1, y1): (i64, i64), mut f: impl FnMut(i64, i64)) {
    let (dx, dy) = ((x1 - x0).abs(), -(y1 - y0).abs());
    let (sx, sy) = (if x0 < x1 { 1 } else { -1 }, if y0 < y1 { 1 } else { -1 });
    let (mut x, mut y, mut err) = (x0, y0, dx + dy);
    loop {
        f(x, y);
        if x == x1 && y == y1 {
            break;
        }
        let e2 = 2 * err;
        if e2 >= dy {
            err += dy;
            x += sx;
        }
        if e2 <= dx {
            err += dx;
            y += sy;
        }
    }
}

/// Bresenham line from `(x0, y0)` to `(x1, y1)`, clipped to the image.
pub fn draw_line(img: &mut RgbImage, p: (i64, i64), q: (i64, i64), c: Rgb<u8>) {
    line_points(p, q, |x, y| put(img, x, y, c));
}

/// The side-by-side picture (module docs). `inliers[i]` belongs to `matches[i]` (missing
/// entries count as rejected); matches with indices outside the keypoint slices are skipped.
pub fn draw_matches(
    a: &GrayView<'_>,
    b: &GrayView<'_>,
    kps_a: &[Keypoint],
    kps_b: &[Keypoint],
    matches: &[Match],
    inliers: &[bool],
) -> RgbImage {
    let w = (a.width() + b.width()) as u32;
    let h = a.height().max(b.height()) as u32;
    let mut img = RgbImage::new(w, h);
    for (view, ox) in [(a, 0usize), (b, a.width())] {
        for y in 0..view.height() {
            let Some(row) = view.row(y) else { continue };
            for (x, &p) in row.iter().enumerate() {
                img.put_pixel((x + ox) as u32, y as u32, Rgb([p, p, p]));
            }
        }
    }
    let off = a.width() as f32;
    let ends = |m: &Match| -> Option<((i64, i64), (i64, i64))> {
        let ka = kps_a.get(m.query as usize)?;
        let kb = kps_b.get(m.train as usize)?;
        Some((
            (ka.x.round() as i64, ka.y.round() as i64),
            ((kb.x + off).round() as i64, kb.y.round() as i64),
        ))
    };
    // Inlier lines get thicker on big images so they stay visible when scaled down.
    let half_width = i64::from(h / 700);
    for pass in [false, true] {
        for (i, m) in matches.iter().enumerate() {
            if inliers.get(i).copied().unwrap_or(false) != pass {
                continue;
            }
            let Some((p, q)) = ends(m) else { continue };
            if pass {
                line_points(p, q, |x, y| {
                    for d in -half_width..=half_width {
                        put(&mut img, x, y + d, INLIER);
                    }
                });
            } else {
                line_points(p, q, |x, y| blend(&mut img, x, y, REJECTED, REJECTED_ALPHA));
            }
        }
    }
    let mut cross = |x: f32, y: f32| {
        let (x, y) = (x.round() as i64, y.round() as i64);
        for d in -2..=2 {
            put(&mut img, x + d, y, KEYPOINT);
            put(&mut img, x, y + d, KEYPOINT);
        }
    };
    for k in kps_a {
        cross(k.x, k.y);
    }
    for k in kps_b {
        cross(k.x + off, k.y);
    }
    img
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_hits_both_ends() {
        let mut img = RgbImage::new(10, 10);
        draw_line(&mut img, (1, 2), (8, 7), INLIER);
        assert_eq!(*img.get_pixel(1, 2), INLIER);
        assert_eq!(*img.get_pixel(8, 7), INLIER);
        assert_eq!(img.pixels().filter(|p| **p == INLIER).count(), 8);
    }
}
