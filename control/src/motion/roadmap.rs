//! A joint-space path around obstacles, for the moves the fixed detours cannot make:
//! RRT-Connect (J. J. Kuffner and S. M. LaValle, "RRT-Connect: An efficient approach to
//! single-query path planning", ICRA 2000), then random shortcuts (R. Geraerts and
//! M. H. Overmars, "Creating high-quality paths for motion planning", IJRR 26(8), 2007).
//!
//! Two trees grow, from the start and from the goal. Each iteration draws a configuration
//! uniformly within the joint limits, extends one tree towards it by at most
//! [`RoadmapParams::step_rad`] (Euclidean in joint space), and then extends the other tree
//! towards the new node until it is reached or blocked; the trees swap roles every
//! iteration. An edge is free when every configuration along it, at most
//! [`RoadmapParams::check_rad`] apart in every joint, keeps the collision model's margins
//! ([`ArmCollisionModel::shortfall`]). The path found is shortened by
//! [`RoadmapParams::shortcuts`] random shortcuts, each kept when its edge is free.
//!
//! The draws come from a generator seeded by [`RoadmapParams::seed`], so the path is a
//! function of the inputs. The caller time-parameterises the via points and checks every
//! sample again ([`super::planner::plan_through`]): the edge checks here are a search aid,
//! not the safety check.

use super::collision::{ArmCollisionModel, CollisionWorld};

/// Search settings (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoadmapParams {
    /// Longest edge a tree grows by (rad, Euclidean over the six joints).
    pub step_rad: f64,
    /// Largest joint step between two checked configurations of an edge (rad): the held
    /// rod's head, 2.5 m out, moves 2.5 cm per 0.01 rad.
    pub check_rad: f64,
    /// Iterations before giving up.
    pub max_iterations: usize,
    /// Shortcut attempts on the path found.
    pub shortcuts: usize,
    /// Seed of the draws.
    pub seed: u64,
}

impl Default for RoadmapParams {
    fn default() -> Self {
        Self {
            step_rad: 0.3,
            check_rad: 0.01,
            max_iterations: 4000,
            shortcuts: 150,
            seed: 0x5EED_2000,
        }
    }
}

/// The world and robot an edge is checked against.
struct Space<'a> {
    collision: &'a ArmCollisionModel,
    world: &'a CollisionWorld,
    lift_m: f64,
    check_rad: f64,
}

impl Space<'_> {
    fn free(&self, q: &[f64; 6]) -> bool {
        self.collision
            .shortfall(self.world, self.lift_m, q)
            .is_none()
    }

    /// Every configuration from `a` to `b` (`a` itself assumed checked).
    fn edge_free(&self, a: &[f64; 6], b: &[f64; 6]) -> bool {
        let longest = (0..6).map(|j| (b[j] - a[j]).abs()).fold(0.0, f64::max);
        let steps = (longest / self.check_rad).ceil().max(1.0) as usize;
        (1..=steps).all(|k| self.free(&lerp(a, b, k as f64 / steps as f64)))
    }
}

fn lerp(a: &[f64; 6], b: &[f64; 6], t: f64) -> [f64; 6] {
    std::array::from_fn(|j| a[j] + (b[j] - a[j]) * t)
}

fn distance(a: &[f64; 6], b: &[f64; 6]) -> f64 {
    (0..6).map(|j| (b[j] - a[j]).powi(2)).sum::<f64>().sqrt()
}

/// A tree of configurations, each with its parent's index (the root's is its own).
struct Tree {
    nodes: Vec<([f64; 6], usize)>,
}

enum Growth {
    Reached,
    Advanced,
    Trapped,
}

impl Tree {
    fn rooted(q: [f64; 6]) -> Self {
        Self {
            nodes: vec![(q, 0)],
        }
    }

    fn nearest(&self, q: &[f64; 6]) -> usize {
        let mut best = (0, f64::INFINITY);
        for (i, (n, _)) in self.nodes.iter().enumerate() {
            let d = distance(n, q);
            if d < best.1 {
                best = (i, d);
            }
        }
        best.0
    }

    /// One step of at most `step_rad` from the nearest node towards `target`.
    fn extend(&mut self, space: &Space<'_>, target: &[f64; 6], step_rad: f64) -> Growth {
        let near = self.nearest(target);
        let Some(&(from, _)) = self.nodes.get(near) else {
            return Growth::Trapped;
        };
        let d = distance(&from, target);
        let (to, reached) = if d <= step_rad {
            (*target, true)
        } else {
            (lerp(&from, target, step_rad / d), false)
        };
        if !space.edge_free(&from, &to) {
            return Growth::Trapped;
        }
        self.nodes.push((to, near));
        if reached {
            Growth::Reached
        } else {
            Growth::Advanced
        }
    }

    /// Steps towards `target` until it is reached or blocked.
    fn connect(&mut self, space: &Space<'_>, target: &[f64; 6], step_rad: f64) -> Growth {
        loop {
            match self.extend(space, target, step_rad) {
                Growth::Advanced => {}
                other => return other,
            }
        }
    }

    /// The configurations from node `i` up to the root.
    fn to_root(&self, mut i: usize) -> Vec<[f64; 6]> {
        let mut out = Vec::new();
        while let Some(&(q, parent)) = self.nodes.get(i) {
            out.push(q);
            if parent == i {
                break;
            }
            i = parent;
        }
        out
    }
}

/// A collision-free joint path from `q_start` to `q_goal` at `lift_m` (module docs): the via
/// points after the start, the last being `q_goal`; `None` when the start or the goal is in
/// collision, or no path was found within the iterations.
#[must_use]
pub fn plan_around(
    collision: &ArmCollisionModel,
    world: &CollisionWorld,
    lift_m: f64,
    q_start: &[f64; 6],
    q_goal: &[f64; 6],
    params: &RoadmapParams,
) -> Option<Vec<[f64; 6]>> {
    let space = Space {
        collision,
        world,
        lift_m,
        check_rad: params.check_rad.max(1e-4),
    };
    if !space.free(q_start) || !space.free(q_goal) {
        return None;
    }
    let limits = &collision.model.arm_limits;
    let mut rng = rng::SplitMix64::new(params.seed);
    let mut trees = [Tree::rooted(*q_start), Tree::rooted(*q_goal)];
    let mut meeting = None;
    for iteration in 0..params.max_iterations {
        let q_rand: [f64; 6] =
            std::array::from_fn(|j| rng.uniform(limits[j].position_min, limits[j].position_max));
        // The trees swap roles every iteration.
        let from_start = iteration % 2 == 0;
        let [start_tree, goal_tree] = &mut trees;
        let (ta, tb) = if from_start {
            (start_tree, goal_tree)
        } else {
            (goal_tree, start_tree)
        };
        if matches!(ta.extend(&space, &q_rand, params.step_rad), Growth::Trapped) {
            continue;
        }
        let Some(&(q_new, _)) = ta.nodes.last() else {
            continue;
        };
        if matches!(tb.connect(&space, &q_new, params.step_rad), Growth::Reached) {
            // The new node of `ta` and the last node of `tb` are the same configuration.
            let (ia, ib) = (ta.nodes.len() - 1, tb.nodes.len() - 1);
            meeting = Some(if from_start { (ia, ib) } else { (ib, ia) });
            break;
        }
    }
    let (i_start, i_goal) = meeting?;
    let mut path = trees[0].to_root(i_start);
    path.reverse();
    path.extend(trees[1].to_root(i_goal).into_iter().skip(1));
    for _ in 0..params.shortcuts {
        if path.len() < 3 {
            break;
        }
        let n = path.len() as u64;
        let i = (rng.next_u64() % n) as usize;
        let j = (rng.next_u64() % n) as usize;
        let (i, j) = (i.min(j), i.max(j));
        if j > i + 1 && space.edge_free(&path[i], &path[j]) {
            path.drain(i + 1..j);
        }
    }
    path.remove(0);
    Some(path)
}

#[cfg(test)]
mod tests {
    use nalgebra::{Isometry3, Vector3};

    use super::*;
    use crate::motion::collision::OrientedBox;

    fn space_with<'a>(
        collision: &'a ArmCollisionModel,
        world: &'a CollisionWorld,
        lift_m: f64,
    ) -> Space<'a> {
        Space {
            collision,
            world,
            lift_m,
            check_rad: 0.01,
        }
    }

    fn post(at: Vector3<f64>, half_extents_m: Vector3<f64>) -> (String, OrientedBox) {
        (
            "post".to_owned(),
            OrientedBox {
                frame_from_box: Isometry3::translation(at.x, at.y, at.z),
                half_extents_m,
            },
        )
    }

    /// A post the direct joint move passes through, with room around it.
    #[test]
    fn finds_a_way_around_a_post_the_direct_move_crosses_and_is_repeatable() {
        let collision = ArmCollisionModel::nominal();
        let lift_m = 0.5;
        let q_start = [-1.2, -0.3, 1.6, 0.3, 1.57, 0.0];
        let q_goal = [1.2, -0.3, 1.6, 0.3, 1.57, 0.0];
        // The tool's tip at half the move.
        let tool = collision.capsules(lift_m, &lerp(&q_start, &q_goal, 0.5))[6].b;
        let mut world = CollisionWorld::default();
        world
            .boxes
            .push(post(tool.coords, Vector3::new(0.05, 0.05, 0.2)));
        let space = space_with(&collision, &world, lift_m);
        assert!(space.free(&q_start) && space.free(&q_goal));
        assert!(
            !space.edge_free(&q_start, &q_goal),
            "the direct move hits the post"
        );
        let params = RoadmapParams::default();
        let Some(path) = plan_around(&collision, &world, lift_m, &q_start, &q_goal, &params) else {
            panic!("no way around the post");
        };
        assert_eq!(path.last(), Some(&q_goal));
        let mut from = q_start;
        for q in &path {
            assert!(space.edge_free(&from, q), "{from:?} -> {q:?}");
            from = *q;
        }
        // A function of its inputs.
        assert_eq!(
            plan_around(&collision, &world, lift_m, &q_start, &q_goal, &params),
            Some(path)
        );
        // A plate through the tool at the start and the goal: no path, no panic.
        world
            .boxes
            .push(post(tool.coords, Vector3::new(3.0, 3.0, 0.02)));
        assert!(!space_with(&collision, &world, lift_m).free(&q_start));
        assert!(plan_around(&collision, &world, lift_m, &q_start, &q_goal, &params).is_none());
    }
}
