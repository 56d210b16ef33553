//! Compact encodings of the camera images for the recording, and the depth captures as points.
//!
//! Raw 1280x1024 colour (3.9 MB) and `32FC1` depth (5.2 MB) barely shrink under the .rrd's
//! LZ4 chunk compression; the viewer decodes JPEG and PNG itself ([`rerun::EncodedImage`],
//! [`rerun::EncodedDepthImage`]), so the sink stores
//! * colour as JPEG at [`JPEG_QUALITY`] (~0.3 MB a wrist capture),
//! * depth as a 16-bit grey PNG in millimetres (`16UC1`'s convention; lossless for `16UC1`,
//!   1 mm steps for `32FC1`, 0 = no depth: holes, NaN, <= 0 or beyond 65.535 m),
//! * each depth capture as coloured points in `map` ([`depth_cloud`]), decimated to at most
//!   [`MAX_CAPTURE_POINTS`].

use image::ImageEncoder as _;

use crate::VizError;
use crate::convert::{CloudPoints, Intrinsics, PixelKind, Pixels, Pose};

/// JPEG quality of the colour images (1..=100).
pub const JPEG_QUALITY: u8 = 90;
/// Most points drawn per depth capture.
pub const MAX_CAPTURE_POINTS: usize = 100_000;

fn encode_error(px: &Pixels, what: &str, e: &dyn std::fmt::Display) -> VizError {
    VizError::Image {
        encoding: format!("{:?}", px.kind),
        width: px.width,
        height: px.height,
        reason: format!("{what}: {e}"),
    }
}

/// JPEG bytes of an 8-bit colour or grey image.
///
/// # Errors
/// [`VizError::Image`] for depth pixels or an encoder failure.
pub fn jpeg(px: &Pixels) -> Result<Vec<u8>, VizError> {
    let colour = match px.kind {
        PixelKind::Rgb8 => image::ExtendedColorType::Rgb8,
        PixelKind::Mono8 => image::ExtendedColorType::L8,
        _ => return Err(encode_error(px, "JPEG", &"not an 8-bit colour image")),
    };
    let mut out = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut out, JPEG_QUALITY)
        .write_image(&px.data, px.width, px.height, colour)
        .map_err(|e| encode_error(px, "JPEG", &e))?;
    Ok(out)
}

/// Depth in millimetres, row-major, 0 where there is no depth.
///
/// # Errors
/// [`VizError::Image`] for colour pixels.
pub fn depth_mm(px: &Pixels) -> Result<Vec<u16>, VizError> {
    match px.kind {
        PixelKind::DepthU16Mm => Ok(px
            .data
            .chunks_exact(2)
            .map(|b| u16::from_le_bytes([b[0], b[1]]))
            .collect()),
        PixelKind::DepthF32M => Ok(px
            .data
            .chunks_exact(4)
            .map(|b| {
                let z = f32::from_le_bytes([b[0], b[1], b[2], b[3]]) * 1000.0;
                if z.is_finite() && z >= 0.5 && z <= f32::from(u16::MAX) {
                    z.round() as u16
                } else {
                    0
                }
            })
            .collect()),
        _ => Err(encode_error(px, "depth", &"not a depth image")),
    }
}

/// 16-bit grey PNG bytes of `mm` (`width * height` values).
///
/// # Errors
/// [`VizError::Image`] for a size mismatch or an encoder failure.
pub fn png16(mm: &[u16], width: u32, height: u32) -> Result<Vec<u8>, VizError> {
    let bad = |reason: String| VizError::Image {
        encoding: "16UC1".into(),
        width,
        height,
        reason,
    };
    if mm.len() != width as usize * height as usize {
        return Err(bad(format!("{} values for {width}x{height}", mm.len())));
    }
    let bytes: Vec<u8> = mm.iter().flat_map(|v| v.to_ne_bytes()).collect();
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new_with_quality(
        &mut out,
        image::codecs::png::CompressionType::Fast,
        image::codecs::png::FilterType::Sub,
    )
    .write_image(&bytes, width, height, image::ExtendedColorType::L16)
    .map_err(|e| bad(format!("PNG: {e}")))?;
    Ok(out)
}

/// The smallest pixel stride `s` with `ceil(w / s) * ceil(h / s) <= max_points`.
pub fn stride_for(width: u32, height: u32, max_points: usize) -> u32 {
    let mut s = 1u32;
    while (width.div_ceil(s) as usize) * (height.div_ceil(s) as usize) > max_points.max(1) {
        s += 1;
    }
    s
}

/// The points of a registered depth capture in the frame of `world_from_camera`: every
/// `stride`-th pixel `(u, v)` of every `stride`-th row with depth `z > 0` becomes
/// `world_from_camera * (z (u - cx) / fx, z (v - cy) / fy, z)` (OpenCV optical axes, pixel
/// centres at integer coordinates; the lens distortion is not undone, a few pixels at the
/// corners at rodlog's coefficients). Colours from `colour` when it has the depth's size
/// (registered), else a grey.
pub fn depth_cloud(
    mm: &[u16],
    width: u32,
    height: u32,
    colour: Option<&Pixels>,
    k: &Intrinsics,
    world_from_camera: &Pose,
    stride: u32,
) -> CloudPoints {
    let colour = colour.filter(|c| {
        c.width == width
            && c.height == height
            && matches!(c.kind, PixelKind::Rgb8 | PixelKind::Mono8)
    });
    let s = stride.max(1) as usize;
    let (w, h) = (width as usize, height as usize);
    let mut out = CloudPoints::default();
    for v in (0..h).step_by(s) {
        for u in (0..w).step_by(s) {
            let i = v * w + u;
            let Some(&z_mm) = mm.get(i) else { continue };
            if z_mm == 0 {
                continue;
            }
            let z = f64::from(z_mm) * 1e-3;
            let p = [
                z * (u as f64 - f64::from(k.principal[0])) / f64::from(k.focal[0]),
                z * (v as f64 - f64::from(k.principal[1])) / f64::from(k.focal[1]),
                z,
            ];
            let world = world_from_camera.compose(&Pose {
                t: p,
                q: [0.0, 0.0, 0.0, 1.0],
            });
            out.positions.push(world.t_f32());
            if let Some(c) = colour {
                let rgb = match c.kind {
                    PixelKind::Rgb8 => c.data.get(3 * i..3 * i + 3).map(|p| [p[0], p[1], p[2]]),
                    _ => c.data.get(i).map(|g| [*g; 3]),
                };
                out.colors.push(rgb.unwrap_or([128; 3]));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn depth_f32(w: u32, h: u32, z: impl Fn(u32, u32) -> f32) -> Pixels {
        let mut data = Vec::new();
        for v in 0..h {
            for u in 0..w {
                data.extend_from_slice(&z(u, v).to_le_bytes());
            }
        }
        Pixels {
            width: w,
            height: h,
            kind: PixelKind::DepthF32M,
            data,
        }
    }

    #[test]
    fn metres_become_millimetres_and_holes_zero() -> Result<(), VizError> {
        let px = depth_f32(4, 1, |u, _| [0.5004, f32::NAN, -1.0, 70.0][u as usize]);
        assert_eq!(depth_mm(&px)?, vec![500, 0, 0, 0]);
        Ok(())
    }

    #[test]
    fn png16_and_jpeg_decode_back() -> Result<(), VizError> {
        let mm: Vec<u16> = (0..64u16).map(|v| v * 1000 + 7).collect();
        let png = png16(&mm, 8, 8)?;
        let back = image::load_from_memory(&png)
            .map_err(|e| VizError::Flush(e.to_string()))?
            .into_luma16();
        assert_eq!(back.into_raw(), mm);
        let rgb = Pixels {
            width: 16,
            height: 8,
            kind: PixelKind::Rgb8,
            data: vec![120; 16 * 8 * 3],
        };
        let j = jpeg(&rgb)?;
        assert_eq!(&j[..2], &[0xff, 0xd8]);
        let back = image::load_from_memory(&j)
            .map_err(|e| VizError::Flush(e.to_string()))?
            .into_rgb8();
        assert_eq!(back.dimensions(), (16, 8));
        assert!(
            back.pixels()
                .all(|p| p.0.iter().all(|c| c.abs_diff(120) <= 2))
        );
        assert!(jpeg(&depth_f32(2, 2, |_, _| 1.0)).is_err());
        Ok(())
    }

    #[test]
    fn a_1280x1024_capture_is_decimated_below_the_cap() {
        let s = stride_for(1280, 1024, MAX_CAPTURE_POINTS);
        assert_eq!(s, 4);
        assert!(1280usize.div_ceil(4) * 1024usize.div_ceil(4) <= MAX_CAPTURE_POINTS);
        assert!(1280usize.div_ceil(3) * 1024usize.div_ceil(3) > MAX_CAPTURE_POINTS);
        assert_eq!(stride_for(10, 10, 1000), 1);
    }

    #[test]
    fn the_principal_point_at_one_metre_lands_on_the_camera_axis_in_the_world() {
        // 5x5 image, principal point at the centre pixel (2, 2), f = 100 px; depth 1 m.
        let k = Intrinsics {
            focal: [100.0, 100.0],
            principal: [2.0, 2.0],
            resolution: [5.0, 5.0],
        };
        let mut mm = vec![1000u16; 25];
        mm[0] = 0; // a hole
        // The camera 2 m up, looking along world +x: camera z = world x, x = -y, y = -z.
        let world_from_camera = Pose {
            t: [0.0, 0.0, 2.0],
            q: [0.5, -0.5, 0.5, -0.5],
        };
        let grey = Pixels {
            width: 5,
            height: 5,
            kind: PixelKind::Mono8,
            data: (0..25).collect(),
        };
        let c = depth_cloud(&mm, 5, 5, Some(&grey), &k, &world_from_camera, 1);
        assert_eq!(c.positions.len(), 24);
        assert_eq!(c.colors.len(), 24);
        // Pixel (2, 2) is index 12 of the image, 11 of the cloud (the hole is skipped).
        let p = c.positions[11];
        for (g, w) in p.iter().zip([1.0f32, 0.0, 2.0]) {
            assert!((g - w).abs() < 1e-6, "{p:?}");
        }
        assert_eq!(c.colors[11], [12; 3]);
        // Pixel (3, 2): 1 cm right in the image = 1 cm towards world -y.
        let q = c.positions[12];
        assert!((q[1] + 0.01).abs() < 1e-6, "{q:?}");
        let sparse = depth_cloud(&mm, 5, 5, None, &k, &world_from_camera, 2);
        assert_eq!(sparse.positions.len(), 8); // 9 samples, one hole
        assert!(sparse.colors.is_empty());
    }
}
