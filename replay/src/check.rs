//! Divergence check: recorded vs regenerated outputs, byte for byte, per channel, in order.
//!
//! Outputs are compared per (topic, producer) channel in log-time order: the k-th
//! regenerated message of a channel against its k-th recorded one. A pair is identical when
//! both the log time and the CDR bytes are equal. The first divergence of every channel is
//! kept with a field-wise explanation: both payloads are decoded with msgs and walked as
//! JSON trees, giving the first differing field, e.g.
//! `points[0].positions[1]: 0.7344 != 0.6120`. The overall first divergence is the earliest
//! by (log_time, topic, producer). Messages left over on one side (missing or extra
//! outputs) are divergences too.

use std::collections::{BTreeMap, VecDeque};
use std::fmt;

use msgs::Msg;

/// What differs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum DivergenceKind {
    /// Same log time, different payload: the first differing field.
    Field {
        /// Path of the field (`transforms[3].transform.translation.x`).
        path: String,
        /// Recorded value.
        recorded: String,
        /// Regenerated value.
        regenerated: String,
    },
    /// Payload bytes differ but no field does (or the type cannot be decoded).
    Bytes {
        /// First differing byte offset.
        offset: usize,
        /// Recorded size.
        recorded_len: usize,
        /// Regenerated size.
        regenerated_len: usize,
    },
    /// Log times differ (payload identical or explained by `field`).
    LogTime {
        /// Recorded log time, ns.
        recorded_ns: u64,
        /// Regenerated log time, ns.
        regenerated_ns: u64,
        /// First differing field, if the payloads differ too.
        field: Option<String>,
    },
    /// A recorded output was not regenerated.
    Missing,
    /// A regenerated output has no recorded counterpart.
    Extra,
}

/// One divergence.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Divergence {
    /// Topic.
    pub topic: String,
    /// Producer (stage).
    pub producer: String,
    /// Log time of the message (the recorded one when there is one), ns.
    pub log_time_ns: u64,
    /// Index of the message in its channel.
    pub index: u64,
    /// What differs.
    pub kind: DivergenceKind,
}

impl fmt::Display for Divergence {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let t = self.log_time_ns;
        write!(
            f,
            "{} (producer {}) at log_time {}.{:09} s (message #{}): ",
            self.topic,
            self.producer,
            t / 1_000_000_000,
            t % 1_000_000_000,
            self.index
        )?;
        match &self.kind {
            DivergenceKind::Field {
                path,
                recorded,
                regenerated,
            } => write!(
                f,
                "{path}: {recorded} != {regenerated} (recorded != regenerated)"
            ),
            DivergenceKind::Bytes {
                offset,
                recorded_len,
                regenerated_len,
            } => write!(
                f,
                "payload bytes differ at offset {offset} ({recorded_len} vs {regenerated_len} bytes)"
            ),
            DivergenceKind::LogTime {
                recorded_ns,
                regenerated_ns,
                field,
            } => {
                write!(f, "log_time: {recorded_ns} != {regenerated_ns} ns")?;
                if let Some(field) = field {
                    write!(f, "; {field}")?;
                }
                Ok(())
            }
            DivergenceKind::Missing => write!(f, "recorded output not regenerated"),
            DivergenceKind::Extra => write!(f, "regenerated output not in the recording"),
        }
    }
}

/// Per-channel comparison counts.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct ChannelComparison {
    /// Topic.
    pub topic: String,
    /// Producer.
    pub producer: String,
    /// ROS type.
    pub type_name: String,
    /// Recorded outputs seen.
    pub recorded: u64,
    /// Regenerated outputs seen.
    pub regenerated: u64,
    /// Pairs compared.
    pub compared: u64,
    /// Identical pairs.
    pub identical: u64,
    /// First divergence of this channel.
    pub first_divergence: Option<Divergence>,
}

impl ChannelComparison {
    /// Divergent pairs plus leftovers.
    pub fn changed(&self) -> u64 {
        self.recorded.max(self.regenerated) - self.identical
    }
}

#[derive(Debug, Default)]
struct Stream {
    stats: ChannelComparison,
    recorded: VecDeque<(u64, Vec<u8>)>,
    regenerated: VecDeque<(u64, Vec<u8>)>,
}

/// Streaming comparator; see the module docs.
#[derive(Debug, Default)]
pub struct Comparator {
    streams: BTreeMap<(String, String), Stream>,
}

impl Comparator {
    /// An empty comparator.
    pub fn new() -> Self {
        Self::default()
    }

    fn stream(&mut self, topic: &str, producer: &str, type_name: &str) -> &mut Stream {
        self.streams
            .entry((topic.to_owned(), producer.to_owned()))
            .or_insert_with(|| Stream {
                stats: ChannelComparison {
                    topic: topic.to_owned(),
                    producer: producer.to_owned(),
                    type_name: type_name.to_owned(),
                    ..ChannelComparison::default()
                },
                ..Stream::default()
            })
    }

    /// Adds a recorded output.
    pub fn recorded(
        &mut self,
        topic: &str,
        producer: &str,
        type_name: &str,
        log_time_ns: u64,
        cdr: Vec<u8>,
    ) {
        let s = self.stream(topic, producer, type_name);
        s.stats.recorded += 1;
        s.recorded.push_back((log_time_ns, cdr));
        settle(s);
    }

    /// Adds a regenerated output.
    pub fn regenerated(
        &mut self,
        topic: &str,
        producer: &str,
        type_name: &str,
        log_time_ns: u64,
        cdr: Vec<u8>,
    ) {
        let s = self.stream(topic, producer, type_name);
        s.stats.regenerated += 1;
        s.regenerated.push_back((log_time_ns, cdr));
        settle(s);
    }

    /// Ends the comparison: leftovers become Missing/Extra divergences.
    pub fn finish(mut self) -> Comparison {
        let mut channels = Vec::new();
        for (_, mut s) in std::mem::take(&mut self.streams) {
            let index = s.stats.compared;
            if s.stats.first_divergence.is_none() {
                if let Some((t, _)) = s.recorded.front() {
                    s.stats.first_divergence = Some(Divergence {
                        topic: s.stats.topic.clone(),
                        producer: s.stats.producer.clone(),
                        log_time_ns: *t,
                        index,
                        kind: DivergenceKind::Missing,
                    });
                } else if let Some((t, _)) = s.regenerated.front() {
                    s.stats.first_divergence = Some(Divergence {
                        topic: s.stats.topic.clone(),
                        producer: s.stats.producer.clone(),
                        log_time_ns: *t,
                        index,
                        kind: DivergenceKind::Extra,
                    });
                }
            }
            channels.push(s.stats);
        }
        Comparison { channels }
    }
}

fn settle(s: &mut Stream) {
    while !s.recorded.is_empty() && !s.regenerated.is_empty() {
        let (Some((t_rec, rec)), Some((t_gen, gen_cdr))) =
            (s.recorded.pop_front(), s.regenerated.pop_front())
        else {
            break;
        };
        let index = s.stats.compared;
        s.stats.compared += 1;
        if t_rec == t_gen && rec == gen_cdr {
            s.stats.identical += 1;
            continue;
        }
        if s.stats.first_divergence.is_some() {
            continue;
        }
        let field = if rec == gen_cdr {
            None
        } else {
            Some(explain(&s.stats.type_name, &rec, &gen_cdr))
        };
        let kind = match field {
            Some(k) if t_rec == t_gen => k,
            other => DivergenceKind::LogTime {
                recorded_ns: t_rec,
                regenerated_ns: t_gen,
                field: other.map(|k| k.text()),
            },
        };
        s.stats.first_divergence = Some(Divergence {
            topic: s.stats.topic.clone(),
            producer: s.stats.producer.clone(),
            log_time_ns: t_rec,
            index,
            kind,
        });
    }
}

impl DivergenceKind {
    /// The explanation alone (`path: a != b`).
    pub fn text(&self) -> String {
        match self {
            DivergenceKind::Field {
                path,
                recorded,
                regenerated,
            } => format!("{path}: {recorded} != {regenerated}"),
            DivergenceKind::Bytes { offset, .. } => format!("bytes differ at offset {offset}"),
            DivergenceKind::LogTime {
                recorded_ns,
                regenerated_ns,
                ..
            } => format!("log_time: {recorded_ns} != {regenerated_ns}"),
            DivergenceKind::Missing => "missing".to_owned(),
            DivergenceKind::Extra => "extra".to_owned(),
        }
    }
}

/// The result of a comparison.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Comparison {
    /// Per output channel, sorted by (topic, producer).
    pub channels: Vec<ChannelComparison>,
}

impl Comparison {
    /// Pairs compared over all channels.
    pub fn compared(&self) -> u64 {
        self.channels.iter().map(|c| c.compared).sum()
    }

    /// Identical pairs over all channels.
    pub fn identical(&self) -> u64 {
        self.channels.iter().map(|c| c.identical).sum()
    }

    /// The earliest divergence by (log_time, topic, producer).
    pub fn first_divergence(&self) -> Option<&Divergence> {
        self.first_matching(|_| true)
    }

    /// The earliest divergence on a command topic (the start of open-loop outputs).
    pub fn first_divergent_command(&self) -> Option<&Divergence> {
        self.first_matching(|d| recorder::is_command_topic(&d.topic))
    }

    fn first_matching(&self, pred: impl Fn(&Divergence) -> bool) -> Option<&Divergence> {
        self.channels
            .iter()
            .filter_map(|c| c.first_divergence.as_ref())
            .filter(|d| pred(d))
            .min_by(|a, b| {
                (a.log_time_ns, &a.topic, &a.producer).cmp(&(b.log_time_ns, &b.topic, &b.producer))
            })
    }
}

/// Explains why two payloads of `type_name` differ.
pub fn explain(type_name: &str, recorded: &[u8], regenerated: &[u8]) -> DivergenceKind {
    let bytes = || DivergenceKind::Bytes {
        offset: recorded
            .iter()
            .zip(regenerated)
            .position(|(a, b)| a != b)
            .unwrap_or(recorded.len().min(regenerated.len())),
        recorded_len: recorded.len(),
        regenerated_len: regenerated.len(),
    };
    let (Ok(a), Ok(b)) = (
        Msg::decode(type_name, recorded),
        Msg::decode(type_name, regenerated),
    ) else {
        return bytes();
    };
    let (Some(a), Some(b)) = (to_json(&a), to_json(&b)) else {
        return bytes();
    };
    let mut walk = Walk {
        a: a.as_bytes(),
        ia: 0,
        b: b.as_bytes(),
        ib: 0,
        path: String::new(),
    };
    match walk.value() {
        Some(Some((path, recorded, regenerated))) => DivergenceKind::Field {
            path: if path.is_empty() {
                "(value)".to_owned()
            } else {
                path
            },
            recorded,
            regenerated,
        },
        _ => bytes(),
    }
}

/// A message as compact JSON, fields in wire order (field names as in the `.msg`).
pub fn to_json(msg: &Msg) -> Option<String> {
    let v = match msg {
        Msg::Image(m) => serde_json::to_string(m),
        Msg::CameraInfo(m) => serde_json::to_string(m),
        Msg::JointState(m) => serde_json::to_string(m),
        Msg::PointCloud2(m) => serde_json::to_string(m),
        Msg::Illuminance(m) => serde_json::to_string(m),
        Msg::PoseStamped(m) => serde_json::to_string(m),
        Msg::TransformStamped(m) => serde_json::to_string(m),
        Msg::TfMessage(m) => serde_json::to_string(m),
        Msg::Clock(m) => serde_json::to_string(m),
        Msg::JointTrajectory(m) => serde_json::to_string(m),
        Msg::Path(m) => serde_json::to_string(m),
        Msg::Log(m) => serde_json::to_string(m),
        Msg::String(m) => serde_json::to_string(m),
        Msg::Float64(m) => serde_json::to_string(m),
        Msg::Empty(m) => serde_json::to_string(m),
        Msg::ClampCommand(m) => serde_json::to_string(m),
        Msg::FeatureMatches(m) => serde_json::to_string(m),
        Msg::HandEyeCalibration(m) => serde_json::to_string(m),
        Msg::TaskEvent(m) => serde_json::to_string(m),
    };
    v.ok()
}

/// Walks two compact JSON texts of the same type in lock step and stops at the first
/// differing leaf (streaming: a 4 MB image is compared without building a tree).
/// `None` = malformed input; `Some(None)` = no difference.
struct Walk<'a> {
    a: &'a [u8],
    ia: usize,
    b: &'a [u8],
    ib: usize,
    path: String,
}

type Found = Option<(String, String, String)>;

/// Skips one JSON value starting at `*i`; returns its text span end.
fn skip_value(s: &[u8], i: &mut usize) -> Option<()> {
    match *s.get(*i)? {
        b'{' | b'[' => {
            let mut depth = 0usize;
            while let Some(&c) = s.get(*i) {
                match c {
                    b'"' => {
                        skip_string(s, i)?;
                        continue;
                    }
                    b'{' | b'[' => depth += 1,
                    b'}' | b']' => {
                        depth -= 1;
                        if depth == 0 {
                            *i += 1;
                            return Some(());
                        }
                    }
                    _ => {}
                }
                *i += 1;
            }
            None
        }
        b'"' => skip_string(s, i),
        _ => {
            while s.get(*i).is_some_and(|c| !matches!(c, b',' | b'}' | b']')) {
                *i += 1;
            }
            Some(())
        }
    }
}

fn skip_string(s: &[u8], i: &mut usize) -> Option<()> {
    *i += 1; // opening quote
    loop {
        match *s.get(*i)? {
            b'\\' => *i += 2,
            b'"' => {
                *i += 1;
                return Some(());
            }
            _ => *i += 1,
        }
    }
}

/// Reads a value's raw text (leaf) and advances.
fn leaf<'s>(s: &'s [u8], i: &mut usize) -> Option<&'s str> {
    let start = *i;
    skip_value(s, i)?;
    std::str::from_utf8(s.get(start..*i)?).ok()
}

/// Counts the elements left in an array (cursor after `[` or `,`), consuming it.
fn count_rest(s: &[u8], i: &mut usize, mut n: usize) -> Option<usize> {
    loop {
        match *s.get(*i)? {
            b']' => {
                *i += 1;
                return Some(n);
            }
            b',' => *i += 1,
            _ => {
                skip_value(s, i)?;
                n += 1;
            }
        }
    }
}

impl Walk<'_> {
    fn value(&mut self) -> Option<Found> {
        let (ca, cb) = (*self.a.get(self.ia)?, *self.b.get(self.ib)?);
        match (ca, cb) {
            (b'{', b'{') => self.object(),
            (b'[', b'[') => self.array(),
            _ => {
                let ta = leaf(self.a, &mut self.ia)?;
                let tb = leaf(self.b, &mut self.ib)?;
                Some((ta != tb).then(|| (self.path.clone(), ta.to_owned(), tb.to_owned())))
            }
        }
    }

    fn object(&mut self) -> Option<Found> {
        self.ia += 1;
        self.ib += 1;
        loop {
            match (*self.a.get(self.ia)?, *self.b.get(self.ib)?) {
                (b'}', b'}') => {
                    self.ia += 1;
                    self.ib += 1;
                    return Some(None);
                }
                (b',', b',') => {
                    self.ia += 1;
                    self.ib += 1;
                }
                (b'"', b'"') => {
                    let ka = leaf(self.a, &mut self.ia)?.trim_matches('"').to_owned();
                    let kb = leaf(self.b, &mut self.ib)?;
                    if ka != kb.trim_matches('"') {
                        return Some(Some((
                            self.path.clone(),
                            ka,
                            kb.trim_matches('"').to_owned(),
                        )));
                    }
                    // ':'
                    self.ia += 1;
                    self.ib += 1;
                    let len = self.path.len();
                    if !self.path.is_empty() {
                        self.path.push('.');
                    }
                    self.path.push_str(&ka);
                    let found = self.value()?;
                    if found.is_some() {
                        return Some(found);
                    }
                    self.path.truncate(len);
                }
                _ => return None,
            }
        }
    }

    fn array(&mut self) -> Option<Found> {
        self.ia += 1;
        self.ib += 1;
        let mut k = 0usize;
        loop {
            match (*self.a.get(self.ia)?, *self.b.get(self.ib)?) {
                (b']', b']') => {
                    self.ia += 1;
                    self.ib += 1;
                    return Some(None);
                }
                (b',', b',') => {
                    self.ia += 1;
                    self.ib += 1;
                }
                (b']', _) | (_, b']') => {
                    let na = count_rest(self.a, &mut self.ia, k)?;
                    let nb = count_rest(self.b, &mut self.ib, k)?;
                    return Some(Some((
                        format!("{}.len()", self.path),
                        na.to_string(),
                        nb.to_string(),
                    )));
                }
                _ => {
                    let len = self.path.len();
                    self.path.push_str(&format!("[{k}]"));
                    let found = self.value()?;
                    if found.is_some() {
                        return Some(found);
                    }
                    self.path.truncate(len);
                    k += 1;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use msgs::geometry_msgs::TransformStamped;
    use msgs::tf2_msgs::TfMessage;

    fn tf(x: f64) -> Result<Vec<u8>, msgs::CdrError> {
        let mut t = TfMessage {
            transforms: vec![TransformStamped::default(); 4],
        };
        t.transforms[3].transform.translation.x = x;
        Msg::TfMessage(t).encode()
    }

    #[test]
    fn names_the_first_differing_field() -> Result<(), msgs::CdrError> {
        let mut c = Comparator::new();
        c.recorded("/tf", "robot_state", "tf2_msgs/msg/TFMessage", 10, tf(0.0)?);
        c.regenerated("/tf", "robot_state", "tf2_msgs/msg/TFMessage", 10, tf(0.0)?);
        c.recorded(
            "/tf",
            "robot_state",
            "tf2_msgs/msg/TFMessage",
            20,
            tf(0.1234)?,
        );
        c.regenerated(
            "/tf",
            "robot_state",
            "tf2_msgs/msg/TFMessage",
            20,
            tf(0.124)?,
        );
        let r = c.finish();
        assert_eq!(r.compared(), 2);
        assert_eq!(r.identical(), 1);
        let d = r.first_divergence().cloned();
        let Some(d) = d else {
            panic!("no divergence found");
        };
        assert_eq!(d.log_time_ns, 20);
        assert_eq!(
            d.kind,
            DivergenceKind::Field {
                path: "transforms[3].transform.translation.x".into(),
                recorded: "0.1234".into(),
                regenerated: "0.124".into()
            }
        );
        assert!(
            d.to_string()
                .contains("transforms[3].transform.translation.x: 0.1234 != 0.124")
        );
        Ok(())
    }

    #[test]
    fn fields_in_wire_order_lengths_and_strings() -> Result<(), msgs::CdrError> {
        use msgs::sensor_msgs::JointState;
        let js = |pos: Vec<f64>, frame: &str| {
            let mut j = JointState {
                name: vec!["a\"b".into(), "c".into()],
                position: pos,
                ..Default::default()
            };
            j.header.frame_id = frame.into();
            Msg::JointState(j).encode()
        };
        let t = "sensor_msgs/msg/JointState";
        // header comes before position on the wire (alphabetically it would not).
        let k = explain(t, &js(vec![1.0, 2.0], "x")?, &js(vec![1.0, 3.0], "y")?);
        assert!(
            matches!(&k, DivergenceKind::Field { path, recorded, .. } if path == "header.frame_id" && recorded == "\"x\""),
            "{k:?}"
        );
        let k = explain(t, &js(vec![1.0, 2.0], "x")?, &js(vec![1.0, 2.5], "x")?);
        assert!(
            matches!(&k, DivergenceKind::Field { path, .. } if path == "position[1]"),
            "{k:?}"
        );
        let k = explain(t, &js(vec![1.0, 2.0], "x")?, &js(vec![1.0, 2.0, 4.0], "x")?);
        assert_eq!(
            k,
            DivergenceKind::Field {
                path: "position.len()".into(),
                recorded: "2".into(),
                regenerated: "3".into()
            }
        );
        // Undecodable bytes fall back to a byte offset.
        let k = explain(t, &[0, 1, 0, 0, 9], &[0, 1, 0, 0, 8]);
        assert!(
            matches!(k, DivergenceKind::Bytes { offset: 4, .. }),
            "{k:?}"
        );
        Ok(())
    }

    #[test]
    fn leftovers_and_log_times_diverge() -> Result<(), msgs::CdrError> {
        let mut c = Comparator::new();
        c.recorded("/a", "s", "tf2_msgs/msg/TFMessage", 5, tf(1.0)?);
        c.regenerated("/a", "s", "tf2_msgs/msg/TFMessage", 6, tf(1.0)?);
        c.recorded("/b", "s", "tf2_msgs/msg/TFMessage", 3, tf(1.0)?);
        let r = c.finish();
        let first = r
            .first_divergence()
            .map(|d| (d.topic.clone(), d.kind.clone()));
        assert_eq!(first, Some(("/b".to_owned(), DivergenceKind::Missing)));
        let a = &r.channels[0];
        assert!(matches!(
            a.first_divergence.as_ref().map(|d| &d.kind),
            Some(DivergenceKind::LogTime {
                recorded_ns: 5,
                regenerated_ns: 6,
                field: None
            })
        ));
        assert_eq!(r.compared(), 1);
        Ok(())
    }
}
