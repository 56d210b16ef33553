//! The wire-perception flow, one implementation that both the `perceive` stage and the
//! `task` stage's hang drive: panoramic fix -> wrist look pose -> captures -> fused hanging
//! point.
//!
//! 1. **Panoramic fix** ([`WireFlow::fix_from_panoramic`]):
//!    [`panoramic::find_wire_region`] on a `/panoramic/image_raw` frame (`rgb8` or `bgr8`)
//!    with the site map's prior of the target conductor; the panoramic camera's pose is
//!    `map -> base_link` (odometry on `/tf`, at the image stamp, else the latest) times
//!    `base_link -> panoramic_optical_frame` at the image stamp. The flow counts the frames
//!    tried and gives up after [`WireFlowParams::panoramic_attempts`]; a found wire
//!    replaces the prior in `map`.
//! 2. **Look** ([`WireFlow::look_pose`]): the wrist camera's pose for the captures, from
//!    the prior in `base_link` ([`WireFlow::prior_in_base`]: the panoramic fix, else the site
//!    map's prior), [`WireFlowParams::standoff_m`] from the wire ([`LookPolicy`]). The driver
//!    plans and commands the motion (the two stages plan with different collision worlds
//!    and lifts).
//! 3. **Captures** ([`WireFlow::observe`]): in each [`WristCapture`], the pixel ROI around
//!    the prior segment ([`WireFlowParams::roi_half_length_m`] either side of the prior point,
//!    margin [`WireFlowParams::roi_margin_m`] at the wire), [`wire::detect_wire`] in depth,
//!    confirmed in the registered colour image when the capture has one
//!    ([`WireObservation::confirm_in_colour`]).
//! 4. **Hanging point** ([`WireFlow::estimate`]): [`wire::estimate_wire`] over the
//!    observations (in `base_link`), near the prior and approached from the arm base;
//!    [`WireFlow::roi_cloud`] is the `/perception/roi_cloud` of the observations' inliers.
//!
//! The flow keeps no clock and no randomness beyond the seeded RANSACs of the panoramic
//! finder and the wire detection: its drivers stay replayable byte for byte.

use msgs::builtin_interfaces::Time;
use msgs::frames::{BASE_LINK, MAP, PANORAMIC_OPTICAL_FRAME};
use msgs::sensor_msgs::{Image, PointCloud2};
use msgs::std_msgs::Header;
use nalgebra::{Isometry3, Point3, Vector3};
use robot::TfBuffer;

use crate::perception::colour::LumaImage;
use crate::perception::confidence::ConfidenceThresholds;
use crate::perception::panoramic::{self, PanoramicParams, PanoramicWire, RgbView, WirePrior};
use crate::perception::point_cloud::{CameraModel, DepthImage, RayTable, to_point_cloud2};
use crate::perception::roi::{PixelRoi, wrist_look_pose};
use crate::perception::wire::{self, WireEstimate, WireObservation, WireParams};
use crate::perception::{PerceptionError, WIRE_RADIUS_M};
use crate::tasks::poses::{self, PoseError};

/// Where the wrist camera looks at the wire from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LookPolicy {
    /// Level with the wire, on the robot's side, the image's up side up
    /// ([`poses::level_look_pose`]): the task raises the lift to the wire's height first.
    Level,
    /// Along the wire's normal through the arm base, optical axis at the wire, x along it
    /// ([`wrist_look_pose`]): the `perceive` stage looks up from the lift where it is.
    TowardsArmBase,
}

/// Settings of the [`WireFlow`]. Every default is documented on its field.
#[derive(Debug, Clone, PartialEq)]
pub struct WireFlowParams {
    /// The site map's prior of the target conductor, in `map`. Default
    /// [`crate::tasks::site::SiteMap::default_bay`]'s.
    pub prior_in_map: WirePrior,
    /// Panoramic finder. Default [`PanoramicParams::default`].
    pub panoramic: PanoramicParams,
    /// Panoramic frames tried before giving up. Default 5.
    pub panoramic_attempts: usize,
    /// Where the wrist camera looks from. Default [`LookPolicy::Level`].
    pub look: LookPolicy,
    /// Wrist camera standoff from the wire (m). Default 0.45.
    pub standoff_m: f64,
    /// Half-length of the prior segment projected into the wrist image (m). Default 0.25.
    pub roi_half_length_m: f64,
    /// ROI margin around the projected prior (m at the wire). Default 0.15.
    pub roi_margin_m: f64,
    /// Wire detection. Default [`WireParams::default`].
    pub wire: WireParams,
    /// Confidence thresholds. Default [`ConfidenceThresholds::default`].
    pub thresholds: ConfidenceThresholds,
}

impl Default for WireFlowParams {
    fn default() -> Self {
        Self {
            prior_in_map: crate::tasks::site::SiteMap::default_bay().wire,
            panoramic: PanoramicParams::default(),
            panoramic_attempts: 5,
            look: LookPolicy::Level,
            standoff_m: 0.45,
            roi_half_length_m: 0.25,
            roi_margin_m: 0.15,
            wire: WireParams::default(),
            thresholds: ConfidenceThresholds::default(),
        }
    }
}

/// A wrist capture: depth, the registered colour image of the same stamp when one came, and
/// the camera's pose at the stamp.
#[derive(Debug, Clone)]
pub struct WristCapture {
    /// The depth image.
    pub depth: DepthImage,
    /// The registered colour image of the same stamp, when one came.
    pub colour: Option<LumaImage>,
    /// `base_link -> camera_color_optical_frame` at the stamp.
    pub base_from_camera: Isometry3<f64>,
    /// The images' stamp.
    pub stamp: Time,
}

/// What a panoramic frame gave.
#[derive(Debug, Clone, PartialEq)]
pub enum PanoramicOutcome {
    /// The wire was found; its line replaces the prior (`map`).
    Fixed(PanoramicWire),
    /// Not in this frame (`attempt` frames tried so far): try the next.
    Retry {
        /// Frames tried, this one included.
        attempt: usize,
        /// Why this frame did not show the wire.
        reason: String,
    },
    /// Not in [`WireFlowParams::panoramic_attempts`] frames: the flow gives up.
    GaveUp {
        /// Frames tried.
        attempts: usize,
        /// Why the last frame did not show the wire.
        reason: String,
    },
}

/// Why no look pose.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LookError {
    /// [`LookPolicy::Level`]: degenerate geometry.
    #[error(transparent)]
    Level(#[from] PoseError),
    /// [`LookPolicy::TowardsArmBase`]: degenerate geometry.
    #[error(transparent)]
    TowardsArmBase(#[from] PerceptionError),
}

/// The wire-perception flow (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct WireFlow {
    params: WireFlowParams,
    /// The panoramic fix: a point on the wire and its direction, `map`.
    fix_in_map: Option<(Point3<f64>, Vector3<f64>)>,
    /// Panoramic frames tried.
    panoramic_tries: usize,
    /// Wire observations and their `base_from_camera`, in capture order.
    observations: Vec<(WireObservation, Isometry3<f64>)>,
}

impl WireFlow {
    /// A flow with `params`, no fix and no observation yet.
    #[must_use]
    pub fn new(params: WireFlowParams) -> Self {
        Self {
            params,
            fix_in_map: None,
            panoramic_tries: 0,
            observations: Vec::new(),
        }
    }

    /// Its settings.
    #[must_use]
    pub fn params(&self) -> &WireFlowParams {
        &self.params
    }

    /// The panoramic fix (point on the wire, direction; `map`), once found.
    #[must_use]
    pub fn fix_in_map(&self) -> Option<(Point3<f64>, Vector3<f64>)> {
        self.fix_in_map
    }

    /// Step 1: looks for the wire in a panoramic frame (`image`; `None` when the frame the
    /// driver waited for never came) seen by `camera` (`None` before
    /// `/panoramic/camera_info`), with the poses in `tf`. Every call counts as one frame
    /// tried, whatever it gives.
    pub fn fix_from_panoramic(
        &mut self,
        tf: &TfBuffer,
        camera: Option<&CameraModel>,
        image: Option<&Image>,
    ) -> PanoramicOutcome {
        match self.find_in_panoramic(tf, camera, image) {
            Ok(found) => {
                self.fix_in_map = Some((found.point, found.direction));
                PanoramicOutcome::Fixed(found)
            }
            Err(reason) => {
                self.panoramic_tries += 1;
                let attempts = self.panoramic_tries;
                if attempts >= self.params.panoramic_attempts.max(1) {
                    PanoramicOutcome::GaveUp { attempts, reason }
                } else {
                    PanoramicOutcome::Retry {
                        attempt: attempts,
                        reason,
                    }
                }
            }
        }
    }

    fn find_in_panoramic(
        &self,
        tf: &TfBuffer,
        camera: Option<&CameraModel>,
        image: Option<&Image>,
    ) -> Result<PanoramicWire, String> {
        let image = image.ok_or("no panoramic frame")?;
        let camera = camera.ok_or("no /panoramic/camera_info")?;
        let stamp_ns = time_ns(&image.header.stamp);
        let map_from_base = tf
            .lookup(BASE_LINK, MAP, stamp_ns)
            .or_else(|_| tf.lookup_latest(BASE_LINK, MAP).map(|(_, t)| t))
            .map_err(|e| format!("no map -> base_link: {e}"))?
            .inverse();
        let base_from_pano = tf
            .lookup(BASE_LINK, PANORAMIC_OPTICAL_FRAME, stamp_ns)
            .map_err(|e| format!("no base_link -> panoramic: {e}"))?;
        let bgr = match image.encoding.as_str() {
            "rgb8" => false,
            "bgr8" => true,
            other => return Err(format!("panoramic encoding {other} (rgb8 or bgr8)")),
        };
        let view = RgbView::new(
            image.width as usize,
            image.height as usize,
            image.step as usize,
            &image.data,
        )
        .map_err(|e| e.to_string())?;
        panoramic::find_wire_region(
            &view,
            &RgbView::luminance_weights(bgr),
            camera,
            &(map_from_base * base_from_pano),
            &self.params.prior_in_map,
            &self.params.panoramic,
        )
        .map_err(|e| e.to_string())
    }

    /// The wire's prior in `base_link` (point, direction) for `base_from_map`: the panoramic
    /// fix once found, else the site map's prior.
    #[must_use]
    pub fn prior_in_base(&self, base_from_map: &Isometry3<f64>) -> (Point3<f64>, Vector3<f64>) {
        let (p, d) = self.fix_in_map.unwrap_or((
            self.params.prior_in_map.point,
            self.params.prior_in_map.direction,
        ));
        (base_from_map * p, base_from_map.rotation * d)
    }

    /// Step 2: `base_from_camera` of the wrist camera looking at the wire `(point, direction)`
    /// (`base_link`) from [`WireFlowParams::standoff_m`], on the side of `robot_point` (the
    /// arm base), by [`WireFlowParams::look`].
    ///
    /// # Errors
    /// [`LookError`] for degenerate geometry (a robot point on the wire's vertical or axis).
    pub fn look_pose(
        &self,
        wire_in_base: &(Point3<f64>, Vector3<f64>),
        robot_point: &Point3<f64>,
    ) -> Result<Isometry3<f64>, LookError> {
        self.look_pose_from(wire_in_base, robot_point, self.params.standoff_m)
    }

    /// [`Self::look_pose`] from `standoff_m` instead of [`WireFlowParams::standoff_m`].
    ///
    /// # Errors
    /// As [`Self::look_pose`].
    pub fn look_pose_from(
        &self,
        wire_in_base: &(Point3<f64>, Vector3<f64>),
        robot_point: &Point3<f64>,
        standoff_m: f64,
    ) -> Result<Isometry3<f64>, LookError> {
        let (point, direction) = wire_in_base;
        Ok(match self.params.look {
            LookPolicy::Level => {
                poses::level_look_pose(point, direction, robot_point, standoff_m, &Vector3::z())?
            }
            LookPolicy::TowardsArmBase => {
                wrist_look_pose(point, direction, robot_point, standoff_m)?
            }
        })
    }

    /// Forgets the observations (a new series of captures begins).
    pub fn clear_observations(&mut self) {
        self.observations.clear();
    }

    /// The observations so far (with their `base_from_camera`).
    #[must_use]
    pub fn observations(&self) -> &[(WireObservation, Isometry3<f64>)] {
        &self.observations
    }

    /// Step 3: looks for the wire in `capture` (wrist camera `camera`, its `rays`) around the
    /// prior `(point, direction)` given in a frame `f` with `camera_from_f`; a found wire is
    /// kept for [`Self::estimate`].
    ///
    /// # Errors
    /// Why the capture shows no wire (the ROI or the detection's refusal), as text.
    pub fn observe(
        &mut self,
        capture: &WristCapture,
        camera: &CameraModel,
        rays: &RayTable,
        camera_from_f: &Isometry3<f64>,
        prior_in_f: &(Point3<f64>, Vector3<f64>),
    ) -> Result<(), String> {
        let (point, direction) = prior_in_f;
        let half = direction.normalize() * self.params.roi_half_length_m;
        let p0 = camera_from_f * (point - half);
        let p1 = camera_from_f * (point + half);
        let distance = 0.5 * (p0.coords.norm() + p1.coords.norm());
        let margin_px = self.params.roi_margin_m * camera.fx / distance.max(0.1);
        let observation =
            PixelRoi::around_segment(camera, &p0, &p1, margin_px, self.params.roi_margin_m)
                .map_err(|e| e.to_string())
                .and_then(|roi| {
                    wire::detect_wire(&capture.depth, rays, camera.fx, &roi, &self.params.wire)
                        .map_err(|e| e.to_string())
                })?;
        let observation = match &capture.colour {
            Some(colour) => observation.confirm_in_colour(colour, camera),
            None => observation,
        };
        self.observations
            .push((observation, capture.base_from_camera));
        Ok(())
    }

    /// Step 4: the fused estimate of the observations (`base_link`): the hanging point
    /// nearest `near` (the prior), approached from `robot_point` (the arm base).
    ///
    /// # Errors
    /// [`PerceptionError::NoCaptures`] without an observation, else as
    /// [`wire::estimate_wire`] (a confidence below the threshold refuses).
    pub fn estimate(
        &self,
        near: &Point3<f64>,
        robot_point: &Point3<f64>,
    ) -> Result<WireEstimate, PerceptionError> {
        wire::estimate_wire(
            &self.observations,
            near,
            robot_point,
            WIRE_RADIUS_M,
            &self.params.thresholds,
        )
    }

    /// `/perception/roi_cloud`: the observations' inliers in `base_link`, stamped `stamp`.
    #[must_use]
    pub fn roi_cloud(&self, stamp: Time) -> PointCloud2 {
        let cloud: Vec<Point3<f64>> = self
            .observations
            .iter()
            .flat_map(|(o, base_from_camera)| {
                o.inlier_points.iter().map(move |p| base_from_camera * p)
            })
            .collect();
        to_point_cloud2(
            &cloud,
            Header {
                stamp,
                frame_id: BASE_LINK.to_owned(),
            },
        )
    }
}

/// Nanoseconds of a ROS time (negative seconds read as 0).
#[must_use]
pub fn time_ns(t: &Time) -> u64 {
    u64::try_from(t.sec).unwrap_or(0) * 1_000_000_000 + u64::from(t.nanosec)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::perception::point_cloud::wrist_nominal;
    use crate::perception::synthetic::{NoiseModel, WireScene, render_wire_rgb, wrist_rays};
    use crate::tasks::site::SiteMap;
    use msgs::builtin_interfaces::Time;

    const STAMP_NS: u64 = 2_000_000_000;

    /// The default bay's working spot: odometry and the panoramic mast in a buffer, and the
    /// panoramic camera (640x360, ~115 deg).
    fn at_the_spot(site: &SiteMap) -> (TfBuffer, CameraModel) {
        let model = robot::RobotModel::nominal();
        let mut tf = TfBuffer::default();
        let inserted = tf
            .insert(MAP, BASE_LINK, STAMP_NS, site.work_spot.isometry())
            .and_then(|()| {
                tf.insert_static(
                    BASE_LINK,
                    PANORAMIC_OPTICAL_FRAME,
                    model.base_from_panoramic_optical,
                )
            });
        assert_eq!(inserted, Ok(()));
        let camera = CameraModel::pinhole(640, 360, 260.0, 260.0, 319.5, 179.5)
            .with_distortion([-0.12, 0.01, 0.0, 0.0, 0.0]);
        (tf, camera)
    }

    fn frame(
        site: &SiteMap,
        camera: &CameraModel,
        wire: Option<(Point3<f64>, Vector3<f64>)>,
    ) -> Image {
        let model = robot::RobotModel::nominal();
        let map_from_camera = site.work_spot.isometry() * model.base_from_panoramic_optical;
        Image {
            header: Header {
                stamp: Time { sec: 2, nanosec: 0 },
                frame_id: PANORAMIC_OPTICAL_FRAME.to_owned(),
            },
            height: camera.height,
            width: camera.width,
            encoding: "rgb8".to_owned(),
            is_bigendian: 0,
            step: camera.width * 3,
            data: render_wire_rgb(camera, &map_from_camera, wire, WIRE_RADIUS_M),
        }
    }

    #[test]
    fn the_panoramic_fix_moves_the_prior_onto_the_seen_wire() {
        let site = SiteMap::default_bay();
        let (tf, camera) = at_the_spot(&site);
        // The wire is 6 cm lower than the survey says.
        let truth = (
            site.wire.point - Vector3::new(0.0, 0.0, 0.06),
            site.wire.direction,
        );
        let mut flow = WireFlow::new(WireFlowParams::default());
        let image = frame(&site, &camera, Some(truth));
        let outcome = flow.fix_from_panoramic(&tf, Some(&camera), Some(&image));
        let PanoramicOutcome::Fixed(found) = outcome else {
            panic!("{outcome:?}");
        };
        let Some((point, direction)) = flow.fix_in_map() else {
            panic!("no fix");
        };
        assert_eq!((point, direction), (found.point, found.direction));
        // The true wire lies in the plane through the camera and the seen line (the part of
        // the prior's error along the viewing rays cannot be seen, and stays).
        let a = truth.1.normalize();
        for s in [-1.0, 0.0, 1.0] {
            let off = found
                .plane_normal
                .dot(&(truth.0 + a * s - found.camera_centre));
            assert!(off.abs() < 0.01, "the true wire is {off} m off the plane");
        }
        assert!(found.correction_m > 0.005, "{found:?}");
        assert!(direction.normalize().dot(&a).abs() > 0.999);
        // The prior in base_link is the fix from now on.
        let base_from_map = site.work_spot.isometry().inverse();
        let (p, _) = flow.prior_in_base(&base_from_map);
        assert!((p - base_from_map * point).norm() < 1e-12);
    }

    #[test]
    fn frames_without_the_wire_are_retried_then_given_up() {
        let site = SiteMap::default_bay();
        let (tf, camera) = at_the_spot(&site);
        let mut flow = WireFlow::new(WireFlowParams {
            panoramic_attempts: 3,
            ..WireFlowParams::default()
        });
        let image = frame(&site, &camera, None);
        for attempt in 1..=2 {
            let outcome = flow.fix_from_panoramic(&tf, Some(&camera), Some(&image));
            assert!(
                matches!(&outcome, PanoramicOutcome::Retry { attempt: a, .. } if *a == attempt),
                "{outcome:?}"
            );
        }
        // No camera info counts as a frame tried too.
        let outcome = flow.fix_from_panoramic(&tf, None, Some(&image));
        let PanoramicOutcome::GaveUp { attempts, reason } = outcome else {
            panic!("{outcome:?}");
        };
        assert_eq!(attempts, 3);
        assert_eq!(reason, "no /panoramic/camera_info");
        assert_eq!(flow.fix_in_map(), None);
        // Without a fix the prior is the site map's.
        let (p, _) = flow.prior_in_base(&Isometry3::identity());
        assert_eq!(p, site.wire.point);
    }

    #[test]
    fn captures_of_the_wire_fuse_into_the_hanging_point_and_a_capture_without_it_is_refused()
    -> Result<(), PerceptionError> {
        let rays = wrist_rays()?;
        let camera = wrist_nominal();
        let scene = WireScene::random(11);
        let prior = (scene.wire.centre, scene.wire.direction);
        let mut flow = WireFlow::new(WireFlowParams::default());
        for seed in [1, 2] {
            let capture = WristCapture {
                depth: scene.render(&rays, &NoiseModel::default(), seed),
                colour: None,
                base_from_camera: Isometry3::identity(),
                stamp: Time::default(),
            };
            let observed = flow.observe(&capture, &camera, &rays, &Isometry3::identity(), &prior);
            assert_eq!(observed, Ok(()));
        }
        // A capture of an empty scene: no wire, not kept.
        let empty = WristCapture {
            depth: crate::perception::synthetic::render_depth(
                &crate::perception::synthetic::Scene::default(),
                &rays,
                &NoiseModel::default(),
                &mut rng::SplitMix64::new(3),
            ),
            colour: None,
            base_from_camera: Isometry3::identity(),
            stamp: Time::default(),
        };
        assert!(
            flow.observe(&empty, &camera, &rays, &Isometry3::identity(), &prior)
                .is_err()
        );
        assert_eq!(flow.observations().len(), 2);
        let estimate = flow.estimate(&scene.wire.centre, &Point3::new(0.0, 0.0, -1.0))?;
        let d = estimate.hanging.point - scene.wire.centre;
        let a = scene.wire.direction;
        let off = (d - a * d.dot(&a)).norm();
        assert!(off < 0.002, "hanging point {off} m off the axis");
        assert!(flow.roi_cloud(Time::default()).width > 0);
        flow.clear_observations();
        assert!(matches!(
            flow.estimate(&scene.wire.centre, &Point3::origin()),
            Err(PerceptionError::NoCaptures)
        ));
        Ok(())
    }
}
