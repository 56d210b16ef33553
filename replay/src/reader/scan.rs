//! Opening a file without a usable summary (crashed, truncated, damaged): a walk over the
//! records from the start, keeping every complete chunk and message and saying where and why
//! it stopped ([`Recovery`]).

use super::*;

impl<R: Read + Seek> McapReader<R> {
    /// Walks the data section from offset 8, keeping every complete record.
    pub(super) fn scan(&mut self) -> Result<(), ReadError> {
        let mut recovery = Recovery::default();
        let mut offset = 8_u64;
        let stop = |offset: u64, reason: LossReason, file_bytes: u64| Truncation {
            valid_until: offset,
            lost_bytes: file_bytes - offset,
            reason,
        };
        loop {
            let remaining = self.file_bytes - offset;
            if remaining == 0 {
                recovery.truncation = Some(stop(offset, LossReason::NoFooter, self.file_bytes));
                break;
            }
            if remaining < RECORD_PREFIX_BYTES {
                let reason = LossReason::TruncatedPrefix {
                    offset,
                    available: remaining,
                };
                recovery.truncation = Some(stop(offset, reason, self.file_bytes));
                break;
            }
            let pre = read_at(&mut self.src, offset, RECORD_PREFIX_BYTES)?;
            let Some((opcode, len)) = prefix(&pre) else {
                break;
            };
            let available = remaining - RECORD_PREFIX_BYTES;
            if opcode == op::CHUNK && len == u64::MAX {
                let reason = LossReason::UnfinishedChunk { offset };
                recovery.truncation = Some(stop(offset, reason, self.file_bytes));
                break;
            }
            if len > available {
                let reason = LossReason::TruncatedRecord {
                    offset,
                    opcode,
                    declared_bytes: len,
                    available,
                };
                recovery.truncation = Some(stop(offset, reason, self.file_bytes));
                break;
            }
            if len > self.options.max_record_bytes {
                let reason = LossReason::BadRecord {
                    offset,
                    opcode,
                    detail: format!(
                        "length {len} exceeds the limit {}",
                        self.options.max_record_bytes
                    ),
                };
                recovery.truncation = Some(stop(offset, reason, self.file_bytes));
                break;
            }
            let body_at = offset + RECORD_PREFIX_BYTES;
            let next = body_at + len;
            let outcome = match opcode {
                op::FOOTER => {
                    // The footer ends the file: the end magic must follow.
                    let tail = read_at(&mut self.src, next, (self.file_bytes - next).min(8))?;
                    if tail.as_slice() != MAGIC.as_slice() {
                        let reason = LossReason::BadEndMagic { offset: next };
                        recovery.truncation = Some(stop(next, reason, self.file_bytes));
                    }
                    break;
                }
                op::MESSAGE => self.scan_message(offset, len),
                op::CHUNK => {
                    let record = read_at(&mut self.src, offset, RECORD_PREFIX_BYTES + len)?;
                    match self.scan_chunk(offset, &record) {
                        Ok(()) => Ok(()),
                        Err(ReadError::Chunk { source, .. }) => {
                            recovery.skipped_chunks.push(SkippedChunk {
                                offset,
                                record_bytes: RECORD_PREFIX_BYTES + len,
                                detail: source.to_string(),
                            });
                            Ok(())
                        }
                        Err(e) => Err(e),
                    }
                }
                op::SCHEMA | op::CHANNEL | op::METADATA | op::ATTACHMENT => {
                    let body = read_at(&mut self.src, body_at, len)?;
                    self.scan_small_record(offset, opcode, &body)
                }
                // Indexes, statistics, data end, header repeats and unknown opcodes: skipped.
                _ => Ok(()),
            };
            if let Err(e) = outcome {
                let reason = LossReason::BadRecord {
                    offset,
                    opcode,
                    detail: e.to_string(),
                };
                recovery.truncation = Some(stop(offset, reason, self.file_bytes));
                break;
            }
            offset = next;
        }
        if recovery.truncation.is_some() || !recovery.skipped_chunks.is_empty() {
            self.recovery = Some(recovery);
        }
        Ok(())
    }

    fn scan_message(&mut self, offset: u64, len: u64) -> Result<(), ReadError> {
        let head = read_at(
            &mut self.src,
            offset + RECORD_PREFIX_BYTES,
            len.min(MESSAGE_HEADER_BYTES as u64),
        )?;
        let Some((channel_id, _, log_time_ns, _)) = message_header(&head) else {
            return Err(ReadError::ShortMessage {
                offset,
                len: head.len(),
            });
        };
        self.loose.push(LooseMessage {
            offset,
            record_bytes: RECORD_PREFIX_BYTES + len,
            log_time_ns,
            channel_id,
        });
        *self.channel_counts.entry(channel_id).or_default() += 1;
        self.note_time(log_time_ns);
        Ok(())
    }

    /// Decodes a whole chunk once: its schemas, channels, counts and real time range. The
    /// index is only updated when the whole chunk decodes.
    fn scan_chunk(&mut self, offset: u64, record: &[u8]) -> Result<(), ReadError> {
        let header = match parse_record(op::CHUNK, record.get(9..).unwrap_or_default()) {
            Ok(Record::Chunk { header, .. }) => header,
            Ok(_) => {
                return Err(ReadError::Record {
                    offset,
                    opcode: op::CHUNK,
                    source: mcap::McapError::BadIndex,
                });
            }
            Err(source) => {
                return Err(ReadError::Record {
                    offset,
                    opcode: op::CHUNK,
                    source,
                });
            }
        };
        let mut schemas = Vec::new();
        let mut channels = Vec::new();
        let mut counts: BTreeMap<u16, u64> = BTreeMap::new();
        let mut range: Option<(u64, u64)> = None;
        let limit = self.options.max_record_bytes;
        for_each_in_chunk(
            record,
            limit,
            |opcode, body| {
                let rec = parse_record(opcode, body).map_err(|source| ReadError::Chunk {
                    offset,
                    compression: header.compression.clone(),
                    source,
                })?;
                match rec {
                    Record::Schema { header, data } => schemas.push((header, data.into_owned())),
                    Record::Channel(c) => channels.push(c),
                    Record::Message { header: m, .. } => {
                        *counts.entry(m.channel_id).or_default() += 1;
                        range = Some(match range {
                            None => (m.log_time, m.log_time),
                            Some((a, b)) => (a.min(m.log_time), b.max(m.log_time)),
                        });
                    }
                    _ => {}
                }
                Ok(())
            },
            offset,
        )?;
        for (h, data) in schemas {
            self.add_schema(h.id, h.name, h.encoding, data);
        }
        for c in channels {
            self.add_channel(c);
        }
        for (&id, &n) in &counts {
            *self.channel_counts.entry(id).or_default() += n;
        }
        let (start_ns, end_ns) =
            range.unwrap_or((header.message_start_time, header.message_end_time));
        if range.is_some() {
            self.note_time(start_ns);
            self.note_time(end_ns);
        }
        self.chunks.push(ChunkInfo {
            offset,
            record_bytes: record.len() as u64,
            start_ns,
            end_ns,
            compression: header.compression,
            compressed_bytes: header.compressed_size,
            uncompressed_bytes: header.uncompressed_size,
            channel_ids: Some(counts.keys().copied().collect()),
        });
        Ok(())
    }

    fn scan_small_record(&mut self, offset: u64, opcode: u8, body: &[u8]) -> Result<(), ReadError> {
        let rec = parse_record(opcode, body).map_err(|source| ReadError::Record {
            offset,
            opcode,
            source,
        })?;
        match rec {
            Record::Schema { header, data } => {
                self.add_schema(header.id, header.name, header.encoding, data.into_owned());
            }
            Record::Channel(c) => self.add_channel(c),
            Record::Metadata(m) => self.metadata.push(MetadataInfo {
                name: m.name,
                entries: m.metadata,
            }),
            Record::Attachment { header, data, .. } => self.attachments.push(AttachmentInfo {
                name: header.name,
                media_type: header.media_type,
                log_time_ns: header.log_time,
                create_time_ns: header.create_time,
                offset,
                record_bytes: RECORD_PREFIX_BYTES + body.len() as u64,
                data_bytes: data.len() as u64,
            }),
            _ => {}
        }
        Ok(())
    }
}
