//! The scene of photographs of `rodlog experiment noise --scene photos`: the calibration
//! views see real image content with exact geometry and depth.
//!
//! The shecar sample's 18 photographs ([`crate::import::shecar`], read from
//! `RODLOG_SHARED_DATA/shecar` or `RODLOG_SHECAR`, never copied into the repository) are
//! laid on a wall where the substation's calibration cabinet stands, in the cabinet's place
//! and facing the same way, six of them tiled 2 x 3 at [`TEXEL_M`] per texel, and three boxes
//! stand out of the wall by 6-14 cm with the other photos on their faces
//! ([`sim::render::photo`]). The views, the arm and the noise are the substation trial's
//! (`super::noise`): only what the camera sees changes. The photos bring what the procedural
//! textures cannot (a photographer's light, blur and JPEG artefacts, repeated chessboard
//! squares and shelves); the depth is exact, plus the noise levels' depth noise.

use std::path::Path;

use anyhow::{Context, Result, bail};
use nalgebra::{Point3, Vector3};
use sim::render::photo::{PhotoScene, PhotoTexture, WallBox};

/// Size of a photo's texel on the wall, metres (a 3264-pixel photo resized to 1600 texels
/// spans 0.6 m; the wrist camera's pixel is 0.44-0.6 mm at 0.38-0.52 m at the noise
/// experiment's render scale, so the photos are about as sharp as the pixels).
pub const TEXEL_M: f64 = 0.000_375;
/// Texels across a resized photo.
pub const TEXELS_WIDE: u32 = 1600;
/// Photos tiled on the wall (columns, rows).
pub const WALL_TILES: (usize, usize) = (2, 3);
/// The boxes standing out of the wall (wall frame: right, up; size: width, height, out).
pub const BOXES: [WallBox; 3] = [
    WallBox {
        centre_m: [-0.13, -0.07],
        size_m: [0.16, 0.12, 0.10],
    },
    WallBox {
        centre_m: [0.15, 0.06],
        size_m: [0.12, 0.18, 0.06],
    },
    WallBox {
        centre_m: [0.02, 0.17],
        size_m: [0.22, 0.09, 0.14],
    },
];
/// Photographs read from the sample folder (`00.jpg` ..).
pub const PHOTOS: usize = 18;

/// The photos of `dir`, resized to [`TEXELS_WIDE`] texels across (aspect kept).
///
/// # Errors
/// A missing or unreadable photo, with where to get the sample.
pub fn read_textures(dir: &Path) -> Result<Vec<PhotoTexture>> {
    if !dir.join("00.jpg").is_file() {
        bail!(
            "--scene photos needs the shecar sample's photographs, and {} has no 00.jpg: get \
             them with `git clone --depth 1 https://github.com/STAR-Center/shecar` and set \
             RODLOG_SHECAR=shecar/data/monocular",
            dir.display()
        );
    }
    (0..PHOTOS)
        .map(|i| {
            let path = dir.join(format!("{i:02}.jpg"));
            let img = image::open(&path)
                .with_context(|| format!("reading {}", path.display()))?
                .to_rgb8();
            let height = (f64::from(img.height()) * f64::from(TEXELS_WIDE)
                / f64::from(img.width().max(1)))
            .round()
            .max(1.0) as u32;
            let small = image::imageops::resize(
                &img,
                TEXELS_WIDE,
                height,
                image::imageops::FilterType::Triangle,
            );
            Ok(PhotoTexture {
                width: small.width() as usize,
                height: small.height() as usize,
                rgb: small.into_raw(),
                texel_m: TEXEL_M,
            })
        })
        .collect()
}

/// The wall of photos centred at `centre` (the noise trials' look-at point), facing
/// `normal` (module docs).
#[must_use]
pub fn scene(centre: Point3<f64>, normal: Vector3<f64>, textures: Vec<PhotoTexture>) -> PhotoScene {
    PhotoScene::wall_with_boxes(centre, normal, Vector3::z(), textures, WALL_TILES, &BOXES)
}

/// Reads the photos of `dir` and builds the scene (module docs).
///
/// # Errors
/// Those of [`read_textures`].
pub fn open(dir: &Path, centre: Point3<f64>, normal: Vector3<f64>) -> Result<PhotoScene> {
    Ok(scene(centre, normal, read_textures(dir)?))
}
