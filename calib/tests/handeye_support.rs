//! Shared synthetic-data helpers of the hand-eye tests (included with `#[path]`; as its own
//! test target it only checks that the generator is self-consistent).
#![allow(dead_code, reason = "each including test file uses a different subset")]
#![allow(missing_docs, reason = "test helpers")]
#![allow(
    clippy::unwrap_used,
    reason = "tests: a failed unwrap is a failed test"
)]

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

/// SplitMix64 + Box-Muller: seeded, dependency-free.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * ((self.next_u64() >> 11) as f64 / (1u64 << 53) as f64)
    }
    pub fn gauss(&mut self, sigma: f64) -> f64 {
        let u1 = self.uniform(f64::MIN_POSITIVE, 1.0);
        let u2 = self.uniform(0.0, 1.0);
        sigma * (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
    pub fn sign(&mut self) -> f64 {
        if self.uniform(-1.0, 1.0) >= 0.0 {
            1.0
        } else {
            -1.0
        }
    }
    pub fn unit(&mut self) -> Vector3<f64> {
        loop {
            let v = Vector3::new(
                self.uniform(-1., 1.),
                self.uniform(-1., 1.),
                self.uniform(-1., 1.),
            );
            let n = v.norm();
            if n > 0.1 && n <= 1.0 {
                return v / n;
            }
        }
    }
}

/// The asymmetric test X = tool0_from_camera: t = (0.05, 0.02, -0.08) m, 30 deg about the
/// skew axis (1, -2, 0.5).
pub fn true_x() -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(0.05, 0.02, -0.08),
        UnitQuaternion::from_scaled_axis(
            Vector3::new(1.0, -2.0, 0.5).normalize() * 30f64.to_radians(),
        ),
    )
}

/// A fixed world_from_base (board somewhere in front of the robot, rotated).
pub fn world_from_base() -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(-0.7, 0.3, 0.1),
        UnitQuaternion::from_scaled_axis(Vector3::new(0.2, 0.1, 1.3)),
    )
}

/// `n` random hand poses (base_from_tool0): rotations 10-60 deg about random axes,
/// translations in a 0.6 m box.
pub fn random_hand(rng: &mut Rng, n: usize) -> Vec<Isometry3<f64>> {
    (0..n)
        .map(|_| {
            let axis = rng.unit();
            Isometry3::from_parts(
                Translation3::new(
                    rng.uniform(0.3, 0.9),
                    rng.uniform(-0.3, 0.3),
                    rng.uniform(0.2, 0.8),
                ),
                UnitQuaternion::from_scaled_axis(axis * rng.uniform(10f64, 60.).to_radians()),
            )
        })
        .collect()
}

/// Eye poses world_from_camera = world_from_base * base_from_tool0 * X.
pub fn eye_of(hand: &[Isometry3<f64>], x: &Isometry3<f64>) -> Vec<Isometry3<f64>> {
    let w = world_from_base();
    hand.iter().map(|h| w * h * x).collect()
}

/// Right-multiplies a pose by a random perturbation (rotation sigma rad, translation sigma m).
pub fn perturb(
    rng: &mut Rng,
    p: &Isometry3<f64>,
    rot_sigma: f64,
    trans_sigma: f64,
) -> Isometry3<f64> {
    let d = Isometry3::from_parts(
        Translation3::new(
            rng.gauss(trans_sigma),
            rng.gauss(trans_sigma),
            rng.gauss(trans_sigma),
        ),
        UnitQuaternion::from_scaled_axis(Vector3::new(
            rng.gauss(rot_sigma),
            rng.gauss(rot_sigma),
            rng.gauss(rot_sigma),
        )),
    );
    p * d
}

/// (rotation error rad, translation error m) of an estimate.
pub fn errors(est: &Isometry3<f64>, truth: &Isometry3<f64>) -> (f64, f64) {
    let d = truth.rotation.inverse() * est.rotation;
    (
        d.angle(),
        (est.translation.vector - truth.translation.vector).norm(),
    )
}

#[test]
fn generator_is_consistent() {
    let mut rng = Rng(1);
    let hand = random_hand(&mut rng, 4);
    let x = true_x();
    let eye = eye_of(&hand, &x);
    // B X = X A for a pair.
    let b = hand[0].inverse() * hand[1];
    let a = eye[0].inverse() * eye[1];
    let d = (b * x).inverse() * (x * a);
    assert!(d.translation.vector.norm() < 1e-12 && d.rotation.angle() < 1e-12);
}

/// Board-pose (PnP-like) noise on an eye pose `world_from_camera`, as OpenCV's hand-eye test
/// applies it: `cam_from_world` gets `R <- exp(d) R` and `t <- t + e` (the board tilts about
/// its own origin as seen from the camera, the board origin's position in the camera barely
/// moves).
pub fn pnp_noise(
    rng: &mut Rng,
    world_from_cam: &Isometry3<f64>,
    rot_sigma: f64,
    trans_sigma: f64,
) -> Isometry3<f64> {
    let cam_from_world = world_from_cam.inverse();
    let d = UnitQuaternion::from_scaled_axis(Vector3::new(
        rng.gauss(rot_sigma),
        rng.gauss(rot_sigma),
        rng.gauss(rot_sigma),
    ));
    let t = cam_from_world.translation.vector
        + Vector3::new(
            rng.gauss(trans_sigma),
            rng.gauss(trans_sigma),
            rng.gauss(trans_sigma),
        );
    Isometry3::from_parts(Translation3::from(t), d * cam_from_world.rotation).inverse()
}
