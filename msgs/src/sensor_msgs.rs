//! `sensor_msgs`: Image, CameraInfo (+RegionOfInterest), JointState, PointCloud2
//! (+PointField), Illuminance.

use serde::{Deserialize, Serialize};

use crate::schema::{
    CAMERA_INFO, ILLUMINANCE, IMAGE, JOINT_STATE, POINT_CLOUD2, POINT_FIELD, REGION_OF_INTEREST,
    impl_ros_message,
};
use crate::std_msgs::Header;

/// `sensor_msgs/msg/Image`: an uncompressed image, row-major, `step` bytes per row.
///
/// Encodings used by rodlog: `rgb8` (also read `bgr8`, `mono8`), depth `32FC1` (metres) and
/// `16UC1` (millimetres).
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Image {
    /// Capture stamp and optical frame.
    pub header: Header,
    /// Rows.
    pub height: u32,
    /// Columns.
    pub width: u32,
    /// Pixel encoding (`sensor_msgs/image_encodings`), e.g. `rgb8`.
    pub encoding: String,
    /// 1 if multi-byte pixel values are big-endian.
    pub is_bigendian: u8,
    /// Row length in bytes.
    pub step: u32,
    /// Pixels, `step * height` bytes.
    #[serde(with = "crate::cdr::bytes")]
    pub data: Vec<u8>,
}
impl_ros_message!(Image, "sensor_msgs", "Image", IMAGE);

/// `sensor_msgs/msg/RegionOfInterest`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct RegionOfInterest {
    /// Leftmost pixel of the ROI.
    pub x_offset: u32,
    /// Topmost pixel of the ROI.
    pub y_offset: u32,
    /// Height of the ROI (0 = full image).
    pub height: u32,
    /// Width of the ROI (0 = full image).
    pub width: u32,
    /// Whether a rectified ROI should be computed.
    pub do_rectify: bool,
}
impl_ros_message!(
    RegionOfInterest,
    "sensor_msgs",
    "RegionOfInterest",
    REGION_OF_INTEREST
);

/// `sensor_msgs/msg/CameraInfo`: pinhole intrinsics and distortion.
///
/// `K = [fx 0 cx; 0 fy cy; 0 0 1]` row-major; `plumb_bob` `d = [k1, k2, p1, p2, k3]`;
/// `R` identity and `P = [K | 0]` for a monocular camera.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct CameraInfo {
    /// Stamp and optical frame.
    pub header: Header,
    /// Image rows the calibration is for.
    pub height: u32,
    /// Image columns the calibration is for.
    pub width: u32,
    /// Distortion model, e.g. `plumb_bob`.
    pub distortion_model: String,
    /// Distortion coefficients (`float64[]`).
    pub d: Vec<f64>,
    /// Intrinsic matrix, 3x3 row-major (`float64[9]`).
    pub k: [f64; 9],
    /// Rectification matrix, 3x3 row-major (`float64[9]`).
    pub r: [f64; 9],
    /// Projection matrix, 3x4 row-major (`float64[12]`).
    pub p: [f64; 12],
    /// Horizontal binning.
    pub binning_x: u32,
    /// Vertical binning.
    pub binning_y: u32,
    /// Region of interest.
    pub roi: RegionOfInterest,
}
impl_ros_message!(CameraInfo, "sensor_msgs", "CameraInfo", CAMERA_INFO);

/// `sensor_msgs/msg/JointState`: parallel arrays, one entry per named joint (or empty).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct JointState {
    /// Stamp of the measurement.
    pub header: Header,
    /// Joint names.
    pub name: Vec<String>,
    /// Positions (rad or m).
    pub position: Vec<f64>,
    /// Velocities (rad/s or m/s).
    pub velocity: Vec<f64>,
    /// Efforts (N m or N).
    pub effort: Vec<f64>,
}
impl_ros_message!(JointState, "sensor_msgs", "JointState", JOINT_STATE);

/// `sensor_msgs/msg/PointField`: one channel of a [`PointCloud2`] point.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct PointField {
    /// Field name (`x`, `y`, `z`, `rgb`, ...).
    pub name: String,
    /// Byte offset in the point.
    pub offset: u32,
    /// One of the datatype constants ([`PointField::FLOAT32`], ...).
    pub datatype: u8,
    /// Number of elements.
    pub count: u32,
}
impl_ros_message!(PointField, "sensor_msgs", "PointField", POINT_FIELD);

impl PointField {
    /// `int8`.
    pub const INT8: u8 = 1;
    /// `uint8`.
    pub const UINT8: u8 = 2;
    /// `int16`.
    pub const INT16: u8 = 3;
    /// `uint16`.
    pub const UINT16: u8 = 4;
    /// `int32`.
    pub const INT32: u8 = 5;
    /// `uint32`.
    pub const UINT32: u8 = 6;
    /// `float32`.
    pub const FLOAT32: u8 = 7;
    /// `float64`.
    pub const FLOAT64: u8 = 8;
}

/// `sensor_msgs/msg/PointCloud2`: points as a binary blob described by `fields`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct PointCloud2 {
    /// Stamp and frame of the points.
    pub header: Header,
    /// Rows (1 for unordered clouds).
    pub height: u32,
    /// Points per row.
    pub width: u32,
    /// Channel layout.
    pub fields: Vec<PointField>,
    /// Whether `data` is big-endian.
    pub is_bigendian: bool,
    /// Bytes per point.
    pub point_step: u32,
    /// Bytes per row.
    pub row_step: u32,
    /// Point data, `row_step * height` bytes.
    #[serde(with = "crate::cdr::bytes")]
    pub data: Vec<u8>,
    /// True if there are no invalid points.
    pub is_dense: bool,
}
impl_ros_message!(PointCloud2, "sensor_msgs", "PointCloud2", POINT_CLOUD2);

/// `sensor_msgs/msg/Illuminance`: one photometric illuminance reading.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Illuminance {
    /// Measurement stamp and sensor frame.
    pub header: Header,
    /// Illuminance (lx).
    pub illuminance: f64,
    /// Variance (lx^2); 0 = unknown.
    pub variance: f64,
}
impl_ros_message!(Illuminance, "sensor_msgs", "Illuminance", ILLUMINANCE);

/// `Image.encoding` strings rodlog writes or reads (`sensor_msgs/image_encodings.hpp`).
pub mod image_encodings {
    /// 8-bit red, green, blue (written by the wrist and panoramic cameras).
    pub const RGB8: &str = "rgb8";
    /// 8-bit blue, green, red (read).
    pub const BGR8: &str = "bgr8";
    /// 8-bit grey (read).
    pub const MONO8: &str = "mono8";
    /// 32-bit float depth in metres.
    pub const TYPE_32FC1: &str = "32FC1";
    /// 16-bit unsigned depth in millimetres.
    pub const TYPE_16UC1: &str = "16UC1";
    /// 16-bit unsigned grey (alias some drivers use for mm depth).
    pub const MONO16: &str = "mono16";
}
