//! Write -> read tests of the MCAP sink and reader at the byte level: order, filters,
//! metadata, attachments, compression kinds, and recovery of truncated and damaged files.

use std::io::Cursor;

use recorder::{ChunkCompression, McapSink, MetadataRecord, RawRecord, SinkOptions};
use replay::{IndexSource, LossReason, McapReader, ReadError, ReadFilter, ReadOptions};

const SCHEMA_A: &str = "float64 data\n";
const SCHEMA_B: &str = "string data\n";

/// One written message, as the test remembers it.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Written {
    topic: &'static str,
    producer: &'static str,
    type_name: &'static str,
    log_time_ns: u64,
    publish_time_ns: u64,
    sequence: u32,
    data: Vec<u8>,
}

/// A deterministic payload whose bytes depend on `i` (some large, most small).
fn payload(i: u64) -> Vec<u8> {
    let len = if i.is_multiple_of(7) {
        5000 + (i as usize % 13)
    } else {
        8 + (i as usize % 29)
    };
    (0..len)
        .map(|k| ((k as u64 * 31 + i * 17) % 251) as u8)
        .collect()
}

fn message(i: u64) -> Written {
    let (topic, producer, type_name) = match i % 4 {
        0 => ("/lift/command", "script", "std_msgs/msg/Float64"),
        1 => ("/tf", "robot_state", "std_msgs/msg/Float64"),
        2 => ("/tf", "base", "std_msgs/msg/Float64"),
        _ => ("/rosout", "calib", "std_msgs/msg/String"),
    };
    Written {
        topic,
        producer,
        type_name,
        log_time_ns: 1_000_000_000 + i * 10_000_000,
        publish_time_ns: 900_000_000 + i * 10_000_000,
        sequence: i as u32,
        data: payload(i),
    }
}

fn write(sink: &mut McapSink<impl std::io::Write + std::io::Seek>, m: &Written) {
    let schema = if m.type_name.ends_with("String") {
        SCHEMA_B
    } else {
        SCHEMA_A
    };
    sink.write_raw(&RawRecord {
        topic: m.topic,
        producer: m.producer,
        type_name: m.type_name,
        schema_text: schema,
        qos_yaml: "- history: 1\n  depth: 10\n",
        log_time_ns: m.log_time_ns,
        publish_time_ns: m.publish_time_ns,
        sequence: m.sequence,
        cdr: &m.data,
    })
    .expect("write");
}

fn read_back(
    reader: &mut McapReader<impl std::io::Read + std::io::Seek>,
    filter: &ReadFilter,
) -> Vec<Written> {
    reader
        .read_all(filter)
        .expect("read")
        .into_iter()
        .map(|m| {
            let orig = message(u64::from(m.sequence));
            assert_eq!(m.topic(), orig.topic);
            assert_eq!(m.producer(), Some(orig.producer));
            assert_eq!(m.schema_name(), orig.type_name);
            Written {
                data: m.data,
                log_time_ns: m.log_time_ns,
                publish_time_ns: m.publish_time_ns,
                sequence: m.sequence,
                ..orig
            }
        })
        .collect()
}

/// Writes `n` messages in memory, flushing every `flush_every`.
fn in_memory(n: u64, options: &SinkOptions, flush_every: u64) -> Vec<u8> {
    let mut sink = McapSink::new(Cursor::new(Vec::new()), options).expect("sink");
    for i in 0..n {
        write(&mut sink, &message(i));
        if (i + 1) % flush_every == 0 {
            sink.flush().expect("flush");
        }
    }
    sink.finish_into_inner().expect("finish").1.into_inner()
}

fn open_bytes(bytes: &[u8]) -> Result<McapReader<Cursor<&[u8]>>, ReadError> {
    McapReader::from_reader(Cursor::new(bytes), ReadOptions::default())
}

#[test]
fn round_trip_through_the_summary_keeps_every_field_and_order() {
    for compression in [
        ChunkCompression::Lz4,
        ChunkCompression::Zstd,
        ChunkCompression::None,
    ] {
        let options = SinkOptions {
            compression,
            chunk_size_bytes: 16 * 1024,
            ..SinkOptions::default()
        };
        let bytes = in_memory(200, &options, 25);
        let mut reader = open_bytes(&bytes).expect("open");
        assert_eq!(reader.index_source(), IndexSource::Summary);
        assert!(reader.recovery().is_none());
        assert_eq!(reader.header().profile, "ros2");
        assert!(
            reader.header().library.starts_with("rodlog/"),
            "{}",
            reader.header().library
        );
        assert_eq!(reader.message_count(), 200);
        assert!(
            reader.chunks().len() >= 8,
            "flush every 25 -> >= 8 chunks, got {}",
            reader.chunks().len()
        );
        assert!(
            reader
                .chunks()
                .iter()
                .all(|c| c.compression == compression.mcap_name())
        );
        // One channel per (topic, producer): /tf has two.
        assert_eq!(reader.channels().len(), 4);
        let tf: Vec<_> = reader
            .channels()
            .values()
            .filter(|c| c.topic == "/tf")
            .collect();
        assert_eq!(tf.len(), 2);
        for c in reader.channels().values() {
            assert_eq!(c.message_encoding, "cdr");
            assert_eq!(c.schema_encoding(), "ros2msg");
            assert!(c.metadata.contains_key("offered_qos_profiles"));
        }
        let expected: Vec<Written> = (0..200).map(message).collect();
        assert_eq!(
            read_back(&mut reader, &ReadFilter::all()),
            expected,
            "{compression:?}"
        );
        // The same through a forced scan.
        let mut scanned = McapReader::from_reader(
            Cursor::new(&bytes[..]),
            ReadOptions {
                force_scan: true,
                ..ReadOptions::default()
            },
        )
        .expect("scan");
        assert_eq!(scanned.index_source(), IndexSource::Scan);
        assert!(scanned.recovery().is_none(), "{:?}", scanned.recovery());
        assert_eq!(scanned.message_count(), 200);
        assert_eq!(read_back(&mut scanned, &ReadFilter::all()), expected);
    }
}

#[test]
fn out_of_order_writes_are_read_in_log_time_order_ties_in_file_order() {
    let mut sink = McapSink::new(Cursor::new(Vec::new()), &SinkOptions::default()).expect("sink");
    // Chunk 1 holds times 50, 10, 30; chunk 2 holds 20, 30 (tie with chunk 1), 5.
    let times = [50_u64, 10, 30, 20, 30, 5];
    for (i, &t) in times.iter().enumerate() {
        let mut m = message(i as u64);
        m.log_time_ns = t;
        write(&mut sink, &m);
        if i == 2 {
            sink.flush().expect("flush");
        }
    }
    let bytes = sink.finish_into_inner().expect("finish").1.into_inner();
    for force_scan in [false, true] {
        let mut reader = McapReader::from_reader(
            Cursor::new(&bytes[..]),
            ReadOptions {
                force_scan,
                ..ReadOptions::default()
            },
        )
        .expect("open");
        let got: Vec<(u64, u32)> = reader
            .read_all(&ReadFilter::all())
            .expect("read")
            .iter()
            .map(|m| (m.log_time_ns, m.sequence))
            .collect();
        assert_eq!(
            got,
            vec![(5, 5), (10, 1), (20, 3), (30, 2), (30, 4), (50, 0)],
            "force_scan={force_scan}"
        );
    }
}

#[test]
fn topic_and_time_filters_select_exactly() {
    let bytes = in_memory(
        120,
        &SinkOptions {
            chunk_size_bytes: 4096,
            ..SinkOptions::default()
        },
        10,
    );
    let mut reader = open_bytes(&bytes).expect("open");
    let got = read_back(&mut reader, &ReadFilter::all().with_topics(["/tf"]));
    let want: Vec<Written> = (0..120).map(message).filter(|m| m.topic == "/tf").collect();
    assert_eq!(got, want);
    let (start, end) = (
        1_000_000_000 + 33 * 10_000_000,
        1_000_000_000 + 77 * 10_000_000,
    );
    let got = read_back(
        &mut reader,
        &ReadFilter::all().with_time_range(Some(start), Some(end)),
    );
    let want: Vec<Written> = (33..77).map(message).collect();
    assert_eq!(got, want, "time range is [start, end)");
    let got = read_back(
        &mut reader,
        &ReadFilter::all()
            .with_topics(["/rosout", "/nope"])
            .with_time_range(Some(start), None),
    );
    let want: Vec<Written> = (33..120)
        .map(message)
        .filter(|m| m.topic == "/rosout")
        .collect();
    assert_eq!(got, want);
    assert!(read_back(&mut reader, &ReadFilter::all().with_topics(["/nope"])).is_empty());
}

#[test]
fn metadata_and_attachments_round_trip() {
    let dir = tempfile::tempdir().expect("tmp");
    let path = dir.path().join("meta.mcap");
    let urdf: Vec<u8> = b"<robot name=\"rodlog\"/>".repeat(100);
    let mut sink = McapSink::create(&path, &SinkOptions::default()).expect("create");
    write(&mut sink, &message(0));
    sink.write_metadata(
        &MetadataRecord::new("robot_info")
            .with("arm", "AUBO i10")
            .with("lift_max_m", 2.5),
    )
    .expect("meta");
    sink.write_metadata(&MetadataRecord::new("scenario").with("seed", 42))
        .expect("meta");
    sink.attach("robot.urdf", "application/xml", 7, &urdf)
        .expect("attach");
    write(&mut sink, &message(1));
    let summary = sink.finish().expect("finish");
    assert_eq!(
        (summary.messages, summary.metadata, summary.attachments),
        (2, 2, 1)
    );
    for force_scan in [false, true] {
        let mut reader = McapReader::open_with(
            &path,
            ReadOptions {
                force_scan,
                ..ReadOptions::default()
            },
        )
        .expect("open");
        let names: Vec<&str> = reader.metadata().iter().map(|m| m.name.as_str()).collect();
        assert_eq!(names, ["robot_info", "scenario"]);
        let info = reader.metadata_named("robot_info").expect("robot_info");
        assert_eq!(info.entries["arm"], "AUBO i10");
        assert_eq!(info.entries["lift_max_m"], "2.5");
        assert_eq!(reader.attachments().len(), 1);
        let a = reader.attachments()[0].clone();
        assert_eq!(
            (
                a.name.as_str(),
                a.media_type.as_str(),
                a.log_time_ns,
                a.data_bytes
            ),
            ("robot.urdf", "application/xml", 7, urdf.len() as u64)
        );
        assert_eq!(reader.read_attachment(&a).expect("data"), urdf);
        assert_eq!(reader.message_count(), 2);
    }
}

#[test]
fn truncation_at_every_cut_recovers_every_flushed_message_as_a_prefix() {
    let dir = tempfile::tempdir().expect("tmp");
    let path = dir.path().join("crash.mcap");
    let options = SinkOptions {
        chunk_size_bytes: 1 << 20,
        ..SinkOptions::default()
    };
    let mut sink = McapSink::create(&path, &options).expect("create");
    // (file length after a flush, messages written before it)
    let mut flushed: Vec<(u64, usize)> = Vec::new();
    let n = 60_u64;
    for i in 0..n {
        write(&mut sink, &message(i));
        if (i + 1) % 6 == 0 {
            sink.flush().expect("flush");
            flushed.push((
                std::fs::metadata(&path).expect("len").len(),
                (i + 1) as usize,
            ));
        }
    }
    sink.finish().expect("finish");
    let bytes = std::fs::read(&path).expect("read");
    let all: Vec<Written> = (0..n).map(message).collect();
    let mut cuts: Vec<usize> = (0..bytes.len()).step_by(97).collect();
    for &(end, _) in &flushed {
        let end = end as usize;
        cuts.extend([end.saturating_sub(1), end, end + 1]);
    }
    cuts.push(bytes.len() - 1);
    for cut in cuts.into_iter().filter(|&c| c < bytes.len()) {
        let part = &bytes[..cut];
        let mut reader = match open_bytes(part) {
            Ok(r) => r,
            Err(ReadError::Empty | ReadError::WrongMagic { .. }) if cut < 8 => continue,
            Err(e) => panic!("cut {cut}: {e}"),
        };
        assert_eq!(reader.index_source(), IndexSource::Scan, "cut {cut}");
        let recovery = reader
            .recovery()
            .cloned()
            .expect("a cut file is a recovered file");
        let t = recovery.truncation.expect("truncation");
        assert_eq!(t.valid_until + t.lost_bytes, cut as u64, "cut {cut}");
        let got = read_back(&mut reader, &ReadFilter::all());
        assert_eq!(got[..], all[..got.len()], "cut {cut}: not a prefix");
        let must = flushed
            .iter()
            .filter(|(end, _)| *end as usize <= cut)
            .map(|f| f.1)
            .max()
            .unwrap_or(0);
        assert!(
            got.len() >= must,
            "cut {cut}: {} messages recovered, {must} were flushed before it",
            got.len()
        );
        assert_eq!(
            reader.message_count(),
            got.len() as u64,
            "cut {cut}: counts agree with reading"
        );
    }
}

#[test]
fn a_sink_dropped_unfinished_leaves_a_recoverable_file() {
    let dir = tempfile::tempdir().expect("tmp");
    let path = dir.path().join("dropped.mcap");
    {
        let mut sink = McapSink::create(&path, &SinkOptions::default()).expect("create");
        for i in 0..10 {
            write(&mut sink, &message(i));
        }
        // No finish: an error path.
    }
    let mut reader = McapReader::open(&path).expect("open");
    assert_eq!(reader.index_source(), IndexSource::Scan);
    let t = reader
        .recovery()
        .and_then(|r| r.truncation.clone())
        .expect("truncation");
    assert_eq!(t.reason, LossReason::NoFooter);
    assert_eq!(t.lost_bytes, 0);
    let got = read_back(&mut reader, &ReadFilter::all());
    assert_eq!(got, (0..10).map(message).collect::<Vec<_>>());
}

#[test]
fn empty_garbage_and_wrong_magic_are_clear_errors() {
    let e = open_bytes(&[]).expect_err("empty");
    assert!(matches!(e, ReadError::Empty), "{e}");
    let e = open_bytes(b"hello, this is not an MCAP file at all").expect_err("garbage");
    assert!(matches!(e, ReadError::WrongMagic { len: 8, .. }), "{e}");
    assert!(e.to_string().contains("68 65 6c 6c 6f"), "{e}");
    let mut wrong = in_memory(3, &SinkOptions::default(), 100);
    wrong[5] = b'1'; // "\x89MCAP1\r\n": a future major version
    let e = open_bytes(&wrong).expect_err("wrong magic");
    assert!(matches!(e, ReadError::WrongMagic { .. }), "{e}");
    let e = open_bytes(&[0x89, b'M', b'C']).expect_err("short");
    assert!(matches!(e, ReadError::WrongMagic { len: 3, .. }), "{e}");
    // Magic then a record that is not a header.
    let mut bad_header = b"\x89MCAP0\r\n".to_vec();
    bad_header.extend_from_slice(&[0x05, 0, 0, 0, 0, 0, 0, 0, 0]);
    let e = open_bytes(&bad_header).expect_err("bad header");
    assert!(matches!(e, ReadError::BadHeader { opcode: 5 }), "{e}");
    let e = McapReader::open("/nonexistent/rec.mcap").expect_err("missing");
    assert!(e.to_string().contains("/nonexistent/rec.mcap"), "{e}");
}

#[test]
fn garbage_after_the_data_is_reported_as_lost() {
    let mut bytes = in_memory(30, &SinkOptions::default(), 10);
    // Cut the summary off and append garbage with an absurd record length.
    let full = open_bytes(&bytes).expect("open");
    let data_end = full
        .chunks()
        .iter()
        .map(|c| c.offset + c.record_bytes)
        .max()
        .expect("chunks");
    drop(full);
    bytes.truncate(data_end as usize);
    bytes.extend_from_slice(&[0x06, 0xff, 0xff, 0xff, 0x7f, 0, 0, 0, 0, 1, 2, 3]);
    let mut reader = open_bytes(&bytes).expect("open");
    let t = reader
        .recovery()
        .and_then(|r| r.truncation.clone())
        .expect("truncation");
    assert!(
        matches!(t.reason, LossReason::TruncatedRecord { opcode: 0x06, .. }),
        "{:?}",
        t.reason
    );
    assert!(t.valid_until >= data_end, "{t:?}");
    assert_eq!(read_back(&mut reader, &ReadFilter::all()).len(), 30);
}

#[test]
fn a_damaged_chunk_is_skipped_by_the_scan_and_an_error_through_the_summary() {
    let bytes = in_memory(
        40,
        &SinkOptions {
            compression: ChunkCompression::None,
            ..SinkOptions::default()
        },
        10,
    );
    let reader = open_bytes(&bytes).expect("open");
    let second = reader.chunks()[1].clone();
    drop(reader);
    let mut damaged = bytes.clone();
    // Flip a byte in the middle of the second chunk's payload: its CRC no longer matches.
    let mid = (second.offset + second.record_bytes / 2) as usize;
    damaged[mid] ^= 0x5a;
    let mut indexed = open_bytes(&damaged).expect("open");
    let results: Vec<_> = indexed.messages(&ReadFilter::all()).collect();
    let errors: Vec<String> = results
        .iter()
        .filter_map(|r| r.as_ref().err().map(ToString::to_string))
        .collect();
    assert_eq!(errors.len(), 1, "{errors:?}");
    assert!(
        errors[0].contains(&format!("offset {}", second.offset)),
        "{}",
        errors[0]
    );
    let mut scanned = McapReader::from_reader(
        Cursor::new(&damaged[..]),
        ReadOptions {
            force_scan: true,
            ..ReadOptions::default()
        },
    )
    .expect("scan");
    let rec = scanned.recovery().cloned().expect("recovery");
    assert_eq!(rec.skipped_chunks.len(), 1);
    assert_eq!(rec.skipped_chunks[0].offset, second.offset);
    let got = read_back(&mut scanned, &ReadFilter::all());
    let want: Vec<Written> = (0..40)
        .filter(|i| !(10..20).contains(i))
        .map(message)
        .collect();
    assert_eq!(got, want);
}

#[test]
fn unchunked_files_are_read_in_order() {
    let mut w = mcap::WriteOptions::new()
        .use_chunks(false)
        .profile("ros2")
        .create(Cursor::new(Vec::new()))
        .expect("writer");
    let schema = w
        .add_schema("std_msgs/msg/Float64", "ros2msg", SCHEMA_A.as_bytes())
        .expect("schema");
    let ch = w
        .add_channel(schema, "/x", "cdr", &Default::default())
        .expect("channel");
    for (seq, t) in [(0_u32, 30_u64), (1, 10), (2, 20)] {
        let header = mcap::records::MessageHeader {
            channel_id: ch,
            sequence: seq,
            log_time: t,
            publish_time: t,
        };
        w.write_to_known_channel(&header, &[seq as u8; 4])
            .expect("msg");
    }
    w.finish().expect("finish");
    let bytes = w.into_inner().into_inner();
    let mut reader = open_bytes(&bytes).expect("open");
    assert_eq!(
        reader.index_source(),
        IndexSource::Scan,
        "messages outside chunks are found by scanning"
    );
    assert!(reader.recovery().is_none(), "{:?}", reader.recovery());
    let got: Vec<(u64, Vec<u8>)> = reader
        .read_all(&ReadFilter::all())
        .expect("read")
        .into_iter()
        .map(|m| (m.log_time_ns, m.data))
        .collect();
    assert_eq!(
        got,
        vec![(10, vec![1; 4]), (20, vec![2; 4]), (30, vec![0; 4])]
    );
}
