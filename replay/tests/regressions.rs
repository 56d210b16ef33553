//! Inputs found by fuzzing (`fuzz/fuzz_targets/mcap_reader.rs`), kept as regression tests.
//! Each must open and read without panicking or allocating what its length fields claim.

use std::io::Cursor;

use replay::{McapReader, ReadFilter, ReadOptions};

/// Opens `bytes` both ways and reads everything; returns the summary problem and the text of
/// every error met.
fn exercise(bytes: &[u8]) -> (Option<String>, Vec<String>) {
    let mut problem = None;
    let mut errors = Vec::new();
    for force_scan in [false, true] {
        let options = ReadOptions {
            max_record_bytes: 1 << 20,
            force_scan,
        };
        let mut reader = match McapReader::from_reader(Cursor::new(bytes), options) {
            Ok(r) => r,
            Err(e) => {
                errors.push(e.to_string());
                continue;
            }
        };
        if let Some(p) = reader.summary_problem() {
            problem = Some(p.to_owned());
        }
        for m in reader.messages(&ReadFilter::all()) {
            match m {
                Ok(m) => {
                    let _ = m.decode();
                }
                Err(e) => errors.push(e.to_string()),
            }
        }
        for a in reader.attachments().to_vec() {
            if let Err(e) = reader.read_attachment(&a) {
                errors.push(e.to_string());
            }
        }
    }
    (problem, errors)
}

/// An attachment index in the summary whose name claims 4294967295 bytes: the mcap parser
/// reserved that much before reading (out of memory under the fuzzer). Now refused from its
/// length, and the file falls back to the scan.
#[test]
fn attachment_index_with_a_4_gib_name_length_is_refused_without_allocating() {
    let bytes = include_bytes!("data/fuzz_attachment_index_name_len_4gib.mcap");
    let (problem, _errors) = exercise(bytes);
    let problem = problem.expect("the summary is unusable");
    assert!(problem.contains("4294967295"), "{problem}");
}

/// Every string-bearing record with a string length of u32::MAX, inside and outside chunks.
#[test]
fn huge_string_lengths_in_every_record_kind_are_refused() {
    let magic = b"\x89MCAP0\r\n";
    let record = |op: u8, body: &[u8]| {
        let mut r = vec![op];
        r.extend_from_slice(&(body.len() as u64).to_le_bytes());
        r.extend_from_slice(body);
        r
    };
    let huge = u32::MAX.to_le_bytes();
    let header = record(0x01, &[0, 0, 0, 0, 0, 0, 0, 0]);
    // (opcode, fixed prefix before the first string)
    for (op, fixed) in [
        (0x03_u8, 2_usize),
        (0x04, 4),
        (0x06, 28),
        (0x09, 16),
        (0x0c, 0),
    ] {
        let mut body = vec![0_u8; fixed];
        body.extend_from_slice(&huge);
        body.extend_from_slice(&[b'x'; 40]);
        let mut file = magic.to_vec();
        file.extend_from_slice(&header);
        file.extend_from_slice(&record(op, &body));
        let mut reader =
            McapReader::from_reader(Cursor::new(&file[..]), ReadOptions::default()).expect("open");
        let t = reader
            .recovery()
            .and_then(|r| r.truncation.clone())
            .expect("stops at the bad record");
        assert!(
            t.reason.to_string().contains("4294967295"),
            "opcode {op:#x}: {}",
            t.reason
        );
        assert_eq!(t.valid_until, (magic.len() + header.len()) as u64);
        assert!(
            reader
                .read_all(&ReadFilter::all())
                .expect("nothing to read")
                .is_empty()
        );
    }
}
