//! The bay's equipment as primitives: lattice columns and beams from angle members, insulator
//! strings, disconnect switches, the kiosk and marshalling boxes, and the calibration cabinet.

use nalgebra::{Matrix3, Point3, Rotation3, Vector3};

use crate::scene::primitives::{Shape, perpendicular};
use crate::scene::{MaterialId, SceneBuilder};

use super::materials::{Dice, Mats};

/// Axis-aligned box from centre and half sizes.
pub(super) fn abox(c: [f64; 3], h: [f64; 3]) -> Shape {
    Shape::Box {
        center: Point3::new(c[0], c[1], c[2]),
        rotation: Matrix3::identity(),
        half_extents_m: Vector3::new(h[0], h[1], h[2]),
    }
}

/// Box along the segment `p0 -> p1` with cross-section half sizes `(hy, hz)` about the
/// frame `(dir, e_y, e_z)` with `e_y` perpendicular to `dir` and closest to `side`.
pub(super) fn member_box(
    p0: Point3<f64>,
    p1: Point3<f64>,
    side: Vector3<f64>,
    hy: f64,
    hz: f64,
    offset: [f64; 2],
) -> Option<Shape> {
    let d = p1 - p0;
    let len = d.norm();
    if len < 1e-6 {
        return None;
    }
    let ex = d / len;
    let mut ey = side - ex * side.dot(&ex);
    if ey.norm() < 1e-6 {
        ey = perpendicular(&ex);
    }
    let ey = ey.normalize();
    let ez = ex.cross(&ey);
    let center = p0 + d * 0.5 + ey * offset[0] + ez * offset[1];
    Some(Shape::Box {
        center,
        rotation: Matrix3::from_columns(&[ex, ey, ez]),
        half_extents_m: Vector3::new(len / 2.0, hy, hz),
    })
}

/// An L-angle steel member from `p0` to `p1` with flange width `w`, thickness 6 mm, flanges
/// opening towards `side` and `side x dir`.
pub(super) fn angle(
    b: &mut SceneBuilder,
    mat: MaterialId,
    p0: Point3<f64>,
    p1: Point3<f64>,
    side: Vector3<f64>,
    w: f64,
) {
    let t = 0.006;
    if let Some(s) = member_box(p0, p1, side, w / 2.0, t / 2.0, [-w / 2.0, 0.0]) {
        b.add(s, mat);
    }
    if let Some(s) = member_box(p0, p1, side, t / 2.0, w / 2.0, [0.0, -w / 2.0]) {
        b.add(s, mat);
    }
}

/// Square lattice column of half width `a` centred at `c`, from its foundation on ground of
/// height `z[0]` up to the height `z[1]`.
pub(super) fn lattice_column(
    b: &mut SceneBuilder,
    steel: MaterialId,
    concrete: MaterialId,
    c: [f64; 2],
    a: f64,
    z: [f64; 2],
) {
    let [ground, height] = z;
    b.add(
        abox([c[0], c[1], ground + 0.1], [a + 0.35, a + 0.35, 0.2]),
        concrete,
    );
    let z0 = ground + 0.3;
    let corners = [(-a, -a), (a, -a), (a, a), (-a, a)];
    for &(dx, dy) in &corners {
        let p0 = Point3::new(c[0] + dx, c[1] + dy, z0);
        let p1 = Point3::new(c[0] + dx, c[1] + dy, height);
        angle(b, steel, p0, p1, Vector3::new(-dx.signum(), 0.0, 0.0), 0.09);
    }
    let panels = ((height - z0) / (2.0 * a * 1.25)).round().max(1.0) as usize;
    let dz = (height - z0) / panels as f64;
    for i in 0..=panels {
        let z = z0 + dz * i as f64;
        for f in 0..4 {
            let (ax, ay) = corners[f];
            let (bx, by) = corners[(f + 1) % 4];
            let pa = Point3::new(c[0] + ax * 0.97, c[1] + ay * 0.97, z);
            let pb = Point3::new(c[0] + bx * 0.97, c[1] + by * 0.97, z);
            if i % 2 == 0 || i == panels {
                angle(b, steel, pa, pb, Vector3::z(), 0.05);
            }
            if i < panels {
                let z1 = z + dz;
                let (q0, q1) = if (i + f) % 2 == 0 {
                    (pa, Point3::new(pb.x, pb.y, z1))
                } else {
                    (pb, Point3::new(pa.x, pa.y, z1))
                };
                angle(
                    b,
                    steel,
                    q0,
                    q1,
                    Vector3::new(c[0] - 0.5 * (pa.x + pb.x), c[1] - 0.5 * (pa.y + pb.y), 0.0),
                    0.045,
                );
            }
        }
    }
}

/// Lattice beam along y from `y0` to `y1` at x = `x`, bottom at `z0`, half width `a`.
pub(super) fn lattice_beam(
    b: &mut SceneBuilder,
    steel: MaterialId,
    x: f64,
    y0: f64,
    y1: f64,
    z0: f64,
    a: f64,
) {
    let chords = [(-a, 0.0), (a, 0.0), (a, 2.0 * a), (-a, 2.0 * a)];
    for &(dx, dz) in &chords {
        angle(
            b,
            steel,
            Point3::new(x + dx, y0, z0 + dz),
            Point3::new(x + dx, y1, z0 + dz),
            Vector3::new(-dx.signum(), 0.0, 0.0),
            0.08,
        );
    }
    let panels = ((y1 - y0) / (2.0 * a * 1.2)).round().max(1.0) as usize;
    let dy = (y1 - y0) / panels as f64;
    for i in 0..=panels {
        let y = y0 + dy * i as f64;
        for f in 0..4 {
            let (ax, az) = chords[f];
            let (bx, bz) = chords[(f + 1) % 4];
            let pa = Point3::new(x + ax * 0.97, y, z0 + a + (az - a) * 0.97);
            let pb = Point3::new(x + bx * 0.97, y, z0 + a + (bz - a) * 0.97);
            if i % 2 == 0 {
                angle(b, steel, pa, pb, Vector3::y(), 0.045);
            }
            if i < panels {
                let (q0, q1) = if (i + f) % 2 == 0 {
                    (pa, Point3::new(pb.x, y + dy, pb.z))
                } else {
                    (pb, Point3::new(pa.x, y + dy, pa.z))
                };
                let inward =
                    Vector3::new(x - 0.5 * (pa.x + pb.x), 0.0, z0 + a - 0.5 * (pa.z + pb.z));
                angle(b, steel, q0, q1, inward, 0.04);
            }
        }
    }
}

/// Tension insulator string from `top` (beam) to `end` (conductor attachment): core rod,
/// disc sheds with caps at 146 mm pitch, yoke plates at both ends.
pub(super) fn insulator_string(
    b: &mut SceneBuilder,
    disc: MaterialId,
    cap: MaterialId,
    top: Point3<f64>,
    end: Point3<f64>,
) {
    let d = end - top;
    let len = d.norm();
    let axis = d / len;
    b.add(
        Shape::Cylinder {
            base: top,
            axis,
            length_m: len,
            radius_m: 0.018,
        },
        cap,
    );
    let pitch = 0.146;
    let n = ((len - 0.5) / pitch).floor().max(1.0) as usize;
    let s0 = 0.5 * (len - (n - 1) as f64 * pitch);
    for i in 0..n {
        let c = top + axis * (s0 + pitch * i as f64);
        b.add(
            Shape::Cylinder {
                base: c - axis * 0.008,
                axis,
                length_m: 0.016,
                radius_m: 0.127,
            },
            disc,
        );
        b.add(
            Shape::Cylinder {
                base: c - axis * 0.05,
                axis,
                length_m: 0.045,
                radius_m: 0.042,
            },
            cap,
        );
    }
    let side = perpendicular(&axis);
    for (p, s) in [(top, 0.12), (end, -0.12)] {
        if let Some(shape) = member_box(
            p + axis * s,
            p + axis * (s * 0.2),
            side,
            0.15,
            0.012,
            [0.0, 0.0],
        ) {
            b.add(shape, cap);
        }
    }
}

/// Disconnect switch: two galvanised pedestals with post insulators and a blade between.
pub(super) fn disconnect_switch(b: &mut SceneBuilder, m: &Mats, disc: MaterialId, x: f64, y: f64) {
    let h_ped = 2.4;
    let h_post = 1.3;
    for dx in [0.0, 1.5] {
        let base = Point3::new(x + dx, y, 0.0);
        b.add(abox([base.x, base.y, 0.1], [0.4, 0.4, 0.2]), m.concrete);
        b.add(
            Shape::Cylinder {
                base: Point3::new(base.x, base.y, 0.3),
                axis: Vector3::z(),
                length_m: h_ped - 0.3,
                radius_m: 0.11,
            },
            m.pedestal,
        );
        b.add(
            abox([base.x, base.y, h_ped + 0.01], [0.2, 0.2, 0.012]),
            m.pedestal,
        );
        let z0 = h_ped + 0.02;
        b.add(
            Shape::Cylinder {
                base: Point3::new(base.x, base.y, z0),
                axis: Vector3::z(),
                length_m: h_post,
                radius_m: 0.055,
            },
            disc,
        );
        let sheds = (h_post / 0.075) as usize;
        for i in 1..sheds {
            let r = if i % 2 == 0 { 0.105 } else { 0.085 };
            b.add(
                Shape::Cylinder {
                    base: Point3::new(base.x, base.y, z0 + 0.075 * i as f64),
                    axis: Vector3::z(),
                    length_m: 0.014,
                    radius_m: r,
                },
                disc,
            );
        }
        b.add(
            abox([base.x, base.y, z0 + h_post + 0.05], [0.09, 0.09, 0.05]),
            m.cap,
        );
    }
    b.add(
        abox(
            [x + 0.75, y, h_ped + 0.02 + h_post + 0.12],
            [0.85, 0.035, 0.02],
        ),
        m.cap,
    );
}

/// Kiosk: painted box with label plates, louvres and a bolted door.
pub(super) fn kiosk(b: &mut SceneBuilder, m: &Mats, at: Point3<f64>, d: &mut Dice) {
    let (hx, hy, hz) = (1.6, 1.0, 1.25);
    b.add(
        abox([at.x, at.y, 0.1], [hx + 0.2, hy + 0.2, 0.1]),
        m.concrete,
    );
    b.add(abox([at.x, at.y, 0.2 + hz], [hx, hy, hz]), m.kiosk);
    b.add(
        abox(
            [at.x, at.y, 0.2 + 2.0 * hz + 0.04],
            [hx + 0.08, hy + 0.08, 0.04],
        ),
        m.kiosk,
    );
    let yf = at.y - hy - 0.003;
    b.add(abox([at.x - 0.6, yf, 1.2], [0.45, 0.004, 0.95]), m.door);
    b.add(
        abox([at.x + 0.6, yf, 1.9], [0.3, 0.004, 0.15]),
        m.label_white,
    );
    b.add(abox([at.x + 0.6, yf, 0.6], [0.5, 0.004, 0.3]), m.louvres);
    b.add(
        abox(
            [at.x + 0.6 + d.range(-0.2, 0.2), yf, 1.45],
            [0.18, 0.004, 0.12],
        ),
        m.label_yellow,
    );
}

/// Small marshalling box on two legs.
pub(super) fn marshalling_box(
    b: &mut SceneBuilder,
    m: &Mats,
    mat: MaterialId,
    at: Point3<f64>,
    size: f64,
) {
    let h = size;
    for dx in [-0.6 * h, 0.6 * h] {
        b.add(
            abox([at.x + dx, at.y, 0.45], [0.03, 0.03, 0.45]),
            m.pedestal,
        );
    }
    b.add(
        abox([at.x, at.y, 0.9 + h * 0.6], [h, h * 0.4, h * 0.6]),
        mat,
    );
    b.add(
        abox(
            [at.x, at.y - h * 0.4 - 0.003, 0.9 + h * 0.9],
            [h * 0.5, 0.004, h * 0.15],
        ),
        m.label_white,
    );
}

/// The calibration cabinet cluster with its front face at `x = x_front` facing -x, centred
/// on `y`. Returns the face centre and normal.
pub(super) fn calibration_cabinet(
    b: &mut SceneBuilder,
    m: &Mats,
    x_front: f64,
    y: f64,
    d: &mut Dice,
) -> (Point3<f64>, Vector3<f64>) {
    let (hx, hy, hz) = (0.3, 0.7, 0.95);
    let cx = x_front + hx;
    b.add(abox([cx, y, 0.08], [hx + 0.1, hy + 0.1, 0.08]), m.concrete);
    b.add(abox([cx, y, 0.16 + hz], [hx, hy, hz]), m.cabinet);
    b.add(
        abox(
            [cx, y, 0.16 + 2.0 * hz + 0.03],
            [hx + 0.05, hy + 0.05, 0.03],
        ),
        m.cabinet,
    );
    // Two doors with a gap, bolted.
    let xf = x_front - 0.004;
    for s in [-1.0, 1.0] {
        b.add(abox([xf, y + s * 0.35, 1.1], [0.004, 0.34, 0.8]), m.door);
        // Door handle.
        b.add(
            abox([xf - 0.02, y + s * 0.05, 1.15], [0.012, 0.012, 0.09]),
            m.dark,
        );
    }
    // Labels (positions jittered by the seed), vents, hazard strip.
    let xl = xf - 0.006;
    b.add(
        abox(
            [xl, y - 0.35 + d.range(-0.05, 0.05), 1.55],
            [0.002, 0.14, 0.09],
        ),
        m.label_white,
    );
    b.add(
        abox(
            [xl, y + 0.35 + d.range(-0.05, 0.05), 1.5],
            [0.002, 0.1, 0.08],
        ),
        m.label_yellow,
    );
    b.add(
        abox([xl, y - 0.3, 1.25], [0.002, 0.12, 0.05]),
        m.label_white,
    );
    b.add(abox([xl, y + 0.3, 0.55], [0.002, 0.22, 0.12]), m.louvres);
    b.add(abox([xl, y - 0.3, 0.55], [0.002, 0.22, 0.12]), m.louvres);
    b.add(abox([xf, y, 0.25], [0.006, hy, 0.05]), m.hazard);
    // Side junction box (rusty, bolted) and a cable tray along the side wall towards -y.
    b.add(abox([cx, y - hy - 0.12, 1.2], [0.2, 0.12, 0.25]), m.rusty);
    b.add(
        abox([cx - 0.2 - 0.004, y - hy - 0.12, 1.2], [0.004, 0.11, 0.23]),
        m.bolted,
    );
    let tray_z = 1.75;
    let y0 = y - hy - 0.3;
    let y1 = y - hy - 2.2;
    b.add(
        abox(
            [x_front + 0.05, 0.5 * (y0 + y1), tray_z],
            [0.15, 0.5 * (y0 - y1), 0.003],
        ),
        m.tray,
    );
    for s in [-1.0, 1.0] {
        b.add(
            abox(
                [x_front + 0.05 + s * 0.15, 0.5 * (y0 + y1), tray_z + 0.04],
                [0.003, 0.5 * (y0 - y1), 0.04],
            ),
            m.tray,
        );
    }
    for yy in [y0 - 0.1, y1 + 0.1] {
        b.add(
            abox(
                [x_front + 0.05, yy, tray_z / 2.0],
                [0.03, 0.03, tray_z / 2.0],
            ),
            m.hazard,
        );
    }
    // A bolted panel on a post in front of the tray end (more near-range texture).
    let rot = Rotation3::from_axis_angle(&Vector3::z_axis(), 0.4).into_inner();
    b.add(
        Shape::Box {
            center: Point3::new(x_front - 0.1, y - hy - 1.3, 1.15),
            rotation: rot,
            half_extents_m: Vector3::new(0.01, 0.3, 0.25),
        },
        m.bolted,
    );
    b.add(
        abox([x_front - 0.1, y - hy - 1.3, 0.45], [0.03, 0.03, 0.45]),
        m.pedestal,
    );
    (Point3::new(xf, y, 1.1), -Vector3::x())
}
