//! The robot clock: [`RobotTime`] and [`RobotDuration`], integer nanoseconds.
//!
//! Every `log_time`, `publish_time` and `header.stamp` rodlog writes comes from this clock
//! (ARCHITECTURE.md section 2). Time is an unsigned count of nanoseconds since the robot clock's
//! epoch (simulation: scenario start; hardware: the runtime's epoch, e.g. Unix time), so it
//! never runs backwards and `u64` lasts 584 years. Durations are unsigned too
//! (`RobotDuration`, `u64` ns): stage latencies, periods and timeouts are never negative;
//! differences that may be negative use [`RobotTime::checked_duration_since`].
//!
//! Conversions to `builtin_interfaces/Time` split `ns` into `sec = ns / 1e9` (must fit
//! `i32`, i.e. before 2038-01-19 for a Unix epoch) and `nanosec = ns mod 1e9`.

use std::fmt;
use std::ops::{Add, AddAssign};

use thiserror::Error;

use crate::builtin_interfaces::{Duration, Time};

const NS_PER_SEC: u64 = 1_000_000_000;

/// Errors converting robot-clock values.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum TimeError {
    /// The time or duration does not fit the `int32` seconds of a ROS message.
    #[error("{ns} ns is {} s, beyond the int32 seconds of builtin_interfaces (max {})", ns / NS_PER_SEC, i32::MAX)]
    OutOfRange {
        /// The value in nanoseconds.
        ns: u64,
    },
    /// A ROS time or duration is negative; the robot clock starts at 0.
    #[error("negative ROS time {sec} s + {nanosec} ns cannot be a robot-clock value")]
    Negative {
        /// Seconds field.
        sec: i32,
        /// Nanoseconds field.
        nanosec: u32,
    },
    /// `nanosec` is not below 1e9.
    #[error("nanosec {nanosec} is not in [0, 1e9)")]
    InvalidNanosec {
        /// Nanoseconds field.
        nanosec: u32,
    },
    /// A float number of seconds is negative, NaN or too large for `u64` nanoseconds.
    #[error("{secs} s is not a valid robot-clock value (must be finite, >= 0, < 1.8e10 s)")]
    InvalidSeconds {
        /// The value.
        secs: f64,
    },
}

fn secs_f64_to_ns(secs: f64) -> Result<u64, TimeError> {
    // u64::MAX ns = 1.8446744e10 s; the comparison is exact enough at this magnitude.
    if !(0.0..1.8e10).contains(&secs) {
        return Err(TimeError::InvalidSeconds { secs });
    }
    Ok((secs * 1e9).round() as u64)
}

fn ns_to_ros(ns: u64) -> Result<(i32, u32), TimeError> {
    let sec = i32::try_from(ns / NS_PER_SEC).map_err(|_| TimeError::OutOfRange { ns })?;
    Ok((sec, (ns % NS_PER_SEC) as u32))
}

fn ros_to_ns(sec: i32, nanosec: u32) -> Result<u64, TimeError> {
    if u64::from(nanosec) >= NS_PER_SEC {
        return Err(TimeError::InvalidNanosec { nanosec });
    }
    let Ok(sec) = u64::try_from(sec) else {
        return Err(TimeError::Negative { sec, nanosec });
    };
    Ok(sec * NS_PER_SEC + u64::from(nanosec))
}

/// A point on the robot clock: nanoseconds since its epoch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct RobotTime {
    ns: u64,
}

impl RobotTime {
    /// The epoch.
    pub const ZERO: Self = Self { ns: 0 };
    /// The latest representable time.
    pub const MAX: Self = Self { ns: u64::MAX };

    /// From nanoseconds since the epoch.
    pub const fn from_nanos(ns: u64) -> Self {
        Self { ns }
    }

    /// Nanoseconds since the epoch.
    pub const fn as_nanos(self) -> u64 {
        self.ns
    }

    /// From whole milliseconds since the epoch (saturating).
    pub const fn from_millis(ms: u64) -> Self {
        Self {
            ns: ms.saturating_mul(1_000_000),
        }
    }

    /// From seconds since the epoch, rounded to the nearest nanosecond.
    ///
    /// # Errors
    /// [`TimeError::InvalidSeconds`] for negative, NaN or too large values.
    pub fn from_secs_f64(secs: f64) -> Result<Self, TimeError> {
        secs_f64_to_ns(secs).map(Self::from_nanos)
    }

    /// Seconds since the epoch (f64: exact to the nanosecond for 104 days).
    pub fn as_secs_f64(self) -> f64 {
        self.ns as f64 * 1e-9
    }

    /// `self + d`, or `None` on overflow.
    pub fn checked_add(self, d: RobotDuration) -> Option<Self> {
        self.ns.checked_add(d.ns).map(Self::from_nanos)
    }

    /// `self - earlier`, or `None` if `earlier` is later than `self`.
    pub fn checked_duration_since(self, earlier: RobotTime) -> Option<RobotDuration> {
        self.ns
            .checked_sub(earlier.ns)
            .map(RobotDuration::from_nanos)
    }

    /// `self - earlier`, or zero if `earlier` is later.
    pub fn saturating_duration_since(self, earlier: RobotTime) -> RobotDuration {
        RobotDuration::from_nanos(self.ns.saturating_sub(earlier.ns))
    }

    /// `self - d`, or `None` before the epoch.
    pub fn checked_sub(self, d: RobotDuration) -> Option<Self> {
        self.ns.checked_sub(d.ns).map(Self::from_nanos)
    }

    /// As a ROS `builtin_interfaces/Time`.
    ///
    /// # Errors
    /// [`TimeError::OutOfRange`] beyond `i32::MAX` seconds.
    pub fn to_ros(self) -> Result<Time, TimeError> {
        let (sec, nanosec) = ns_to_ros(self.ns)?;
        Ok(Time { sec, nanosec })
    }

    /// From a ROS `builtin_interfaces/Time`.
    ///
    /// # Errors
    /// [`TimeError::Negative`], [`TimeError::InvalidNanosec`].
    pub fn from_ros(t: Time) -> Result<Self, TimeError> {
        ros_to_ns(t.sec, t.nanosec).map(Self::from_nanos)
    }
}

/// Saturating at [`RobotTime::MAX`] (584 years): never panics.
impl Add<RobotDuration> for RobotTime {
    type Output = RobotTime;
    fn add(self, d: RobotDuration) -> RobotTime {
        RobotTime::from_nanos(self.ns.saturating_add(d.ns))
    }
}

impl AddAssign<RobotDuration> for RobotTime {
    fn add_assign(&mut self, d: RobotDuration) {
        *self = *self + d;
    }
}

impl TryFrom<Time> for RobotTime {
    type Error = TimeError;
    fn try_from(t: Time) -> Result<Self, TimeError> {
        Self::from_ros(t)
    }
}

impl TryFrom<RobotTime> for Time {
    type Error = TimeError;
    fn try_from(t: RobotTime) -> Result<Self, TimeError> {
        t.to_ros()
    }
}

impl fmt::Display for RobotTime {
    /// `S.NNNNNNNNNs`, exact.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}.{:09}s", self.ns / NS_PER_SEC, self.ns % NS_PER_SEC)
    }
}

/// A non-negative span of robot time in nanoseconds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct RobotDuration {
    ns: u64,
}

impl RobotDuration {
    /// Zero.
    pub const ZERO: Self = Self { ns: 0 };

    /// From nanoseconds.
    pub const fn from_nanos(ns: u64) -> Self {
        Self { ns }
    }

    /// From microseconds (saturating).
    pub const fn from_micros(us: u64) -> Self {
        Self {
            ns: us.saturating_mul(1_000),
        }
    }

    /// From milliseconds (saturating).
    pub const fn from_millis(ms: u64) -> Self {
        Self {
            ns: ms.saturating_mul(1_000_000),
        }
    }

    /// From whole seconds (saturating).
    pub const fn from_secs(s: u64) -> Self {
        Self {
            ns: s.saturating_mul(NS_PER_SEC),
        }
    }

    /// From seconds, rounded to the nearest nanosecond.
    ///
    /// # Errors
    /// [`TimeError::InvalidSeconds`] for negative, NaN or too large values.
    pub fn from_secs_f64(secs: f64) -> Result<Self, TimeError> {
        secs_f64_to_ns(secs).map(Self::from_nanos)
    }

    /// Nanoseconds.
    pub const fn as_nanos(self) -> u64 {
        self.ns
    }

    /// Seconds as f64.
    pub fn as_secs_f64(self) -> f64 {
        self.ns as f64 * 1e-9
    }

    /// `self + other`, or `None` on overflow.
    pub fn checked_add(self, other: RobotDuration) -> Option<Self> {
        self.ns.checked_add(other.ns).map(Self::from_nanos)
    }

    /// As a ROS `builtin_interfaces/Duration`.
    ///
    /// # Errors
    /// [`TimeError::OutOfRange`] beyond `i32::MAX` seconds.
    pub fn to_ros(self) -> Result<Duration, TimeError> {
        let (sec, nanosec) = ns_to_ros(self.ns)?;
        Ok(Duration { sec, nanosec })
    }

    /// From a ROS `builtin_interfaces/Duration`.
    ///
    /// # Errors
    /// [`TimeError::Negative`], [`TimeError::InvalidNanosec`].
    pub fn from_ros(d: Duration) -> Result<Self, TimeError> {
        ros_to_ns(d.sec, d.nanosec).map(Self::from_nanos)
    }
}

/// Saturating at `u64::MAX` ns: never panics.
impl Add for RobotDuration {
    type Output = RobotDuration;
    fn add(self, other: RobotDuration) -> RobotDuration {
        RobotDuration::from_nanos(self.ns.saturating_add(other.ns))
    }
}

impl TryFrom<Duration> for RobotDuration {
    type Error = TimeError;
    fn try_from(d: Duration) -> Result<Self, TimeError> {
        Self::from_ros(d)
    }
}

impl TryFrom<RobotDuration> for Duration {
    type Error = TimeError;
    fn try_from(d: RobotDuration) -> Result<Self, TimeError> {
        d.to_ros()
    }
}

impl fmt::Display for RobotDuration {
    /// `S.NNNNNNNNNs`, exact.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}.{:09}s", self.ns / NS_PER_SEC, self.ns % NS_PER_SEC)
    }
}

impl From<std::time::Duration> for RobotDuration {
    /// Saturating at `u64::MAX` ns.
    fn from(d: std::time::Duration) -> Self {
        Self::from_nanos(u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
    }
}

impl From<RobotDuration> for std::time::Duration {
    fn from(d: RobotDuration) -> Self {
        std::time::Duration::from_nanos(d.ns)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ros_time_conversion_splits_seconds_and_nanoseconds() {
        let t = RobotTime::from_nanos(12_345_678_901);
        let ros = t.to_ros().expect("fits");
        assert_eq!(
            ros,
            Time {
                sec: 12,
                nanosec: 345_678_901
            }
        );
        assert_eq!(RobotTime::from_ros(ros), Ok(t));
        assert_eq!(t.to_string(), "12.345678901s");
    }

    #[test]
    fn ros_time_overflow_and_invalid_values_are_errors() {
        let max_ok = RobotTime::from_nanos(i32::MAX as u64 * NS_PER_SEC + 999_999_999);
        assert!(max_ok.to_ros().is_ok());
        let too_big = RobotTime::from_nanos((i32::MAX as u64 + 1) * NS_PER_SEC);
        assert_eq!(
            too_big.to_ros(),
            Err(TimeError::OutOfRange {
                ns: too_big.as_nanos()
            })
        );
        assert!(matches!(
            RobotTime::from_ros(Time {
                sec: -1,
                nanosec: 0
            }),
            Err(TimeError::Negative { sec: -1, .. })
        ));
        assert_eq!(
            RobotTime::from_ros(Time {
                sec: 0,
                nanosec: 1_000_000_000
            }),
            Err(TimeError::InvalidNanosec {
                nanosec: 1_000_000_000
            })
        );
        assert!(
            RobotDuration::from_ros(Duration {
                sec: -2,
                nanosec: 300_000_000
            })
            .is_err()
        );
    }

    #[test]
    fn float_seconds_round_to_nearest_nanosecond_and_reject_bad_values() {
        assert_eq!(
            RobotTime::from_secs_f64(1.5).map(RobotTime::as_nanos),
            Ok(1_500_000_000)
        );
        assert_eq!(
            RobotDuration::from_secs_f64(0.1).map(RobotDuration::as_nanos),
            Ok(100_000_000)
        );
        for bad in [-1e-9, f64::NAN, f64::INFINITY, 2e10] {
            assert!(RobotTime::from_secs_f64(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn arithmetic_saturates_and_orders() {
        let t = RobotTime::from_millis(100);
        let d = RobotDuration::from_millis(50);
        assert_eq!((t + d).as_nanos(), 150_000_000);
        assert_eq!(RobotTime::MAX + d, RobotTime::MAX);
        assert_eq!(RobotTime::MAX.checked_add(d), None);
        assert_eq!((t + d).checked_duration_since(t), Some(d));
        assert_eq!(t.checked_duration_since(t + d), None);
        assert_eq!(t.saturating_duration_since(t + d), RobotDuration::ZERO);
        assert_eq!(t.checked_sub(RobotDuration::from_secs(1)), None);
        assert!(t < t + d);
        let mut u = t;
        u += d;
        assert_eq!(u, t + d);
        assert_eq!(
            RobotDuration::from_secs(2).to_ros(),
            Ok(Duration { sec: 2, nanosec: 0 })
        );
        assert_eq!(
            std::time::Duration::from(RobotDuration::from_micros(3)),
            std::time::Duration::from_micros(3)
        );
    }
}
