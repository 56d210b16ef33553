//! TF frames (their axes, the edges Rerun composes) and the executed `tool0` path.

use msgs::geometry_msgs::TransformStamped;
use rerun::{AsComponents, CoordinateFrame, LineStrips3D, TransformAxes3D};

use crate::VizError;
use crate::convert::Pose;

use super::{
    CYAN, EXECUTED, FRAME_AXES_M, LABELLED_FRAMES, TRAJECTORY_PERIOD_NS, TRAJECTORY_STEP_M, Viz,
    part, transform,
};

impl Viz {
    /// Logs the axes of `frame` the first time it is seen (at that time, not static: a frame
    /// drawn before its transform arrives is unreachable, which the viewer flags as an error).
    pub(super) fn see_frame(&mut self, frame: &str) -> Result<(), VizError> {
        if self.frames_seen.contains(frame) {
            return Ok(());
        }
        self.frames_seen.insert(frame.to_owned());
        let entity = format!("world/frames/{}", part(frame));
        self.anchor(&entity)?;
        self.rec.log(
            entity,
            &[
                &CoordinateFrame::new(frame) as &dyn AsComponents,
                &TransformAxes3D::new(FRAME_AXES_M)
                    .with_show_frame(LABELLED_FRAMES.contains(&frame)),
            ],
        )?;
        Ok(())
    }

    pub(super) fn log_tf_edge(&mut self, ts: &TransformStamped) -> Result<(), VizError> {
        let parent = ts.header.frame_id.trim_start_matches('/');
        let child = ts.child_frame_id.trim_start_matches('/');
        if parent.is_empty() || child.is_empty() {
            return Err(VizError::Transform {
                parent: parent.to_owned(),
                child: child.to_owned(),
            });
        }
        let pose = Pose::from_transform(&ts.transform);
        if parent == msgs::frames::TOOL0 && child == msgs::frames::CAMERA_COLOR_OPTICAL_FRAME {
            self.camera_edge_moved(&pose)?;
        }
        self.tf.set(parent, child, pose);
        self.see_frame(parent)?;
        self.see_frame(child)?;
        self.rec.log(
            format!("world/tf/{}", part(child)),
            &transform(parent, child, &pose),
        )?;
        Ok(())
    }

    /// Appends `base_link_from_tool0` to the executed path when it moved, and re-logs the
    /// path at most every [`TRAJECTORY_PERIOD_NS`].
    pub(super) fn update_executed(&mut self, log_time_ns: u64) -> Result<(), VizError> {
        if let Some(p) = self.tf.lookup(msgs::frames::BASE_LINK, msgs::frames::TOOL0) {
            let moved = self.executed_last.is_none_or(|q| {
                let d = [p.t[0] - q[0], p.t[1] - q[1], p.t[2] - q[2]];
                (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() > TRAJECTORY_STEP_M
            });
            if moved {
                self.executed_last = Some(p.t);
                self.executed.push(p.t_f32());
                self.executed_dirty = true;
            }
        }
        let due = self
            .executed_logged_ns
            .is_none_or(|t0| log_time_ns.saturating_sub(t0) >= TRAJECTORY_PERIOD_NS);
        if self.executed_dirty && due {
            self.log_executed(log_time_ns)?;
        }
        Ok(())
    }

    pub(super) fn log_executed(&mut self, log_time_ns: u64) -> Result<(), VizError> {
        self.anchor(EXECUTED)?;
        let strips = LineStrips3D::new([self.executed.clone()])
            .with_colors([CYAN])
            .with_radii([0.003f32]);
        self.rec.log(
            EXECUTED,
            &[
                &strips as &dyn AsComponents,
                &CoordinateFrame::new(msgs::frames::BASE_LINK),
            ],
        )?;
        self.executed_dirty = false;
        self.executed_logged_ns = Some(log_time_ns);
        Ok(())
    }
}
