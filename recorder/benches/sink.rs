//! Sink benchmarks.
//!
//! * `sink_vs_bare_mcap/{rodlog,bare}/1280x1024`: the same stream (1280x1024 `rgb8` +
//!   `16UC1` depth at 10 Hz, `/joint_states` at 100 Hz, 1 s = 10 frames, 65.5 MB of
//!   payload), pre-encoded CDR, written with lz4 chunks into memory by rodlog's sink path
//!   ([`SinkFanout`] over [`McapStreamSink`], flushing every robot second) and by the bare
//!   `mcap::Writer` with the same options. The figure of interest is the ratio
//!   bare time / rodlog time (goal >= 0.9).
//! * `live_10hz/1280x1024_rgb_depth16`: the live hardware path ([`run_hardware`]): a
//!   camera driver task produces RGB + 16-bit depth at 10 Hz by wall clock for 1 s per
//!   iteration, `try_send`s into the bounded channel (drops counted), the runner task
//!   merges, the sink thread writes lz4 chunks to a file. Prints drops and the MB/s written;
//!   the run must show zero drops.

// Wall-clock timings and hashed sets of a test, bench or example: not a stage, so the
// crate's determinism lints do not apply here.
#![allow(clippy::disallowed_methods, clippy::disallowed_types)]

use std::hint::black_box;
use std::io::Cursor;
use std::time::{Duration, Instant};

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use msgs::drivers::{DriverError, DriverOutput};
use msgs::sensor_msgs::{Image, JointState};
use msgs::std_msgs::Header;
use msgs::{Msg, RobotDuration, RobotTime};
use recorder::{
    Channel, LiveDriver, LiveOptions, McapSink, McapStreamSink, Runner, SinkFanout, SinkOptions,
};

const WIDTH: u32 = 1280;
const HEIGHT: u32 = 1024;

/// A textured image (gradient + hashed noise): compresses like a real one, not like zeros.
fn image(encoding: &str, bytes_per_px: u32, frame: u32) -> Image {
    let step = WIDTH * bytes_per_px;
    let mut data = vec![0u8; (step * HEIGHT) as usize];
    let mut h: u32 = 0x9E37_79B9 ^ frame;
    for (i, b) in data.iter_mut().enumerate() {
        h ^= h << 13;
        h ^= h >> 17;
        h ^= h << 5;
        let x = (i as u32 % step) / bytes_per_px;
        let y = i as u32 / step;
        *b = ((x / 5 + y / 7 + frame) as u8).wrapping_add((h & 0x0f) as u8);
    }
    Image {
        header: Header {
            stamp: Default::default(),
            frame_id: "camera_color_optical_frame".into(),
        },
        height: HEIGHT,
        width: WIDTH,
        encoding: encoding.into(),
        is_bigendian: 0,
        step,
        data,
    }
}

fn joint_state(k: u32) -> JointState {
    JointState {
        header: Header::default(),
        name: msgs::frames::ARM_JOINT_NAMES
            .iter()
            .map(|s| (*s).to_owned())
            .collect(),
        position: (0..6).map(|j| f64::from(k + j) * 1e-3).collect(),
        velocity: vec![0.0; 6],
        effort: Vec::new(),
    }
}

struct Stream {
    /// (channel index, log_time_ns, cdr)
    messages: Vec<(usize, u64, Vec<u8>)>,
    channels: Vec<std::sync::Arc<Channel>>,
    bytes: u64,
}

/// One second: 10 RGB + 10 depth frames, 100 joint states.
fn stream() -> Result<Stream, msgs::CdrError> {
    let channels = vec![
        Channel::known(
            "/camera/color/image_raw",
            "camera_driver",
            "sensor_msgs/msg/Image",
        ),
        Channel::known(
            "/camera/depth/image_raw",
            "camera_driver",
            "sensor_msgs/msg/Image",
        ),
        Channel::known("/joint_states", "arm_driver", "sensor_msgs/msg/JointState"),
    ];
    let mut messages = Vec::new();
    for k in 0..100u32 {
        let t = u64::from(k) * 10_000_000;
        if k % 10 == 0 {
            messages.push((0, t, Msg::Image(image("rgb8", 3, k)).encode()?));
            messages.push((1, t, Msg::Image(image("16UC1", 2, k)).encode()?));
        }
        messages.push((2, t, Msg::JointState(joint_state(k)).encode()?));
    }
    let bytes = messages.iter().map(|m| m.2.len() as u64).sum();
    Ok(Stream {
        messages,
        channels,
        bytes,
    })
}

fn write_rodlog(s: &Stream) -> Result<usize, Box<dyn std::error::Error>> {
    let sink = McapStreamSink::new(McapSink::new(
        Cursor::new(Vec::new()),
        &SinkOptions::default(),
    )?);
    let mut fan = SinkFanout::new(vec![Box::new(sink)]);
    for (c, t, cdr) in &s.messages {
        let Some(ch) = s.channels.get(*c) else {
            continue;
        };
        fan.write(
            ch,
            RobotTime::from_nanos(*t),
            RobotTime::from_nanos(*t),
            cdr,
        )?;
    }
    let n = fan.written() as usize;
    fan.finish()?;
    Ok(n)
}

fn write_bare(s: &Stream) -> Result<usize, Box<dyn std::error::Error>> {
    let mut w = mcap::WriteOptions::new()
        .profile("ros2")
        .compression(Some(mcap::Compression::Lz4))
        .compression_threads(0)
        .chunk_size(Some(recorder::mcap_writer::DEFAULT_CHUNK_SIZE_BYTES))
        .create(Cursor::new(Vec::new()))?;
    let mut ids = Vec::new();
    for ch in &s.channels {
        let schema = w.add_schema(&ch.type_name, "ros2msg", ch.schema_text.as_bytes())?;
        let mut meta = std::collections::BTreeMap::new();
        meta.insert("offered_qos_profiles".to_owned(), ch.qos_yaml.clone());
        meta.insert("producer".to_owned(), ch.producer.clone());
        ids.push(w.add_channel(schema, &ch.topic, "cdr", &meta)?);
    }
    let mut seq = vec![0u32; ids.len()];
    for (c, t, cdr) in &s.messages {
        let (Some(&channel_id), Some(sq)) = (ids.get(*c), seq.get_mut(*c)) else {
            continue;
        };
        let header = mcap::records::MessageHeader {
            channel_id,
            sequence: *sq,
            log_time: *t,
            publish_time: *t,
        };
        *sq += 1;
        w.write_to_known_channel(&header, cdr)?;
    }
    w.finish()?;
    Ok(s.messages.len())
}

fn sink_vs_bare(c: &mut Criterion) {
    let Ok(s) = stream() else {
        eprintln!("cannot build the stream");
        return;
    };
    let mut g = c.benchmark_group("sink_vs_bare_mcap");
    g.sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(4))
        .throughput(Throughput::Bytes(s.bytes));
    g.bench_with_input(BenchmarkId::new("rodlog", "1280x1024"), &s, |b, s| {
        b.iter(|| black_box(write_rodlog(s).ok()));
    });
    g.bench_with_input(BenchmarkId::new("bare", "1280x1024"), &s, |b, s| {
        b.iter(|| black_box(write_bare(s).ok()));
    });
    g.finish();
}

/// The wrist camera as a live device: RGB + 16-bit depth every poll.
struct Camera {
    color: Msg,
    depth: Msg,
}

impl LiveDriver for Camera {
    fn name(&self) -> &str {
        "camera_driver"
    }
    fn period(&self) -> Duration {
        Duration::from_millis(100)
    }
    fn poll(&mut self, now: RobotTime) -> Result<Vec<DriverOutput>, DriverError> {
        let out = |topic: &str, msg: &Msg| DriverOutput {
            producer: "camera_driver".into(),
            topic: topic.into(),
            msg: msg.clone(),
            log_time: now,
            publish_time: now,
        };
        Ok(vec![
            out("/camera/color/image_raw", &self.color),
            out("/camera/depth/image_raw", &self.depth),
        ])
    }
}

fn live_10hz(c: &mut Criterion) {
    let mut g = c.benchmark_group("live_10hz");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(10));
    let frame_bytes = u64::from(WIDTH * HEIGHT * 5);
    g.throughput(Throughput::Bytes(frame_bytes * 10));
    g.bench_function(BenchmarkId::new("1280x1024_rgb_depth16", "1s"), |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                let Ok(dir) = tempfile::tempdir() else {
                    return total;
                };
                let path = dir.path().join("live.mcap");
                let Ok(mcap) = McapSink::create(&path, &SinkOptions::default()) else {
                    return total;
                };
                let fan = SinkFanout::new(vec![Box::new(McapStreamSink::new(mcap))]);
                let Ok(runner) = Runner::new(Vec::new()) else {
                    return total;
                };
                let camera = Camera {
                    color: Msg::Image(image("rgb8", 3, 1)),
                    depth: Msg::Image(image("16UC1", 2, 2)),
                };
                let start = Instant::now();
                let r = recorder::run_hardware(
                    vec![Box::new(camera)],
                    runner,
                    fan,
                    RobotDuration::from_millis(950),
                    &LiveOptions::default(),
                );
                let elapsed = start.elapsed();
                total += elapsed;
                match r {
                    Ok(s) => {
                        let file_mb = std::fs::metadata(&path).map_or(0.0, |m| m.len() as f64 / 1e6);
                        eprintln!(
                            "live_10hz: {} msgs, payload {:.1} MB in {:.2} s = {:.1} MB/s, file {:.1} MB, drops {:?}",
                            s.messages,
                            s.payload_bytes as f64 / 1e6,
                            elapsed.as_secs_f64(),
                            s.payload_bytes as f64 / 1e6 / elapsed.as_secs_f64(),
                            file_mb,
                            s.drops
                        );
                    }
                    Err(e) => eprintln!("live_10hz failed: {e}"),
                }
            }
            total
        });
    });
    g.finish();
}

criterion_group!(benches, sink_vs_bare, live_10hz);
criterion_main!(benches);
