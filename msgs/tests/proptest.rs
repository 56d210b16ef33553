//! Property tests: random strings, arrays and floats (NaN, infinities, subnormals, -0.0)
//! round trip bit-exactly.

use msgs::builtin_interfaces::Time;
use msgs::geometry_msgs::{Quaternion, Transform, TransformStamped, Vector3};
use msgs::rodlog_msgs::FeatureMatches;
use msgs::sensor_msgs::{Image, JointState};
use msgs::std_msgs::Header;
use msgs::{Msg, from_cdr, to_cdr};
use proptest::prelude::*;

fn f64_any() -> impl Strategy<Value = f64> {
    prop_oneof![
        any::<f64>(),
        Just(f64::NAN),
        Just(f64::from_bits(0xfff8_0000_0000_0001)), // negative NaN with payload
        Just(-0.0),
        Just(f64::INFINITY),
        Just(f64::from_bits(1)), // smallest subnormal
    ]
}

fn f32_any() -> impl Strategy<Value = f32> {
    prop_oneof![any::<f32>(), Just(f32::NAN), Just(-0.0f32)]
}

fn header() -> impl Strategy<Value = Header> {
    (any::<i32>(), 0u32..1_000_000_000, any::<String>()).prop_map(|(sec, nanosec, frame_id)| {
        Header {
            stamp: Time { sec, nanosec },
            frame_id,
        }
    })
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

proptest! {
    #[test]
    fn joint_state_roundtrips_bitwise(
        header in header(),
        name in prop::collection::vec(any::<String>(), 0..8),
        position in prop::collection::vec(f64_any(), 0..8),
        velocity in prop::collection::vec(f64_any(), 0..8),
        effort in prop::collection::vec(f64_any(), 0..3),
    ) {
        let js = JointState { header, name, position, velocity, effort };
        let bytes = to_cdr(&js).expect("encode");
        let back: JointState = from_cdr(&bytes).expect("decode");
        prop_assert_eq!(&back.header, &js.header);
        prop_assert_eq!(&back.name, &js.name);
        prop_assert_eq!(bits(&back.position), bits(&js.position));
        prop_assert_eq!(bits(&back.velocity), bits(&js.velocity));
        prop_assert_eq!(bits(&back.effort), bits(&js.effort));
        prop_assert_eq!(to_cdr(&back).expect("re-encode"), bytes);
    }

    #[test]
    fn transform_stamped_roundtrips_bitwise(
        header in header(),
        child in any::<String>(),
        t in prop::array::uniform3(f64_any()),
        q in prop::array::uniform4(f64_any()),
    ) {
        let ts = TransformStamped {
            header,
            child_frame_id: child,
            transform: Transform {
                translation: Vector3 { x: t[0], y: t[1], z: t[2] },
                rotation: Quaternion { x: q[0], y: q[1], z: q[2], w: q[3] },
            },
        };
        let bytes = Msg::from(ts.clone()).encode().expect("encode");
        let back = Msg::decode("geometry_msgs/msg/TransformStamped", &bytes).expect("decode");
        let Msg::TransformStamped(back) = back else { panic!("wrong variant") };
        let tr = back.transform.translation;
        let ro = back.transform.rotation;
        prop_assert_eq!(bits(&[tr.x, tr.y, tr.z]), bits(&t));
        prop_assert_eq!(bits(&[ro.x, ro.y, ro.z, ro.w]), bits(&q));
        prop_assert_eq!(&back.child_frame_id, &ts.child_frame_id);
        prop_assert_eq!(Msg::TransformStamped(back).encode().expect("re-encode"), bytes);
    }

    #[test]
    fn feature_matches_roundtrip(
        header in header(),
        method in any::<String>(),
        ka in prop::collection::vec(f32_any(), 0..40),
        kb in prop::collection::vec(f32_any(), 0..40),
        pairs in prop::collection::vec(any::<u32>(), 0..20),
        inlier in prop::collection::vec(any::<bool>(), 0..10),
    ) {
        let fm = FeatureMatches {
            header,
            stamp_a: Time { sec: 1, nanosec: 2 },
            stamp_b: Time { sec: 3, nanosec: 4 },
            method,
            keypoints_a: ka,
            keypoints_b: kb,
            pairs,
            inlier,
        };
        let bytes = to_cdr(&fm).expect("encode");
        let back: FeatureMatches = from_cdr(&bytes).expect("decode");
        let fb = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        prop_assert_eq!(fb(&back.keypoints_a), fb(&fm.keypoints_a));
        prop_assert_eq!(fb(&back.keypoints_b), fb(&fm.keypoints_b));
        prop_assert_eq!(&back.pairs, &fm.pairs);
        prop_assert_eq!(&back.inlier, &fm.inlier);
        prop_assert_eq!(&back.method, &fm.method);
        prop_assert_eq!(to_cdr(&back).expect("re-encode"), bytes);
    }

    #[test]
    fn image_roundtrips(
        header in header(),
        encoding in "[a-z0-9]{0,7}",
        data in prop::collection::vec(any::<u8>(), 0..300),
        width in any::<u32>(),
    ) {
        let img = Image {
            header,
            height: 1,
            width,
            encoding,
            is_bigendian: 0,
            step: data.len() as u32,
            data,
        };
        let bytes = to_cdr(&img).expect("encode");
        prop_assert_eq!(from_cdr::<Image>(&bytes).expect("decode"), img);
    }

    #[test]
    fn random_bytes_never_panic(
        type_index in 0..Msg::TYPE_NAMES.len(),
        body in prop::collection::vec(any::<u8>(), 0..200),
    ) {
        let mut bytes = vec![0, 1, 0, 0];
        bytes.extend(body);
        let _ = Msg::decode(Msg::TYPE_NAMES[type_index], &bytes);
    }
}
