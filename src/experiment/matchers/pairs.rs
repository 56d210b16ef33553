//! The image pairs with known geometry: simulator views, shecar photos, synthetic warps.

use super::*;

// ---------------------------------------------------------------------------------------
// Pair generation
// ---------------------------------------------------------------------------------------

/// Random stream ids (for `sim::rng`).
pub(super) const STREAM_SIM_VIEW: u64 = 11;
pub(super) const STREAM_SHECAR_ORDER: u64 = 12;
pub(super) const STREAM_WARP: u64 = 13;
pub(super) const STREAM_WARP_NOISE: u64 = 14;

/// Renders the simulated pairs (module docs, set 1).
pub(super) fn sim_pairs(
    settings: &Settings,
    n: usize,
    progress: &Progress,
) -> Result<Vec<ImagePair>> {
    let (scene, layout) = sim::scene::SubstationBuilder::new(SIM_SCENE_SEED)
        .build()
        .context("building the simulated substation")?;
    let camera = wrist_camera()
        .scaled(settings.image_scale)
        .context("scaling the wrist camera")?;
    let rays = RayTable::new(&camera).context("ray table")?;
    let light = LightConditions::from_hour(SIM_HOUR);
    let mut sensor = SensorParams::wrist();
    sensor.depth = SensorParams::ideal().depth;
    let normal = layout.calibration_target_normal;
    let target = layout.calibration_target_center + Vector3::new(0.0, 0.0, 0.15);
    let e1 = normal.cross(&Vector3::z()).normalize();
    let e2 = normal.cross(&e1).normalize();
    let mut pairs = Vec::with_capacity(n);
    for t in 0..n {
        let seed = trial_seed(settings.seed, PairSet::Sim as u64, t as u64);
        let u = |i: u64, lo: f64, hi: f64| sim::rng::uniform_in(seed, STREAM_SIM_VIEW, i, lo, hi);
        let az_a = u(0, 0.0, 360.0);
        let azimuths = [az_a, az_a + u(1, 80.0, 120.0)];
        let mut poses = Vec::with_capacity(2);
        for (k, az) in azimuths.iter().enumerate() {
            let k = 10 * (k as u64 + 1);
            let tilt = u(k, 8.0, 22.0).to_radians();
            let d = u(k + 1, 0.38, 0.52);
            let roll = u(k + 2, -22.0, 22.0).to_radians();
            let az = az.to_radians();
            let dir = normal * tilt.cos() + (e1 * az.cos() + e2 * az.sin()) * tilt.sin();
            let eye = target + dir * d;
            let look =
                world_from_camera_looking_at(&eye, &Point3::from(target.coords), &Vector3::z())
                    .context("degenerate simulated view")?;
            poses.push(look * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), roll));
        }
        let [world_from_a, world_from_b] = [poses[0], poses[1]];
        let fa = render_rgbd_with_rays(&scene, &world_from_a, &rays, &light, &sensor, seed);
        let fb = render_rgbd_with_rays(&scene, &world_from_b, &rays, &light, &sensor, seed ^ 1);
        let gray = |f: &sim::render::RgbdFrame| -> Result<GrayImage> {
            let rgb = image::RgbImage::from_raw(f.width, f.height, f.rgb.clone())
                .context("render buffer of the wrong size")?;
            Ok(calib::features::gray::rgb_to_gray(&rgb))
        };
        let angle = (world_from_a.rotation.inverse() * world_from_b.rotation)
            .angle()
            .to_degrees();
        let b_from_a = world_from_b.inverse() * world_from_a;
        pairs.push(ImagePair {
            set: PairSet::Sim,
            label: format!(
                "sim {t} ({angle:.0} deg, {:.0} mm)",
                b_from_a.translation.vector.norm() * 1e3
            ),
            seed,
            a: gray(&fa)?,
            b: gray(&fb)?,
            truth: Truth::Depth(Box::new(DepthTruth {
                camera,
                depth_a: fa.depth_m,
                depth_b: fb.depth_m,
                b_from_a,
            })),
        });
        progress.inc(1);
    }
    Ok(pairs)
}

/// The shecar photos and camera at one scale, loaded lazily.
pub(super) struct Shecar {
    pub(super) dataset: crate::import::Dataset,
    pub(super) scale: f64,
    pub(super) camera: CameraModel,
    pub(super) images: BTreeMap<usize, GrayImage>,
    pub(super) boards: BTreeMap<usize, std::result::Result<calib::board::BoardView, String>>,
}

impl Shecar {
    pub(super) fn open(settings: &Settings) -> Result<Self> {
        let crate::import::shecar::Resized {
            dataset,
            scale,
            camera,
        } = crate::import::shecar::open_resized(
            &compose::data::shecar_dir(),
            settings.image_scale,
        )?;
        Ok(Self {
            dataset,
            scale,
            camera,
            images: BTreeMap::new(),
            boards: BTreeMap::new(),
        })
    }

    pub(super) fn image(&mut self, i: usize) -> Result<GrayImage> {
        if let Some(img) = self.images.get(&i) {
            return Ok(img.clone());
        }
        let view = self
            .dataset
            .views
            .get(i)
            .with_context(|| format!("shecar has no view {i}"))?;
        let img = image::open(&view.image)
            .with_context(|| format!("decoding {}", view.image.display()))?
            .resize_exact(
                self.camera.width,
                self.camera.height,
                image::imageops::FilterType::Triangle,
            )
            .to_luma8();
        self.images.insert(i, img.clone());
        Ok(img)
    }

    pub(super) fn board(
        &mut self,
        i: usize,
    ) -> Result<std::result::Result<calib::board::BoardView, String>> {
        if let Some(b) = self.boards.get(&i) {
            return Ok(b.clone());
        }
        let img = self.image(i)?;
        let spec = BoardSpec::new(6, 8, 0.0283).context("board spec")?;
        let view = board_view(&img, &self.camera, &spec, &BoardOptions::default())
            .map_err(|e| format!("board not found in view {i}: {e}"));
        self.boards.insert(i, view.clone());
        Ok(view)
    }
}

/// Shecar pairs (module docs, set 2). A pair whose board is not found is returned as an
/// `Err` reason (counted as a refused pair).
pub(super) fn shecar_pairs(
    shecar: &mut Shecar,
    settings: &Settings,
    n: usize,
    progress: &Progress,
) -> Result<Vec<std::result::Result<ImagePair, String>>> {
    let views = shecar.dataset.views.len();
    if views < 2 {
        bail!("shecar has fewer than 2 views");
    }
    // Consecutive pairs in a seeded order, cycling when more are asked for.
    let mut order: Vec<usize> = (0..views - 1).collect();
    order.sort_by_key(|&i| sim::rng::key(settings.seed, STREAM_SHECAR_ORDER, i as u64));
    let spec = BoardSpec::new(6, 8, 0.0283).context("board spec")?;
    let mut out = Vec::with_capacity(n);
    for t in 0..n {
        let Some(&i) = order.get(t % order.len()) else {
            break;
        };
        let j = i + 1;
        let seed = trial_seed(settings.seed, PairSet::Shecar as u64, t as u64);
        let label = format!("shecar {i:02}-{j:02}");
        let pair = match (shecar.board(i)?, shecar.board(j)?) {
            (Ok(ba), Ok(bb)) => {
                board_truth(&shecar.camera, &spec, &ba, &bb).map(|truth| ImagePair {
                    set: PairSet::Shecar,
                    label: label.clone(),
                    seed,
                    a: GrayImage::new(1, 1),
                    b: GrayImage::new(1, 1),
                    truth: Truth::Board(Box::new(truth)),
                })
            }
            (Err(e), _) | (_, Err(e)) => Err(e),
        };
        let pair = match pair {
            Ok(mut p) => {
                p.a = shecar.image(i)?;
                p.b = shecar.image(j)?;
                Ok(p)
            }
            Err(e) => Err(format!("{label}: {e}")),
        };
        out.push(pair);
        progress.inc(1);
    }
    Ok(out)
}

/// Board homographies and the fundamental matrix of two board views.
pub(super) fn board_truth(
    camera: &CameraModel,
    spec: &BoardSpec,
    a: &calib::board::BoardView,
    b: &calib::board::BoardView,
) -> std::result::Result<BoardTruth, String> {
    let lattice: Vec<Point2<f64>> = (0..spec.rows)
        .flat_map(|r| (0..spec.cols).map(move |c| Point2::new(c as f64, r as f64)))
        .collect();
    let und = |v: &calib::board::BoardView| -> std::result::Result<Vec<Point2<f64>>, String> {
        v.corners_px
            .iter()
            .map(|p| {
                undistorted_px(camera, (p.x, p.y))
                    .map(|(x, y)| Point2::new(x, y))
                    .ok_or_else(|| "a board corner cannot be undistorted".to_owned())
            })
            .collect()
    };
    let (ua, ub) = (und(a)?, und(b)?);
    let h_a = homography_dlt(&lattice, &ua).map_err(|e| format!("board homography: {e}"))?;
    let h_b = homography_dlt(&lattice, &ub).map_err(|e| format!("board homography: {e}"))?;
    let board_from_a = h_a
        .try_inverse()
        .ok_or_else(|| "singular board homography".to_owned())?;
    // x_b^T F x_a = 0 with F = K^-T [t]x R K^-1, (R, t) = b_from_a.
    let b_from_a = b.world_from_camera.inverse() * a.world_from_camera;
    let t = b_from_a.translation.vector;
    let tx = Matrix3::new(0.0, -t.z, t.y, t.z, 0.0, -t.x, -t.y, t.x, 0.0);
    let e = tx * b_from_a.rotation.to_rotation_matrix().into_inner();
    let k = Matrix3::new(
        camera.fx, 0.0, camera.cx, 0.0, camera.fy, camera.cy, 0.0, 0.0, 1.0,
    );
    let k_inv = k
        .try_inverse()
        .ok_or_else(|| "singular camera matrix".to_owned())?;
    Ok(BoardTruth {
        camera: *camera,
        board_from_a,
        b_from_board: h_b,
        cols: spec.cols,
        rows: spec.rows,
        fundamental: k_inv.transpose() * e * k_inv,
    })
}

/// `img` warped by `h` (A pixels -> B pixels): `B(x) = A(h^-1 x)`, bilinear, 0 outside, plus
/// Gaussian noise of sigma 2 grey levels from `sim::rng` keyed by the pixel index.
pub(super) fn warp(img: &GrayImage, h: &Matrix3<f64>, seed: u64) -> Option<GrayImage> {
    let inv = h.try_inverse()?;
    let (w, hh) = img.dimensions();
    let sample = |x: f64, y: f64| -> Option<f64> {
        if x < 0.0 || y < 0.0 || x > f64::from(w - 1) || y > f64::from(hh - 1) {
            return None;
        }
        let (x0, y0) = (x.floor() as u32, y.floor() as u32);
        let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(hh - 1));
        let (fx, fy) = (x - f64::from(x0), y - f64::from(y0));
        let p = |x: u32, y: u32| f64::from(img.get_pixel(x, y).0[0]);
        Some(
            (p(x0, y0) * (1.0 - fx) + p(x1, y0) * fx) * (1.0 - fy)
                + (p(x0, y1) * (1.0 - fx) + p(x1, y1) * fx) * fy,
        )
    };
    Some(GrayImage::from_fn(w, hh, |x, y| {
        let v = apply_h(&inv, f64::from(x), f64::from(y))
            .and_then(|(sx, sy)| sample(sx, sy))
            .map_or(0.0, |v| {
                v + 2.0
                    * sim::rng::normal(
                        seed,
                        STREAM_WARP_NOISE,
                        u64::from(y) * u64::from(w) + u64::from(x),
                    )
            });
        image::Luma([v.round().clamp(0.0, 255.0) as u8])
    }))
}

/// Warp pairs (module docs, set 3).
pub(super) fn warp_pairs(
    shecar: &mut Shecar,
    settings: &Settings,
    n: usize,
    progress: &Progress,
) -> Result<Vec<ImagePair>> {
    let views = shecar.dataset.views.len().max(1);
    let mut out = Vec::with_capacity(n);
    for t in 0..n {
        let seed = trial_seed(settings.seed, PairSet::Warp as u64, t as u64);
        let u = |i: u64, lo: f64, hi: f64| sim::rng::uniform_in(seed, STREAM_WARP, i, lo, hi);
        let i = (sim::rng::key(seed, STREAM_WARP, 99) % views as u64) as usize;
        let a = shecar.image(i)?;
        let (w, h) = (f64::from(a.width()), f64::from(a.height()));
        let angle = u(0, -30.0, 30.0).to_radians();
        let scale = u(1, 0.8, 1.25);
        let (tx, ty) = (u(2, -0.05, 0.05) * w, u(3, -0.05, 0.05) * h);
        let (px, py) = (u(4, -0.15, 0.15) / w, u(5, -0.15, 0.15) / h);
        let (c, s) = (angle.cos() * scale, angle.sin() * scale);
        let (cx, cy) = (0.5 * (w - 1.0), 0.5 * (h - 1.0));
        let centre = Matrix3::new(1.0, 0.0, -cx, 0.0, 1.0, -cy, 0.0, 0.0, 1.0);
        let back = Matrix3::new(1.0, 0.0, cx + tx, 0.0, 1.0, cy + ty, 0.0, 0.0, 1.0);
        let similarity = Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
        let perspective = Matrix3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, px, py, 1.0);
        let hm = back * similarity * perspective * centre;
        let b = warp(&a, &hm, seed).context("singular warp")?;
        out.push(ImagePair {
            set: PairSet::Warp,
            label: format!(
                "warp {t} (view {i:02}, {:.0} deg, x{scale:.2})",
                angle.to_degrees()
            ),
            seed,
            a,
            b,
            truth: Truth::Homography(hm),
        });
        progress.inc(1);
    }
    Ok(out)
}
