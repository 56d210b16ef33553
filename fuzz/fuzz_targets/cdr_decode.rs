//! Arbitrary bytes -> `Msg::decode` of every type name. Must never panic; whatever decodes
//! must re-encode, and the re-encoding must decode and encode to the same bytes.
#![no_main]

use libfuzzer_sys::fuzz_target;
use msgs::Msg;

fuzz_target!(|data: &[u8]| {
    for name in Msg::TYPE_NAMES {
        let Ok(msg) = Msg::decode(name, data) else {
            continue;
        };
        let Ok(bytes) = msg.encode() else {
            panic!("{name}: a decoded message does not re-encode");
        };
        let Ok(again) = Msg::decode(name, &bytes) else {
            panic!("{name}: a re-encoded message does not decode");
        };
        assert_eq!(
            again.encode().ok(),
            Some(bytes),
            "{name}: encoding is not stable"
        );
    }
});
