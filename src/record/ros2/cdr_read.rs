//! A minimal CDR deserializer: the counterpart of [`super::cdr`] for reading ROS 2 messages
//! that other programs recorded (`tumble diff` against a robot's `/joint_states` log).
//!
//! Plain CDR (XCDR1) as [`super::cdr`] describes it, in either byte order: the encapsulation
//! header's representation identifier `00 01` is little endian (`CDR_LE`, what ROS 2 writes on
//! every common machine), `00 00` big endian (`CDR_BE`); anything else is refused. Alignment
//! counts from the end of the 4-byte header. Every read is bounds-checked, and a sequence's
//! count is checked against the bytes left before anything is allocated, so a damaged message
//! is an error naming the offset, never a panic or a huge allocation.

use anyhow::{Context, bail};

/// Reads CDR values from a message (header included).
#[derive(Debug)]
pub struct CdrReader<'a> {
    /// The bytes after the encapsulation header.
    body: &'a [u8],
    /// The next byte to read, counted from the start of `body`.
    at: usize,
    little_endian: bool,
}

impl<'a> CdrReader<'a> {
    /// Reads the encapsulation header of `data`.
    pub fn new(data: &'a [u8]) -> anyhow::Result<Self> {
        let header = data
            .get(..4)
            .context("a CDR message shorter than its 4-byte encapsulation header")?;
        let little_endian = match [header[0], header[1]] {
            [0x00, 0x01] => true,
            [0x00, 0x00] => false,
            id => bail!(
                "CDR representation {:02x} {:02x} (only plain CDR, 00 00 or 00 01, is read)",
                id[0],
                id[1]
            ),
        };
        Ok(Self {
            body: &data[4..],
            at: 0,
            little_endian,
        })
    }

    /// The next `n` bytes after aligning to `align`.
    fn take(&mut self, align: usize, n: usize) -> anyhow::Result<&'a [u8]> {
        let start = self.at.div_ceil(align) * align;
        let end = start
            .checked_add(n)
            .filter(|&end| end <= self.body.len())
            .with_context(|| {
                format!(
                    "the CDR message ends at byte {} where {n} more were expected at {start}",
                    self.body.len()
                )
            })?;
        self.at = end;
        Ok(&self.body[start..end])
    }

    pub fn u32(&mut self) -> anyhow::Result<u32> {
        let b: [u8; 4] = self.take(4, 4)?.try_into()?;
        Ok(if self.little_endian {
            u32::from_le_bytes(b)
        } else {
            u32::from_be_bytes(b)
        })
    }

    pub fn i32(&mut self) -> anyhow::Result<i32> {
        Ok(self.u32()? as i32)
    }

    pub fn f64(&mut self) -> anyhow::Result<f64> {
        let b: [u8; 8] = self.take(8, 8)?.try_into()?;
        Ok(if self.little_endian {
            f64::from_le_bytes(b)
        } else {
            f64::from_be_bytes(b)
        })
    }

    /// A `string` (its length counts a terminating NUL, which is dropped).
    pub fn string(&mut self) -> anyhow::Result<String> {
        let len = self.u32()? as usize;
        let bytes = self.take(1, len)?;
        let text = bytes.strip_suffix(&[0]).unwrap_or(bytes);
        String::from_utf8(text.to_vec()).context("a CDR string is not UTF-8")
    }

    /// A sequence's element count, checked against the bytes left (each element takes at
    /// least `min_bytes`).
    pub fn sequence_len(&mut self, min_bytes: usize) -> anyhow::Result<usize> {
        let len = self.u32()? as usize;
        let left = self.body.len() - self.at;
        if len.saturating_mul(min_bytes) > left {
            bail!("a CDR sequence of {len} elements in {left} bytes");
        }
        Ok(len)
    }

    /// A `string[]`.
    pub fn string_sequence(&mut self) -> anyhow::Result<Vec<String>> {
        let len = self.sequence_len(4)?;
        (0..len).map(|_| self.string()).collect()
    }

    /// A `float64[]`.
    pub fn f64_sequence(&mut self) -> anyhow::Result<Vec<f64>> {
        let len = self.sequence_len(8)?;
        (0..len).map(|_| self.f64()).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::super::cdr::CdrWriter;
    use super::*;

    /// What the writer writes, the reader reads back, alignment included.
    #[test]
    fn reads_what_the_writer_wrote() {
        let mut buf = Vec::new();
        let mut w = CdrWriter::new(&mut buf);
        w.i32(-3);
        w.string("abc").unwrap();
        w.f64_sequence(&[1.5, -0.25]).unwrap();
        w.u32(7);
        let mut r = CdrReader::new(&buf).unwrap();
        assert_eq!(r.i32().unwrap(), -3);
        assert_eq!(r.string().unwrap(), "abc");
        assert_eq!(r.f64_sequence().unwrap(), [1.5, -0.25]);
        assert_eq!(r.u32().unwrap(), 7);
        assert!(r.u32().is_err());
    }

    /// Big-endian CDR (representation 00 00) reads too: a u32 then an f64 at offset 8.
    #[test]
    fn reads_big_endian() {
        let mut data = vec![0, 0, 0, 0, 0, 0, 0, 2, 0, 0, 0, 0];
        data.extend_from_slice(&2.5f64.to_be_bytes());
        let mut r = CdrReader::new(&data).unwrap();
        assert_eq!(r.u32().unwrap(), 2);
        assert_eq!(r.f64().unwrap(), 2.5);
    }

    /// A sequence claiming more elements than bytes left, a cut message and an unknown
    /// representation are errors, not panics or huge allocations.
    #[test]
    fn damaged_messages_are_errors() {
        let data = [0, 1, 0, 0, 0xff, 0xff, 0xff, 0x7f];
        let err = CdrReader::new(&data).unwrap().f64_sequence().unwrap_err();
        assert!(
            err.to_string().contains("2147483647 elements in 0 bytes"),
            "{err}"
        );
        let err = CdrReader::new(&[0, 1, 0, 0, 1, 0])
            .unwrap()
            .u32()
            .unwrap_err();
        assert!(err.to_string().contains("ends at byte 2"), "{err}");
        let err = CdrReader::new(&[0, 2, 0, 0]).unwrap_err();
        assert!(err.to_string().contains("00 02"), "{err}");
        assert!(CdrReader::new(&[0, 1]).is_err());
    }
}
