//! Denavit-Hartenberg parameters (standard, "distal" convention) and forward kinematics of a
//! serial chain of revolute joints.
//!
//! Each row `i` (1-based in the literature, 0-based here) maps DH frame `i` into frame `i-1`:
//!
//! ```text
//! T_i(q_i) = Rz(q_i + offset_i) Tz(d_i) Tx(a_i) Rx(alpha_i)
//!
//!          = [ cθ  -sθ cα   sθ sα   a cθ ]
//!            [ sθ   cθ cα  -cθ sα   a sθ ]      θ = q_i + offset_i, α = alpha_i
//!            [ 0    sα      cα      d    ]
//!            [ 0    0       0       1    ]
//! ```
//!
//! and `base_from_frame_n = T_1 T_2 ... T_n` (Spong, Hutchinson & Vidyasagar, *Robot Modeling
//! and Control*, 2nd ed., eq. 3.10). Frame 0 is the arm base, frame n the flange.
//!
//! The moving body of joint `i` is also given a URDF-style *link frame* `L_i = F_{i-1} Rz(q_i +
//! offset_i)` (with `F_{i-1}` the DH frame `i-1`): it sits on joint `i`'s axis (its z) and turns
//! with the joint. The two are related by `F_i = L_i Tz(d_i) Tx(a_i) Rx(alpha_i)`, so a URDF
//! joint `i+1` has the fixed origin `Tz(d_i) Tx(a_i) Rx(alpha_i) Rz(offset_{i+1})` and axis z.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

/// One row of a standard DH table (metres, radians).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DhRow {
    /// Constant added to the joint angle: `theta_i = q_i + theta_offset_rad`.
    pub theta_offset_rad: f64,
    /// Offset along the previous z axis, metres.
    pub d_m: f64,
    /// Length along the new x axis, metres.
    pub a_m: f64,
    /// Twist about the new x axis, radians.
    pub alpha_rad: f64,
}

impl DhRow {
    /// `Tz(d) Tx(a) Rx(alpha)`: the part of the row that does not depend on the joint angle.
    #[must_use]
    pub fn fixed_part(&self) -> Isometry3<f64> {
        Isometry3::from_parts(
            Translation3::new(self.a_m, 0.0, self.d_m),
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), self.alpha_rad),
        )
    }

    /// `Rz(q + offset)`: the joint rotation, about the previous frame's z axis.
    #[must_use]
    pub fn joint_rotation(&self, q_rad: f64) -> Isometry3<f64> {
        Isometry3::from_parts(
            Translation3::identity(),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), q_rad + self.theta_offset_rad),
        )
    }

    /// `T_i(q) = Rz(q + offset) Tz(d) Tx(a) Rx(alpha)`: DH frame `i` in frame `i-1`.
    #[must_use]
    pub fn transform(&self, q_rad: f64) -> Isometry3<f64> {
        let theta = q_rad + self.theta_offset_rad;
        let (s, c) = theta.sin_cos();
        Isometry3::from_parts(
            Translation3::new(self.a_m * c, self.a_m * s, self.d_m),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), theta)
                * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), self.alpha_rad),
        )
    }
}

/// A 6-joint revolute chain in standard DH form.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DhTable {
    /// Rows 1..6 of the table (index 0 = joint 1).
    pub rows: [DhRow; 6],
}

impl DhTable {
    /// Flange pose: `frame0_from_frame6 = T_1(q_1) ... T_6(q_6)`.
    #[must_use]
    pub fn forward(&self, q_rad: &[f64; 6]) -> Isometry3<f64> {
        self.rows
            .iter()
            .zip(q_rad)
            .fold(Isometry3::identity(), |acc, (row, &q)| {
                acc * row.transform(q)
            })
    }

    /// All DH frames in frame 0: element `i` is `frame0_from_frame_i` (element 0 = identity,
    /// element 6 = the flange).
    #[must_use]
    pub fn dh_frames(&self, q_rad: &[f64; 6]) -> [Isometry3<f64>; 7] {
        let mut frames = [Isometry3::identity(); 7];
        let mut acc = Isometry3::identity();
        for (i, (row, &q)) in self.rows.iter().zip(q_rad).enumerate() {
            acc *= row.transform(q);
            frames[i + 1] = acc;
        }
        frames
    }

    /// The URDF-style link frames in frame 0: element `i` is `frame0_from_link_{i+1}` =
    /// `F_i Rz(q_{i+1} + offset_{i+1})`, the body turned by joint `i+1`, origin and z on its axis.
    #[must_use]
    pub fn link_frames(&self, q_rad: &[f64; 6]) -> [Isometry3<f64>; 6] {
        let mut links = [Isometry3::identity(); 6];
        let mut dh_frame = Isometry3::identity();
        for (i, (row, &q)) in self.rows.iter().zip(q_rad).enumerate() {
            links[i] = dh_frame * row.joint_rotation(q);
            dh_frame = links[i] * row.fixed_part();
        }
        links
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix4;

    /// The textbook DH matrix, written out element by element.
    fn dh_matrix(row: &DhRow, q: f64) -> Matrix4<f64> {
        let th = q + row.theta_offset_rad;
        let (st, ct) = th.sin_cos();
        let (sa, ca) = row.alpha_rad.sin_cos();
        Matrix4::new(
            ct,
            -st * ca,
            st * sa,
            row.a_m * ct, //
            st,
            ct * ca,
            -ct * sa,
            row.a_m * st, //
            0.0,
            sa,
            ca,
            row.d_m, //
            0.0,
            0.0,
            0.0,
            1.0,
        )
    }

    #[test]
    fn transform_matches_the_textbook_matrix_and_split_form() {
        let row = DhRow {
            theta_offset_rad: 0.3,
            d_m: 0.2,
            a_m: -0.5,
            alpha_rad: -1.1,
        };
        for q in [-2.0, -0.4, 0.0, 1.3, 3.0] {
            let m = row.transform(q).to_homogeneous();
            assert!((m - dh_matrix(&row, q)).amax() < 1e-15);
            let split = (row.joint_rotation(q) * row.fixed_part()).to_homogeneous();
            assert!((split - dh_matrix(&row, q)).amax() < 1e-15);
        }
    }

    #[test]
    fn forward_equals_the_hand_multiplied_product_for_random_joints() {
        let table = crate::aubo_i10::AUBO_I10_DH;
        // A deterministic low-discrepancy sweep of joint space (golden-ratio sequence).
        let golden = 0.618_033_988_749_895_f64;
        for n in 0..500 {
            let q: [f64; 6] = std::array::from_fn(|i| {
                let u = ((n * 6 + i) as f64 * golden).fract();
                (2.0 * u - 1.0) * 175f64.to_radians()
            });
            let product = table
                .rows
                .iter()
                .zip(&q)
                .fold(Matrix4::identity(), |acc, (row, &qi)| {
                    acc * dh_matrix(row, qi)
                });
            let fk = table.forward(&q).to_homogeneous();
            assert!((fk - product).amax() < 1e-14, "q = {q:?}");
        }
    }

    #[test]
    fn frames_agree_with_forward_and_links() {
        let table = crate::aubo_i10::AUBO_I10_DH;
        let q = [0.3, -1.2, 0.7, 2.0, -0.4, 1.1];
        let frames = table.dh_frames(&q);
        let links = table.link_frames(&q);
        let flange = table.forward(&q);
        assert!((frames[6].to_homogeneous() - flange.to_homogeneous()).amax() < 1e-15);
        for i in 0..6 {
            // F_{i+1} = L_{i+1} * fixed_part(i+1)
            let f = links[i] * table.rows[i].fixed_part();
            assert!((f.to_homogeneous() - frames[i + 1].to_homogeneous()).amax() < 1e-14);
        }
    }
}
