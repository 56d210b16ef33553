//! Joint limits: position range, maximum speed and maximum acceleration of one joint.

/// Limits of one joint, in the joint's unit (rad for revolute joints, m for prismatic ones).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointLimit {
    /// Lowest allowed position (rad or m).
    pub position_min: f64,
    /// Highest allowed position (rad or m).
    pub position_max: f64,
    /// Maximum speed magnitude (rad/s or m/s).
    pub velocity_max: f64,
    /// Maximum acceleration magnitude (rad/s^2 or m/s^2).
    pub acceleration_max: f64,
}

impl JointLimit {
    /// Whether `position` lies in `[position_min, position_max]` (NaN is never within).
    #[must_use]
    pub fn contains(&self, position: f64) -> bool {
        position >= self.position_min && position <= self.position_max
    }

    /// Every `position + k 2 pi` (integer k) inside the range, ascending. For a range narrower
    /// than 2 pi (the AUBO i10's +-175 deg) this is at most one value.
    #[must_use]
    pub fn revolute_equivalents(&self, position_rad: f64) -> Vec<f64> {
        use std::f64::consts::TAU;
        if !position_rad.is_finite()
            || !self.position_min.is_finite()
            || !self.position_max.is_finite()
        {
            return Vec::new();
        }
        let k_min = ((self.position_min - position_rad) / TAU).ceil();
        let k_max = ((self.position_max - position_rad) / TAU).floor();
        let mut out = Vec::new();
        let mut k = k_min;
        while k <= k_max {
            let candidate = position_rad + k * TAU;
            if self.contains(candidate) {
                out.push(candidate);
            }
            k += 1.0;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn equivalents_inside_narrow_and_wide_ranges() {
        let narrow = JointLimit {
            position_min: -175f64.to_radians(),
            position_max: 175f64.to_radians(),
            velocity_max: 1.0,
            acceleration_max: 1.0,
        };
        assert_eq!(narrow.revolute_equivalents(0.5), vec![0.5]);
        assert!(narrow.revolute_equivalents(179f64.to_radians()).is_empty());
        assert_eq!(narrow.revolute_equivalents(0.5 + 2.0 * PI).len(), 1);
        let wide = JointLimit {
            position_min: -2.0 * PI,
            position_max: 2.0 * PI,
            ..narrow
        };
        let eq = wide.revolute_equivalents(0.5);
        assert_eq!(eq.len(), 2);
        assert!((eq[0] - (0.5 - 2.0 * PI)).abs() < 1e-15 && (eq[1] - 0.5).abs() < 1e-15);
        assert!(wide.revolute_equivalents(f64::NAN).is_empty());
    }
}
