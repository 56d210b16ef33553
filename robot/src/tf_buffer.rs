//! A TF buffer: the frame tree built from `/tf` and `/tf_static`, with time interpolation.
//!
//! Each edge `parent -> child` stores `parent_from_child`: fixed for static edges, a
//! time-ordered history of samples for dynamic ones. A child has exactly one parent (a tree, as
//! in tf2). `lookup(target, source, stamp_ns)` returns `target_from_source` by walking from both
//! frames up to their closest common ancestor:
//!
//! ```text
//! target_from_source = (common_from_target)^-1 common_from_source
//! common_from_x      = common_from_p_k ... p_1_from_x        (edges evaluated at stamp_ns)
//! ```
//!
//! A dynamic edge is evaluated by interpolating between the two samples bracketing the stamp
//! (translation lerp, rotation slerp: [`crate::se3::interpolate`]), as tf2's `BufferCore`
//! does. No extrapolation: a stamp outside an edge's buffered range is an error naming the edge,
//! the stamp and the range. History is bounded by a time window (default 10 s, tf2's default)
//! and a sample count per edge. All containers are ordered (`BTreeMap`, `VecDeque` sorted by
//! stamp), so results never depend on hash order.

use crate::conversions::isometry_from_msg;
use crate::se3::interpolate;
use msgs::RobotTime;
use msgs::tf2_msgs::TfMessage;
use nalgebra::Isometry3;
use std::collections::{BTreeMap, VecDeque};

/// Default history window per dynamic edge (ns): 10 s.
pub const DEFAULT_HISTORY_NS: u64 = 10_000_000_000;
/// Hard cap on samples kept per dynamic edge (bounds memory at high publishing rates).
pub const MAX_SAMPLES_PER_EDGE: usize = 100_000;

/// Why a transform could not be stored or looked up.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TfError {
    /// The frame appears in no stored edge.
    #[error("frame '{frame}' is unknown to the TF buffer")]
    UnknownFrame {
        /// The frame asked for.
        frame: String,
    },
    /// The two frames are in different trees.
    #[error(
        "no transform from '{source_frame}' to '{target_frame}': '{source_frame}' chains up to root '{source_root}' and '{target_frame}' to root '{target_root}'; an edge above one of these roots is missing"
    )]
    NotConnected {
        /// Target frame of the lookup.
        target_frame: String,
        /// Source frame of the lookup.
        source_frame: String,
        /// Topmost ancestor of the target.
        target_root: String,
        /// Topmost ancestor of the source.
        source_root: String,
    },
    /// The stamp is outside the buffered range of a dynamic edge.
    #[error(
        "edge '{parent}' -> '{child}': stamp {stamp_ns} ns is outside the buffered range [{oldest_ns}, {newest_ns}] ns"
    )]
    Extrapolation {
        /// Parent of the edge.
        parent: String,
        /// Child of the edge.
        child: String,
        /// Requested stamp.
        stamp_ns: u64,
        /// Oldest buffered sample.
        oldest_ns: u64,
        /// Newest buffered sample.
        newest_ns: u64,
    },
    /// A child frame was given a second, different parent.
    #[error("frame '{child}' already has parent '{parent}', refusing new parent '{new_parent}'")]
    Reparent {
        /// The child frame.
        child: String,
        /// Its stored parent.
        parent: String,
        /// The parent in the rejected transform.
        new_parent: String,
    },
    /// An edge was sent both as static and as dynamic.
    #[error("edge '{parent}' -> '{child}' is {stored} in the buffer but was sent as {sent}")]
    KindConflict {
        /// Parent of the edge.
        parent: String,
        /// Child of the edge.
        child: String,
        /// `static` or `dynamic`.
        stored: &'static str,
        /// `static` or `dynamic`.
        sent: &'static str,
    },
    /// The edge would close a loop in the tree (including `parent == child`).
    #[error("edge '{parent}' -> '{child}' would create a cycle")]
    Cycle {
        /// Parent of the rejected edge.
        parent: String,
        /// Child of the rejected edge.
        child: String,
    },
    /// The transform or its stamp is not usable (non-finite, not a unit quaternion, empty frame
    /// name, negative stamp).
    #[error("edge '{parent}' -> '{child}': {reason}")]
    Invalid {
        /// Parent of the rejected edge.
        parent: String,
        /// Child of the rejected edge.
        child: String,
        /// What is wrong.
        reason: String,
    },
    /// A dynamic sample older than the history window (relative to the edge's newest sample).
    #[error(
        "edge '{parent}' -> '{child}': sample at {stamp_ns} ns is older than the history window (newest {newest_ns} ns, window {history_ns} ns)"
    )]
    TooOld {
        /// Parent of the edge.
        parent: String,
        /// Child of the edge.
        child: String,
        /// The rejected sample's stamp.
        stamp_ns: u64,
        /// The edge's newest sample.
        newest_ns: u64,
        /// The buffer's history window.
        history_ns: u64,
    },
}

#[derive(Debug, Clone, PartialEq)]
enum EdgeData {
    Static(Isometry3<f64>),
    /// Samples sorted by stamp, unique stamps.
    Dynamic(VecDeque<(u64, Isometry3<f64>)>),
}

#[derive(Debug, Clone, PartialEq)]
struct Edge {
    parent: String,
    data: EdgeData,
}

/// Time-stamped transform tree with interpolation (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct TfBuffer {
    /// Keyed by child frame.
    edges: BTreeMap<String, Edge>,
    history_ns: u64,
}

impl Default for TfBuffer {
    fn default() -> Self {
        Self::new(DEFAULT_HISTORY_NS)
    }
}

impl TfBuffer {
    /// An empty buffer keeping `history_ns` of samples per dynamic edge (before its newest).
    #[must_use]
    pub fn new(history_ns: u64) -> Self {
        Self {
            edges: BTreeMap::new(),
            history_ns,
        }
    }

    /// The history window (ns).
    #[must_use]
    pub fn history_ns(&self) -> u64 {
        self.history_ns
    }

    /// Stores a static edge `parent_from_child` (replacing an earlier static value).
    ///
    /// # Errors
    /// [`TfError::Invalid`], [`TfError::Reparent`], [`TfError::KindConflict`],
    /// [`TfError::Cycle`]; the buffer is unchanged then.
    pub fn insert_static(
        &mut self,
        parent: &str,
        child: &str,
        parent_from_child: Isometry3<f64>,
    ) -> Result<(), TfError> {
        self.check_edge(parent, child, &parent_from_child, true)?;
        self.edges.insert(
            child.to_owned(),
            Edge {
                parent: parent.to_owned(),
                data: EdgeData::Static(parent_from_child),
            },
        );
        Ok(())
    }

    /// Stores a dynamic sample `parent_from_child` at `stamp_ns` (out-of-order samples are
    /// placed in order; a sample with an existing stamp replaces it), then drops samples older
    /// than the history window.
    ///
    /// # Errors
    /// As [`TfBuffer::insert_static`], and [`TfError::TooOld`] for a sample before the window.
    pub fn insert(
        &mut self,
        parent: &str,
        child: &str,
        stamp_ns: u64,
        parent_from_child: Isometry3<f64>,
    ) -> Result<(), TfError> {
        self.check_edge(parent, child, &parent_from_child, false)?;
        let history_ns = self.history_ns;
        let edge = self.edges.entry(child.to_owned()).or_insert_with(|| Edge {
            parent: parent.to_owned(),
            data: EdgeData::Dynamic(VecDeque::new()),
        });
        let EdgeData::Dynamic(samples) = &mut edge.data else {
            // check_edge rejected static edges already.
            return Err(TfError::KindConflict {
                parent: parent.to_owned(),
                child: child.to_owned(),
                stored: "static",
                sent: "dynamic",
            });
        };
        if let Some(&(newest_ns, _)) = samples.back()
            && stamp_ns < newest_ns.saturating_sub(history_ns)
        {
            return Err(TfError::TooOld {
                parent: parent.to_owned(),
                child: child.to_owned(),
                stamp_ns,
                newest_ns,
                history_ns,
            });
        }
        match samples.binary_search_by_key(&stamp_ns, |(s, _)| *s) {
            Ok(i) => {
                if let Some(slot) = samples.get_mut(i) {
                    slot.1 = parent_from_child;
                }
            }
            Err(i) => samples.insert(i, (stamp_ns, parent_from_child)),
        }
        if let Some(&(newest_ns, _)) = samples.back() {
            let cutoff = newest_ns.saturating_sub(history_ns);
            while samples.front().is_some_and(|(s, _)| *s < cutoff)
                || samples.len() > MAX_SAMPLES_PER_EDGE
            {
                samples.pop_front();
            }
        }
        Ok(())
    }

    fn check_edge(
        &self,
        parent: &str,
        child: &str,
        parent_from_child: &Isometry3<f64>,
        is_static: bool,
    ) -> Result<(), TfError> {
        let finite = parent_from_child
            .translation
            .vector
            .iter()
            .all(|v| v.is_finite())
            && parent_from_child
                .rotation
                .coords
                .iter()
                .all(|v| v.is_finite());
        if !finite || parent.is_empty() || child.is_empty() {
            let reason = if finite {
                "empty frame name"
            } else {
                "transform is not finite"
            };
            return Err(TfError::Invalid {
                parent: parent.to_owned(),
                child: child.to_owned(),
                reason: reason.to_owned(),
            });
        }
        if let Some(edge) = self.edges.get(child) {
            if edge.parent != parent {
                return Err(TfError::Reparent {
                    child: child.to_owned(),
                    parent: edge.parent.clone(),
                    new_parent: parent.to_owned(),
                });
            }
            let stored_static = matches!(edge.data, EdgeData::Static(_));
            if stored_static != is_static {
                let kind = |s: bool| if s { "static" } else { "dynamic" };
                return Err(TfError::KindConflict {
                    parent: parent.to_owned(),
                    child: child.to_owned(),
                    stored: kind(stored_static),
                    sent: kind(is_static),
                });
            }
            return Ok(());
        }
        // New edge: the parent's ancestry must not contain the child.
        let mut frame = parent;
        for _ in 0..=self.edges.len() {
            if frame == child {
                return Err(TfError::Cycle {
                    parent: parent.to_owned(),
                    child: child.to_owned(),
                });
            }
            match self.edges.get(frame) {
                Some(edge) => frame = &edge.parent,
                None => break,
            }
        }
        Ok(())
    }

    /// Inserts every transform of a `tf2_msgs/TFMessage` (from `/tf` when `is_static` is false,
    /// `/tf_static` when true), stamps converted from the ROS time to robot-clock nanoseconds.
    ///
    /// Returns the rejected transforms' errors, in message order; the others are stored.
    pub fn insert_message(&mut self, msg: &TfMessage, is_static: bool) -> Vec<TfError> {
        let mut errors = Vec::new();
        for t in &msg.transforms {
            let parent = t.header.frame_id.as_str();
            let child = t.child_frame_id.as_str();
            let invalid = |reason: String| TfError::Invalid {
                parent: parent.to_owned(),
                child: child.to_owned(),
                reason,
            };
            let result = match isometry_from_msg(&t.transform) {
                Err(e) => Err(invalid(e.to_string())),
                Ok(parent_from_child) if is_static => {
                    self.insert_static(parent, child, parent_from_child)
                }
                Ok(parent_from_child) => match RobotTime::from_ros(t.header.stamp) {
                    Err(e) => Err(invalid(e.to_string())),
                    Ok(stamp) => self.insert(parent, child, stamp.as_nanos(), parent_from_child),
                },
            };
            if let Err(e) = result {
                errors.push(e);
            }
        }
        errors
    }

    /// Whether `frame` is the parent or child of any stored edge.
    #[must_use]
    pub fn has_frame(&self, frame: &str) -> bool {
        self.edges.contains_key(frame) || self.edges.values().any(|e| e.parent == frame)
    }

    /// All known frames, sorted.
    #[must_use]
    pub fn frames(&self) -> Vec<String> {
        let mut all: std::collections::BTreeSet<&str> =
            self.edges.keys().map(String::as_str).collect();
        all.extend(self.edges.values().map(|e| e.parent.as_str()));
        all.into_iter().map(str::to_owned).collect()
    }

    /// The parent of `frame`, if it has one.
    #[must_use]
    pub fn parent_of(&self, frame: &str) -> Option<&str> {
        self.edges.get(frame).map(|e| e.parent.as_str())
    }

    /// The buffered range `[oldest_ns, newest_ns]` of the dynamic edge whose child is `child`
    /// (`None` for static or unknown edges).
    #[must_use]
    pub fn range_ns(&self, child: &str) -> Option<(u64, u64)> {
        match &self.edges.get(child)?.data {
            EdgeData::Static(_) => None,
            EdgeData::Dynamic(s) => Some((s.front()?.0, s.back()?.0)),
        }
    }

    /// `frame`, its parent, grandparent, ... up to the root.
    fn ancestry<'a>(&'a self, frame: &'a str) -> Vec<&'a str> {
        let mut chain = vec![frame];
        let mut current = frame;
        // The tree has no cycles (checked at insert); the bound is a belt-and-braces guard.
        for _ in 0..=self.edges.len() {
            match self.edges.get(current) {
                Some(edge) => {
                    current = &edge.parent;
                    chain.push(current);
                }
                None => break,
            }
        }
        chain
    }

    /// The path `source -> ... -> common` and `target -> ... -> common` (each starting at the
    /// frame itself and ending at the closest common ancestor).
    fn path<'a>(
        &'a self,
        target_frame: &'a str,
        source_frame: &'a str,
    ) -> Result<(Vec<&'a str>, Vec<&'a str>), TfError> {
        for frame in [target_frame, source_frame] {
            if !self.has_frame(frame) {
                return Err(TfError::UnknownFrame {
                    frame: frame.to_owned(),
                });
            }
        }
        let mut up_source = self.ancestry(source_frame);
        let mut up_target = self.ancestry(target_frame);
        let Some(common_pos_in_target) = up_target.iter().position(|f| up_source.contains(f))
        else {
            return Err(TfError::NotConnected {
                target_frame: target_frame.to_owned(),
                source_frame: source_frame.to_owned(),
                target_root: up_target.last().copied().unwrap_or(target_frame).to_owned(),
                source_root: up_source.last().copied().unwrap_or(source_frame).to_owned(),
            });
        };
        up_target.truncate(common_pos_in_target + 1);
        let common = up_target.last().copied().unwrap_or(target_frame);
        if let Some(pos) = up_source.iter().position(|f| *f == common) {
            up_source.truncate(pos + 1);
        }
        Ok((up_source, up_target))
    }

    /// `parent_from_child` of the edge above `child`, evaluated at `stamp_ns`.
    fn edge_at(&self, child: &str, stamp_ns: u64) -> Result<Isometry3<f64>, TfError> {
        let Some(edge) = self.edges.get(child) else {
            return Err(TfError::UnknownFrame {
                frame: child.to_owned(),
            });
        };
        let samples = match &edge.data {
            EdgeData::Static(t) => return Ok(*t),
            EdgeData::Dynamic(samples) => samples,
        };
        let extrapolation = || TfError::Extrapolation {
            parent: edge.parent.clone(),
            child: child.to_owned(),
            stamp_ns,
            oldest_ns: samples.front().map_or(0, |s| s.0),
            newest_ns: samples.back().map_or(0, |s| s.0),
        };
        match samples.binary_search_by_key(&stamp_ns, |(s, _)| *s) {
            Ok(i) => samples.get(i).map(|s| s.1).ok_or_else(extrapolation),
            Err(i) => {
                let (Some(before), Some(after)) = (
                    i.checked_sub(1).and_then(|j| samples.get(j)),
                    samples.get(i),
                ) else {
                    return Err(extrapolation());
                };
                let fraction = (stamp_ns - before.0) as f64 / (after.0 - before.0) as f64;
                Ok(interpolate(&before.1, &after.1, fraction))
            }
        }
    }

    /// `common_from_frame` along a path `frame -> ... -> common`.
    fn compose_up(&self, path: &[&str], stamp_ns: u64) -> Result<Isometry3<f64>, TfError> {
        let mut common_from_frame = Isometry3::identity();
        // path[k] -> path[k+1] is the edge above path[k]; left-multiply going up.
        for child in path.iter().take(path.len().saturating_sub(1)) {
            common_from_frame = self.edge_at(child, stamp_ns)? * common_from_frame;
        }
        Ok(common_from_frame)
    }

    /// `target_from_source` at `stamp_ns` (maps points in `source_frame` to `target_frame`).
    ///
    /// # Errors
    /// [`TfError::UnknownFrame`], [`TfError::NotConnected`] (names both roots), or
    /// [`TfError::Extrapolation`] for the first edge on the path whose buffered range does not
    /// contain the stamp.
    pub fn lookup(
        &self,
        target_frame: &str,
        source_frame: &str,
        stamp_ns: u64,
    ) -> Result<Isometry3<f64>, TfError> {
        if target_frame == source_frame {
            return Ok(Isometry3::identity());
        }
        let (up_source, up_target) = self.path(target_frame, source_frame)?;
        let common_from_source = self.compose_up(&up_source, stamp_ns)?;
        let common_from_target = self.compose_up(&up_target, stamp_ns)?;
        Ok(common_from_target.inverse() * common_from_source)
    }

    /// The latest stamp at which every dynamic edge between the two frames has data: the
    /// minimum of their newest stamps (`None` when the path has only static edges).
    ///
    /// # Errors
    /// [`TfError::UnknownFrame`], [`TfError::NotConnected`].
    pub fn latest_common_stamp_ns(
        &self,
        target_frame: &str,
        source_frame: &str,
    ) -> Result<Option<u64>, TfError> {
        if target_frame == source_frame {
            return Ok(None);
        }
        let (up_source, up_target) = self.path(target_frame, source_frame)?;
        let edges = up_source
            .iter()
            .take(up_source.len().saturating_sub(1))
            .chain(up_target.iter().take(up_target.len().saturating_sub(1)));
        Ok(edges
            .filter_map(|child| self.range_ns(child).map(|(_, newest)| newest))
            .min())
    }

    /// `target_from_source` at [`TfBuffer::latest_common_stamp_ns`] (like tf2's time 0),
    /// with that stamp (0 when only static edges are involved).
    ///
    /// # Errors
    /// As [`TfBuffer::lookup`].
    pub fn lookup_latest(
        &self,
        target_frame: &str,
        source_frame: &str,
    ) -> Result<(u64, Isometry3<f64>), TfError> {
        let stamp_ns = self
            .latest_common_stamp_ns(target_frame, source_frame)?
            .unwrap_or(0);
        Ok((stamp_ns, self.lookup(target_frame, source_frame, stamp_ns)?))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::se3::rotation_angle_between_rad;
    use nalgebra::{Translation3, UnitQuaternion, Vector3};

    fn rz(angle: f64, t: [f64; 3]) -> Isometry3<f64> {
        Isometry3::from_parts(
            Translation3::new(t[0], t[1], t[2]),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), angle),
        )
    }

    fn assert_close(a: &Isometry3<f64>, b: &Isometry3<f64>) {
        let dt = (a.translation.vector - b.translation.vector).norm();
        let dr = rotation_angle_between_rad(&a.rotation, &b.rotation);
        assert!(dt < 1e-12 && dr < 1e-12, "{a} vs {b}: {dt:e} {dr:e}");
    }

    /// map -> base (dynamic), base -> lift (dynamic), lift -> arm (static), base -> pano (static).
    fn tree() -> TfBuffer {
        let mut tf = TfBuffer::default();
        tf.insert("map", "base", 1_000, rz(0.0, [0.0, 0.0, 0.0]))
            .expect("ok");
        tf.insert("map", "base", 3_000, rz(1.0, [2.0, 0.0, 0.0]))
            .expect("ok");
        tf.insert("base", "lift", 0, rz(0.0, [0.0, 0.0, 0.5]))
            .expect("ok");
        tf.insert("base", "lift", 10_000, rz(0.0, [0.0, 0.0, 1.5]))
            .expect("ok");
        tf.insert_static("lift", "arm", rz(0.2, [0.1, 0.0, 0.03]))
            .expect("ok");
        tf.insert_static("base", "pano", rz(-0.3, [0.35, 0.0, 0.9]))
            .expect("ok");
        tf
    }

    #[test]
    fn chain_lookup_up_and_down_with_interpolation() {
        let tf = tree();
        let stamp = 2_000;
        let map_from_base = rz(0.5, [1.0, 0.0, 0.0]);
        let base_from_lift = rz(0.0, [0.0, 0.0, 0.7]);
        let lift_from_arm = rz(0.2, [0.1, 0.0, 0.03]);
        let base_from_pano = rz(-0.3, [0.35, 0.0, 0.9]);
        let map_from_arm = tf.lookup("map", "arm", stamp).expect("connected");
        assert_close(
            &map_from_arm,
            &(map_from_base * base_from_lift * lift_from_arm),
        );
        // Down one branch and up another: pano_from_arm through base.
        let pano_from_arm = tf.lookup("pano", "arm", stamp).expect("connected");
        assert_close(
            &pano_from_arm,
            &(base_from_pano.inverse() * base_from_lift * lift_from_arm),
        );
        let arm_from_pano = tf.lookup("arm", "pano", stamp).expect("connected");
        assert_close(&arm_from_pano, &pano_from_arm.inverse());
        assert_close(
            &tf.lookup("arm", "arm", 7).expect("identity"),
            &Isometry3::identity(),
        );
        // Exact samples are returned as stored.
        assert_close(
            &tf.lookup("map", "base", 3_000).expect("ok"),
            &rz(1.0, [2.0, 0.0, 0.0]),
        );
    }

    #[test]
    fn out_of_range_and_missing_edges_are_named() {
        let tf = tree();
        match tf.lookup("map", "arm", 3_001) {
            Err(TfError::Extrapolation {
                parent,
                child,
                stamp_ns,
                oldest_ns,
                newest_ns,
            }) => {
                assert_eq!((parent.as_str(), child.as_str()), ("map", "base"));
                assert_eq!((stamp_ns, oldest_ns, newest_ns), (3_001, 1_000, 3_000));
            }
            other => panic!("expected Extrapolation, got {other:?}"),
        }
        let err = tf.lookup("map", "base", 999).expect_err("before the range");
        assert!(err.to_string().contains("[1000, 3000]"), "{err}");
        // Static-only paths work at any stamp.
        assert!(tf.lookup("lift", "arm", u64::MAX).is_ok());
        assert_eq!(
            tf.lookup("camera", "arm", 2_000),
            Err(TfError::UnknownFrame {
                frame: "camera".into()
            })
        );
        let mut tf = tf;
        tf.insert("tool0", "camera", 2_000, Isometry3::identity())
            .expect("ok");
        match tf.lookup("map", "camera", 2_000) {
            Err(TfError::NotConnected {
                target_root,
                source_root,
                ..
            }) => {
                assert_eq!(
                    (target_root.as_str(), source_root.as_str()),
                    ("map", "tool0")
                );
            }
            other => panic!("expected NotConnected, got {other:?}"),
        }
    }

    #[test]
    fn insert_rejects_bad_edges() {
        let mut tf = tree();
        assert!(matches!(
            tf.insert("map", "lift", 5, Isometry3::identity()),
            Err(TfError::Reparent { .. })
        ));
        assert!(matches!(
            tf.insert("lift", "arm", 5, Isometry3::identity()),
            Err(TfError::KindConflict { .. })
        ));
        assert!(matches!(
            tf.insert("arm", "map", 5, Isometry3::identity()),
            Err(TfError::Cycle { .. })
        ));
        assert!(matches!(
            tf.insert("x", "x", 5, Isometry3::identity()),
            Err(TfError::Cycle { .. })
        ));
        let nan = Isometry3::translation(f64::NAN, 0.0, 0.0);
        assert!(matches!(
            tf.insert("arm", "tool", 5, nan),
            Err(TfError::Invalid { .. })
        ));
        assert!(!tf.has_frame("tool"));
    }

    #[test]
    fn history_is_bounded_and_out_of_order_is_sorted() {
        let mut tf = TfBuffer::new(1_000);
        for stamp in [500u64, 100, 300, 1_200, 1_400] {
            tf.insert(
                "a",
                "b",
                stamp,
                Isometry3::translation(stamp as f64, 0.0, 0.0),
            )
            .expect("ok");
        }
        // Window [400, 1400]: 100 and 300 evicted.
        assert_eq!(tf.range_ns("b"), Some((500, 1_400)));
        let mid = tf.lookup("a", "b", 850).expect("inside");
        assert!((mid.translation.x - 850.0).abs() < 1e-9);
        assert!(matches!(
            tf.insert("a", "b", 10, Isometry3::identity()),
            Err(TfError::TooOld { .. })
        ));
        let (stamp, latest) = tf.lookup_latest("a", "b").expect("ok");
        assert_eq!(stamp, 1_400);
        assert!((latest.translation.x - 1_400.0).abs() < 1e-12);
    }

    #[test]
    fn messages_are_inserted_and_bad_ones_reported() {
        use crate::conversions::transform_stamped;
        use msgs::builtin_interfaces::Time;
        let mut tf = TfBuffer::default();
        let stamp = Time {
            sec: 2,
            nanosec: 500,
        };
        let mut msg = TfMessage {
            transforms: vec![
                transform_stamped("map", "base", stamp, &rz(0.3, [1.0, 0.0, 0.0])),
                transform_stamped("base", "lift", stamp, &rz(0.0, [0.0, 0.0, 0.6])),
            ],
        };
        let mut bad = transform_stamped("lift", "arm", stamp, &Isometry3::identity());
        bad.transform.rotation.w = 0.5;
        msg.transforms.push(bad);
        let errors = tf.insert_message(&msg, false);
        assert_eq!(errors.len(), 1);
        assert!(
            matches!(&errors[0], TfError::Invalid { child, .. } if child == "arm"),
            "{errors:?}"
        );
        let map_from_lift = tf.lookup("map", "lift", 2_000_000_500).expect("stored");
        assert_close(
            &map_from_lift,
            &(rz(0.3, [1.0, 0.0, 0.0]) * rz(0.0, [0.0, 0.0, 0.6])),
        );
        let statics = TfMessage {
            transforms: vec![transform_stamped(
                "lift",
                "arm",
                Time::default(),
                &rz(0.1, [0.0; 3]),
            )],
        };
        assert!(tf.insert_message(&statics, true).is_empty());
        assert!(tf.lookup("map", "arm", 2_000_000_500).is_ok());
    }

    #[test]
    fn interpolation_slerps_rotation() {
        let mut tf = TfBuffer::default();
        tf.insert("a", "b", 0, rz(0.0, [0.0; 3])).expect("ok");
        tf.insert("a", "b", 100, rz(1.0, [1.0, 2.0, 3.0]))
            .expect("ok");
        let q = tf.lookup("a", "b", 25).expect("ok");
        assert_close(&q, &rz(0.25, [0.25, 0.5, 0.75]));
    }
}
