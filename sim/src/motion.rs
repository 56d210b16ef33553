//! Speed- and acceleration-limited tracking of one axis, shared by the arm joints, the lift
//! and the clamp's lead screw.
//!
//! Each world tick `dt` the axis picks the velocity that still lets it stop on the goal,
//! `v_brake(e) = -a dt / 2 + sqrt(a^2 dt^2 / 4 + 2 a |e|)` (the discrete braking curve: the
//! distance covered while decelerating from `v` in steps of `a dt` is `v^2 / (2a) + v dt / 2`),
//! limits it to `v_lim`, and moves towards it by at most `a dt`:
//! `v_new = clamp(sign(e) min(v_lim, v_brake), v - a dt, v + a dt)`, `x += v_new dt`. It snaps
//! onto the goal when the last step would reach it with `|v| <= a dt`, or at rest within
//! [`SNAP_DISTANCE`] (so every move ends exactly on its goal). By construction
//! `|v| <= v_lim` and `|dv/dt| <= a` at every tick.
//!
//! Several axes moving together (the arm's joints) are synchronised: each joint's minimum
//! time `T_i` of a rest-to-rest trapezoid is computed, `T = max(T_i, requested)`, and joint
//! `i` runs with `v_lim = k v_max`, `a_lim = k^2 a_max`, `k = max(T_i / T, 0.05)` (a trapezoid
//! scaled in time by `1 / k`), so all arrive together (joints with tiny moves, floored at
//! [`MIN_SYNC_SCALE`], arrive early).

/// Errors at most this large (rad or m) are closed by snapping onto the goal at rest.
pub const SNAP_DISTANCE: f64 = 1e-12;

/// Smallest limit scale `k` of a synchronised axis.
pub const MIN_SYNC_SCALE: f64 = 0.05;

/// Minimum time (s) of a rest-to-rest move over `distance` with limits `v_max`, `a_max`.
#[must_use]
pub fn min_move_time_s(distance: f64, v_max: f64, a_max: f64) -> f64 {
    let d = distance.abs();
    if d == 0.0 || v_max <= 0.0 || a_max <= 0.0 {
        return 0.0;
    }
    if d <= v_max * v_max / a_max {
        2.0 * (d / a_max).sqrt()
    } else {
        d / v_max + v_max / a_max
    }
}

/// One tracked axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Axis {
    /// Position (rad or m).
    pub position: f64,
    /// Velocity (rad/s or m/s).
    pub velocity: f64,
    /// Goal.
    pub goal: f64,
    /// Speed limit of the current move.
    pub v_lim: f64,
    /// Acceleration limit of the current move.
    pub a_lim: f64,
}

impl Axis {
    /// At rest at `position`, with default limits.
    #[must_use]
    pub fn at_rest(position: f64, v_max: f64, a_max: f64) -> Self {
        Self {
            position,
            velocity: 0.0,
            goal: position,
            v_lim: v_max,
            a_lim: a_max,
        }
    }

    /// Whether it rests on its goal.
    #[must_use]
    pub fn settled(&self) -> bool {
        self.position == self.goal && self.velocity == 0.0
    }

    /// One tick of `dt_s`.
    pub fn step(&mut self, dt_s: f64) {
        let a = self.a_lim.max(0.0);
        let dv = a * dt_s;
        let e = self.goal - self.position;
        if e.abs() <= SNAP_DISTANCE && self.velocity.abs() <= dv {
            self.position = self.goal;
            self.velocity = 0.0;
            return;
        }
        let half = 0.5 * a * dt_s;
        let v_brake = -half + (half * half + 2.0 * a * e.abs()).sqrt();
        let v_des = e.signum() * self.v_lim.max(0.0).min(v_brake);
        let v_new = v_des.clamp(self.velocity - dv, self.velocity + dv);
        // At rest with no progress possible (rounding of v_brake for a tiny error): snap.
        let stuck = v_new == 0.0 && self.velocity == 0.0;
        if stuck
            || (v_new * dt_s).abs() >= e.abs()
                && self.velocity.abs() <= dv * (1.0 + 1e-9)
                && v_new * e >= 0.0
        {
            self.position = self.goal;
            self.velocity = 0.0;
        } else {
            self.position += v_new * dt_s;
            self.velocity = v_new;
        }
    }
}

/// Sets synchronised goals on `axes` (see the module docs); `requested_s` is the wanted
/// duration (0 = as fast as the limits allow). Returns the planned duration (s).
pub fn plan_synchronised(
    axes: &mut [Axis],
    goals: &[f64],
    limits: &[(f64, f64)],
    requested_s: f64,
) -> f64 {
    let times: Vec<f64> = axes
        .iter()
        .zip(goals)
        .zip(limits)
        .map(|((ax, g), (v, a))| min_move_time_s(g - ax.position, *v, *a))
        .collect();
    let t = times.iter().copied().fold(requested_s.max(0.0), f64::max);
    for (((ax, g), (v, a)), ti) in axes.iter_mut().zip(goals).zip(limits).zip(&times) {
        // Floors: an axis with a tiny move keeps usable limits (it simply arrives early),
        // and a moving axis keeps enough authority to brake from its current speed.
        let k = if t > 0.0 {
            (ti / t).clamp(MIN_SYNC_SCALE, 1.0)
        } else {
            1.0
        };
        let k = if ax.velocity != 0.0 { k.max(0.25) } else { k };
        ax.goal = *g;
        ax.v_lim = v * k;
        ax.a_lim = a * k * k;
        if ax.a_lim <= 0.0 {
            ax.a_lim = *a;
        }
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reaches_the_goal_within_limits_in_about_the_minimum_time() {
        let (v, a, dt) = (2.0, 5.0, 0.001);
        for goal in [1.5, -0.3, 0.01, 3.0] {
            let mut ax = Axis::at_rest(0.0, v, a);
            ax.goal = goal;
            let mut t = 0.0;
            let mut prev_v = 0.0;
            while !ax.settled() && t < 10.0 {
                ax.step(dt);
                t += dt;
                assert!(ax.velocity.abs() <= v + 1e-12);
                assert!((ax.velocity - prev_v).abs() <= a * dt * (1.0 + 1e-9));
                prev_v = ax.velocity;
            }
            assert_eq!(ax.position, goal);
            let tmin = min_move_time_s(goal, v, a);
            assert!(
                t >= tmin - 2.0 * dt && t <= tmin * 1.05 + 0.02,
                "goal {goal}: {t} vs {tmin}"
            );
        }
    }

    #[test]
    fn regression_tiny_moves_settle_exactly_and_in_time() {
        // 2 cm Cartesian steps gave joint moves of 1e-17..1e-3 rad next to large ones; the
        // arm never reported idle (an axis crawling with limits scaled to ~1e-12).
        for (i, tiny) in [1e-17, 3e-16, 1e-12, 1e-9, 1e-6, 1e-3]
            .into_iter()
            .enumerate()
        {
            let mut axes = [Axis::at_rest(0.3, 3.0, 5.0), Axis::at_rest(-0.2, 3.0, 5.0)];
            axes[1].velocity = if i % 2 == 0 { 0.0 } else { 1e-3 };
            let t = plan_synchronised(
                &mut axes,
                &[0.3 + tiny, 0.6],
                &[(3.0, 5.0), (3.0, 5.0)],
                0.0,
            );
            let mut n = 0;
            while axes.iter().any(|a| !a.settled()) && n < 10_000 {
                for a in &mut axes {
                    a.step(0.001);
                }
                n += 1;
            }
            assert!(
                axes.iter().all(Axis::settled),
                "move {tiny}: not settled after {n} ticks"
            );
            assert!(
                f64::from(n) * 0.001 <= t + 0.05,
                "move {tiny}: {n} ticks for a {t} s plan"
            );
            assert_eq!(axes[0].position, 0.3 + tiny);
        }
    }

    #[test]
    fn synchronised_axes_arrive_together() {
        let mut axes = [Axis::at_rest(0.0, 3.0, 5.0), Axis::at_rest(0.0, 3.0, 5.0)];
        let limits = [(3.0, 5.0), (3.0, 5.0)];
        let t = plan_synchronised(&mut axes, &[2.0, 0.2], &limits, 0.0);
        let mut arrival = [0.0_f64; 2];
        let mut time = 0.0;
        while axes.iter().any(|a| !a.settled()) && time < 10.0 {
            time += 0.001;
            for (i, a) in axes.iter_mut().enumerate() {
                a.step(0.001);
                if a.settled() && arrival[i] == 0.0 {
                    arrival[i] = time;
                }
            }
        }
        assert!(
            (arrival[0] - arrival[1]).abs() < 0.05 * t,
            "{arrival:?} planned {t}"
        );
    }
}
