//! [`LiveClock`]: the robot clock of a live run, read at the edge and handed to everything
//! else as [`RobotTime`].
//!
//! Two kinds:
//! - **wall**: robot time = wall time since the start, times a speed factor (a robot's own
//!   clock; `record --ros2` on hardware);
//! - **external**: robot time = the latest time some source announced ([`LiveClock::advance_to`]),
//!   e.g. the graph's `/clock` under ROS 2's `use_sim_time`. It never goes backwards: an
//!   earlier announcement is ignored.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use msgs::{RobotDuration, RobotTime};

#[derive(Debug)]
enum Kind {
    Wall { start: Instant, speed: u32 },
    External { now_ns: AtomicU64 },
}

/// The robot clock of a live run (module docs). Cheap to clone; clones share the clock.
#[derive(Debug, Clone)]
pub struct LiveClock(Arc<Kind>);

impl LiveClock {
    /// Robot time = wall time since now, times `speed` (at least 1).
    #[must_use]
    pub fn wall(speed: u32) -> Self {
        Self(Arc::new(Kind::Wall {
            start: Instant::now(),
            speed: speed.max(1),
        }))
    }

    /// Robot time = the latest [`LiveClock::advance_to`] (0 until the first).
    #[must_use]
    pub fn external() -> Self {
        Self(Arc::new(Kind::External {
            now_ns: AtomicU64::new(0),
        }))
    }

    /// Whether the clock follows announcements rather than the wall clock.
    #[must_use]
    pub fn is_external(&self) -> bool {
        matches!(*self.0, Kind::External { .. })
    }

    /// The robot time now.
    #[must_use]
    pub fn now(&self) -> RobotTime {
        match &*self.0 {
            Kind::Wall { start, speed } => {
                let elapsed = RobotDuration::from(start.elapsed());
                RobotTime::ZERO
                    + RobotDuration::from_nanos(
                        elapsed.as_nanos().saturating_mul(u64::from(*speed)),
                    )
            }
            Kind::External { now_ns } => RobotTime::from_nanos(now_ns.load(Ordering::Acquire)),
        }
    }

    /// Announces robot time `t` (external clocks; a wall clock ignores it). Earlier times
    /// than the current one are ignored, so the clock is monotonic.
    pub fn advance_to(&self, t: RobotTime) {
        if let Kind::External { now_ns } = &*self.0 {
            now_ns.fetch_max(t.as_nanos(), Ordering::AcqRel);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn external_clocks_only_move_forward() {
        let c = LiveClock::external();
        assert_eq!(c.now(), RobotTime::ZERO);
        c.advance_to(RobotTime::from_millis(300));
        c.advance_to(RobotTime::from_millis(200));
        assert_eq!(c.now(), RobotTime::from_millis(300));
        assert!(c.clone().is_external());
    }

    #[test]
    fn wall_clocks_run_at_their_speed() {
        let c = LiveClock::wall(50);
        c.advance_to(RobotTime::from_millis(1_000_000));
        std::thread::sleep(std::time::Duration::from_millis(20));
        let t = c.now();
        assert!(t >= RobotTime::from_millis(1000), "{t}");
        assert!(t < RobotTime::from_millis(1_000_000), "{t}");
    }
}
