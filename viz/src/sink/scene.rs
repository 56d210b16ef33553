//! The site as the robot knows it (surveyed bodies, the believed rod, the perceived wire), the
//! simulator's true rod, and named poses.

use std::collections::BTreeMap;

use msgs::geometry_msgs::PoseStamped;
use rerun::{AsComponents, CoordinateFrame, TransformAxes3D};

use crate::VizError;
use crate::convert::Pose;
use crate::site::{Body, RodBelief, Site};
use crate::urdf::Shape;

use super::shapes::{Part, along_y, body_parts, is_hook_goal, log_bodies};
use super::{
    DEFAULT_WIRE_RADIUS_M, POSE_AXES_M, ROD_FRAME, SIM, SIM_ROD_FRAME, SITE, TRUTH_RGBA, Viz,
    WIRE_DRAWN_LENGTH_M, WIRE_RGBA, frame_or, part, transform,
};

impl Viz {
    /// Draws the site as the robot knows it: the surveyed fixed bodies (static, in `map`, under
    /// `world/site/<name>`), and the rod (its parts static in [`ROD_FRAME`]) on the rack when
    /// the site knows where the stored rod stands. Keeps the site for the rod's belief and the
    /// wire's radius.
    ///
    /// # Errors
    /// [`VizError::Rerun`].
    pub fn log_site(&mut self, site: &Site) -> Result<(), VizError> {
        let mut groups: BTreeMap<String, Vec<Body>> = BTreeMap::new();
        for b in &site.fixed {
            let group = b.name.split('_').next().unwrap_or("site").to_owned();
            groups.entry(group).or_default().push(b.clone());
        }
        for (group, bodies) in &groups {
            let (parts, labels) = body_parts(bodies);
            log_bodies(
                &self.rec,
                &format!("{SITE}/{}", part(group)),
                msgs::frames::MAP,
                &parts,
                Some(&labels),
                true,
            )?;
        }
        let (parts, labels) = body_parts(&site.rod_parts);
        log_bodies(
            &self.rec,
            &format!("{SITE}/rod"),
            ROD_FRAME,
            &parts,
            Some(&labels),
            true,
        )?;
        self.site = Some(site.clone());
        if let Some(p) = site.map_from_stored_rod {
            let t = self.last_time_ns;
            self.set_time(t);
            self.set_rod(RodBelief {
                parent: msgs::frames::MAP.to_owned(),
                pose: p,
            })?;
        }
        Ok(())
    }

    pub(super) fn set_rod(&mut self, belief: RodBelief) -> Result<(), VizError> {
        self.rec.log(
            format!("{SITE}/rod"),
            &transform(&belief.parent, ROD_FRAME, &belief.pose),
        )?;
        self.rod = Some(belief);
        Ok(())
    }

    pub(super) fn wire_radius(&self) -> f32 {
        self.site
            .as_ref()
            .map(|s| s.wire_radius_m)
            .filter(|r| *r > 0.0)
            .unwrap_or(DEFAULT_WIRE_RADIUS_M)
    }

    /// The true rod at `/sim/handle_pose` (static parts under `sim/rod`, once).
    pub(super) fn draw_sim_rod(&mut self) -> Result<(), VizError> {
        if self.sim_rod_drawn {
            return Ok(());
        }
        let Some(site) = &self.site else {
            return Ok(());
        };
        self.sim_rod_drawn = true;
        let handle_from_rod = site.rod_from_handle.inverse();
        let parts: Vec<Part> = site
            .rod_parts
            .iter()
            .map(|b| (b.pose, b.shape, TRUTH_RGBA))
            .collect();
        self.rec.log_static(
            format!("{SIM}/rod"),
            &transform("sim/handle_pose", SIM_ROD_FRAME, &handle_from_rod),
        )?;
        log_bodies(
            &self.rec,
            &format!("{SIM}/rod"),
            SIM_ROD_FRAME,
            &parts,
            None,
            true,
        )
    }

    /// A hook goal becomes the perceived wire; a grasp the perceived rod (in `map`, at the
    /// time of the estimate).
    pub(super) fn log_perceived(&mut self, p: &PoseStamped) -> Result<(), VizError> {
        let frame = frame_or(&p.header.frame_id, msgs::frames::BASE_LINK);
        let Some(map_from_frame) = self.tf.lookup(msgs::frames::MAP, frame) else {
            return Ok(());
        };
        let target = map_from_frame.compose(&Pose::from_pose(&p.pose));
        if is_hook_goal(target.q) {
            let wire = Shape::Cylinder {
                radius_m: self.wire_radius(),
                length_m: WIRE_DRAWN_LENGTH_M,
            };
            let pose = Pose {
                t: target.t,
                q: along_y(target.q),
            };
            self.anchor(&format!("{SITE}/wire/cylinders"))?;
            log_bodies(
                &self.rec,
                &format!("{SITE}/wire"),
                msgs::frames::MAP,
                &[(pose, wire, WIRE_RGBA)],
                Some(&["wire (perceived)".to_owned()]),
                false,
            )?;
        } else if let Some(site) = &self.site
            && !self.rod.as_ref().is_some_and(RodBelief::held)
        {
            let pose = target.compose(&site.tool0_from_rod);
            self.set_rod(RodBelief {
                parent: msgs::frames::MAP.to_owned(),
                pose,
            })?;
        }
        Ok(())
    }

    /// A pose message as a named frame `frame_name` under its header frame, with axes.
    pub(super) fn log_pose(
        &mut self,
        entity: &str,
        p: &PoseStamped,
        frame_name: &str,
    ) -> Result<(), VizError> {
        let parent = frame_or(&p.header.frame_id, msgs::frames::BASE_LINK);
        self.log_named_pose(entity, parent, frame_name, &Pose::from_pose(&p.pose))
    }

    /// `frame_name` under `parent` at `pose`, with axes (named for the perception target only:
    /// the calibration's and the commands' names would crowd the robot).
    pub(super) fn log_named_pose(
        &mut self,
        entity: &str,
        parent: &str,
        frame_name: &str,
        pose: &Pose,
    ) -> Result<(), VizError> {
        self.rec.log(entity, &transform(parent, frame_name, pose))?;
        let named = frame_name.starts_with("perception/");
        let axes = format!("{entity}/axes");
        self.anchor(&axes)?;
        self.rec.log(
            axes,
            &[
                &CoordinateFrame::new(frame_name) as &dyn AsComponents,
                &TransformAxes3D::new(POSE_AXES_M).with_show_frame(named),
            ],
        )?;
        Ok(())
    }
}
