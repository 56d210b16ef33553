//! CDR (XCDR1, "plain CDR") codec as ROS 2 uses it, as a serde `Serializer`/`Deserializer`.
//!
//! # Wire format (OMG DDS-XTypes 1.3, section 7.4.1 "XCDR version 1"; OMG CORBA 3.4 part 2, 9.3)
//!
//! ```text
//! [0x00 kind] [opt0 opt1]  payload...
//!  kind 0x01 = CDR_LE, 0x00 = CDR_BE      options: ignored on read, written as 0x00 0x00
//! ```
//! - Every primitive of size `n` (1, 2, 4, 8 bytes) is aligned to a multiple of `n`, measured
//!   from the first byte *after* the 4-byte encapsulation header: padding
//!   `p = (n - (pos - 4) mod n) mod n` zero bytes precede it.
//! - `bool` is one byte (0 or 1; anything else is an error on read).
//! - `string`: `uint32` length *including* the NUL terminator, the UTF-8 bytes, the NUL.
//!   An empty string is `01 00 00 00 00`. A length of 0 (written by some non-ROS DDS
//!   vendors for empty strings) is accepted on read as the empty string.
//! - Sequences `T[]`: `uint32` element count, then the elements (each aligned itself).
//! - Fixed arrays `T[N]` (Rust `[T; N]`, serialised by serde as a tuple): the `N` elements,
//!   **no** count.
//! - Structs: the fields in order, no header and no alignment of their own.
//! - Byte sequences `uint8[]` go through [`bytes`] (serde `serialize_bytes`), a single
//!   `memcpy` each way: a 1280x1024 rgb8 image is 3.9 MB and must not be a per-element loop.
//!
//! Writing is always little-endian (`00 01 00 00`) and without trailing padding; reading
//! accepts both endiannesses.
//!
//! # Trailing bytes policy
//!
//! RTPS payloads are padded to a multiple of 4 bytes, so recordings made by ROS 2 (rosbag2)
//! often carry 1-3 zero bytes after the last field. [`from_cdr`] accepts up to
//! [`MAX_TRAILING_PADDING`] (= 3) trailing bytes if they are all zero, and rejects anything
//! else with [`CdrError::TrailingBytes`]: more than 3 bytes, or non-zero bytes, means the
//! bytes were decoded with the wrong type.
//!
//! # Rejected encapsulations
//!
//! XCDR2 (`0x00 0x06`..`0x00 0x0b`: CDR2, D_CDR2, PL_CDR2, each BE/LE) is rejected with
//! [`CdrError::Xcdr2Encapsulation`]; parameter-list CDR1 (`0x00 0x02`, `0x00 0x03`) and any
//! other kind with [`CdrError::UnsupportedEncapsulation`].

use serde::de::{DeserializeOwned, DeserializeSeed, SeqAccess, Visitor};
use serde::ser::{self, Serialize};
use thiserror::Error;

/// Size of the encapsulation header (`0x00 kind opt0 opt1`).
pub const HEADER_LEN: usize = 4;
/// Encapsulation header written by [`to_cdr`]: CDR_LE, options 0.
pub const HEADER_CDR_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];
/// Encapsulation header of big-endian plain CDR (read only).
pub const HEADER_CDR_BE: [u8; 4] = [0x00, 0x00, 0x00, 0x00];
/// Most trailing zero bytes accepted after the last field (RTPS pads payloads to 4 bytes).
pub const MAX_TRAILING_PADDING: usize = 3;

/// Errors of the CDR codec. Offsets are byte offsets into the whole buffer, header included.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum CdrError {
    /// The input ended before a value was complete.
    #[error("CDR input truncated: need {needed} bytes at offset {offset}, only {available} left")]
    Truncated {
        /// Offset of the value being read.
        offset: usize,
        /// Bytes the value needs (including alignment padding).
        needed: usize,
        /// Bytes left from `offset` to the end of the input.
        available: usize,
    },
    /// The encapsulation header says XCDR2, which ROS 2 (XCDR1) does not write.
    #[error(
        "CDR encapsulation {b0:#04x} {b1:#04x} is XCDR2, not supported: ROS 2 uses XCDR1 (0x00 0x01 little-endian, 0x00 0x00 big-endian)"
    )]
    Xcdr2Encapsulation {
        /// First header byte.
        b0: u8,
        /// Second header byte.
        b1: u8,
    },
    /// The encapsulation header is neither CDR_LE, CDR_BE nor XCDR2.
    #[error(
        "unsupported CDR encapsulation {b0:#04x} {b1:#04x} (expected 0x00 0x01 CDR_LE or 0x00 0x00 CDR_BE)"
    )]
    UnsupportedEncapsulation {
        /// First header byte.
        b0: u8,
        /// Second header byte.
        b1: u8,
    },
    /// A `bool` byte was neither 0 nor 1.
    #[error("invalid bool byte {value:#04x} at offset {offset} (must be 0 or 1)")]
    BadBool {
        /// Offset of the byte.
        offset: usize,
        /// The byte found.
        value: u8,
    },
    /// A string's bytes were not valid UTF-8.
    #[error("string at offset {offset} ({len} bytes) is not valid UTF-8: {reason}")]
    BadUtf8 {
        /// Offset of the first string byte (after the length).
        offset: usize,
        /// Length field (including the NUL).
        len: usize,
        /// What `std::str::from_utf8` said.
        reason: String,
    },
    /// A string's last byte was not the NUL terminator.
    #[error(
        "string at offset {offset} of length {len} does not end with NUL (last byte {last:#04x})"
    )]
    MissingNul {
        /// Offset of the first string byte (after the length).
        offset: usize,
        /// Length field (including the NUL).
        len: usize,
        /// The byte found where the NUL should be.
        last: u8,
    },
    /// A sequence count is larger than the remaining input could hold.
    #[error(
        "sequence at offset {offset} claims {count} elements but only {available} bytes are left"
    )]
    SequenceTooLong {
        /// Offset of the first element.
        offset: usize,
        /// Count read from the wire.
        count: usize,
        /// Bytes left.
        available: usize,
    },
    /// Bytes left after the value that are not up to 3 zero padding bytes.
    #[error(
        "{count} trailing bytes after the message at offset {offset} (at most {MAX_TRAILING_PADDING} zero padding bytes are allowed)"
    )]
    TrailingBytes {
        /// Offset where the value ended.
        offset: usize,
        /// Number of bytes left.
        count: usize,
    },
    /// A string or sequence is longer than a `uint32` length can say.
    #[error("length {len} does not fit the uint32 CDR length field")]
    LengthOverflow {
        /// The length.
        len: usize,
    },
    /// A serde construct CDR cannot represent (maps, options, enums, `deserialize_any`, ...).
    #[error("CDR cannot represent {what}")]
    Unsupported {
        /// The construct.
        what: &'static str,
    },
    /// A message from a `Serialize`/`Deserialize` impl.
    #[error("{0}")]
    Custom(String),
}

impl ser::Error for CdrError {
    fn custom<T: std::fmt::Display>(msg: T) -> Self {
        CdrError::Custom(msg.to_string())
    }
}

impl serde::de::Error for CdrError {
    fn custom<T: std::fmt::Display>(msg: T) -> Self {
        CdrError::Custom(msg.to_string())
    }
}

/// Encodes `value` as little-endian XCDR1 with the 4-byte encapsulation header.
///
/// # Errors
/// [`CdrError::LengthOverflow`] for strings/sequences longer than `u32::MAX`,
/// [`CdrError::Unsupported`] for serde constructs outside ROS 2 messages (maps, options).
pub fn to_cdr<T: Serialize + ?Sized>(value: &T) -> Result<Vec<u8>, CdrError> {
    let mut out = Vec::new();
    to_cdr_into(value, &mut out)?;
    Ok(out)
}

/// Like [`to_cdr`] but writes into `out`, which is cleared first (its allocation is reused).
///
/// # Errors
/// As [`to_cdr`]; on error `out` holds a partial encoding.
pub fn to_cdr_into<T: Serialize + ?Sized>(value: &T, out: &mut Vec<u8>) -> Result<(), CdrError> {
    out.clear();
    out.extend_from_slice(&HEADER_CDR_LE);
    let mut ser = CdrSerializer {
        out,
        origin: HEADER_LEN,
    };
    value.serialize(&mut ser)
}

/// Decodes one value from XCDR1 bytes (header included), either endianness.
///
/// # Errors
/// Header errors ([`CdrError::Xcdr2Encapsulation`], [`CdrError::UnsupportedEncapsulation`],
/// [`CdrError::Truncated`] for fewer than 4 bytes), value errors (truncation, bad bool, bad
/// UTF-8, missing NUL, impossible sequence counts) and [`CdrError::TrailingBytes`].
pub fn from_cdr<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, CdrError> {
    let mut de = CdrDeserializer::new(bytes)?;
    let value = T::deserialize(&mut de)?;
    de.finish()?;
    Ok(value)
}

/// Checks the encapsulation header; returns `true` for big-endian.
///
/// # Errors
/// See [`from_cdr`].
pub fn parse_header(bytes: &[u8]) -> Result<bool, CdrError> {
    let &[b0, b1, _, _, ..] = bytes else {
        return Err(CdrError::Truncated {
            offset: 0,
            needed: HEADER_LEN,
            available: bytes.len(),
        });
    };
    match (b0, b1) {
        (0x00, 0x01) => Ok(false),
        (0x00, 0x00) => Ok(true),
        (0x00, 0x06..=0x0b) => Err(CdrError::Xcdr2Encapsulation { b0, b1 }),
        _ => Err(CdrError::UnsupportedEncapsulation { b0, b1 }),
    }
}

/// serde-with module for `uint8[]` fields: one `memcpy` instead of a per-element loop.
///
/// Use as `#[serde(with = "crate::cdr::bytes")] pub data: Vec<u8>`. With CDR this is the
/// ordinary sequence encoding (uint32 count + bytes); self-describing formats see a byte
/// string (and sequences of numbers are accepted on read).
pub mod bytes {
    use serde::de::{Deserializer, SeqAccess, Visitor};
    use serde::ser::Serializer;

    /// Serialises a byte slice with `serialize_bytes`.
    ///
    /// # Errors
    /// Those of the serializer.
    pub fn serialize<S: Serializer>(bytes: &[u8], serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_bytes(bytes)
    }

    /// Deserialises a byte buffer with `deserialize_byte_buf`.
    ///
    /// # Errors
    /// Those of the deserializer.
    pub fn deserialize<'de, D: Deserializer<'de>>(deserializer: D) -> Result<Vec<u8>, D::Error> {
        deserializer.deserialize_byte_buf(BytesVisitor)
    }

    struct BytesVisitor;

    impl<'de> Visitor<'de> for BytesVisitor {
        type Value = Vec<u8>;

        fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            f.write_str("a byte array")
        }

        fn visit_bytes<E: serde::de::Error>(self, v: &[u8]) -> Result<Vec<u8>, E> {
            Ok(v.to_vec())
        }

        fn visit_byte_buf<E: serde::de::Error>(self, v: Vec<u8>) -> Result<Vec<u8>, E> {
            Ok(v)
        }

        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Vec<u8>, A::Error> {
            let mut out = Vec::with_capacity(seq.size_hint().unwrap_or(0).min(1 << 20));
            while let Some(b) = seq.next_element::<u8>()? {
                out.push(b);
            }
            Ok(out)
        }
    }
}

// ------------------------------------------------------------------------------------------
// Serializer
// ------------------------------------------------------------------------------------------

/// Little-endian XCDR1 serializer writing after an existing encapsulation header.
pub struct CdrSerializer<'a> {
    out: &'a mut Vec<u8>,
    /// Index in `out` that alignment is measured from (first byte after the header).
    origin: usize,
}

impl CdrSerializer<'_> {
    fn align(&mut self, n: usize) {
        let pos = self.out.len() - self.origin;
        let pad = (n - pos % n) % n;
        self.out.resize(self.out.len() + pad, 0);
    }

    fn write_len(&mut self, len: usize) -> Result<(), CdrError> {
        let len32 = u32::try_from(len).map_err(|_| CdrError::LengthOverflow { len })?;
        self.align(4);
        self.out.extend_from_slice(&len32.to_le_bytes());
        Ok(())
    }
}

macro_rules! ser_prim {
    ($fn:ident, $t:ty) => {
        fn $fn(self, v: $t) -> Result<(), CdrError> {
            self.align(std::mem::size_of::<$t>());
            self.out.extend_from_slice(&v.to_le_bytes());
            Ok(())
        }
    };
}

impl<'b> ser::Serializer for &mut CdrSerializer<'b> {
    type Ok = ();
    type Error = CdrError;
    type SerializeSeq = Self;
    type SerializeTuple = Self;
    type SerializeTupleStruct = Self;
    type SerializeTupleVariant = ser::Impossible<(), CdrError>;
    type SerializeMap = ser::Impossible<(), CdrError>;
    type SerializeStruct = Self;
    type SerializeStructVariant = ser::Impossible<(), CdrError>;

    fn serialize_bool(self, v: bool) -> Result<(), CdrError> {
        self.out.push(u8::from(v));
        Ok(())
    }
    ser_prim!(serialize_i8, i8);
    ser_prim!(serialize_i16, i16);
    ser_prim!(serialize_i32, i32);
    ser_prim!(serialize_i64, i64);
    ser_prim!(serialize_u8, u8);
    ser_prim!(serialize_u16, u16);
    ser_prim!(serialize_u32, u32);
    ser_prim!(serialize_u64, u64);
    ser_prim!(serialize_f32, f32);
    ser_prim!(serialize_f64, f64);

    fn serialize_char(self, _v: char) -> Result<(), CdrError> {
        Err(CdrError::Unsupported {
            what: "Rust char (use u8 for ROS char)",
        })
    }

    fn serialize_str(self, v: &str) -> Result<(), CdrError> {
        self.write_len(v.len() + 1)?;
        self.out.extend_from_slice(v.as_bytes());
        self.out.push(0);
        Ok(())
    }

    fn serialize_bytes(self, v: &[u8]) -> Result<(), CdrError> {
        self.write_len(v.len())?;
        self.out.extend_from_slice(v);
        Ok(())
    }

    fn serialize_none(self) -> Result<(), CdrError> {
        Err(CdrError::Unsupported { what: "Option" })
    }

    fn serialize_some<T: Serialize + ?Sized>(self, _value: &T) -> Result<(), CdrError> {
        Err(CdrError::Unsupported { what: "Option" })
    }

    fn serialize_unit(self) -> Result<(), CdrError> {
        Ok(())
    }

    fn serialize_unit_struct(self, _name: &'static str) -> Result<(), CdrError> {
        Ok(())
    }

    fn serialize_unit_variant(
        self,
        _name: &'static str,
        _index: u32,
        _variant: &'static str,
    ) -> Result<(), CdrError> {
        Err(CdrError::Unsupported { what: "enum" })
    }

    fn serialize_newtype_struct<T: Serialize + ?Sized>(
        self,
        _name: &'static str,
        value: &T,
    ) -> Result<(), CdrError> {
        value.serialize(self)
    }

    fn serialize_newtype_variant<T: Serialize + ?Sized>(
        self,
        _name: &'static str,
        _index: u32,
        _variant: &'static str,
        _value: &T,
    ) -> Result<(), CdrError> {
        Err(CdrError::Unsupported { what: "enum" })
    }

    fn serialize_seq(self, len: Option<usize>) -> Result<Self, CdrError> {
        let Some(len) = len else {
            return Err(CdrError::Unsupported {
                what: "sequence of unknown length",
            });
        };
        self.write_len(len)?;
        Ok(self)
    }

    fn serialize_tuple(self, _len: usize) -> Result<Self, CdrError> {
        Ok(self)
    }

    fn serialize_tuple_struct(self, _name: &'static str, _len: usize) -> Result<Self, CdrError> {
        Ok(self)
    }

    fn serialize_tuple_variant(
        self,
        _name: &'static str,
        _index: u32,
        _variant: &'static str,
        _len: usize,
    ) -> Result<Self::SerializeTupleVariant, CdrError> {
        Err(CdrError::Unsupported { what: "enum" })
    }

    fn serialize_map(self, _len: Option<usize>) -> Result<Self::SerializeMap, CdrError> {
        Err(CdrError::Unsupported { what: "map" })
    }

    fn serialize_struct(self, _name: &'static str, _len: usize) -> Result<Self, CdrError> {
        Ok(self)
    }

    fn serialize_struct_variant(
        self,
        _name: &'static str,
        _index: u32,
        _variant: &'static str,
        _len: usize,
    ) -> Result<Self::SerializeStructVariant, CdrError> {
        Err(CdrError::Unsupported { what: "enum" })
    }

    fn is_human_readable(&self) -> bool {
        false
    }
}

impl ser::SerializeSeq for &mut CdrSerializer<'_> {
    type Ok = ();
    type Error = CdrError;
    fn serialize_element<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), CdrError> {
        value.serialize(&mut **self)
    }
    fn end(self) -> Result<(), CdrError> {
        Ok(())
    }
}

impl ser::SerializeTuple for &mut CdrSerializer<'_> {
    type Ok = ();
    type Error = CdrError;
    fn serialize_element<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), CdrError> {
        value.serialize(&mut **self)
    }
    fn end(self) -> Result<(), CdrError> {
        Ok(())
    }
}

impl ser::SerializeTupleStruct for &mut CdrSerializer<'_> {
    type Ok = ();
    type Error = CdrError;
    fn serialize_field<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), CdrError> {
        value.serialize(&mut **self)
    }
    fn end(self) -> Result<(), CdrError> {
        Ok(())
    }
}

impl ser::SerializeStruct for &mut CdrSerializer<'_> {
    type Ok = ();
    type Error = CdrError;
    fn serialize_field<T: Serialize + ?Sized>(
        &mut self,
        _key: &'static str,
        value: &T,
    ) -> Result<(), CdrError> {
        value.serialize(&mut **self)
    }
    fn end(self) -> Result<(), CdrError> {
        Ok(())
    }
}

// ------------------------------------------------------------------------------------------
// Deserializer
// ------------------------------------------------------------------------------------------

/// XCDR1 deserializer over a whole buffer (header included), either endianness.
pub struct CdrDeserializer<'de> {
    data: &'de [u8],
    /// Absolute read position in `data`.
    pos: usize,
    big_endian: bool,
}

impl<'de> CdrDeserializer<'de> {
    /// Parses the encapsulation header and positions the reader after it.
    ///
    /// # Errors
    /// See [`parse_header`].
    pub fn new(data: &'de [u8]) -> Result<Self, CdrError> {
        let big_endian = parse_header(data)?;
        Ok(Self {
            data,
            pos: HEADER_LEN,
            big_endian,
        })
    }

    /// Whether the payload is big-endian.
    pub fn is_big_endian(&self) -> bool {
        self.big_endian
    }

    /// Checks the trailing-bytes policy after the value was read (see the module docs).
    ///
    /// # Errors
    /// [`CdrError::TrailingBytes`].
    pub fn finish(&self) -> Result<(), CdrError> {
        let rest = self.data.get(self.pos..).unwrap_or(&[]);
        if rest.len() <= MAX_TRAILING_PADDING && rest.iter().all(|&b| b == 0) {
            Ok(())
        } else {
            Err(CdrError::TrailingBytes {
                offset: self.pos,
                count: rest.len(),
            })
        }
    }

    fn remaining(&self) -> usize {
        self.data.len().saturating_sub(self.pos)
    }

    /// Skips the padding before a primitive of size `n` and returns its `n` bytes.
    fn take_aligned(&mut self, n: usize) -> Result<&'de [u8], CdrError> {
        let pad = (n - (self.pos - HEADER_LEN) % n) % n;
        let start = self.pos + pad;
        let Some(bytes) = self.data.get(start..start + n) else {
            return Err(CdrError::Truncated {
                offset: self.pos,
                needed: pad + n,
                available: self.remaining(),
            });
        };
        self.pos = start + n;
        Ok(bytes)
    }

    fn take(&mut self, n: usize) -> Result<&'de [u8], CdrError> {
        let Some(bytes) = self
            .pos
            .checked_add(n)
            .and_then(|end| self.data.get(self.pos..end))
        else {
            return Err(CdrError::Truncated {
                offset: self.pos,
                needed: n,
                available: self.remaining(),
            });
        };
        self.pos += n;
        Ok(bytes)
    }

    fn read_array<const N: usize>(&mut self) -> Result<[u8; N], CdrError> {
        let offset = self.pos;
        let bytes = self.take_aligned(N)?;
        <[u8; N]>::try_from(bytes).map_err(|_| CdrError::Truncated {
            offset,
            needed: N,
            available: bytes.len(),
        })
    }

    fn read_len(&mut self) -> Result<usize, CdrError> {
        let raw = self.read_array::<4>()?;
        let v = if self.big_endian {
            u32::from_be_bytes(raw)
        } else {
            u32::from_le_bytes(raw)
        };
        Ok(v as usize)
    }

    fn read_str(&mut self) -> Result<&'de str, CdrError> {
        let len = self.read_len()?;
        if len == 0 {
            return Ok("");
        }
        let offset = self.pos;
        let bytes = self.take(len)?;
        let (body, last) = match bytes.split_last() {
            Some((&last, body)) => (body, last),
            None => (bytes, 0),
        };
        if last != 0 {
            return Err(CdrError::MissingNul { offset, len, last });
        }
        std::str::from_utf8(body).map_err(|e| CdrError::BadUtf8 {
            offset,
            len,
            reason: e.to_string(),
        })
    }
}

macro_rules! de_prim {
    ($fn:ident, $visit:ident, $t:ty) => {
        fn $fn<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, CdrError> {
            let raw = self.read_array::<{ std::mem::size_of::<$t>() }>()?;
            let v = if self.big_endian {
                <$t>::from_be_bytes(raw)
            } else {
                <$t>::from_le_bytes(raw)
            };
            visitor.$visit(v)
        }
    };
}

struct Access<'a, 'de> {
    de: &'a mut CdrDeserializer<'de>,
    remaining: usize,
}

impl<'de> SeqAccess<'de> for Access<'_, 'de> {
    type Error = CdrError;

    fn next_element_seed<T: DeserializeSeed<'de>>(
        &mut self,
        seed: T,
    ) -> Result<Option<T::Value>, CdrError> {
        if self.remaining == 0 {
            return Ok(None);
        }
        self.remaining -= 1;
        seed.deserialize(&mut *self.de).map(Some)
    }

    fn size_hint(&self) -> Option<usize> {
        Some(self.remaining)
    }
}

impl<'de> serde::Deserializer<'de> for &mut CdrDeserializer<'de> {
    type Error = CdrError;

    fn deserialize_any<V: Visitor<'de>>(self, _visitor: V) -> Result<V::Value, CdrError> {
        Err(CdrError::Unsupported {
            what: "deserialize_any (CDR is not self-describing)",
        })
    }

    fn deserialize_bool<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, CdrError> {
        let offset = self.pos;
        let [b] = self.read_array::<1>()?;
        match b {
            0 => visitor.visit_bool(false),
            1 => visitor.visit_bool(true),
            value => Err(CdrError::BadBool { offset, value }),
        }
    }

    de_prim!(deserialize_i8, visit_i8, i8);
    de_prim!(deserialize_i16, visit_i16, i16);
    de_prim!(deserialize_i32, visit_i32, i32);
    de_prim!(deserialize_i64, visit_i64, i64);
    de_prim!(deserialize_u8, visit_u8, u8);
    de_prim!(deserialize_u16, visit_u16, u16);
    de_prim!(deserialize_u32, visit_u32, u32);
    de_prim!(deserialize_u64, visit_u64, u64);
    de_prim!(deserialize_f32, visit_f32, f32);
    de_prim!(deserialize_f64, visit_f64, f64);

    fn deserialize_char<V: Visitor<'de>>(self, _visitor: V) -> Result<V::Value, CdrError> {
        Err(CdrError::Unsupported {
            what: "Rust char (use u8 for ROS char)",
        })
    }

    fn deserialize_str<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, CdrError> {
        let s = self.read_str()?;
        visitor.visit_borrowed_str(s)
    }

    fn deserialize_string<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, CdrError> {
        self.deserialize_str(visitor)
    }

    fn deserialize_bytes<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, CdrError> {
        let len = self.read_len()?;
        let bytes = self.take(len)?;
        visitor.visit_borrowed_bytes(bytes)
    }

    fn deserialize_byte_buf<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, CdrError> {
        self.deserialize_bytes(visitor)
    }

    fn deserialize_option<V: Visitor<'de>>(self, _visitor: V) -> Result<V::Value, CdrError> {
        Err(CdrError::Unsupported { what: "Option" })
    }

    fn deserialize_unit<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, CdrError> {
        visitor.visit_unit()
    }

    fn deserialize_unit_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        visitor: V,
    ) -> Result<V::Value, CdrError> {
        visitor.visit_unit()
    }

    fn deserialize_newtype_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        visitor: V,
    ) -> Result<V::Value, CdrError> {
        visitor.visit_newtype_struct(self)
    }

    fn deserialize_seq<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, CdrError> {
        let count = self.read_len()?;
        // Every element of a ROS message occupies at least one byte.
        if count > self.remaining() {
            return Err(CdrError::SequenceTooLong {
                offset: self.pos,
                count,
                available: self.remaining(),
            });
        }
        visitor.visit_seq(Access {
            de: self,
            remaining: count,
        })
    }

    fn deserialize_tuple<V: Visitor<'de>>(
        self,
        len: usize,
        visitor: V,
    ) -> Result<V::Value, CdrError> {
        visitor.visit_seq(Access {
            de: self,
            remaining: len,
        })
    }

    fn deserialize_tuple_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        len: usize,
        visitor: V,
    ) -> Result<V::Value, CdrError> {
        self.deserialize_tuple(len, visitor)
    }

    fn deserialize_map<V: Visitor<'de>>(self, _visitor: V) -> Result<V::Value, CdrError> {
        Err(CdrError::Unsupported { what: "map" })
    }

    fn deserialize_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        fields: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, CdrError> {
        self.deserialize_tuple(fields.len(), visitor)
    }

    fn deserialize_enum<V: Visitor<'de>>(
        self,
        _name: &'static str,
        _variants: &'static [&'static str],
        _visitor: V,
    ) -> Result<V::Value, CdrError> {
        Err(CdrError::Unsupported { what: "enum" })
    }

    fn deserialize_identifier<V: Visitor<'de>>(self, _visitor: V) -> Result<V::Value, CdrError> {
        Err(CdrError::Unsupported {
            what: "identifier (CDR is not self-describing)",
        })
    }

    fn deserialize_ignored_any<V: Visitor<'de>>(self, _visitor: V) -> Result<V::Value, CdrError> {
        Err(CdrError::Unsupported {
            what: "ignored_any (CDR is not self-describing)",
        })
    }

    fn is_human_readable(&self) -> bool {
        false
    }
}
