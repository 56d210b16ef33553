//! The grounding rod (a movable object) and its rack (static).
//!
//! Rod frame `rod`: origin on the axis at the bottom of the handle, `z` along the rod towards
//! the clamp head, `x` towards the open side of the hook. Parts along `z` (metres):
//!
//! | part | z range | radius / size |
//! |---|---|---|
//! | handle (knurled rubber) | 0 .. 0.25 | r 0.021 |
//! | outer support rod (insulating tube) | 0.25 .. 1.45 | r 0.019 |
//! | inner drive rod (steel, lead screw) | 1.45 .. 1.78 | r 0.009 |
//! | clamp head body, moving jaw, hook | 1.78 .. 2.02 | see [`HOOK_CENTER_IN_ROD`] |
//!
//! Rack frame `rack`: origin on the ground at the foot of the holder, `z` up; the stored rod
//! stands upright with [`rack_from_rod`].

use nalgebra::{Isometry3, Matrix3, Point3, Vector3};

use super::primitives::{Primitive, Shape};
use super::textures::{Material, Shading, Texture};
use super::{ObjectId, SceneBuilder};

/// Name of the rod object in the scene.
pub const ROD_OBJECT_NAME: &str = "grounding_rod";
/// Heights of the rack's two C-shaped holders above the rack frame (m).
pub const RACK_HOLDER_HEIGHTS_M: [f64; 2] = [0.75, 1.45];

pub use robot::grounding_rod::{
    DRIVE_RADIUS_M, DRIVE_TOP_M, HANDLE_LENGTH_M, HANDLE_RADIUS_M, HOOK_CENTER_IN_ROD,
    RACK_STORE_HEIGHT_M, SUPPORT_RADIUS_M, SUPPORT_TOP_M, rack_from_rod,
};

fn cyl(z0: f64, z1: f64, r: f64) -> Shape {
    Shape::Cylinder {
        base: Point3::new(0.0, 0.0, z0),
        axis: Vector3::z(),
        length_m: z1 - z0,
        radius_m: r,
    }
}

fn bx(c: [f64; 3], h: [f64; 3]) -> Shape {
    Shape::Box {
        center: Point3::new(c[0], c[1], c[2]),
        rotation: Matrix3::identity(),
        half_extents_m: Vector3::new(h[0], h[1], h[2]),
    }
}

/// Adds the rod as a movable object at `world_from_rod`; returns its id.
pub fn add_rod(b: &mut SceneBuilder, world_from_rod: Isometry3<f64>) -> ObjectId {
    let rubber = b.material(Material::matte(
        [0.035, 0.035, 0.04],
        Texture::Rubber { pitch_m: 0.004 },
        301,
    ));
    let tube = b.material(
        Material::matte(
            [0.75, 0.32, 0.04],
            Texture::Painted {
                grime: 0.05,
                rust: 0.0,
            },
            302,
        )
        .with_shading(Shading::Glossy {
            specular: 0.06,
            exponent: 40.0,
        }),
    );
    let steel = b.material(
        Material::matte(
            [0.55, 0.55, 0.56],
            Texture::Strands { pitch_m: 0.0025 },
            303,
        )
        .with_shading(Shading::Metal {
            specular: 0.3,
            exponent: 30.0,
        }),
    );
    let head = b.material(
        Material::matte([0.62, 0.6, 0.55], Texture::Galvanized, 304).with_shading(Shading::Metal {
            specular: 0.2,
            exponent: 20.0,
        }),
    );
    let bronze = b.material(
        Material::matte(
            [0.55, 0.35, 0.15],
            Texture::Painted {
                grime: 0.08,
                rust: 0.0,
            },
            305,
        )
        .with_shading(Shading::Metal {
            specular: 0.25,
            exponent: 25.0,
        }),
    );
    let warning = b.material(
        Material::matte([0.8, 0.65, 0.03], Texture::Hazard { pitch_m: 0.04 }, 306)
            .with_accent([0.03, 0.03, 0.03]),
    );
    let p = |shape, material| Primitive { shape, material };
    let prims = vec![
        p(cyl(0.0, HANDLE_LENGTH_M, HANDLE_RADIUS_M), rubber),
        p(cyl(HANDLE_LENGTH_M, HANDLE_LENGTH_M + 0.03, 0.026), warning),
        p(
            cyl(HANDLE_LENGTH_M + 0.03, SUPPORT_TOP_M, SUPPORT_RADIUS_M),
            tube,
        ),
        p(cyl(SUPPORT_TOP_M - 0.04, SUPPORT_TOP_M, 0.024), head),
        p(cyl(SUPPORT_TOP_M, DRIVE_TOP_M, DRIVE_RADIUS_M), steel),
        // Clamp head body.
        p(bx([0.0, 0.0, 1.82], [0.035, 0.025, 0.04]), head),
        // Moving jaw (driven by the inner rod), below the wire seat.
        p(bx([0.01, 0.0, 1.895], [0.03, 0.022, 0.012]), bronze),
        // Hook: back plate, top bar over the wire, short lip.
        p(bx([-0.032, 0.0, 1.93], [0.008, 0.02, 0.07]), head),
        p(bx([0.0, 0.0, 2.0], [0.04, 0.02, 0.008]), head),
        p(bx([0.036, 0.0, 1.985], [0.006, 0.02, 0.02]), head),
        // Contact pad inside the hook.
        p(bx([0.0, 0.0, 1.988], [0.022, 0.018, 0.004]), bronze),
    ];
    b.object(ROD_OBJECT_NAME, prims, world_from_rod)
}

/// Adds the rack (static) at `world_from_rack`: a base plate, an upright post and two
/// C-shaped holders around the stored rod, on a pedestal down to the ground (at height
/// `ground_z_m` under the rack) when the rack frame is above it.
pub fn add_rack(b: &mut SceneBuilder, world_from_rack: &Isometry3<f64>, ground_z_m: f64) {
    let paint = b.material(
        Material::matte(
            [0.55, 0.42, 0.05],
            Texture::Painted {
                grime: 0.08,
                rust: 0.35,
            },
            311,
        )
        .with_shading(Shading::Glossy {
            specular: 0.05,
            exponent: 30.0,
        }),
    );
    let plate = b.material(Material::matte(
        [0.3, 0.3, 0.3],
        Texture::BoltedPanel {
            pitch_m: 0.06,
            bolt_radius_m: 0.007,
        },
        312,
    ));
    let r = world_from_rack.rotation.to_rotation_matrix().into_inner();
    let place = |c: [f64; 3], h: [f64; 3]| Shape::Box {
        center: world_from_rack * Point3::new(c[0], c[1], c[2]),
        rotation: r,
        half_extents_m: Vector3::new(h[0], h[1], h[2]),
    };
    b.add(place([0.0, 0.05, 0.01], [0.2, 0.2, 0.01]), plate);
    // The pedestal the rack stands on (from the ground to the rack frame).
    let pedestal_m = world_from_rack.translation.z - ground_z_m;
    if pedestal_m > 0.01 {
        b.add(
            place(
                [0.0, 0.05, -0.5 * pedestal_m],
                [0.22, 0.22, 0.5 * pedestal_m],
            ),
            plate,
        );
    }
    // The post stands 0.13 m off the rod axis on the rack's +y side: the gripper closes
    // around the handle between them. The holders open towards -y.
    b.add(place([0.0, 0.13, 0.6], [0.025, 0.025, 0.6]), paint);
    // The holders grip the support tube above the handle, clear of the gripper as it pulls
    // the rod straight up out of the rack (the rod then leaves them through their open side).
    for z in RACK_HOLDER_HEIGHTS_M {
        // Arm from the post to the holder, then three bars forming a C around the rod.
        b.add(place([0.0, 0.08, z], [0.012, 0.05, 0.012]), paint);
        b.add(place([0.0, 0.032, z], [0.035, 0.006, 0.015]), paint);
        b.add(place([-0.032, 0.0, z], [0.006, 0.035, 0.015]), paint);
        b.add(place([0.032, 0.0, z], [0.006, 0.035, 0.015]), paint);
    }
}
