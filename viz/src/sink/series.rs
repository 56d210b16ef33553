//! Time series and text lanes: scalars, joint positions, task states, command lines, and the
//! series' styles.

use msgs::rodlog_msgs::TaskEvent;
use msgs::sensor_msgs::JointState;
use rerun::{Scalars, SeriesLines, StateChange, TextLog};

use crate::VizError;
use crate::site::RodBelief;

use super::{CYAN, GREEN, ORANGE, RED, STATES, Viz, part};

impl Viz {
    pub(super) fn command_line(&mut self, topic: &str, text: String) -> Result<(), VizError> {
        self.rec.log(
            "log/commands",
            &TextLog::new(format!("{topic}: {text}")).with_level(rerun::TextLogLevel::DEBUG),
        )?;
        Ok(())
    }

    pub(super) fn scalar(&mut self, entity: &str, v: f64) -> Result<(), VizError> {
        self.rec.log(entity, &Scalars::new([v]))?;
        Ok(())
    }

    pub(super) fn log_joints(&mut self, js: &JointState) -> Result<(), VizError> {
        for (name, pos) in js.name.iter().zip(&js.position) {
            let group = if name == msgs::frames::LIFT_JOINT || name == msgs::frames::CLAMP_JOINT {
                "prismatic_m"
            } else {
                "joints_rad"
            };
            self.scalar(&format!("plots/{group}/{}", part(name)), *pos)?;
        }
        Ok(())
    }

    pub(super) fn log_task_event(&mut self, e: &TaskEvent) -> Result<(), VizError> {
        let (kind, level) = match e.kind {
            TaskEvent::REFUSED => ("REFUSED", rerun::TextLogLevel::WARN),
            TaskEvent::FAILED => ("FAILED", rerun::TextLogLevel::ERROR),
            TaskEvent::DONE => ("DONE", rerun::TextLogLevel::INFO),
            _ => ("INFO", rerun::TextLogLevel::INFO),
        };
        let reason = if e.reason_code.is_empty() {
            String::new()
        } else {
            format!(" ({})", e.reason_code)
        };
        let text = format!("[{}/{}] {kind}{reason}: {}", e.task, e.state, e.text);
        self.rec
            .log("log/task", &TextLog::new(text).with_level(level))?;
        let lane = format!("{}/{}", e.task, e.state);
        if self.task_state.as_deref() != Some(lane.as_str()) {
            self.rec.log(STATES, &StateChange::single(lane.as_str()))?;
            self.task_state = Some(lane);
            if let Some(site) = &self.site {
                let tool = self.tf.lookup(msgs::frames::MAP, msgs::frames::TOOL0);
                if let Some(next) =
                    RodBelief::after_state(self.rod.as_ref(), &e.state, site, tool.as_ref())
                {
                    self.set_rod(next)?;
                }
            }
        }
        Ok(())
    }

    /// Logs the static names and colours of the fixed series.
    pub(super) fn log_series_styles(&mut self) -> Result<(), VizError> {
        let styles: [(&str, &str, [u8; 3]); 10] = [
            (
                "plots/wind/measured",
                "wind (anemometer, 3-s mean) m/s",
                CYAN,
            ),
            (
                "plots/wind/truth",
                "wind (simulator truth) m/s",
                [120, 120, 120],
            ),
            (
                "plots/illuminance/measured",
                "illuminance (lux sensor) lx",
                ORANGE,
            ),
            (
                "plots/illuminance/truth",
                "illuminance (truth) lx",
                [120, 120, 120],
            ),
            (
                "plots/wrist_light/commanded",
                "wrist light commanded (0..1)",
                ORANGE,
            ),
            (
                "plots/wrist_light/state",
                "wrist light state (0..1)",
                [120, 120, 120],
            ),
            (
                "plots/calibration/residual_rot_deg",
                "AX=XB residual deg",
                GREEN,
            ),
            (
                "plots/calibration/residual_trans_mm",
                "AX=XB residual mm",
                RED,
            ),
            (
                "plots/calibration/sigma_rot_deg",
                "1-sigma deg",
                [60, 120, 60],
            ),
            (
                "plots/calibration/sigma_trans_mm",
                "1-sigma mm",
                [120, 60, 60],
            ),
        ];
        for (entity, name, color) in styles {
            self.rec.log_static(
                entity,
                &SeriesLines::new().with_names([name]).with_colors([color]),
            )?;
        }
        Ok(())
    }
}
