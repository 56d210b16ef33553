//! The latest transform of every TF edge, for composing chains the viewer draws itself
//! (the executed tool0 trajectory in `base_link`).
//!
//! Rerun composes the frames it displays on its own (each `/tf` edge is logged as a
//! `Transform3D` with parent and child frame names); this tree exists only because a
//! trajectory is a line through *past* poses, which Rerun does not accumulate. viz may not
//! depend on the robot crate's TF buffer (ARCHITECTURE.md section 1), and needs no interpolation
//! here: the executed path samples the chain at each `/tf` message.

use std::collections::BTreeMap;

use crate::convert::Pose;

/// Longest chain followed (guards against a cycle in malformed input).
const MAX_DEPTH: usize = 64;

/// `child -> (parent, parent_from_child)`, latest value per child frame.
#[derive(Debug, Clone, Default)]
pub struct TfTree {
    edges: BTreeMap<String, (String, Pose)>,
}

impl TfTree {
    /// An empty tree.
    pub fn new() -> Self {
        Self::default()
    }

    /// Sets the edge `parent_from_child` (replacing any earlier parent of `child`).
    pub fn set(&mut self, parent: &str, child: &str, parent_from_child: Pose) {
        self.edges
            .insert(child.to_owned(), (parent.to_owned(), parent_from_child));
    }

    /// Frames with a parent.
    pub fn len(&self) -> usize {
        self.edges.len()
    }

    /// True when no edge is known.
    pub fn is_empty(&self) -> bool {
        self.edges.is_empty()
    }

    /// `ancestor_from_frame`: the product of the edges from `frame` up to `ancestor`, or `None`
    /// when `ancestor` is not above `frame` (or an edge is missing).
    pub fn lookup(&self, ancestor: &str, frame: &str) -> Option<Pose> {
        let mut pose = Pose::IDENTITY;
        let mut current = frame;
        for _ in 0..MAX_DEPTH {
            if current == ancestor {
                return Some(pose);
            }
            let (parent, parent_from_current) = self.edges.get(current)?;
            pose = parent_from_current.compose(&pose);
            current = parent;
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shift(x: f64, y: f64, z: f64) -> Pose {
        Pose {
            t: [x, y, z],
            q: [0.0, 0.0, 0.0, 1.0],
        }
    }

    #[test]
    fn a_chain_composes_from_the_leaf_up() {
        let mut tf = TfTree::new();
        tf.set("base_link", "lift_link", shift(0.0, 0.0, 1.0));
        let s = std::f64::consts::FRAC_1_SQRT_2;
        tf.set(
            "lift_link",
            "arm_base_link",
            Pose {
                t: [0.5, 0.0, 0.0],
                q: [0.0, 0.0, s, s],
            },
        );
        tf.set("arm_base_link", "tool0", shift(1.0, 0.0, 0.0));
        let p = tf.lookup("base_link", "tool0").map(|p| p.t);
        let expect = [0.5, 1.0, 1.0];
        let got = p.unwrap_or([f64::NAN; 3]);
        for (g, e) in got.iter().zip(expect) {
            assert!((g - e).abs() < 1e-12, "{got:?}");
        }
        assert_eq!(tf.lookup("tool0", "tool0"), Some(Pose::IDENTITY));
        assert_eq!(tf.len(), 3);
    }

    #[test]
    fn unrelated_frames_and_cycles_give_none() {
        let mut tf = TfTree::new();
        tf.set("map", "base_link", shift(1.0, 0.0, 0.0));
        assert_eq!(tf.lookup("base_link", "map"), None);
        assert_eq!(tf.lookup("map", "tool0"), None);
        tf.set("a", "b", shift(0.0, 0.0, 0.0));
        tf.set("b", "a", shift(0.0, 0.0, 0.0));
        assert_eq!(tf.lookup("map", "a"), None);
    }
}
