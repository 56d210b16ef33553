//! Messages in `(log_time, file position)` order: a k-way merge over the chunks sorted by
//! start time, decompressing a chunk only when the smallest pending log time reaches it.

use super::*;

impl<R: Read + Seek> McapReader<R> {
    /// Channel ids whose topic passes `filter`.
    fn wanted_channels(&self, filter: &ReadFilter) -> Option<BTreeSet<u16>> {
        let topics = filter.topics.as_ref()?;
        Some(
            self.channels
                .values()
                .filter(|c| topics.contains(&c.topic))
                .map(|c| c.id)
                .collect(),
        )
    }

    /// Messages passing `filter`, in `(log_time, file position)` order. Errors (a damaged
    /// chunk found while reading) are yielded in place; the iteration goes on after them.
    pub fn messages(&mut self, filter: &ReadFilter) -> Messages<'_, R> {
        let wanted = self.wanted_channels(filter);
        let mut sources: Vec<Source> = Vec::new();
        for c in &self.chunks {
            let has_wanted = match (&wanted, &c.channel_ids) {
                (Some(w), Some(ids)) => !w.is_disjoint(ids),
                (Some(w), None) => !w.is_empty(),
                (None, _) => true,
            };
            if has_wanted && filter.overlaps(c.start_ns, c.end_ns) {
                sources.push(Source {
                    start_ns: c.start_ns,
                    offset: c.offset,
                    record_bytes: c.record_bytes,
                    is_chunk: true,
                });
            }
        }
        for m in &self.loose {
            let ok = wanted.as_ref().is_none_or(|w| w.contains(&m.channel_id));
            if ok && filter.admits_time(m.log_time_ns) {
                sources.push(Source {
                    start_ns: m.log_time_ns,
                    offset: m.offset,
                    record_bytes: m.record_bytes,
                    is_chunk: false,
                });
            }
        }
        sources.sort_by_key(|s| (s.start_ns, s.offset));
        Messages {
            reader: self,
            sources: sources.into(),
            heap: BinaryHeap::new(),
            errors: VecDeque::new(),
            wanted,
            filter: filter.clone(),
        }
    }

    /// All messages passing `filter`, collected; stops at the first error.
    ///
    /// # Errors
    /// The first [`ReadError`] met.
    pub fn read_all(&mut self, filter: &ReadFilter) -> Result<Vec<McapMessage>, ReadError> {
        self.messages(filter).collect()
    }
}

/// A chunk or a loose message still to load.
#[derive(Debug, Clone, Copy)]
struct Source {
    start_ns: u64,
    offset: u64,
    record_bytes: u64,
    is_chunk: bool,
}

/// A decoded message waiting in the merge, ordered by (log_time, source offset, index).
#[derive(Debug)]
struct Pending {
    key: (u64, u64, u32),
    message: McapMessage,
}

impl PartialEq for Pending {
    fn eq(&self, other: &Self) -> bool {
        self.key == other.key
    }
}
impl Eq for Pending {}
impl PartialOrd for Pending {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Pending {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.key.cmp(&other.key)
    }
}

/// Iterator of [`McapReader::messages`].
pub struct Messages<'r, R: Read + Seek> {
    reader: &'r mut McapReader<R>,
    sources: VecDeque<Source>,
    heap: BinaryHeap<Reverse<Pending>>,
    errors: VecDeque<ReadError>,
    wanted: Option<BTreeSet<u16>>,
    filter: ReadFilter,
}

impl<R: Read + Seek> Messages<'_, R> {
    /// Queues a decoded message (its channel must be known by now).
    fn push_message(
        &mut self,
        source: Source,
        index: u32,
        raw: RawMessage,
    ) -> Result<(), ReadError> {
        let Some(channel) = self.reader.channels.get(&raw.channel_id).cloned() else {
            return Err(ReadError::UnknownChannel {
                channel_id: raw.channel_id,
                log_time_ns: raw.log_time_ns,
                offset: source.offset,
            });
        };
        self.heap.push(Reverse(Pending {
            key: (raw.log_time_ns, source.offset, index),
            message: McapMessage {
                channel,
                log_time_ns: raw.log_time_ns,
                publish_time_ns: raw.publish_time_ns,
                sequence: raw.sequence,
                data: raw.data,
            },
        }));
        Ok(())
    }

    fn load(&mut self, source: Source) -> Result<(), ReadError> {
        let limit = self.reader.file_bytes.saturating_sub(source.offset).min(
            self.reader
                .options
                .max_record_bytes
                .saturating_add(RECORD_PREFIX_BYTES),
        );
        if source.record_bytes > limit || source.record_bytes < RECORD_PREFIX_BYTES {
            return Err(ReadError::RecordTooLarge {
                offset: source.offset,
                opcode: if source.is_chunk {
                    op::CHUNK
                } else {
                    op::MESSAGE
                },
                len: source.record_bytes,
                limit,
            });
        }
        let record = read_at(&mut self.reader.src, source.offset, source.record_bytes)?;
        let wanted = &self.wanted;
        let filter = &self.filter;
        // Decodes a message body, keeping it only if the filter admits it (one payload copy).
        let decode = |body: &[u8]| -> Result<Option<RawMessage>, ReadError> {
            let Some((channel_id, sequence, log_time_ns, publish_time_ns)) = message_header(body)
            else {
                return Err(ReadError::ShortMessage {
                    offset: source.offset,
                    len: body.len(),
                });
            };
            let admitted = wanted.as_ref().is_none_or(|w| w.contains(&channel_id))
                && filter.admits_time(log_time_ns);
            Ok(admitted.then(|| RawMessage {
                channel_id,
                sequence,
                log_time_ns,
                publish_time_ns,
                data: body
                    .get(MESSAGE_HEADER_BYTES..)
                    .unwrap_or_default()
                    .to_vec(),
            }))
        };
        if !source.is_chunk {
            return match decode(record.get(9..).unwrap_or_default())? {
                Some(raw) => self.push_message(source, 0, raw),
                None => Ok(()),
            };
        }
        let mut index = 0_u32;
        let mut first_error = None;
        let mut new_schemas = Vec::new();
        let mut new_channels = Vec::new();
        let mut messages: Vec<(u32, RawMessage)> = Vec::new();
        let result = for_each_in_chunk(
            &record,
            self.reader.options.max_record_bytes,
            |opcode, body| {
                match opcode {
                    op::MESSAGE => {
                        if let Some(raw) = decode(body)? {
                            messages.push((index, raw));
                        }
                        index = index.saturating_add(1);
                    }
                    op::SCHEMA | op::CHANNEL => match parse_record(opcode, body) {
                        Ok(Record::Schema { header, data }) => {
                            new_schemas.push((header, data.into_owned()));
                        }
                        Ok(Record::Channel(c)) => new_channels.push(c),
                        Ok(_) => {}
                        Err(source_err) => {
                            first_error.get_or_insert(ReadError::Record {
                                offset: source.offset,
                                opcode,
                                source: source_err,
                            });
                        }
                    },
                    _ => {}
                }
                Ok(())
            },
            source.offset,
        );
        for (h, data) in new_schemas {
            self.reader.add_schema(h.id, h.name, h.encoding, data);
        }
        for c in new_channels {
            self.reader.add_channel(c);
        }
        for (i, raw) in messages {
            if let Err(e) = self.push_message(source, i, raw) {
                first_error.get_or_insert(e);
            }
        }
        result?;
        match first_error {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }
}

/// A message record's fields before its channel is resolved.
#[derive(Debug)]
struct RawMessage {
    channel_id: u16,
    sequence: u32,
    log_time_ns: u64,
    publish_time_ns: u64,
    data: Vec<u8>,
}

impl<R: Read + Seek> Iterator for Messages<'_, R> {
    type Item = Result<McapMessage, ReadError>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            if let Some(e) = self.errors.pop_front() {
                return Some(Err(e));
            }
            let min_pending = self.heap.peek().map(|p| p.0.key.0);
            let due = self
                .sources
                .front()
                .is_some_and(|s| min_pending.is_none_or(|m| s.start_ns <= m));
            if due {
                if let Some(source) = self.sources.pop_front()
                    && let Err(e) = self.load(source)
                {
                    self.errors.push_back(e);
                }
                continue;
            }
            return self.heap.pop().map(|p| Ok(p.0.message));
        }
    }
}
