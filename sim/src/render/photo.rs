//! A scene of photographs: flat rectangles textured with real photos, ray cast exactly.
//!
//! The calibration experiments' substation is procedural; this scene puts real image
//! content (a photographer's textures, lighting and blur) in front of the camera while the
//! geometry stays exact: a wall of photos with boxes standing out of it, every face a
//! rectangle with a photo on it. Depth is the exact distance along the optical axis of each
//! pixel centre's ray (NaN where the ray hits nothing); colour is the photo's sRGB value
//! averaged over a 2x2 grid of sub-pixel rays with bilinear lookups, so a texture up to
//! about twice as fine as the pixels does not alias. There is no shading and no sensor
//! model: the photos carry their own light, and noise is the caller's to add.

use nalgebra::{Isometry3, Point2, Point3, Vector3};
use rayon::prelude::*;

use super::camera_model::RayTable;

/// A photo as a texture: sRGB bytes, row-major RGB, and its size on a face.
#[derive(Clone, Debug)]
pub struct PhotoTexture {
    /// Width, texels.
    pub width: usize,
    /// Height, texels.
    pub height: usize,
    /// sRGB, `3 * width * height` bytes.
    pub rgb: Vec<u8>,
    /// Edge length of one texel on a face, metres.
    pub texel_m: f64,
}

impl PhotoTexture {
    /// Bilinear sRGB lookup at texel coordinates (`x` right, `y` down, texel centres at
    /// `i + 0.5`), clamped to the photo's edge.
    fn sample(&self, x: f64, y: f64) -> [f32; 3] {
        if self.width == 0 || self.height == 0 {
            return [0.0; 3];
        }
        let fx = (x - 0.5).clamp(0.0, (self.width - 1) as f64);
        let fy = (y - 0.5).clamp(0.0, (self.height - 1) as f64);
        let (x0, y0) = (fx.floor() as usize, fy.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(self.width - 1), (y0 + 1).min(self.height - 1));
        let (ax, ay) = ((fx - x0 as f64) as f32, (fy - y0 as f64) as f32);
        let at = |x: usize, y: usize, c: usize| {
            f32::from(
                self.rgb
                    .get(3 * (y * self.width + x) + c)
                    .copied()
                    .unwrap_or(0),
            )
        };
        let mut out = [0.0; 3];
        for (c, o) in out.iter_mut().enumerate() {
            let top = at(x0, y0, c) * (1.0 - ax) + at(x1, y0, c) * ax;
            let bottom = at(x0, y1, c) * (1.0 - ax) + at(x1, y1, c) * ax;
            *o = top * (1.0 - ay) + bottom * ay;
        }
        out
    }
}

/// A textured rectangle: `corner + a u + b v` for `a` in `[0, size_m[0]]`, `b` in
/// `[0, size_m[1]]`, with `u`, `v` orthonormal. Its photo is laid from texel `offset` on,
/// `u` to the right and `v` down the photo.
#[derive(Clone, Copy, Debug)]
pub struct PhotoQuad {
    /// The corner at the photo's `offset`.
    pub corner: Point3<f64>,
    /// Unit edge direction along the photo's rows.
    pub u: Vector3<f64>,
    /// Unit edge direction down the photo's columns.
    pub v: Vector3<f64>,
    /// Edge lengths along `u` and `v`, metres.
    pub size_m: [f64; 2],
    /// Index of the texture.
    pub texture: usize,
    /// Texel of the photo at `corner`.
    pub offset: [f64; 2],
}

impl PhotoQuad {
    /// Ray parameter and surface coordinates (metres) of the hit of `origin + t dir`, for
    /// `t > 0` inside the rectangle.
    fn hit(&self, origin: &Point3<f64>, dir: &Vector3<f64>) -> Option<(f64, f64, f64)> {
        let n = self.u.cross(&self.v);
        let denom = n.dot(dir);
        if denom.abs() < 1e-12 {
            return None;
        }
        let t = n.dot(&(self.corner - origin)) / denom;
        if t <= 1e-9 {
            return None;
        }
        let p = origin + dir * t - self.corner;
        let (a, b) = (p.dot(&self.u), p.dot(&self.v));
        let inside = (0.0..=self.size_m[0]).contains(&a) && (0.0..=self.size_m[1]).contains(&b);
        inside.then_some((t, a, b))
    }
}

/// A wall of photos with boxes standing out of it (module docs).
#[derive(Clone, Debug)]
pub struct PhotoScene {
    /// The textures the quads index.
    pub textures: Vec<PhotoTexture>,
    /// Every textured face.
    pub quads: Vec<PhotoQuad>,
}

/// A box standing out of a [`PhotoScene::wall_with_boxes`] wall, in the wall's frame.
#[derive(Clone, Copy, Debug)]
pub struct WallBox {
    /// Centre of its footprint on the wall, metres along the wall's right and up axes.
    pub centre_m: [f64; 2],
    /// Width (right), height (up) and how far it stands out, metres.
    pub size_m: [f64; 3],
}

impl PhotoScene {
    /// A wall centred at `centre` facing `normal` (towards the camera), `up` its upward
    /// direction (made orthogonal to `normal`), tiled with `wall_tiles` (columns, rows) of
    /// the first textures at the first one's size; then `boxes`, each face with the next
    /// texture not on the wall in turn (cycling), each face's photo laid from a different texel
    /// offset. Without
    /// textures the scene is empty.
    #[must_use]
    pub fn wall_with_boxes(
        centre: Point3<f64>,
        normal: Vector3<f64>,
        up: Vector3<f64>,
        textures: Vec<PhotoTexture>,
        wall_tiles: (usize, usize),
        boxes: &[WallBox],
    ) -> Self {
        let mut quads = Vec::new();
        if textures.is_empty() {
            return Self { textures, quads };
        }
        let n = normal.normalize();
        let up = (up - n * n.dot(&up)).normalize();
        let right = up.cross(&n);
        let down = -up;
        let size = |t: usize| {
            let tex = &textures[t % textures.len()];
            [
                tex.width as f64 * tex.texel_m,
                tex.height as f64 * tex.texel_m,
            ]
        };
        // The wall: tiles of the first textures, the grid centred on `centre`.
        let tile = size(0);
        let (cols, rows) = wall_tiles;
        let top_left =
            centre - right * (0.5 * cols as f64 * tile[0]) + up * (0.5 * rows as f64 * tile[1]);
        let mut next = 0usize;
        for r in 0..rows {
            for c in 0..cols {
                quads.push(PhotoQuad {
                    corner: top_left + right * (c as f64 * tile[0]) + down * (r as f64 * tile[1]),
                    u: right,
                    v: down,
                    size_m: tile,
                    texture: next % textures.len(),
                    offset: [0.0, 0.0],
                });
                next += 1;
            }
        }
        // The boxes: front, then the four sides, each seen from outside.
        for b in boxes {
            let [w, h, d] = b.size_m;
            let base = centre + right * b.centre_m[0] + up * b.centre_m[1];
            let front_tl = base - right * (0.5 * w) + up * (0.5 * h) + n * d;
            let faces = [
                (front_tl, right, down, [w, h]),
                // Left side: from the wall out to the front edge, seen from the left.
                (front_tl - n * d, n, down, [d, h]),
                // Right side.
                (front_tl + right * w, -n, down, [d, h]),
                // Top: from the wall out to the front edge, seen from above.
                (front_tl - n * d, right, n, [w, d]),
                // Bottom.
                (front_tl + down * h, right, -n, [w, d]),
            ];
            for (k, (corner, u, v, size_m)) in faces.into_iter().enumerate() {
                // The photos not on the wall, in turn (all of them when the wall has taken
                // every one), so no content stands at two depths.
                let spare = textures.len().saturating_sub(cols * rows);
                let t = if spare > 0 {
                    cols * rows + (next - cols * rows) % spare
                } else {
                    next % textures.len()
                };
                let [tw, th] = size(t);
                // A different part of the photo on each face, within the photo.
                let frac = [0.13, 0.41, 0.67, 0.29, 0.83][k];
                let room = [(tw - size_m[0]).max(0.0), (th - size_m[1]).max(0.0)];
                let texel = textures[t].texel_m;
                quads.push(PhotoQuad {
                    corner,
                    u,
                    v,
                    size_m,
                    texture: t,
                    offset: [frac * room[0] / texel, (1.0 - frac) * room[1] / texel],
                });
                next += 1;
            }
        }
        Self { textures, quads }
    }

    /// The nearest hit of a ray: `(t, quad, a, b)`.
    fn trace(&self, origin: &Point3<f64>, dir: &Vector3<f64>) -> Option<(f64, usize, f64, f64)> {
        self.quads
            .iter()
            .enumerate()
            .filter_map(|(i, q)| q.hit(origin, dir).map(|(t, a, b)| (t, i, a, b)))
            .min_by(|x, y| x.0.total_cmp(&y.0))
    }

    /// The colour of a ray, `None` when it hits nothing.
    fn colour(&self, origin: &Point3<f64>, dir: &Vector3<f64>) -> Option<[f32; 3]> {
        let (_, i, a, b) = self.trace(origin, dir)?;
        let q = self.quads.get(i)?;
        let tex = self.textures.get(q.texture)?;
        Some(tex.sample(q.offset[0] + a / tex.texel_m, q.offset[1] + b / tex.texel_m))
    }

    /// Renders the view of a camera at `world_from_camera` (optical frame: z forward, x
    /// right, y down) through `rays`' lens: sRGB colour (black where nothing is hit) and
    /// depth along the optical axis, metres (module docs). Rows in parallel; the result does
    /// not depend on the thread count.
    #[must_use]
    pub fn render(
        &self,
        world_from_camera: &Isometry3<f64>,
        rays: &RayTable,
    ) -> (Vec<u8>, Vec<f32>) {
        let k = rays.intrinsics();
        let (w, h) = (k.width as usize, k.height as usize);
        let xy = rays.normalized();
        let origin = Point3::from(world_from_camera.translation.vector);
        let rot = world_from_camera.rotation;
        let mut rgb = vec![0u8; 3 * w * h];
        let mut depth_m = vec![f32::NAN; w * h];
        rgb.par_chunks_mut(3 * w)
            .zip(depth_m.par_chunks_mut(w))
            .enumerate()
            .for_each(|(row, (rgb_row, depth_row))| {
                for col in 0..w {
                    let centre = xy.get(row * w + col).copied().unwrap_or([0.0, 0.0]);
                    let dir_cam = Vector3::new(centre[0], centre[1], 1.0);
                    if let Some((t, ..)) = self.trace(&origin, &(rot * dir_cam)) {
                        // `dir_cam` has unit z: `t` is the depth along the optical axis.
                        depth_row[col] = t as f32;
                    }
                    let mut sum = [0.0_f32; 3];
                    for (dc, dr) in [(-0.25, -0.25), (0.25, -0.25), (-0.25, 0.25), (0.25, 0.25)] {
                        // The lens's own inverse distortion, started from the pixel
                        // centre's (the table solved it there; a sub-pixel step converges
                        // at once). It cannot fail where the centre succeeded.
                        let sub = Point2::new(col as f64 + dc, row as f64 + dr);
                        let guess = Point2::new(centre[0], centre[1]);
                        let p = k.undistort_pixel_from(&sub, &guess).unwrap_or(guess);
                        if let Some(c) = self.colour(&origin, &(rot * Vector3::new(p.x, p.y, 1.0)))
                        {
                            for (s, v) in sum.iter_mut().zip(c) {
                                *s += v;
                            }
                        }
                    }
                    for (ch, s) in sum.iter().enumerate() {
                        rgb_row[3 * col + ch] = (0.25 * s).round().clamp(0.0, 255.0) as u8;
                    }
                }
            });
        (rgb, depth_m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::CameraModel;
    use nalgebra::{Translation3, UnitQuaternion};

    fn checker(width: usize, height: usize, texel_m: f64) -> PhotoTexture {
        let mut rgb = Vec::with_capacity(3 * width * height);
        for y in 0..height {
            for x in 0..width {
                let v = if (x / 8 + y / 8) % 2 == 0 { 220 } else { 30 };
                rgb.extend_from_slice(&[v, (x % 256) as u8, (y % 256) as u8]);
            }
        }
        PhotoTexture {
            width,
            height,
            rgb,
            texel_m,
        }
    }

    fn camera() -> (RayTable, CameraModel) {
        let k = CameraModel::pinhole(160, 120, 150.0, 150.0, 79.5, 59.5);
        (RayTable::new(&k).expect("ray table"), k)
    }

    /// A camera 0.5 m in front of the wall (wall normal +z in the world, camera looking
    /// along -z).
    fn facing_the_wall() -> Isometry3<f64> {
        Isometry3::from_parts(
            Translation3::new(0.0, 0.0, 0.5),
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI),
        )
    }

    #[test]
    fn the_depth_of_a_wall_and_a_box_is_exact() {
        let scene = PhotoScene::wall_with_boxes(
            Point3::origin(),
            Vector3::z(),
            Vector3::y(),
            vec![checker(400, 300, 0.002)],
            (2, 2),
            &[WallBox {
                centre_m: [0.0, 0.0],
                size_m: [0.1, 0.1, 0.2],
            }],
        );
        let (rays, k) = camera();
        let (rgb, depth) = scene.render(&facing_the_wall(), &rays);
        assert_eq!(rgb.len(), 3 * 160 * 120);
        // The optical centre sees the box's front, 0.2 m out of the wall.
        let centre = depth[60 * 160 + 80];
        assert!((centre - 0.3).abs() < 1e-6, "{centre}");
        // A corner pixel sees the wall: its depth is the wall's distance along the axis.
        let corner = depth[0];
        assert!((corner - 0.5).abs() < 1e-6, "{corner}");
        // Every pixel is hit (the wall is 1.6 x 1.2 m).
        assert!(depth.iter().all(|d| d.is_finite()));
        let _ = k;
    }

    #[test]
    fn colour_is_the_photo_where_the_pixel_lands() {
        // One texel per pixel at 0.5 m: texel 1/300 m, pixel footprint 0.5 / 150 m.
        let tex = checker(320, 240, 0.5 / 150.0);
        let scene = PhotoScene::wall_with_boxes(
            Point3::origin(),
            Vector3::z(),
            Vector3::y(),
            vec![tex.clone()],
            (1, 1),
            &[],
        );
        let (rays, _) = camera();
        let (rgb, _) = scene.render(&facing_the_wall(), &rays);
        // The camera's x is the wall's right (x flipped twice: image x right = world +x),
        // its y the wall's down: pixel (col, row) sees texel (col + 80, row + 60) of the
        // photo laid from its top-left corner at (-0.533, 0.4) m.
        let mut max_diff = 0i32;
        for row in 10..110 {
            for col in 10..150 {
                let i = 3 * (row * 160 + col);
                let t = 3 * ((row + 60) * 320 + col + 80);
                // The green channel is the texel's column: exact at texel centres, and
                // bilinear averaging keeps it exact on a linear ramp.
                max_diff = max_diff.max((i32::from(rgb[i + 1]) - i32::from(tex.rgb[t + 1])).abs());
            }
        }
        assert!(max_diff <= 1, "green off by {max_diff}");
    }

    #[test]
    fn box_faces_take_the_photos_not_on_the_wall() {
        let textures = (0..18).map(|_| checker(16, 9, 0.04)).collect();
        let b = WallBox {
            centre_m: [0.0, 0.0],
            size_m: [0.1, 0.1, 0.1],
        };
        let scene = PhotoScene::wall_with_boxes(
            Point3::origin(),
            Vector3::z(),
            Vector3::y(),
            textures,
            (2, 3),
            &[b, b, b],
        );
        assert_eq!(scene.quads.len(), 6 + 15);
        let (wall, faces) = scene.quads.split_at(6);
        assert!(wall.iter().enumerate().all(|(i, q)| q.texture == i));
        assert!(faces.iter().all(|q| (6..18).contains(&q.texture)));
    }

    #[test]
    fn a_ray_missing_every_face_has_no_depth() {
        let scene = PhotoScene::wall_with_boxes(
            Point3::origin(),
            Vector3::z(),
            Vector3::y(),
            vec![checker(10, 10, 0.001)],
            (1, 1),
            &[],
        );
        let (rays, _) = camera();
        let (rgb, depth) = scene.render(&facing_the_wall(), &rays);
        assert!(depth[0].is_nan());
        assert_eq!(&rgb[0..3], &[0, 0, 0]);
        assert!(depth[60 * 160 + 80].is_finite());
    }
}
