//! The calibration's results: the hand-eye message as text and scalars, and the matches of a
//! view pair drawn side by side.

use msgs::builtin_interfaces::Time;
use msgs::rodlog_msgs::{FeatureMatches, HandEyeCalibration};
use rerun::{EncodedImage, LineStrips2D, MediaType, TextLog};

use crate::VizError;
use crate::convert;
use crate::convert::{PixelKind, Pixels};
use crate::encode;

use super::{GREEN, MATCHES_IMAGE, MATCHES_INLIERS, MATCHES_REJECTED, RED, Viz};

impl Viz {
    pub(super) fn log_hand_eye(&mut self, c: &HandEyeCalibration) -> Result<(), VizError> {
        self.scalar("plots/calibration/residual_rot_deg", c.residual_rot_deg)?;
        self.scalar("plots/calibration/residual_trans_mm", c.residual_trans_mm)?;
        self.scalar("plots/calibration/sigma_rot_deg", c.sigma_rot_deg)?;
        self.scalar("plots/calibration/sigma_trans_mm", c.sigma_trans_mm)?;
        let tr = c.tool0_from_camera.translation;
        let text = format!(
            "hand-eye {} ({}): {} views, {} pairs, t = [{:.4}, {:.4}, {:.4}] m, residual {:.3} deg / {:.2} mm, sigma {:.3} deg / {:.2} mm, condition {:.1}, scale {:.4}",
            c.method,
            c.mode,
            c.views,
            c.pairs,
            tr.x,
            tr.y,
            tr.z,
            c.residual_rot_deg,
            c.residual_trans_mm,
            c.sigma_rot_deg,
            c.sigma_trans_mm,
            c.condition,
            c.scale
        );
        self.rec.log(
            "log/calibration",
            &TextLog::new(text).with_level(rerun::TextLogLevel::INFO),
        )?;
        Ok(())
    }

    pub(super) fn log_matches(&mut self, m: &FeatureMatches) -> Result<(), VizError> {
        let find = |stamp: Time| {
            self.images
                .iter()
                .rev()
                .find(|(s, _)| *s == stamp)
                .map(|(_, p)| p)
        };
        let (a, b) = (find(m.stamp_a), find(m.stamp_b));
        let fallback = self.wrist.map(|(_, size)| size).unwrap_or_else(|| {
            // No camera info yet: the keypoints' extent.
            let max = |kp: &[f32], k: usize| {
                kp.iter()
                    .skip(k)
                    .step_by(2)
                    .fold(1.0f32, |acc, v| acc.max(v.ceil()))
            };
            [
                max(&m.keypoints_a, 0).max(max(&m.keypoints_b, 0)) as u32,
                max(&m.keypoints_a, 1).max(max(&m.keypoints_b, 1)) as u32,
            ]
        });
        let canvas = convert::match_canvas(m, a, b, fallback)?;
        let n_in = canvas.inliers.len();
        let n_out = canvas.rejected.len();
        let px = Pixels {
            width: canvas.width,
            height: canvas.height,
            kind: PixelKind::Rgb8,
            data: canvas.rgb,
        };
        self.rec.log(
            MATCHES_IMAGE,
            &EncodedImage::new(encode::jpeg(&px)?).with_media_type(MediaType::jpeg()),
        )?;
        let segs = |v: &[[[f32; 2]; 2]]| v.iter().map(|s| s.to_vec()).collect::<Vec<_>>();
        self.rec.log(
            MATCHES_INLIERS,
            &LineStrips2D::new(segs(&canvas.inliers))
                .with_colors([GREEN])
                .with_radii([0.75f32])
                .with_draw_order(10.0),
        )?;
        self.rec.log(
            MATCHES_REJECTED,
            &LineStrips2D::new(segs(&canvas.rejected))
                .with_colors([RED])
                .with_radii([0.5f32])
                .with_draw_order(9.0),
        )?;
        self.rec.log(
            "log/calibration",
            &TextLog::new(format!(
                "matches {}: {n_in} inliers, {n_out} rejected ({} / {} keypoints{})",
                m.method,
                m.keypoints_a.len() / 2,
                m.keypoints_b.len() / 2,
                if a.is_none() || b.is_none() {
                    ", an image was not in the stream"
                } else {
                    ""
                }
            ))
            .with_level(rerun::TextLogLevel::DEBUG),
        )?;
        Ok(())
    }
}
