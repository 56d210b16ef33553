//! The pixel conversions of [`super::Remap::convert`]: `bgr8` to `rgb8`, depth units.

use msgs::sensor_msgs::Image;

fn check_image(img: &Image, bytes_per_pixel: usize) -> Result<(), String> {
    let w = img.width as usize;
    let need = (img.height as usize).saturating_sub(1) * img.step as usize + w * bytes_per_pixel;
    if (img.step as usize) < w * bytes_per_pixel || (img.height > 0 && img.data.len() < need) {
        return Err(format!(
            "{}x{} {} image with step {} has {} bytes",
            img.width,
            img.height,
            img.encoding,
            img.step,
            img.data.len()
        ));
    }
    Ok(())
}

/// `bgr8` -> `rgb8` in place.
pub(super) fn swap_bgr(img: &mut Image) -> Result<(), String> {
    check_image(img, 3)?;
    let (w, step) = (img.width as usize, img.step as usize);
    for row in 0..img.height as usize {
        let start = row * step;
        let Some(line) = img.data.get_mut(start..start + 3 * w) else {
            break;
        };
        for px in line.chunks_exact_mut(3) {
            px.swap(0, 2);
        }
    }
    img.encoding = "rgb8".to_owned();
    Ok(())
}

/// Multiplies a `32FC1` image by `scale` in place.
pub(super) fn scale_depth(img: &mut Image, scale: f64) -> Result<(), String> {
    if img.encoding != "32FC1" {
        return Err(format!(
            "depth_scale applies to 32FC1 depth, not {}",
            img.encoding
        ));
    }
    check_image(img, 4)?;
    let big = img.is_bigendian != 0;
    for v in img.data.chunks_exact_mut(4) {
        let b = [v[0], v[1], v[2], v[3]];
        let x = if big {
            f32::from_be_bytes(b)
        } else {
            f32::from_le_bytes(b)
        };
        let y = (f64::from(x) * scale) as f32;
        v.copy_from_slice(&if big {
            y.to_be_bytes()
        } else {
            y.to_le_bytes()
        });
    }
    Ok(())
}
