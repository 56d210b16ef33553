//! Low-level MCAP records: reading at an offset, the opcode and length prefix, bounds checks
//! of a record's strings before the mcap crate parses it, and walking the records of a chunk.

use super::*;

/// Reads `len` bytes at `offset`.
pub(super) fn read_at<R: Read + Seek>(
    src: &mut R,
    offset: u64,
    len: u64,
) -> Result<Vec<u8>, ReadError> {
    let io = |source| ReadError::Io { offset, source };
    src.seek(SeekFrom::Start(offset)).map_err(io)?;
    let len_usize = usize::try_from(len).map_err(|_| ReadError::RecordTooLarge {
        offset,
        opcode: 0,
        len,
        limit: usize::MAX as u64,
    })?;
    let mut buf = vec![0_u8; len_usize];
    src.read_exact(&mut buf).map_err(io)?;
    Ok(buf)
}

/// Splits the record prefix `opcode | len` off `buf`.
pub(super) fn prefix(buf: &[u8]) -> Option<(u8, u64)> {
    let (&opcode, rest) = buf.split_first()?;
    let len_bytes: [u8; 8] = rest.get(..8)?.try_into().ok()?;
    Some((opcode, u64::from_le_bytes(len_bytes)))
}

pub(super) fn hex(bytes: &[u8]) -> String {
    bytes
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// Parses the fixed header of a message record body: (channel, sequence, log, publish).
pub(super) fn message_header(body: &[u8]) -> Option<(u16, u32, u64, u64)> {
    let channel = u16::from_le_bytes(body.get(0..2)?.try_into().ok()?);
    let sequence = u32::from_le_bytes(body.get(2..6)?.try_into().ok()?);
    let log = u64::from_le_bytes(body.get(6..14)?.try_into().ok()?);
    let publish = u64::from_le_bytes(body.get(14..22)?.try_into().ok()?);
    Some((channel, sequence, log, publish))
}

/// Parts of a record body, for [`strings_fit`].
#[derive(Debug, Clone, Copy)]
pub(super) enum Part {
    /// A fixed-size field of this many bytes.
    Fixed(usize),
    /// `u32` length + UTF-8 bytes.
    Str,
    /// `u32` byte length + (string, string) pairs.
    StrMap,
    /// `u32` byte length + fixed-size entries.
    IntMap,
}

/// Layout of the records whose bodies hold strings (MCAP spec), up to their last string.
pub(super) fn string_layout(opcode: u8) -> &'static [Part] {
    use Part::{Fixed, IntMap, Str, StrMap};
    match opcode {
        op::HEADER => &[Str, Str],
        op::SCHEMA => &[Fixed(2), Str, Str],
        op::CHANNEL => &[Fixed(4), Str, Str, StrMap],
        op::CHUNK => &[Fixed(8 + 8 + 8 + 4), Str],
        op::CHUNK_INDEX => &[Fixed(8 * 4), IntMap, Fixed(8), Str],
        op::ATTACHMENT => &[Fixed(16), Str, Str],
        op::ATTACHMENT_INDEX => &[Fixed(8 * 5), Str, Str],
        op::METADATA => &[Str, StrMap],
        op::METADATA_INDEX => &[Fixed(16), Str],
        _ => &[],
    }
}

/// Checks that every string length prefix of a record body fits in the body. The mcap crate's
/// parser reserves a string's declared length before reading it, so an unchecked corrupt
/// prefix would allocate up to 4 GiB (found by fuzzing: `replay/tests/regressions.rs`).
/// Returns the first offending length.
pub(super) fn strings_fit(opcode: u8, body: &[u8]) -> Result<(), u64> {
    fn u32_at(body: &[u8], pos: usize) -> Option<usize> {
        let b: [u8; 4] = body.get(pos..pos.checked_add(4)?)?.try_into().ok()?;
        usize::try_from(u32::from_le_bytes(b)).ok()
    }
    // Skips a string at `pos`; `None` when the body ends first (the parser reports that).
    fn string(body: &[u8], pos: usize) -> Result<Option<usize>, u64> {
        let Some(len) = u32_at(body, pos) else {
            return Ok(None);
        };
        let start = pos + 4;
        if len > body.len().saturating_sub(start) {
            return Err(len as u64);
        }
        Ok(Some(start + len))
    }
    let mut pos = 0_usize;
    for part in string_layout(opcode) {
        let next = match *part {
            Part::Fixed(n) => pos.checked_add(n).filter(|&p| p <= body.len()),
            Part::Str => string(body, pos)?,
            Part::IntMap => u32_at(body, pos).and_then(|n| (pos + 4).checked_add(n)),
            Part::StrMap => {
                let Some(len) = u32_at(body, pos) else {
                    return Ok(());
                };
                let end = (pos + 4).saturating_add(len).min(body.len());
                let mut p = pos + 4;
                while p < end {
                    let Some(after_key) = string(body, p)? else {
                        return Ok(());
                    };
                    let Some(after_value) = string(body, after_key)? else {
                        return Ok(());
                    };
                    p = after_value;
                }
                Some(end)
            }
        };
        match next {
            Some(p) => pos = p,
            None => return Ok(()),
        }
    }
    Ok(())
}

/// [`mcap::parse_record`] after [`strings_fit`]: never allocates more than the body holds.
pub(super) fn parse_record(opcode: u8, body: &[u8]) -> Result<Record<'_>, mcap::McapError> {
    strings_fit(opcode, body).map_err(|len| mcap::McapError::RecordTooLarge { opcode, len })?;
    mcap::parse_record(opcode, body)
}

/// Runs the sans-io reader over one chunk record, calling `on_record(opcode, body)` for each
/// record inside it.
pub(super) fn for_each_in_chunk(
    record: &[u8],
    max_record_bytes: u64,
    mut on_record: impl FnMut(u8, &[u8]) -> Result<(), ReadError>,
    offset: u64,
) -> Result<(), ReadError> {
    let compression = || match parse_record(op::CHUNK, record.get(9..).unwrap_or_default()) {
        Ok(Record::Chunk { header, .. }) => header.compression,
        _ => String::new(),
    };
    // The sans-io reader parses the chunk header itself: check its string first.
    if let Err(len) = strings_fit(op::CHUNK, record.get(9..).unwrap_or_default()) {
        return Err(ReadError::Chunk {
            offset,
            compression: String::new(),
            source: mcap::McapError::RecordTooLarge {
                opcode: op::CHUNK,
                len,
            },
        });
    }
    let limit = usize::try_from(max_record_bytes).unwrap_or(usize::MAX);
    let mut reader = LinearReader::new_with_options(
        LinearReaderOptions::default()
            .with_skip_start_magic(true)
            .with_skip_end_magic(true)
            .with_emit_chunks(false)
            .with_validate_chunk_crcs(true)
            .with_record_length_limit(limit),
    );
    let mut rest = record;
    while let Some(event) = reader.next_event() {
        match event {
            Ok(LinearReadEvent::ReadRequest(need)) => {
                let n = need.min(rest.len());
                let (now, later) = rest.split_at(n);
                reader.insert(n).copy_from_slice(now);
                reader.notify_read(n);
                rest = later;
            }
            Ok(LinearReadEvent::Record { data, opcode }) => on_record(opcode, data)?,
            Err(source) => {
                return Err(ReadError::Chunk {
                    offset,
                    compression: compression(),
                    source,
                });
            }
        }
    }
    Ok(())
}
