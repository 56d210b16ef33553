//! The cameras: pinholes, images, depth captures as points in `map`, and the hand-eye frusta
//! drawn when the camera edge moves (a recalibration).

use msgs::builtin_interfaces::Time;
use msgs::sensor_msgs::{CameraInfo, Image};
use rerun::{
    AsComponents, CoordinateFrame, EncodedDepthImage, EncodedImage, MediaType, Pinhole, Points3D,
    TextLog,
};

use crate::VizError;
use crate::convert;
use crate::convert::{Intrinsics, PixelKind, Pixels, Pose};
use crate::encode;

use super::{
    CALIBRATION, CALIBRATION_CAPTURES, CALIBRATION_PLANE_M, CAPTURE_POINT_RADIUS_M, CAPTURES,
    GREEN, GREY, RECALIBRATION_EPS, Viz, frame_or,
};

impl Viz {
    /// One depth capture as coloured points in `map`, under `world/captures/<nnnn>`.
    pub(super) fn log_capture(&mut self, depth: &Pixels, stamp: Time) -> Result<(), VizError> {
        let Some((k, _)) = self.wrist else {
            return Ok(());
        };
        let camera = msgs::frames::CAMERA_COLOR_OPTICAL_FRAME;
        let Some(map_from_camera) = self.tf.lookup(msgs::frames::MAP, camera) else {
            return Ok(());
        };
        let mm = encode::depth_mm(depth)?;
        let colour = self
            .images
            .iter()
            .rev()
            .find(|(s, _)| *s == stamp)
            .map(|(_, p)| p);
        let stride = encode::stride_for(depth.width, depth.height, encode::MAX_CAPTURE_POINTS);
        let cloud = encode::depth_cloud(
            &mm,
            depth.width,
            depth.height,
            colour,
            &k,
            &map_from_camera,
            stride,
        );
        self.stats.captures += 1;
        let mut points = Points3D::new(cloud.positions).with_radii([CAPTURE_POINT_RADIUS_M]);
        if !cloud.colors.is_empty() {
            points = points.with_colors(cloud.colors);
        }
        let group = if self.calibration_views {
            CALIBRATION_CAPTURES.to_owned()
        } else {
            format!("{CAPTURES}/task")
        };
        let entity = format!("{group}/{:04}", self.stats.captures);
        // The frame static: before the capture's time the entity must still resolve to `map`
        // (an entity without a frame at the cursor's time is in `tf#/<path>`, which has no
        // path to `map`, and the whole 3D view is reported in error).
        self.rec
            .log_static(entity.as_str(), &CoordinateFrame::new(msgs::frames::MAP))?;
        self.rec.log(entity, &points)?;
        Ok(())
    }

    /// Draws the hand-eye X before and after a change of the camera edge (a recalibration
    /// accepted by the calibration stage) as two frusta under `tool0`.
    pub(super) fn camera_edge_moved(&mut self, now: &Pose) -> Result<(), VizError> {
        let Some(before) = self.camera_edge.replace(*now) else {
            return Ok(());
        };
        let moved = before
            .t
            .iter()
            .zip(&now.t)
            .chain(before.q.iter().zip(&now.q))
            .any(|(a, b)| (a - b).abs() > RECALIBRATION_EPS);
        if !moved {
            return Ok(());
        }
        let Some((k, _)) = self.wrist else {
            return Ok(());
        };
        self.stats.recalibrations += 1;
        for (name, pose, colour) in [("x_before", before, GREY), ("x_after", *now, GREEN)] {
            let frame = format!("calibration/{name}");
            let entity = format!("{CALIBRATION}/{name}");
            self.log_named_pose(&entity, msgs::frames::TOOL0, &frame, &pose)?;
            self.log_frustum(&format!("{entity}/frustum"), &frame, &k, colour)?;
        }
        let dt = [
            (now.t[0] - before.t[0]) * 1e3,
            (now.t[1] - before.t[1]) * 1e3,
            (now.t[2] - before.t[2]) * 1e3,
        ];
        let dot = before
            .q
            .iter()
            .zip(&now.q)
            .map(|(a, b)| a * b)
            .sum::<f64>()
            .abs()
            .min(1.0);
        self.rec.log(
            "log/calibration",
            &TextLog::new(format!(
                "tool0_from_camera changed by {:.2} mm, {:.3} deg (frusta: grey before, green after)",
                (dt[0] * dt[0] + dt[1] * dt[1] + dt[2] * dt[2]).sqrt(),
                (2.0 * dot.acos()).to_degrees()
            ))
            .with_level(rerun::TextLogLevel::INFO),
        )?;
        Ok(())
    }

    /// A pinhole frustum (no image) in `frame`.
    pub(super) fn log_frustum(
        &mut self,
        entity: &str,
        frame: &str,
        k: &Intrinsics,
        colour: [u8; 3],
    ) -> Result<(), VizError> {
        let pinhole = Pinhole::from_focal_length_and_resolution(k.focal, k.resolution)
            .with_principal_point(k.principal)
            .with_parent_frame(frame)
            .with_child_frame(format!("{frame}_image_plane"))
            .with_image_plane_distance(CALIBRATION_PLANE_M)
            .with_color(rerun::Color::from_rgb(colour[0], colour[1], colour[2]));
        self.anchor(entity)?;
        self.rec.log(
            entity,
            &[&pinhole as &dyn AsComponents, &CoordinateFrame::new(frame)],
        )?;
        Ok(())
    }

    pub(super) fn log_pinhole(
        &mut self,
        entity: &str,
        info: &CameraInfo,
        default_frame: &str,
        plane_m: f32,
    ) -> Result<(), VizError> {
        let k = convert::intrinsics(info)?;
        let frame = frame_or(&info.header.frame_id, default_frame);
        self.see_frame(frame)?;
        let pinhole = Pinhole::from_focal_length_and_resolution(k.focal, k.resolution)
            .with_principal_point(k.principal)
            .with_parent_frame(frame)
            .with_child_frame(format!("{frame}_image_plane"))
            .with_image_plane_distance(plane_m);
        // Static: the camera model is the recording's (a later camera info replaces it for
        // all times), and its image plane then exists at all times, so the image entity below
        // it is never without a pinhole ancestor (a view error) before the first camera info.
        self.rec.log_static(
            entity,
            &[&pinhole as &dyn AsComponents, &CoordinateFrame::new(frame)],
        )?;
        Ok(())
    }

    /// Logs a colour (JPEG) or depth (16-bit PNG, mm) image in `<frame>_image_plane` and
    /// returns its pixels.
    pub(super) fn log_image(
        &mut self,
        entity: &str,
        img: &Image,
        default_frame: &str,
    ) -> Result<Pixels, VizError> {
        let px = convert::image_pixels(img)?;
        let plane_frame = format!(
            "{}_image_plane",
            frame_or(&img.header.frame_id, default_frame)
        );
        // The image plane static (its camera's static pinhole defines it at all times): every
        // temporal row of an encoded-image entity then holds an image. The viewer plays
        // encoded images through its video cache, which panicked ("index out of bounds" in
        // video_stream_cache.rs) on an entity whose chunks also held rows without one (a
        // temporal frame-only row).
        if self.anchored.insert(entity.to_owned()) {
            self.rec
                .log_static(entity, &CoordinateFrame::new(plane_frame))?;
        }
        match px.kind {
            PixelKind::Rgb8 | PixelKind::Mono8 => {
                let image =
                    EncodedImage::new(encode::jpeg(&px)?).with_media_type(MediaType::jpeg());
                self.rec.log(entity, &image)?;
            }
            PixelKind::DepthF32M | PixelKind::DepthU16Mm => {
                let mm = encode::depth_mm(&px)?;
                let depth = EncodedDepthImage::new(encode::png16(&mm, px.width, px.height)?)
                    .with_media_type(MediaType::png())
                    .with_meter(1000.0f32);
                self.rec.log(entity, &depth)?;
            }
        }
        Ok(px)
    }
}
