//! RustDDS (de)serializer adapters that move CDR bytes without decoding them.
//!
//! RustDDS hands an adapter the serialized payload behind the 4-byte encapsulation header and
//! the representation identifier (its first two bytes); [`RawCdr`] puts the header back in
//! front (options `00 00`) in one copy. On the way out the header is sliced off (no copy):
//! RustDDS writes its own, `00 01 00 00` (CDR_LE, [`RawCdr::output_encoding`]).

use std::convert::Infallible;

use rustdds::RepresentationIdentifier;
use rustdds::bytes::Bytes;
use rustdds::no_key::{Decode, DefaultDecoder, DeserializerAdapter, SerializerAdapter};

/// Adapter of raw CDR payloads (header included) for readers (`Vec<u8>`) and writers (`Bytes`).
pub(crate) struct RawCdr;

/// The decoder of [`RawCdr`]: prepends the encapsulation header.
#[derive(Clone, Copy)]
pub(crate) struct RawDecoder;

/// Encodings a ROS 2 reader accepts: plain CDR (XCDR1), both byte orders.
const ENCODINGS: [RepresentationIdentifier; 2] = [
    RepresentationIdentifier::CDR_LE,
    RepresentationIdentifier::CDR_BE,
];

impl DeserializerAdapter<Vec<u8>> for RawCdr {
    type Error = Infallible;
    type Decoded = Vec<u8>;

    fn supported_encodings() -> &'static [RepresentationIdentifier] {
        &ENCODINGS
    }

    fn transform_decoded(decoded: Vec<u8>) -> Vec<u8> {
        decoded
    }
}

impl DefaultDecoder<Vec<u8>> for RawCdr {
    type Decoder = RawDecoder;
    const DECODER: RawDecoder = RawDecoder;
}

impl<'de> Decode<'de, Vec<u8>> for RawDecoder {
    type Error = Infallible;

    fn decode_bytes(
        self,
        input_bytes: &'de [u8],
        encoding: RepresentationIdentifier,
    ) -> Result<Vec<u8>, Infallible> {
        Ok(with_header(encoding.to_bytes(), input_bytes))
    }
}

/// `kind` + `00 00` + `payload`.
pub(crate) fn with_header(kind: [u8; 2], payload: &[u8]) -> Vec<u8> {
    let mut cdr = Vec::with_capacity(payload.len() + msgs::cdr::HEADER_LEN);
    cdr.extend_from_slice(&kind);
    cdr.extend_from_slice(&[0, 0]);
    cdr.extend_from_slice(payload);
    cdr
}

impl SerializerAdapter<Bytes> for RawCdr {
    type Error = Infallible;

    fn output_encoding() -> RepresentationIdentifier {
        RepresentationIdentifier::CDR_LE
    }

    /// The payload behind the header; [`crate::Publisher::publish`] checked that there is one
    /// and that it says CDR_LE.
    fn to_bytes(value: &Bytes) -> Result<Bytes, Infallible> {
        Ok(value.slice(msgs::cdr::HEADER_LEN.min(value.len())..))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use msgs::Msg;
    use msgs::sensor_msgs::JointState;

    #[test]
    fn header_goes_off_and_back_on_without_touching_the_payload() {
        let msg = Msg::JointState(JointState {
            name: vec!["a".into(), "b".into()],
            position: vec![1.0, -2.5],
            ..JointState::default()
        });
        let cdr = msg.encode().expect("encode");
        let sent = Bytes::from(cdr.clone());
        let Ok(payload) = <RawCdr as SerializerAdapter<Bytes>>::to_bytes(&sent);
        assert_eq!(&payload[..], &cdr[4..]);
        let Ok(back) = RawDecoder.decode_bytes(&payload, RawCdr::output_encoding());
        assert_eq!(back, cdr);
        let Ok(decoded) = Msg::decode("sensor_msgs/msg/JointState", &back) else {
            panic!("decodes")
        };
        assert_eq!(decoded, msg);
    }
}
