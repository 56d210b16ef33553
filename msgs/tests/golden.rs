//! Golden bytes derived by hand from the CDR rules, big-endian decoding, rejected
//! encapsulations, the trailing-bytes policy and malformed input (never a panic).

mod common;

use msgs::builtin_interfaces::Time;
use msgs::cdr::CdrError;
use msgs::geometry_msgs::{Quaternion, Transform, TransformStamped, Vector3};
use msgs::sensor_msgs::JointState;
use msgs::std_msgs::{Empty, Header};
use msgs::{from_cdr, to_cdr};

fn header_abc() -> Header {
    Header {
        stamp: Time { sec: 1, nanosec: 2 },
        frame_id: "abc".into(),
    }
}

/// Payload offsets (after the 4-byte encapsulation header):
/// 0..4 sec = 1, 4..8 nanosec = 2, 8..12 frame_id length 4 ("abc" + NUL), 12..16 "abc\0".
const HEADER_ABC_LE: &[u8] = &[
    0x00, 0x01, 0x00, 0x00, // CDR_LE, options 0
    0x01, 0x00, 0x00, 0x00, // sec
    0x02, 0x00, 0x00, 0x00, // nanosec
    0x04, 0x00, 0x00, 0x00, // frame_id length incl. NUL
    b'a', b'b', b'c', 0x00, // frame_id
];

#[test]
fn header_golden() {
    assert_eq!(to_cdr(&header_abc()).expect("encode"), HEADER_ABC_LE);
    assert_eq!(
        from_cdr::<Header>(HEADER_ABC_LE).expect("decode"),
        header_abc()
    );
}

fn transform_stamped() -> TransformStamped {
    TransformStamped {
        header: Header {
            stamp: Time {
                sec: 10,
                nanosec: 20,
            },
            frame_id: "ab".into(),
        },
        child_frame_id: "tool0".into(),
        transform: Transform {
            translation: Vector3 {
                x: 1.0,
                y: -2.0,
                z: 0.5,
            },
            rotation: Quaternion::IDENTITY,
        },
    }
}

/// Payload offsets: 0 sec, 4 nanosec, 8 len 3, 12..15 "ab\0", 15 pad 1 (uint32 alignment),
/// 16 len 6, 20..26 "tool0\0", 26..32 pad 6 (float64 alignment is measured from the end of
/// the encapsulation header), 32 x, 40 y, 48 z, 56 qx, 64 qy, 72 qz, 80 qw, end at 88.
/// IEEE 754: 1.0 = 0x3FF0_0000_0000_0000, -2.0 = 0xC000.., 0.5 = 0x3FE0...
const TRANSFORM_STAMPED_LE: &[u8] = &[
    0x00, 0x01, 0x00, 0x00, // CDR_LE
    0x0a, 0x00, 0x00, 0x00, // sec 10
    0x14, 0x00, 0x00, 0x00, // nanosec 20
    0x03, 0x00, 0x00, 0x00, // frame_id length 3
    b'a', b'b', 0x00, 0x00, // "ab\0" + 1 pad
    0x06, 0x00, 0x00, 0x00, // child_frame_id length 6
    b't', b'o', b'o', b'l', b'0', 0x00, // "tool0\0"
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, // 6 pad to offset 32
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xf0, 0x3f, // x 1.0
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xc0, // y -2.0
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xe0, 0x3f, // z 0.5
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, // qx 0
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, // qy 0
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, // qz 0
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xf0, 0x3f, // qw 1.0
];

/// The same message big-endian (CDR_BE `00 00`): same offsets and padding, bytes reversed
/// within each primitive.
const TRANSFORM_STAMPED_BE: &[u8] = &[
    0x00, 0x00, 0x00, 0x00, // CDR_BE
    0x00, 0x00, 0x00, 0x0a, // sec 10
    0x00, 0x00, 0x00, 0x14, // nanosec 20
    0x00, 0x00, 0x00, 0x03, // frame_id length 3
    b'a', b'b', 0x00, 0x00, // "ab\0" + 1 pad
    0x00, 0x00, 0x00, 0x06, // child_frame_id length 6
    b't', b'o', b'o', b'l', b'0', 0x00, // "tool0\0"
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, // 6 pad
    0x3f, 0xf0, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, // x 1.0
    0xc0, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, // y -2.0
    0x3f, 0xe0, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, // z 0.5
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, // qx
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, // qy
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, // qz
    0x3f, 0xf0, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, // qw 1.0
];

#[test]
fn transform_stamped_golden() {
    assert_eq!(TRANSFORM_STAMPED_LE.len(), 4 + 88);
    assert_eq!(
        to_cdr(&transform_stamped()).expect("encode"),
        TRANSFORM_STAMPED_LE
    );
    assert_eq!(
        from_cdr::<TransformStamped>(TRANSFORM_STAMPED_LE).expect("decode"),
        transform_stamped()
    );
}

#[test]
fn big_endian_golden_decodes() {
    assert_eq!(
        from_cdr::<TransformStamped>(TRANSFORM_STAMPED_BE).expect("decode BE"),
        transform_stamped()
    );
}

fn joint_state() -> JointState {
    JointState {
        header: Header {
            stamp: Time { sec: 1, nanosec: 0 },
            frame_id: String::new(),
        },
        name: vec!["j1".into(), "j2".into()],
        position: vec![0.5, -1.0],
        velocity: vec![],
        effort: vec![2.0],
    }
}

/// Payload offsets: 0 sec, 4 nanosec, 8 len 1, 12 "\0", 13..16 pad, 16 name count 2,
/// 20 len 3, 24..27 "j1\0", 27 pad, 28 len 3, 32..35 "j2\0", 35 pad, 36 position count 2,
/// 40 0.5 (already 8-aligned), 48 -1.0, 56 velocity count 0, 60 effort count 1, 64 2.0,
/// end at 72.
const JOINT_STATE_LE: &[u8] = &[
    0x00, 0x01, 0x00, 0x00, // CDR_LE
    0x01, 0x00, 0x00, 0x00, // sec 1
    0x00, 0x00, 0x00, 0x00, // nanosec 0
    0x01, 0x00, 0x00, 0x00, // frame_id length 1 (empty string)
    0x00, 0x00, 0x00, 0x00, // NUL + 3 pad
    0x02, 0x00, 0x00, 0x00, // name count 2
    0x03, 0x00, 0x00, 0x00, // len 3
    b'j', b'1', 0x00, 0x00, // "j1\0" + 1 pad
    0x03, 0x00, 0x00, 0x00, // len 3
    b'j', b'2', 0x00, 0x00, // "j2\0" + 1 pad
    0x02, 0x00, 0x00, 0x00, // position count 2
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xe0, 0x3f, // 0.5
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xf0, 0xbf, // -1.0
    0x00, 0x00, 0x00, 0x00, // velocity count 0
    0x01, 0x00, 0x00, 0x00, // effort count 1
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x40, // 2.0
];

#[test]
fn joint_state_golden() {
    assert_eq!(JOINT_STATE_LE.len(), 4 + 72);
    assert_eq!(to_cdr(&joint_state()).expect("encode"), JOINT_STATE_LE);
    assert_eq!(
        from_cdr::<JointState>(JOINT_STATE_LE).expect("decode"),
        joint_state()
    );
}

#[test]
fn empty_golden() {
    // rosidl gives std_msgs/Empty one uint8 member `structure_needs_at_least_one_member`.
    assert_eq!(
        to_cdr(&Empty).expect("encode"),
        [0x00, 0x01, 0x00, 0x00, 0x00]
    );
    assert_eq!(from_cdr::<Empty>(&[0, 1, 0, 0, 0]).expect("decode"), Empty);
    // Big-endian, and with the 3 padding bytes RTPS adds.
    assert_eq!(
        from_cdr::<Empty>(&[0, 0, 0, 0, 0, 0, 0, 0]).expect("decode"),
        Empty
    );
}

#[test]
fn xcdr2_and_unknown_encapsulations_are_rejected() {
    for kind in 0x06..=0x0b_u8 {
        let mut bytes = HEADER_ABC_LE.to_vec();
        bytes[1] = kind;
        let err = from_cdr::<Header>(&bytes).expect_err("XCDR2");
        assert_eq!(err, CdrError::Xcdr2Encapsulation { b0: 0, b1: kind });
        assert!(err.to_string().contains(&format!("{kind:#04x}")), "{err}");
        assert!(err.to_string().contains("XCDR2"), "{err}");
    }
    for (b0, b1) in [(0x00, 0x02), (0x00, 0x03), (0x01, 0x01), (0xff, 0x00)] {
        let mut bytes = HEADER_ABC_LE.to_vec();
        bytes[0] = b0;
        bytes[1] = b1;
        let err = from_cdr::<Header>(&bytes).expect_err("unsupported");
        assert_eq!(err, CdrError::UnsupportedEncapsulation { b0, b1 });
    }
}

#[test]
fn options_bytes_are_ignored() {
    let mut bytes = HEADER_ABC_LE.to_vec();
    bytes[2] = 0x12;
    bytes[3] = 0x03;
    assert_eq!(from_cdr::<Header>(&bytes).expect("decode"), header_abc());
}

#[test]
fn every_prefix_of_every_sample_is_an_error_not_a_panic() {
    let mut checked = 0usize;
    for msg in common::samples() {
        let bytes = msg.encode().expect("encode");
        for len in 0..bytes.len() {
            let result = msgs::Msg::decode(msg.type_name(), &bytes[..len]);
            assert!(
                result.is_err(),
                "{} decoded from a {len}-byte prefix of {}",
                msg.type_name(),
                bytes.len()
            );
            checked += 1;
        }
    }
    for golden in [TRANSFORM_STAMPED_LE, TRANSFORM_STAMPED_BE] {
        for len in 0..golden.len() {
            let err = from_cdr::<TransformStamped>(&golden[..len]).expect_err("prefix");
            assert!(
                matches!(err, CdrError::Truncated { .. }),
                "prefix {len}: {err}"
            );
        }
    }
    assert!(checked > 1000);
}

#[test]
fn truncation_error_names_offset_and_size() {
    let err = from_cdr::<TransformStamped>(&TRANSFORM_STAMPED_LE[..40]).expect_err("cut");
    // Reading x at payload offset 26 (absolute 30) needs 6 pad + 8 bytes; 10 are left.
    assert_eq!(
        err,
        CdrError::Truncated {
            offset: 30,
            needed: 14,
            available: 10
        }
    );
}

#[test]
fn trailing_padding_policy() {
    for pad in 1..=3 {
        let mut bytes = HEADER_ABC_LE.to_vec();
        bytes.extend(std::iter::repeat_n(0u8, pad));
        assert_eq!(from_cdr::<Header>(&bytes).expect("padded"), header_abc());
    }
    let mut four = HEADER_ABC_LE.to_vec();
    four.extend([0u8; 4]);
    assert_eq!(
        from_cdr::<Header>(&four).expect_err("4 trailing"),
        CdrError::TrailingBytes {
            offset: 20,
            count: 4
        }
    );
    let mut nonzero = HEADER_ABC_LE.to_vec();
    nonzero.push(1);
    assert!(matches!(
        from_cdr::<Header>(&nonzero),
        Err(CdrError::TrailingBytes { count: 1, .. })
    ));
}

#[test]
fn malformed_strings_and_bools() {
    let mut no_nul = HEADER_ABC_LE.to_vec();
    no_nul[19] = b'd';
    assert_eq!(
        from_cdr::<Header>(&no_nul).expect_err("no NUL"),
        CdrError::MissingNul {
            offset: 16,
            len: 4,
            last: b'd'
        }
    );
    let mut bad_utf8 = HEADER_ABC_LE.to_vec();
    bad_utf8[16] = 0xff;
    assert!(matches!(
        from_cdr::<Header>(&bad_utf8),
        Err(CdrError::BadUtf8 {
            offset: 16,
            len: 4,
            ..
        })
    ));
    // PointCloud2 ends with `bool is_dense`.
    let mut cloud = to_cdr(&common::point_cloud2()).expect("encode");
    let last = cloud.len() - 1;
    cloud[last] = 2;
    assert_eq!(
        from_cdr::<msgs::sensor_msgs::PointCloud2>(&cloud).expect_err("bool 2"),
        CdrError::BadBool {
            offset: last,
            value: 2
        }
    );
}

#[test]
fn absurd_sequence_count_is_rejected_without_allocating() {
    let mut bytes = JOINT_STATE_LE.to_vec();
    bytes[20..24].copy_from_slice(&u32::MAX.to_le_bytes()); // name count
    assert!(matches!(
        from_cdr::<JointState>(&bytes),
        Err(CdrError::SequenceTooLong {
            count: 0xffff_ffff,
            ..
        })
    ));
    let mut bytes = HEADER_ABC_LE.to_vec();
    bytes[12..16].copy_from_slice(&u32::MAX.to_le_bytes()); // string length
    assert!(matches!(
        from_cdr::<Header>(&bytes),
        Err(CdrError::Truncated { .. })
    ));
}

#[test]
fn zero_length_string_is_accepted_as_empty() {
    // Some non-ROS DDS vendors write "" as length 0 without a NUL.
    let bytes = [0u8, 1, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0, 0, 0, 0, 0];
    assert_eq!(
        from_cdr::<Header>(&bytes).expect("decode"),
        Header {
            stamp: Time { sec: 1, nanosec: 2 },
            frame_id: String::new()
        }
    );
}
