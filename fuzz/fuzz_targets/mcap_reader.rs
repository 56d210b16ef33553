//! Arbitrary bytes -> open (summary and forced scan) -> read every message (all, and
//! filtered) -> decode each -> read every attachment. Must never panic, hang or allocate
//! beyond the record limit.
#![no_main]

use std::io::Cursor;

use libfuzzer_sys::fuzz_target;
use replay::{McapReader, ReadFilter, ReadOptions};

fuzz_target!(|data: &[u8]| {
    for force_scan in [false, true] {
        let options = ReadOptions {
            max_record_bytes: 1 << 20,
            force_scan,
        };
        let Ok(mut reader) = McapReader::from_reader(Cursor::new(data), options) else {
            continue;
        };
        let _ = (
            reader.message_count(),
            reader.time_range_ns(),
            reader.recovery(),
        );
        for message in reader.messages(&ReadFilter::all()).flatten() {
            let _ = message.decode();
        }
        let filter = ReadFilter::all()
            .with_topics(["/tf", "/camera/color/image_raw"])
            .with_time_range(Some(1_000), Some(1 << 40));
        let _ = reader.messages(&filter).count();
        let attachments = reader.attachments().to_vec();
        for a in &attachments {
            let _ = reader.read_attachment(a);
        }
    }
});
