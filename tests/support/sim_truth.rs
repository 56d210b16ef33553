//! Ground truth the simulator records, read by tests only (the pipelines never read `/sim/`).

use std::path::Path;

use msgs::Msg;
use nalgebra::Isometry3;
use replay::{McapReader, ReadFilter};

/// The simulator's true `tool0_from_camera` at the end of a recording (`/sim/camera_mount`).
///
/// # Panics
/// When the recording cannot be read or holds no finite true mount.
pub fn true_mount(rec: &Path) -> Isometry3<f64> {
    let mut reader = McapReader::open(rec).expect("open");
    let filter = ReadFilter::all().with_topics(["/sim/camera_mount".to_owned()]);
    let msgs = reader.read_all(&filter).expect("read");
    let last = msgs.last().expect("the simulator publishes the true mount");
    let Msg::TransformStamped(t) = last.decode().expect("decode") else {
        panic!("unexpected type on /sim/camera_mount");
    };
    robot::conversions::isometry_from_msg(&t.transform).expect("finite")
}
