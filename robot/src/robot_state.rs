//! The `robot_state` stage: `/joint_states` -> `/tf` with the nominal model, plus the fixed
//! joints on `/tf_static` and the URDF on `/robot_description` (ARCHITECTURE.md section 3).
//!
//! Behaviour (deterministic: the outputs depend only on the inputs and the model):
//! - On the first input it publishes, once, `/robot_description` (the URDF of [`crate::urdf`])
//!   and `/tf_static` (the fixed edges of [`RobotModel::fixed_edges`], stamped with that
//!   input's header stamp). Both topics are latched, so replay from `--start` re-feeds them.
//!   The camera edge `tool0 -> camera_color_optical_frame` is never published here: it belongs
//!   to the calibration stage.
//! - For every `/joint_states` message it publishes one `/tf` message with the edge of every
//!   known joint the message names (`lift_joint`: `base_link -> lift_link`; arm joint i: the
//!   previous link -> `arm_*_link`), each stamped with the JointState's `header.stamp`, in the
//!   fixed joint order (lift, J1..J6) whatever the order in the message. Drivers publish
//!   separately (arm, lift, clamp), so each message updates only the edges it measures.
//! - Joint names without a frame (`clamp_joint`) or unknown ones are ignored.
//! - A NaN/infinite position, a duplicated known joint, or `name`/`position` arrays of different
//!   lengths reject the whole message with [`StageError::InvalidInput`] naming the joint.

use crate::conversions::transform_stamped;
use crate::kinematics::{JointKind, RobotModel};
use crate::urdf::robot_urdf;
use msgs::builtin_interfaces::Time;
use msgs::sensor_msgs::JointState;
use msgs::std_msgs::String as StringMsg;
use msgs::tf2_msgs::TfMessage;
use msgs::{Msg, RobotDuration, RobotTime, RosMessage, Stage, StageError, topics};

/// Producer name of the stage (channel metadata `producer=robot_state`).
pub const STAGE_NAME: &str = "robot_state";

/// Default latency added to the trigger's log_time: 1 ms (FK takes microseconds; the figure
/// models the processing delay of a real robot_state_publisher, and keeps outputs strictly
/// after their trigger in merge order).
pub const DEFAULT_LATENCY: RobotDuration = RobotDuration::from_millis(1);

/// Configuration of the stage.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotStateConfig {
    /// Output latency (default [`DEFAULT_LATENCY`]).
    pub latency: RobotDuration,
    /// Publish `/robot_description` on the first input (default true).
    pub publish_robot_description: bool,
}

impl Default for RobotStateConfig {
    fn default() -> Self {
        Self {
            latency: DEFAULT_LATENCY,
            publish_robot_description: true,
        }
    }
}

impl RobotStateConfig {
    /// Reads `robot_state.{latency_ms, publish_robot_description}` through `r`.
    ///
    /// # Errors
    /// [`scenario::ParamError::Value`] for a wrong type or an out-of-range value.
    pub fn from_params(r: &mut scenario::Reader<'_>) -> Result<Self, scenario::ParamError> {
        let d = Self::default();
        let mut s = r.section("robot_state");
        Ok(Self {
            latency: s.millis("latency_ms", d.latency, "stage latency")?,
            publish_robot_description: s.bool(
                "publish_robot_description",
                d.publish_robot_description,
                "publish /robot_description (the URDF) on the first input",
            )?,
        })
    }
}

/// The `robot_state` stage (see the module docs).
#[derive(Debug, Clone)]
pub struct RobotStateStage {
    model: RobotModel,
    config: RobotStateConfig,
    statics_sent: bool,
}

impl RobotStateStage {
    /// A stage over `model` with `config`.
    #[must_use]
    pub fn new(model: RobotModel, config: RobotStateConfig) -> Self {
        Self {
            model,
            config,
            statics_sent: false,
        }
    }

    /// The model it publishes.
    #[must_use]
    pub fn model(&self) -> &RobotModel {
        &self.model
    }

    /// The `/tf_static` message: every fixed edge, stamped `stamp`.
    #[must_use]
    pub fn static_transforms(&self, stamp: Time) -> TfMessage {
        TfMessage {
            transforms: self
                .model
                .fixed_edges()
                .iter()
                .map(|e| transform_stamped(e.parent, e.child, stamp, &e.parent_from_child))
                .collect(),
        }
    }

    /// The `/tf` message for one JointState (see the module docs for the rules).
    ///
    /// # Errors
    /// A description of the first invalid entry (mismatched lengths, non-finite position,
    /// duplicated joint).
    pub fn transforms_for(&self, joint_state: &JointState) -> Result<TfMessage, String> {
        if joint_state.name.len() != joint_state.position.len() {
            return Err(format!(
                "{} joint names but {} positions",
                joint_state.name.len(),
                joint_state.position.len()
            ));
        }
        // Slot 0 = lift, 1..=6 = arm joints: a fixed output order.
        let mut positions: [Option<f64>; 7] = [None; 7];
        for (name, &position) in joint_state.name.iter().zip(&joint_state.position) {
            let Some(kind) = JointKind::from_name(name) else {
                continue;
            };
            if !position.is_finite() {
                return Err(format!("joint '{name}' has non-finite position {position}"));
            }
            let slot = match kind {
                JointKind::Lift => 0,
                JointKind::Arm(i) => i + 1,
            };
            let Some(entry) = positions.get_mut(slot) else {
                continue;
            };
            if entry.replace(position).is_some() {
                return Err(format!("joint '{name}' appears more than once"));
            }
        }
        let stamp = joint_state.header.stamp;
        let transforms = positions
            .iter()
            .enumerate()
            .filter_map(|(slot, p)| {
                let kind = if slot == 0 {
                    JointKind::Lift
                } else {
                    JointKind::Arm(slot - 1)
                };
                let edge = self.model.joint_edge(kind, (*p)?)?;
                Some(transform_stamped(
                    edge.parent,
                    edge.child,
                    stamp,
                    &edge.parent_from_child,
                ))
            })
            .collect();
        Ok(TfMessage { transforms })
    }
}

impl Default for RobotStateStage {
    fn default() -> Self {
        Self::new(RobotModel::nominal(), RobotStateConfig::default())
    }
}

/// The `/robot_description` message for `model` (std_msgs/String with the URDF text).
#[must_use]
pub fn robot_description_msg(model: &RobotModel) -> StringMsg {
    StringMsg {
        data: robot_urdf(model),
    }
}

impl Stage for RobotStateStage {
    fn name(&self) -> &str {
        STAGE_NAME
    }

    fn inputs(&self) -> Vec<String> {
        vec![topics::JOINT_STATES.to_owned()]
    }

    fn outputs(&self) -> Vec<(String, &'static str)> {
        vec![
            (topics::ROBOT_DESCRIPTION.to_owned(), StringMsg::TYPE_NAME),
            (topics::TF_STATIC.to_owned(), TfMessage::TYPE_NAME),
            (topics::TF.to_owned(), TfMessage::TYPE_NAME),
        ]
    }

    fn latency(&self) -> RobotDuration {
        self.config.latency
    }

    fn on_message(
        &mut self,
        log_time: RobotTime,
        topic: &str,
        msg: &Msg,
    ) -> Result<Vec<(String, Msg)>, StageError> {
        if topic != topics::JOINT_STATES {
            return Ok(Vec::new());
        }
        let Some(joint_state) = msg.get::<JointState>() else {
            return Err(StageError::UnexpectedType {
                stage: STAGE_NAME.to_owned(),
                topic: topic.to_owned(),
                log_time,
                expected: JointState::TYPE_NAME,
                got: msg.type_name(),
            });
        };
        let tf = self
            .transforms_for(joint_state)
            .map_err(|reason| StageError::InvalidInput {
                stage: STAGE_NAME.to_owned(),
                topic: topic.to_owned(),
                log_time,
                reason,
            })?;
        let mut out = Vec::with_capacity(3);
        if !self.statics_sent {
            self.statics_sent = true;
            if self.config.publish_robot_description {
                out.push((
                    topics::ROBOT_DESCRIPTION.to_owned(),
                    Msg::from(robot_description_msg(&self.model)),
                ));
            }
            out.push((
                topics::TF_STATIC.to_owned(),
                Msg::from(self.static_transforms(joint_state.header.stamp)),
            ));
        }
        if !tf.transforms.is_empty() {
            out.push((topics::TF.to_owned(), Msg::from(tf)));
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::names;
    use crate::tf_buffer::TfBuffer;
    use msgs::std_msgs::Header;

    fn joint_state(sec: i32, names: &[&str], positions: &[f64]) -> Msg {
        Msg::from(JointState {
            header: Header {
                stamp: Time { sec, nanosec: 0 },
                frame_id: String::new(),
            },
            name: names.iter().map(|s| (*s).to_owned()).collect(),
            position: positions.to_vec(),
            velocity: Vec::new(),
            effort: Vec::new(),
        })
    }

    #[test]
    fn publishes_statics_once_and_tf_that_reproduces_fk() {
        let mut stage = RobotStateStage::default();
        let q = [0.3, -1.2, 0.7, 2.0, -0.4, 1.1];
        let arm = joint_state(1, &names::ARM_JOINTS, &q);
        let lift = joint_state(
            1,
            &[names::LIFT_JOINT, names::CLAMP_JOINT, "mystery"],
            &[0.8, 0.01, 5.0],
        );
        let t0 = RobotTime::from_millis(1000);
        let first = stage
            .on_message(t0, topics::JOINT_STATES, &arm)
            .expect("valid");
        let topics_out: Vec<&str> = first.iter().map(|(t, _)| t.as_str()).collect();
        assert_eq!(
            topics_out,
            [topics::ROBOT_DESCRIPTION, topics::TF_STATIC, topics::TF]
        );
        let second = stage
            .on_message(t0, topics::JOINT_STATES, &lift)
            .expect("valid");
        assert_eq!(second.len(), 1, "statics only once");
        assert_eq!(second[0].0, topics::TF);

        let mut tf = TfBuffer::default();
        for (topic, msg) in first.iter().chain(&second) {
            if let Some(m) = msg.get::<TfMessage>() {
                assert!(
                    m.transforms
                        .iter()
                        .all(|t| t.child_frame_id != names::CAMERA_COLOR_OPTICAL_FRAME)
                );
                assert!(tf.insert_message(m, topic == topics::TF_STATIC).is_empty());
            }
        }
        let base_from_tool0 = tf
            .lookup(names::BASE_LINK, names::TOOL0, 1_000_000_000)
            .expect("chain");
        let expected = stage.model().base_from_tool0(0.8, &q);
        assert!((base_from_tool0.to_homogeneous() - expected.to_homogeneous()).amax() < 1e-12);
    }

    #[test]
    fn deterministic_and_order_independent() {
        let q = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6];
        let forward = joint_state(3, &names::ARM_JOINTS, &q);
        let mut reversed_names = names::ARM_JOINTS;
        reversed_names.reverse();
        let mut reversed_q = q;
        reversed_q.reverse();
        let reversed = joint_state(3, &reversed_names, &reversed_q);
        let run = |m: &Msg| {
            let mut s = RobotStateStage::default();
            s.on_message(RobotTime::ZERO, topics::JOINT_STATES, m)
                .expect("valid")
        };
        let a = run(&forward);
        assert_eq!(a, run(&forward));
        assert_eq!(a, run(&reversed));
        let bytes = |v: &[(String, Msg)]| -> Vec<Vec<u8>> {
            v.iter()
                .map(|(_, m)| m.encode().expect("encodes"))
                .collect()
        };
        assert_eq!(bytes(&a), bytes(&run(&forward)));
    }

    #[test]
    fn rejects_nan_mismatch_duplicates_and_wrong_types() {
        let mut stage = RobotStateStage::default();
        let nan = joint_state(1, &[names::ARM_WRIST2_JOINT], &[f64::NAN]);
        let err = stage
            .on_message(RobotTime::ZERO, topics::JOINT_STATES, &nan)
            .expect_err("NaN");
        assert!(err.to_string().contains("arm_wrist2_joint"), "{err}");
        let short = joint_state(1, &names::ARM_JOINTS, &[0.0; 5]);
        assert!(
            stage
                .on_message(RobotTime::ZERO, topics::JOINT_STATES, &short)
                .is_err()
        );
        let dup = joint_state(1, &[names::LIFT_JOINT, names::LIFT_JOINT], &[0.1, 0.2]);
        assert!(
            stage
                .on_message(RobotTime::ZERO, topics::JOINT_STATES, &dup)
                .is_err()
        );
        let wrong = Msg::from(TfMessage::default());
        assert!(matches!(
            stage.on_message(RobotTime::ZERO, topics::JOINT_STATES, &wrong),
            Err(StageError::UnexpectedType { .. })
        ));
        // NaN on an ignored joint is fine; an empty /tf is not published.
        let clamp = joint_state(1, &[names::CLAMP_JOINT], &[f64::NAN]);
        let out = stage
            .on_message(RobotTime::ZERO, topics::JOINT_STATES, &clamp)
            .expect("ignored");
        assert!(out.iter().all(|(t, _)| t != topics::TF));
    }
}
