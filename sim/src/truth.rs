//! Ground truth on `/sim/...` topics (producer `sim`): for scoring only, never an input to
//! calibration, perception or control (ARCHITECTURE.md section 2).
//!
//! | topic | type | rate | content |
//! |---|---|---|---|
//! | `/sim/camera_mount` | TransformStamped | 1 Hz and at the bump | true `tool0_from_camera` (`tool0` -> `camera_color_optical_frame`) |
//! | `/sim/camera_info` | CameraInfo | with every wrist capture | the wrist camera's true intrinsics (the published `/camera/color/camera_info` is a calibration of them, `camera.info_error`) |
//! | `/sim/panoramic/camera_info` | CameraInfo | with every panoramic image | the panoramic camera's true intrinsics |
//! | `/sim/wire_pose` | PoseStamped (`map`) | 10 Hz | hanging point: the target conductor's axis at the robot's working spot (x = span position), `x` along the wire, `z` perpendicular and up; includes sway |
//! | `/sim/handle_pose` | PoseStamped (`map`) | 10 Hz | rod handle: origin on the rod axis halfway up the handle, rod axes |
//! | `/sim/wind` | Float64 | 1 Hz | true 3-s mean wind (m/s) |
//! | `/sim/illuminance` | Illuminance | 1 Hz | true global horizontal illuminance (lx), variance 0 |
//! | `/sim/rod_state` | String | 1 Hz and on change | `on_rack`, `in_gripper`, `hooked`, `clamped`, `dropped` |
//! | `/sim/base_pose` | PoseStamped (`map`) | 10 Hz | true `map_from_base_link` (odometry drifts away from it) |

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};

use crate::scene::Catenary;

/// Producer of the truth topics.
pub const SIM: &str = "sim";
/// Position of the handle's reference point in the rod frame (m).
pub use robot::grounding_rod::HANDLE_CENTER_IN_ROD_M;

pub use robot::conversions::pose_stamped;

/// The hanging point at span position `u_m` of `wire` swayed by `world_from_wire` (the rigid
/// sway pose): origin on the axis, `x` along the tangent, `z` perpendicular and upwards.
#[must_use]
pub fn hanging_point(
    wire: &Catenary,
    world_from_wire: &Isometry3<f64>,
    u_m: f64,
) -> Isometry3<f64> {
    let u = u_m.clamp(0.0, wire.span_m());
    let p = wire.point_at(u);
    let x = wire
        .tangent_at(u)
        .try_normalize(1e-12)
        .unwrap_or_else(Vector3::x);
    let y = Vector3::z()
        .cross(&x)
        .try_normalize(1e-12)
        .unwrap_or_else(Vector3::y);
    let z = x.cross(&y);
    let r = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(
        Matrix3::from_columns(&[x, y, z]),
    ));
    world_from_wire * Isometry3::from_parts(Translation3::from(p.coords), r)
}
