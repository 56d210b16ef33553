//! [`Msg`]: one enum over every top-level message type rodlog logs, with type-name based
//! decoding (what an MCAP reader has: a schema name and CDR bytes).

use thiserror::Error;

use crate::builtin_interfaces::Time;
use crate::cdr::{CdrError, from_cdr, to_cdr, to_cdr_into};
use crate::geometry_msgs::{PoseStamped, TransformStamped};
use crate::nav_msgs::Path;
use crate::rcl_interfaces::Log;
use crate::rodlog_msgs::{ClampCommand, FeatureMatches, HandEyeCalibration, TaskEvent};
use crate::rosgraph_msgs::Clock;
use crate::schema::{RosMessage, normalize_type_name};
use crate::sensor_msgs::{CameraInfo, Illuminance, Image, JointState, PointCloud2};
use crate::std_msgs::{Empty, Float64, String as StringMsg};
use crate::tf2_msgs::TfMessage;
use crate::trajectory_msgs::JointTrajectory;

/// Errors of [`Msg::decode`].
#[derive(Debug, Clone, PartialEq, Error)]
pub enum DecodeError {
    /// The type name is not one of [`Msg::TYPE_NAMES`].
    #[error(
        "unknown message type {type_name:?} (rodlog knows {known} types, e.g. sensor_msgs/msg/Image)"
    )]
    UnknownType {
        /// The type name given.
        type_name: String,
        /// How many types are known.
        known: usize,
    },
    /// The bytes are not a valid CDR encoding of the type.
    #[error("cannot decode {type_name} from CDR: {source}")]
    Cdr {
        /// The type name.
        type_name: &'static str,
        /// The codec error.
        #[source]
        source: CdrError,
    },
}

/// A message type that is a [`Msg`] variant.
pub trait MsgPayload: RosMessage + Into<Msg> {
    /// The payload if `msg` is this type's variant.
    fn from_msg(msg: &Msg) -> Option<&Self>;
}

macro_rules! msg_enum {
    ($( $(#[$doc:meta])* $variant:ident($ty:ty) ),* $(,)?) => {
        /// Any top-level message rodlog logs (ARCHITECTURE.md section 3).
        #[derive(Debug, Clone, PartialEq)]
        pub enum Msg {
            $( $(#[$doc])* $variant($ty), )*
        }

        impl Msg {
            /// Full ROS type names (`pkg/msg/Type`) of all variants, in declaration order.
            pub const TYPE_NAMES: &'static [&'static str] =
                &[$( <$ty as RosMessage>::TYPE_NAME, )*];

            /// Full ROS type name of this message, e.g. `sensor_msgs/msg/Image`.
            pub fn type_name(&self) -> &'static str {
                match self {
                    $( Msg::$variant(_) => <$ty as RosMessage>::TYPE_NAME, )*
                }
            }

            /// CDR (XCDR1 little-endian, with the encapsulation header).
            ///
            /// # Errors
            /// See [`crate::cdr::to_cdr`].
            pub fn encode(&self) -> Result<Vec<u8>, CdrError> {
                match self {
                    $( Msg::$variant(m) => to_cdr(m), )*
                }
            }

            /// Like [`Msg::encode`], into a reused buffer (cleared first).
            ///
            /// # Errors
            /// See [`crate::cdr::to_cdr`].
            pub fn encode_into(&self, out: &mut Vec<u8>) -> Result<(), CdrError> {
                match self {
                    $( Msg::$variant(m) => to_cdr_into(m, out), )*
                }
            }

            /// Decodes CDR bytes of the type `type_name` (`pkg/msg/Type`; `pkg/Type` is
            /// accepted too).
            ///
            /// # Errors
            /// [`DecodeError::UnknownType`], [`DecodeError::Cdr`].
            pub fn decode(type_name: &str, cdr: &[u8]) -> Result<Msg, DecodeError> {
                let short = normalize_type_name(type_name);
                $(
                    if short == <$ty as RosMessage>::DEFINITION.name {
                        return from_cdr::<$ty>(cdr).map(Msg::$variant).map_err(|source| {
                            DecodeError::Cdr { type_name: <$ty as RosMessage>::TYPE_NAME, source }
                        });
                    }
                )*
                Err(DecodeError::UnknownType {
                    type_name: type_name.to_string(),
                    known: Self::TYPE_NAMES.len(),
                })
            }

            /// The `ros2msg` schema text of a variant type (`pkg/msg/Type` or `pkg/Type`),
            /// `None` if it is not a [`Msg`] type.
            pub fn schema_text(type_name: &str) -> Option<String> {
                let short = normalize_type_name(type_name);
                $(
                    if short == <$ty as RosMessage>::DEFINITION.name {
                        return Some(<$ty as RosMessage>::schema_text());
                    }
                )*
                None
            }

            /// The stamp the message carries: `header.stamp` for stamped types, `clock` of
            /// a Clock, `stamp` of a Log, the first transform's stamp of a TFMessage; `None`
            /// for unstamped types (String, Float64, Empty) and empty TFMessages.
            pub fn stamp(&self) -> Option<Time> {
                match self {
                    Msg::Image(m) => Some(m.header.stamp),
                    Msg::CameraInfo(m) => Some(m.header.stamp),
                    Msg::JointState(m) => Some(m.header.stamp),
                    Msg::PointCloud2(m) => Some(m.header.stamp),
                    Msg::Illuminance(m) => Some(m.header.stamp),
                    Msg::PoseStamped(m) => Some(m.header.stamp),
                    Msg::TransformStamped(m) => Some(m.header.stamp),
                    Msg::TfMessage(m) => m.transforms.first().map(|t| t.header.stamp),
                    Msg::Clock(m) => Some(m.clock),
                    Msg::JointTrajectory(m) => Some(m.header.stamp),
                    Msg::Path(m) => Some(m.header.stamp),
                    Msg::Log(m) => Some(m.stamp),
                    Msg::String(_) | Msg::Float64(_) | Msg::Empty(_) => None,
                    Msg::ClampCommand(m) => Some(m.header.stamp),
                    Msg::FeatureMatches(m) => Some(m.header.stamp),
                    Msg::HandEyeCalibration(m) => Some(m.header.stamp),
                    Msg::TaskEvent(m) => Some(m.header.stamp),
                }
            }

            /// The payload as `T`, if this is `T`'s variant.
            pub fn get<T: MsgPayload>(&self) -> Option<&T> {
                T::from_msg(self)
            }
        }

        $(
            impl From<$ty> for Msg {
                fn from(m: $ty) -> Msg {
                    Msg::$variant(m)
                }
            }

            impl MsgPayload for $ty {
                fn from_msg(msg: &Msg) -> Option<&Self> {
                    match msg {
                        Msg::$variant(m) => Some(m),
                        #[allow(unreachable_patterns)] // needed only if Msg had one variant
                        _ => None,
                    }
                }
            }
        )*
    };
}

msg_enum! {
    /// `sensor_msgs/msg/Image`.
    Image(Image),
    /// `sensor_msgs/msg/CameraInfo`.
    CameraInfo(CameraInfo),
    /// `sensor_msgs/msg/JointState`.
    JointState(JointState),
    /// `sensor_msgs/msg/PointCloud2`.
    PointCloud2(PointCloud2),
    /// `sensor_msgs/msg/Illuminance`.
    Illuminance(Illuminance),
    /// `geometry_msgs/msg/PoseStamped`.
    PoseStamped(PoseStamped),
    /// `geometry_msgs/msg/TransformStamped`.
    TransformStamped(TransformStamped),
    /// `tf2_msgs/msg/TFMessage`.
    TfMessage(TfMessage),
    /// `rosgraph_msgs/msg/Clock`.
    Clock(Clock),
    /// `trajectory_msgs/msg/JointTrajectory`.
    JointTrajectory(JointTrajectory),
    /// `nav_msgs/msg/Path`.
    Path(Path),
    /// `rcl_interfaces/msg/Log`.
    Log(Log),
    /// `std_msgs/msg/String`.
    String(StringMsg),
    /// `std_msgs/msg/Float64`.
    Float64(Float64),
    /// `std_msgs/msg/Empty`.
    Empty(Empty),
    /// `rodlog_msgs/msg/ClampCommand`.
    ClampCommand(ClampCommand),
    /// `rodlog_msgs/msg/FeatureMatches`.
    FeatureMatches(FeatureMatches),
    /// `rodlog_msgs/msg/HandEyeCalibration`.
    HandEyeCalibration(HandEyeCalibration),
    /// `rodlog_msgs/msg/TaskEvent`.
    TaskEvent(TaskEvent),
}
