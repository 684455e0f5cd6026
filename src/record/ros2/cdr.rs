//! A minimal CDR serializer: what ROS 2 messages need, little-endian only.
//!
//! ROS 2 serializes messages as OMG CDR (XCDR version 1, "plain CDR", DDS-XTYPES 1.3 §7.4.3.5
//! "CDR: Version 1"; the byte layout is that of CORBA 3.x GIOP §9.3 "CDR Transfer Syntax"):
//!
//! - a 4-byte encapsulation header: representation identifier `00 01` (`CDR_LE`, little
//!   endian), then two option bytes `00 00`;
//! - each primitive aligned to its own size (`u8` 1, `i32`/`u32` 4, `f64`/`u64` 8), the
//!   alignment counted from the first byte AFTER the 4-byte header, padding bytes zero;
//! - a `string`: `u32` length counting the terminating NUL, the UTF-8 bytes, the NUL;
//! - a sequence (`T[]`): `u32` element count, then the elements, each aligned as above;
//! - a nested struct: its fields in order, with no alignment or padding of its own.
//!
//! Written here rather than through `serde` so that the bytes of every message are spelled out
//! next to its `.msg` definition ([`super::msgs`]); the tests decode them with two
//! independent readers (`mcap-ros2-support` and `rosbags`).

/// The encapsulation header of little-endian plain CDR.
pub const ENCAPSULATION_CDR_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// Appends CDR-encoded values to a byte buffer that starts with the encapsulation header.
#[derive(Debug)]
pub struct CdrWriter<'a> {
    buf: &'a mut Vec<u8>,
}

impl<'a> CdrWriter<'a> {
    /// Clears `buf` and writes the encapsulation header into it.
    pub fn new(buf: &'a mut Vec<u8>) -> Self {
        buf.clear();
        buf.extend_from_slice(&ENCAPSULATION_CDR_LE);
        Self { buf }
    }

    /// Zero bytes up to the next multiple of `n` counted from the end of the header.
    fn align(&mut self, n: usize) {
        let offset = self.buf.len() - ENCAPSULATION_CDR_LE.len();
        let pad = (n - offset % n) % n;
        self.buf.resize(self.buf.len() + pad, 0);
    }

    /// A `bool`: one byte, 0 or 1.
    pub fn bool(&mut self, v: bool) {
        self.buf.push(u8::from(v));
    }

    pub fn u32(&mut self, v: u32) {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    pub fn i32(&mut self, v: i32) {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    pub fn u64(&mut self, v: u64) {
        self.align(8);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    pub fn f64(&mut self, v: f64) {
        self.align(8);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    /// A `string`. Fails for strings longer than `u32::MAX - 1` bytes (CDR cannot say it).
    pub fn string(&mut self, s: &str) -> anyhow::Result<()> {
        let len = u32::try_from(s.len() + 1)
            .map_err(|_| anyhow::anyhow!("a CDR string holds at most 4 GiB"))?;
        self.u32(len);
        self.buf.extend_from_slice(s.as_bytes());
        self.buf.push(0);
        Ok(())
    }

    /// The element count of a sequence; the caller writes the elements after it.
    pub fn sequence_len(&mut self, len: usize) -> anyhow::Result<()> {
        let len = u32::try_from(len)
            .map_err(|_| anyhow::anyhow!("a CDR sequence holds at most 2^32 - 1 elements"))?;
        self.u32(len);
        Ok(())
    }

    /// A `float64[]`.
    pub fn f64_sequence(&mut self, values: &[f64]) -> anyhow::Result<()> {
        self.sequence_len(values.len())?;
        for &v in values {
            self.f64(v);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Alignment is relative to the end of the header: a `u32` then an `f64` puts 4 bytes of
    /// padding between them (offset 4 -> 8), not 0 (absolute offset 8 would already be aligned).
    #[test]
    fn alignment_counts_from_after_the_encapsulation_header() {
        let mut buf = Vec::new();
        let mut w = CdrWriter::new(&mut buf);
        w.u32(7);
        w.f64(1.5);
        let mut expected = vec![0, 1, 0, 0, 7, 0, 0, 0, 0, 0, 0, 0];
        expected.extend_from_slice(&1.5f64.to_le_bytes());
        assert_eq!(buf, expected);
    }

    /// A string counts its NUL; the next `f64` after "ab" (4 + 3 bytes) is padded to offset 8.
    #[test]
    fn string_counts_its_nul_and_pads_before_the_next_double() {
        let mut buf = Vec::new();
        let mut w = CdrWriter::new(&mut buf);
        w.string("ab").unwrap();
        w.f64(-2.0);
        let mut expected = vec![0, 1, 0, 0, 3, 0, 0, 0, b'a', b'b', 0, 0];
        expected.extend_from_slice(&(-2.0f64).to_le_bytes());
        assert_eq!(buf, expected);
    }

    /// An empty sequence is its count alone; `new` starts a fresh buffer.
    #[test]
    fn empty_sequence_is_a_zero_count_and_new_clears_the_buffer() {
        let mut buf = vec![9, 9, 9];
        let mut w = CdrWriter::new(&mut buf);
        w.f64_sequence(&[]).unwrap();
        assert_eq!(buf, vec![0, 1, 0, 0, 0, 0, 0, 0]);
    }
}
