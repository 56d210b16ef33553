//! Opening a finished file by its summary section: the footer points at the schemas,
//! channels, statistics and the chunk, attachment and metadata indexes.

use super::*;

impl<R: Read + Seek> McapReader<R> {
    /// Uses the summary if the file has a usable one. `Ok(false)`: no summary (scan).
    pub(super) fn try_summary(&mut self) -> Result<bool, ReadError> {
        if self.file_bytes < 8 + FOOTER_RECORD_BYTES + 8 {
            return Ok(false);
        }
        let footer_at = self.file_bytes - 8 - FOOTER_RECORD_BYTES;
        let tail = read_at(&mut self.src, footer_at, FOOTER_RECORD_BYTES + 8)?;
        let (Some(footer_bytes), Some(end_magic)) = (
            tail.get(..FOOTER_RECORD_BYTES as usize),
            tail.get(FOOTER_RECORD_BYTES as usize..),
        ) else {
            return Ok(false);
        };
        if end_magic != MAGIC || prefix(footer_bytes) != Some((op::FOOTER, 20)) {
            return Ok(false);
        }
        let Ok(Record::Footer(footer)) =
            parse_record(op::FOOTER, footer_bytes.get(9..).unwrap_or_default())
        else {
            return Ok(false);
        };
        if footer.summary_start == 0 {
            return Ok(false);
        }
        let bad = |reason: String| ReadError::Summary {
            offset: footer.summary_start,
            reason,
        };
        if footer.summary_start < 8 || footer.summary_start > footer_at {
            return Err(bad(format!(
                "summary_start {} outside the file (footer at {footer_at})",
                footer.summary_start
            )));
        }
        let summary = read_at(
            &mut self.src,
            footer.summary_start,
            footer_at - footer.summary_start,
        )?;
        let mut stats = None;
        let mut chunk_indexes = Vec::new();
        let mut attachment_indexes = Vec::new();
        let mut metadata_indexes = Vec::new();
        let mut pos = 0_usize;
        while pos < summary.len() {
            let rec_offset = footer.summary_start + pos as u64;
            let Some((opcode, len)) = summary.get(pos..).and_then(prefix) else {
                return Err(bad(format!("record prefix cut at offset {rec_offset}")));
            };
            let body_start = pos + RECORD_PREFIX_BYTES as usize;
            let Some(body) = usize::try_from(len)
                .ok()
                .and_then(|l| body_start.checked_add(l))
                .and_then(|end| summary.get(body_start..end))
            else {
                return Err(bad(format!(
                    "record at offset {rec_offset} declares {len} bytes past the footer"
                )));
            };
            pos = body_start + body.len();
            let rec = parse_record(opcode, body).map_err(|e| {
                bad(format!(
                    "record (opcode {opcode:#04x}) at offset {rec_offset}: {e}"
                ))
            })?;
            match rec {
                Record::Schema { header, data } => {
                    self.add_schema(header.id, header.name, header.encoding, data.into_owned());
                }
                Record::Channel(c) => self.add_channel(c),
                Record::Statistics(s) => stats = Some(s),
                Record::ChunkIndex(c) => chunk_indexes.push(c),
                Record::AttachmentIndex(a) => attachment_indexes.push(a),
                Record::MetadataIndex(m) => metadata_indexes.push(m),
                _ => {}
            }
        }
        let Some(stats) = stats else {
            return Err(bad("no statistics record".into()));
        };
        if stats.chunk_count as usize != chunk_indexes.len() {
            return Err(bad(format!(
                "statistics count {} chunks, {} chunk indexes",
                stats.chunk_count,
                chunk_indexes.len()
            )));
        }
        let indexed: u64 = stats.channel_message_counts.values().sum();
        if stats.message_count > 0 && (chunk_indexes.is_empty() || indexed != stats.message_count) {
            // Messages outside chunks, or counts that do not add up: scan instead.
            return Ok(false);
        }
        for c in chunk_indexes {
            let in_file = c
                .chunk_start_offset
                .checked_add(c.chunk_length)
                .is_some_and(|end| end <= footer.summary_start);
            if !in_file {
                return Err(bad(format!(
                    "chunk index points at {}+{} beyond the data section",
                    c.chunk_start_offset, c.chunk_length
                )));
            }
            self.chunks.push(ChunkInfo {
                offset: c.chunk_start_offset,
                record_bytes: c.chunk_length,
                start_ns: c.message_start_time,
                end_ns: c.message_end_time,
                compression: c.compression,
                compressed_bytes: c.compressed_size,
                uncompressed_bytes: c.uncompressed_size,
                channel_ids: if c.message_index_offsets.is_empty() {
                    None
                } else {
                    Some(c.message_index_offsets.keys().copied().collect())
                },
            });
        }
        for m in metadata_indexes {
            if m.length > self.options.max_record_bytes
                || m.offset.saturating_add(m.length) > footer.summary_start
            {
                return Err(bad(format!("metadata index {:?} out of range", m.name)));
            }
            let rec = read_at(&mut self.src, m.offset, m.length)?;
            match rec.get(9..).map(|b| parse_record(op::METADATA, b)) {
                Some(Ok(Record::Metadata(md))) => self.metadata.push(MetadataInfo {
                    name: md.name,
                    entries: md.metadata,
                }),
                _ => return Err(bad(format!("metadata record {:?} unreadable", m.name))),
            }
        }
        for a in attachment_indexes {
            self.attachments.push(AttachmentInfo {
                name: a.name,
                media_type: a.media_type,
                log_time_ns: a.log_time,
                create_time_ns: a.create_time,
                offset: a.offset,
                record_bytes: a.length,
                data_bytes: a.data_size,
            });
        }
        self.channel_counts = stats.channel_message_counts;
        if stats.message_count > 0 {
            self.time_range_ns = Some((stats.message_start_time, stats.message_end_time));
        }
        Ok(true)
    }
}
