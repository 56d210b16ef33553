//! TUM pose files (ARCHITECTURE.md section 5): one pose per line, `timestamp tx ty tz qx qy qz qw`, the
//! pose of the moving frame in the fixed frame (hand: `base_from_tool0`, eye:
//! `world_from_camera`). `#` starts a comment; blank lines are skipped. Parsing works on
//! text (no I/O); [`write_tum`] prints floats in their shortest round-trip form.

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};

/// Largest accepted deviation of a quaternion's norm from 1 (it is then normalised).
pub const QUATERNION_NORM_TOLERANCE: f64 = 1e-3;

/// Hand and eye poses paired by timestamp (`base_from_tool0`, `world_from_camera`).
pub type PairedPoses = (Vec<Isometry3<f64>>, Vec<Isometry3<f64>>);

/// A timestamped pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StampedPose {
    /// Timestamp as written (seconds, or an image index for folder datasets).
    pub timestamp: f64,
    /// `fixed_from_moving`.
    pub pose: Isometry3<f64>,
}

/// Why a pose file could not be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PoseFileError {
    /// A line does not have 8 fields.
    #[error("line {line}: expected 8 fields `timestamp tx ty tz qx qy qz qw`, found {found}")]
    FieldCount {
        /// 1-based line number.
        line: usize,
        /// Fields found.
        found: usize,
    },
    /// A field is not a number.
    #[error("line {line}: field {field} ({text:?}) is not a number")]
    NotANumber {
        /// 1-based line number.
        line: usize,
        /// 1-based field number.
        field: usize,
        /// The text.
        text: String,
    },
    /// A field is NaN or infinite.
    #[error("line {line}: field {field} is not finite ({value})")]
    NonFinite {
        /// 1-based line number.
        line: usize,
        /// 1-based field number.
        field: usize,
        /// The value.
        value: f64,
    },
    /// The quaternion is not (close to) unit.
    #[error("line {line}: quaternion norm {norm} is not 1 (tolerance {QUATERNION_NORM_TOLERANCE})")]
    NotUnitQuaternion {
        /// 1-based line number.
        line: usize,
        /// Its norm.
        norm: f64,
    },
    /// A timestamp occurs twice in one file.
    #[error("{file} poses: timestamp {timestamp} occurs twice (lines {first_line} and {line})")]
    DuplicateTimestamp {
        /// `hand` or `eye`.
        file: &'static str,
        /// The timestamp.
        timestamp: f64,
        /// Index of the first occurrence (0-based pose index).
        first_line: usize,
        /// Index of the second.
        line: usize,
    },
    /// A timestamp has no partner in the other file.
    #[error("timestamp {timestamp} is in the {present_in} poses but not in the {missing_in} poses")]
    UnpairedTimestamp {
        /// The timestamp.
        timestamp: f64,
        /// File that has it.
        present_in: &'static str,
        /// File that lacks it.
        missing_in: &'static str,
    },
}

/// Parses a TUM pose file's text.
///
/// # Errors
///
/// [`PoseFileError`] naming the 1-based line: wrong field count, a non-number, a
/// non-finite value, a quaternion whose norm is not within
/// [`QUATERNION_NORM_TOLERANCE`] of 1.
pub fn parse_tum(text: &str) -> Result<Vec<StampedPose>, PoseFileError> {
    let mut poses = Vec::new();
    for (index, raw) in text.lines().enumerate() {
        let line = index + 1;
        let content = raw.split('#').next().unwrap_or("").trim();
        if content.is_empty() {
            continue;
        }
        let fields: Vec<&str> = content.split_whitespace().collect();
        if fields.len() != 8 {
            return Err(PoseFileError::FieldCount {
                line,
                found: fields.len(),
            });
        }
        let mut v = [0.0f64; 8];
        for (k, (slot, text)) in v.iter_mut().zip(&fields).enumerate() {
            let value: f64 = text.parse().map_err(|_| PoseFileError::NotANumber {
                line,
                field: k + 1,
                text: (*text).to_owned(),
            })?;
            if !value.is_finite() {
                return Err(PoseFileError::NonFinite {
                    line,
                    field: k + 1,
                    value,
                });
            }
            *slot = value;
        }
        let [timestamp, tx, ty, tz, qx, qy, qz, qw] = v;
        let q = Quaternion::new(qw, qx, qy, qz);
        let norm = q.norm();
        if norm.is_nan() || (norm - 1.0).abs() > QUATERNION_NORM_TOLERANCE {
            return Err(PoseFileError::NotUnitQuaternion { line, norm });
        }
        poses.push(StampedPose {
            timestamp,
            pose: Isometry3::from_parts(
                Translation3::new(tx, ty, tz),
                UnitQuaternion::from_quaternion(q),
            ),
        });
    }
    Ok(poses)
}

/// Writes poses as TUM text (`timestamp tx ty tz qx qy qz qw`, shortest round-trip floats).
pub fn write_tum(poses: &[StampedPose]) -> String {
    let mut out = String::from("# timestamp tx ty tz qx qy qz qw\n");
    for p in poses {
        let t = p.pose.translation.vector;
        let q = p.pose.rotation.coords; // (x, y, z, w)
        out.push_str(&format!(
            "{} {} {} {} {} {} {} {}\n",
            p.timestamp, t.x, t.y, t.z, q.x, q.y, q.z, q.w
        ));
    }
    out
}

fn check_unique(poses: &[StampedPose], file: &'static str) -> Result<(), PoseFileError> {
    let mut order: Vec<usize> = (0..poses.len()).collect();
    order.sort_by(|&a, &b| {
        let (ta, tb) = (poses.get(a), poses.get(b));
        ta.map(|p| p.timestamp)
            .unwrap_or(0.0)
            .total_cmp(&tb.map(|p| p.timestamp).unwrap_or(0.0))
            .then(a.cmp(&b))
    });
    for w in order.windows(2) {
        if let [a, b] = w
            && let (Some(pa), Some(pb)) = (poses.get(*a), poses.get(*b))
            && pa.timestamp == pb.timestamp
        {
            return Err(PoseFileError::DuplicateTimestamp {
                file,
                timestamp: pa.timestamp,
                first_line: *a,
                line: *b,
            });
        }
    }
    Ok(())
}

/// Pairs hand and eye poses by equal timestamp, in the hand file's order.
///
/// # Errors
///
/// [`PoseFileError::DuplicateTimestamp`], and [`PoseFileError::UnpairedTimestamp`] naming
/// the first timestamp present in only one of the two files.
pub fn pair_by_timestamp(
    hand: &[StampedPose],
    eye: &[StampedPose],
) -> Result<PairedPoses, PoseFileError> {
    check_unique(hand, "hand")?;
    check_unique(eye, "eye")?;
    let mut hand_out = Vec::with_capacity(hand.len());
    let mut eye_out = Vec::with_capacity(hand.len());
    for h in hand {
        let Some(e) = eye.iter().find(|e| e.timestamp == h.timestamp) else {
            return Err(PoseFileError::UnpairedTimestamp {
                timestamp: h.timestamp,
                present_in: "hand",
                missing_in: "eye",
            });
        };
        hand_out.push(h.pose);
        eye_out.push(e.pose);
    }
    if let Some(e) = eye
        .iter()
        .find(|e| !hand.iter().any(|h| h.timestamp == e.timestamp))
    {
        return Err(PoseFileError::UnpairedTimestamp {
            timestamp: e.timestamp,
            present_in: "eye",
            missing_in: "hand",
        });
    }
    Ok((hand_out, eye_out))
}
