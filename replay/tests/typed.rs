//! The typed layer: every message type through MCAP and back, sequence numbers, determinism,
//! and clear errors for payloads and channels rodlog cannot decode.

#[path = "../../tests/support/fixture.rs"]
mod fixture;

use std::collections::{BTreeMap, BTreeSet};
use std::io::Cursor;

use msgs::{Msg, RobotTime};
use recorder::{ChunkCompression, McapSink, RawRecord, SinkOptions, WriteError};
use replay::{McapReader, ReadError, ReadFilter, ReadOptions};

#[test]
fn every_message_type_round_trips_through_mcap() {
    let entries = fixture::all_topics().expect("fixture");
    let types: BTreeSet<&str> = entries.iter().map(|e| e.msg.type_name()).collect();
    let all: BTreeSet<&str> = Msg::TYPE_NAMES.iter().copied().collect();
    assert_eq!(types, all, "the fixture covers every Msg type");
    let dir = tempfile::tempdir().expect("tmp");
    let path = dir.path().join("all.mcap");
    fixture::write_mcap(&path, &entries, ChunkCompression::Lz4).expect("write");
    let mut reader = McapReader::open(&path).expect("open");
    let names: Vec<&str> = reader.metadata().iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["robot_info", "scenario", "build"]);
    let got = reader.read_all(&ReadFilter::all()).expect("read");
    assert_eq!(got.len(), entries.len());
    for (m, e) in got.iter().zip(&entries) {
        assert_eq!((m.topic(), m.producer()), (e.topic, Some(e.producer)));
        assert_eq!(
            (m.log_time_ns, m.publish_time_ns),
            (e.log_time_ns, e.publish_time_ns)
        );
        assert_eq!(m.schema_name(), e.msg.type_name());
        assert_eq!(m.sequence, 0, "first message of its channel");
        let qos = &m.channel.metadata["offered_qos_profiles"];
        let spec = msgs::topics::lookup(e.topic).expect("registered");
        assert_eq!(qos, spec.offered_qos_profiles, "{}", e.topic);
        assert_eq!(m.decode().expect("decode"), e.msg, "{}", e.topic);
    }
}

#[test]
fn sequences_count_per_channel_and_the_same_calls_give_the_same_bytes() {
    let write = |compression| {
        let mut sink = McapSink::new(
            Cursor::new(Vec::new()),
            &SinkOptions {
                compression,
                ..SinkOptions::default()
            },
        )
        .expect("sink");
        for i in 0..30_u64 {
            let producer = if i % 2 == 0 { "robot_state" } else { "base" };
            let e = &fixture::all_topics().expect("fixture")[(i % 3) as usize];
            sink.write_msg(
                "/tf",
                producer,
                RobotTime::from_nanos(i * 1000),
                RobotTime::from_nanos(i),
                &msgs::Msg::TfMessage(msgs::tf2_msgs::TfMessage::default()),
            )
            .expect("write");
            sink.write_msg(
                e.topic,
                "camera",
                RobotTime::from_nanos(i * 1000 + 1),
                RobotTime::from_nanos(i),
                &e.msg,
            )
            .expect("write");
            if i % 10 == 9 {
                sink.flush().expect("flush");
            }
        }
        sink.finish_into_inner().expect("finish").1.into_inner()
    };
    for compression in [ChunkCompression::Lz4, ChunkCompression::Zstd] {
        let a = write(compression);
        assert_eq!(a, write(compression), "{compression:?}: byte-identical");
        let mut reader =
            McapReader::from_reader(Cursor::new(&a[..]), ReadOptions::default()).expect("open");
        let mut seqs: BTreeMap<(String, String), Vec<u32>> = BTreeMap::new();
        for m in reader.read_all(&ReadFilter::all()).expect("read") {
            seqs.entry((m.topic().to_owned(), m.producer().unwrap_or("").to_owned()))
                .or_default()
                .push(m.sequence);
        }
        assert_eq!(
            seqs[&("/tf".to_owned(), "base".to_owned())],
            (0..15).collect::<Vec<_>>()
        );
        assert_eq!(
            seqs[&("/tf".to_owned(), "robot_state".to_owned())],
            (0..15).collect::<Vec<_>>()
        );
        assert_eq!(seqs.len(), 5, "{seqs:?}");
    }
}

#[test]
fn another_type_on_an_existing_channel_is_refused() {
    let mut sink = McapSink::new(Cursor::new(Vec::new()), &SinkOptions::default()).expect("sink");
    let t = RobotTime::from_nanos(1);
    sink.write_msg(
        "/lift/command",
        "script",
        t,
        t,
        &Msg::Float64(msgs::std_msgs::Float64 { data: 1.0 }),
    )
    .expect("write");
    let e = sink
        .write_msg(
            "/lift/command",
            "script",
            t,
            t,
            &Msg::Empty(msgs::std_msgs::Empty),
        )
        .expect_err("mismatch");
    assert!(matches!(e, WriteError::TypeMismatch { .. }), "{e}");
    assert!(e.to_string().contains("std_msgs/msg/Float64"), "{e}");
    // Another producer may publish it: its own channel.
    sink.write_msg(
        "/lift/command",
        "task",
        t,
        t,
        &Msg::Float64(msgs::std_msgs::Float64 { data: 2.0 }),
    )
    .expect("write");
    sink.finish().expect("finish");
}

/// Writes one raw payload with the given encodings through the bare mcap writer.
fn foreign(schema_encoding: &str, message_encoding: &str, type_name: &str, data: &[u8]) -> Vec<u8> {
    let mut w = mcap::WriteOptions::new()
        .profile("ros2")
        .create(Cursor::new(Vec::new()))
        .expect("writer");
    let schema = w
        .add_schema(type_name, schema_encoding, b"float64 data\n")
        .expect("schema");
    let ch = w
        .add_channel(schema, "/x", message_encoding, &BTreeMap::new())
        .expect("channel");
    let header = mcap::records::MessageHeader {
        channel_id: ch,
        sequence: 0,
        log_time: 7,
        publish_time: 7,
    };
    w.write_to_known_channel(&header, data).expect("msg");
    w.finish().expect("finish");
    w.into_inner().into_inner()
}

fn decode_only(bytes: &[u8]) -> Result<Msg, ReadError> {
    let mut reader =
        McapReader::from_reader(Cursor::new(bytes), ReadOptions::default()).expect("open");
    let msgs = reader.read_all(&ReadFilter::all()).expect("read");
    msgs.first().expect("one message").decode()
}

#[test]
fn undecodable_payloads_and_foreign_encodings_are_clear_errors() {
    let f64_cdr = [0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0xf0, 0x3f]; // 1.0 little-endian
    assert_eq!(
        decode_only(&foreign("ros2msg", "cdr", "std_msgs/msg/Float64", &f64_cdr)).expect("ok"),
        Msg::Float64(msgs::std_msgs::Float64 { data: 1.0 })
    );
    let xcdr2 = [0, 7, 0, 0, 0, 0, 0, 0, 0, 0, 0xf0, 0x3f];
    let e =
        decode_only(&foreign("ros2msg", "cdr", "std_msgs/msg/Float64", &xcdr2)).expect_err("xcdr2");
    assert!(matches!(e, ReadError::Decode { log_time_ns: 7, .. }), "{e}");
    assert!(
        e.to_string().contains("XCDR2") && e.to_string().contains("/x"),
        "{e}"
    );
    let e = decode_only(&foreign(
        "ros2msg",
        "cdr",
        "std_msgs/msg/Float64",
        &f64_cdr[..7],
    ))
    .expect_err("short");
    assert!(matches!(e, ReadError::Decode { bytes: 7, .. }), "{e}");
    let e = decode_only(&foreign("ros2msg", "cdr", "foo_msgs/msg/Bar", &f64_cdr))
        .expect_err("unknown type");
    assert!(e.to_string().contains("foo_msgs/msg/Bar"), "{e}");
    let e =
        decode_only(&foreign("ros2idl", "cdr", "std_msgs/msg/Float64", &f64_cdr)).expect_err("idl");
    assert!(
        matches!(e, ReadError::UnknownSchemaEncoding { ref encoding, .. } if encoding == "ros2idl"),
        "{e}"
    );
    let e = decode_only(&foreign(
        "jsonschema",
        "json",
        "std_msgs/msg/Float64",
        b"{}",
    ))
    .expect_err("json");
    assert!(
        matches!(e, ReadError::UnsupportedMessageEncoding { ref encoding, .. } if encoding == "json"),
        "{e}"
    );
    // The low-level API accepts anything; the reader still reports the payload's fault.
    let mut sink = McapSink::new(Cursor::new(Vec::new()), &SinkOptions::default()).expect("sink");
    sink.write_raw(&RawRecord {
        topic: "/camera/color/image_raw",
        producer: "camera",
        type_name: "sensor_msgs/msg/Image",
        schema_text: &Msg::schema_text("sensor_msgs/msg/Image").expect("schema"),
        qos_yaml: "",
        log_time_ns: 42,
        publish_time_ns: 42,
        sequence: 0,
        cdr: &[0, 1, 0, 0, 0xff, 0xff, 0xff, 0x7f],
    })
    .expect("raw");
    let bytes = sink.finish_into_inner().expect("finish").1.into_inner();
    let e = decode_only(&bytes).expect_err("bad image");
    assert!(
        e.to_string().contains("/camera/color/image_raw") && e.to_string().contains("42"),
        "{e}"
    );
}
