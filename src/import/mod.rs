//! Importers: datasets on disk -> a rodlog recording (ARCHITECTURE.md section 5).
//!
//! An imported dataset becomes the same topics a robot would have logged: per view `i`
//! (log_time = stamp = `i + 1` seconds, so the first view is not at the epoch) the hand pose
//! on `/tf` (`base_link -> tool0`, i.e. `base_from_tool0`), the colour image on
//! `/camera/color/image_raw` (`rgb8`), the registered depth on `/camera/depth/image_raw`
//! (`16UC1`, mm) when the dataset has it, and `/camera/color/camera_info` (plumb_bob) before
//! the first image. Producers are named after the importer (they are inputs, not stages), so
//! `calib self` and `replay` treat them exactly like driver data.

pub mod folder;
pub mod shecar;

use std::path::Path;

use anyhow::{Context, Result, bail};
use image::{DynamicImage, GenericImageView, imageops::FilterType};
use msgs::frames::{BASE_LINK, CAMERA_COLOR_OPTICAL_FRAME, TOOL0};
use msgs::sensor_msgs::{Image, image_encodings};
use msgs::std_msgs::Header;
use msgs::tf2_msgs::TfMessage;
use msgs::{Msg, RobotTime, topics};
use nalgebra::Isometry3;
use recorder::{McapSink, MetadataRecord, SinkOptions};
use robot::camera::CameraModel;

/// One view of a dataset: image (and depth) files and the hand pose at capture.
#[derive(Debug, Clone)]
pub struct View {
    /// Colour (or grey) image file.
    pub image: std::path::PathBuf,
    /// Registered depth image file (16-bit PNG, mm), if any.
    pub depth: Option<std::path::PathBuf>,
    /// `base_from_tool0` at the capture.
    pub base_from_tool0: Isometry3<f64>,
}

/// A dataset ready to be written.
#[derive(Debug, Clone)]
pub struct Dataset {
    /// Importer name, used as producer prefix and in metadata (`folder`, `shecar`).
    pub source: &'static str,
    /// Where it came from (for the metadata record).
    pub origin: String,
    /// Camera intrinsics at the files' resolution.
    pub camera: CameraModel,
    /// Views in capture order.
    pub views: Vec<View>,
}

/// What [`write_recording`] wrote.
#[derive(Debug, Clone, Copy)]
pub struct ImportSummary {
    /// Views written.
    pub views: usize,
    /// Views with depth.
    pub depth_views: usize,
    /// Messages written.
    pub messages: u64,
}

/// Writes `dataset` as a recording at `out`, resizing images by `scale` (1 = as stored).
///
/// # Errors
/// Unreadable or inconsistent images (size differs from the intrinsics, depth not 16-bit or
/// not the image's size), and MCAP write errors. The file is finished on every path.
pub fn write_recording(dataset: &Dataset, out: &Path, scale: f64) -> Result<ImportSummary> {
    if !(scale > 0.0 && scale <= 1.0) {
        bail!("--scale must be in (0, 1], got {scale}");
    }
    if dataset.views.is_empty() {
        bail!("the dataset has no views");
    }
    let mut sink = McapSink::create(out, &SinkOptions::default())
        .with_context(|| format!("cannot create {}", out.display()))?;
    let written = write_views(&mut sink, dataset, scale);
    // Finish on every path so that nothing written so far is lost.
    let finished = sink.finish();
    let summary = written?;
    finished.with_context(|| format!("cannot finish {}", out.display()))?;
    Ok(summary)
}

fn write_views(
    sink: &mut McapSink<std::io::BufWriter<std::fs::File>>,
    dataset: &Dataset,
    scale: f64,
) -> Result<ImportSummary> {
    let producer_camera = format!("{}_camera", dataset.source);
    let producer_hand = format!("{}_hand", dataset.source);
    sink.write_metadata(
        &MetadataRecord::new("robot_info")
            .with("source", dataset.source)
            .with("origin", &dataset.origin)
            .with("hand_frames", format!("{BASE_LINK}->{TOOL0}"))
            .with("camera_frame", CAMERA_COLOR_OPTICAL_FRAME),
    )?;
    sink.write_metadata(
        &MetadataRecord::new("build")
            .with("rodlog", env!("CARGO_PKG_VERSION"))
            .with("importer", dataset.source),
    )?;
    let mut camera: Option<CameraModel> = None;
    let mut summary = ImportSummary {
        views: 0,
        depth_views: 0,
        messages: 0,
    };
    for (index, view) in dataset.views.iter().enumerate() {
        let log_time = RobotTime::from_secs_f64(index as f64 + 1.0)?;
        let stamp = log_time.to_ros()?;
        let header = Header {
            stamp,
            frame_id: CAMERA_COLOR_OPTICAL_FRAME.to_owned(),
        };
        let color = load_rgb(&view.image, scale)
            .with_context(|| format!("view {index}: {}", view.image.display()))?;
        let (width, height) = color.dimensions();
        let intrinsics = match &camera {
            Some(c) => *c,
            None => {
                let c = check_size(&dataset.camera, scale, width, height)
                    .with_context(|| format!("view {index}: {}", view.image.display()))?;
                sink.write_msg(
                    topics::CAMERA_COLOR_INFO,
                    &producer_camera,
                    log_time,
                    log_time,
                    &Msg::from(c.to_camera_info(header.clone())),
                )?;
                summary.messages += 1;
                camera = Some(c);
                c
            }
        };
        if (width, height) != (intrinsics.width, intrinsics.height) {
            bail!(
                "view {index}: {} is {width}x{height}, the first view was {}x{}",
                view.image.display(),
                intrinsics.width,
                intrinsics.height
            );
        }
        let tf = TfMessage {
            transforms: vec![robot::conversions::transform_stamped(
                BASE_LINK,
                TOOL0,
                stamp,
                &view.base_from_tool0,
            )],
        };
        sink.write_msg(
            topics::TF,
            &producer_hand,
            log_time,
            log_time,
            &Msg::from(tf),
        )?;
        let image = Image {
            header: header.clone(),
            height,
            width,
            encoding: image_encodings::RGB8.to_owned(),
            is_bigendian: 0,
            step: width * 3,
            data: color.into_raw(),
        };
        sink.write_msg(
            topics::CAMERA_COLOR_IMAGE,
            &producer_camera,
            log_time,
            log_time,
            &Msg::from(image),
        )?;
        summary.messages += 2;
        if let Some(depth_path) = &view.depth {
            let depth = load_depth_mm(depth_path, width, height, scale)
                .with_context(|| format!("view {index}: {}", depth_path.display()))?;
            sink.write_msg(
                topics::CAMERA_DEPTH_IMAGE,
                &producer_camera,
                log_time,
                log_time,
                &Msg::from(depth.into_image(header)),
            )?;
            summary.messages += 1;
            summary.depth_views += 1;
        }
        summary.views += 1;
        sink.flush()?;
    }
    Ok(summary)
}

fn check_size(camera: &CameraModel, scale: f64, width: u32, height: u32) -> Result<CameraModel> {
    let expect_w = (f64::from(camera.width) * scale).round() as u32;
    let expect_h = (f64::from(camera.height) * scale).round() as u32;
    if (width, height) != (expect_w, expect_h) {
        bail!(
            "image is {width}x{height} but the intrinsics are for {}x{} (x{scale} = {expect_w}x{expect_h})",
            camera.width,
            camera.height
        );
    }
    Ok(if scale == 1.0 {
        *camera
    } else {
        camera.scaled(scale)?
    })
}

fn resized_dims(width: u32, height: u32, scale: f64) -> (u32, u32) {
    (
        ((f64::from(width) * scale).round() as u32).max(1),
        ((f64::from(height) * scale).round() as u32).max(1),
    )
}

fn load_rgb(path: &Path, scale: f64) -> Result<image::RgbImage> {
    let img = image::open(path).context("cannot decode image")?;
    let (w, h) = img.dimensions();
    let img = if scale == 1.0 {
        img
    } else {
        let (nw, nh) = resized_dims(w, h, scale);
        img.resize_exact(nw, nh, FilterType::Triangle)
    };
    Ok(img.to_rgb8())
}

/// A 16UC1 depth image in millimetres (0 = no data).
struct DepthMm {
    width: u32,
    height: u32,
    mm: Vec<u16>,
}

impl DepthMm {
    fn into_image(self, header: Header) -> Image {
        let mut data = Vec::with_capacity(self.mm.len() * 2);
        for v in &self.mm {
            data.extend_from_slice(&v.to_le_bytes());
        }
        Image {
            header,
            height: self.height,
            width: self.width,
            encoding: image_encodings::TYPE_16UC1.to_owned(),
            is_bigendian: 0,
            step: self.width * 2,
            data,
        }
    }
}

/// Loads a 16-bit depth PNG (mm). Resizing uses nearest neighbour on purpose: averaging
/// depth across an edge invents surfaces that are not there.
fn load_depth_mm(path: &Path, width: u32, height: u32, scale: f64) -> Result<DepthMm> {
    let img = image::open(path).context("cannot decode depth image")?;
    let DynamicImage::ImageLuma16(depth) = img else {
        bail!(
            "depth must be a 16-bit single-channel PNG in millimetres, got {:?}",
            img.color()
        );
    };
    let depth = if scale == 1.0 {
        depth
    } else {
        let (w, h) = depth.dimensions();
        let (nw, nh) = resized_dims(w, h, scale);
        image::imageops::resize(&depth, nw, nh, FilterType::Nearest)
    };
    if depth.dimensions() != (width, height) {
        let (w, h) = depth.dimensions();
        bail!(
            "depth is {w}x{h} but its colour image is {width}x{height} (depth must be registered)"
        );
    }
    Ok(DepthMm {
        width,
        height,
        mm: depth.into_raw(),
    })
}
