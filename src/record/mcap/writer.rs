//! The MCAP writer of `simulate`'s recordings: chunked, indexed, summarised, and compressed
//! without the work nobody reads.
//!
//! Written from the format's specification (<https://mcap.dev/spec>, version 0x30), for the
//! records tumble writes: header, one metadata record, schemas and channels (in the data
//! section, outside chunks, and repeated in the summary), messages in chunks each followed by
//! one message index per channel, data end with the data section's CRC-32, and a summary of
//! schemas, channels, statistics, chunk indexes and metadata indexes with a summary offset per
//! group, then the footer with the summary's CRC-32. Every chunk holds at least one message
//! (Foxglove refuses chunks without message indexes), a chunk is closed once its records reach
//! the chunk size, and every CRC is computed (readers check them).
//!
//! Why not the `mcap` crate's writer (which `tumble` still reads with, and which writes the
//! ROS 2 files): its LZ4 chunks are LZ4 frames with a content checksum (XXH32 over every
//! uncompressed byte), which MCAP does not ask for (the chunk record holds its own CRC-32 of
//! the uncompressed records) and which cost as much CPU as the compression itself (measured
//! with the `lz4` command line on the 10 000-body swarm's 224 MB: 0.17-0.21 s with the
//! checksum, 0.08-0.12 s without); and it offers no way to leave it out. Here the LZ4 frames
//! have neither content nor block checksums, at [`LZ4_LEVEL`]; zstd chunks are
//! single zstd frames at [`ZSTD_LEVEL`]. The bytes depend on the calls alone.

use std::collections::BTreeMap;
use std::io::{Seek, Write};

/// The file's magic, at both ends.
/// zstd level of the chunks: -1, the first of zstd's fast levels (`zstd --fast=1`). On
/// tumble's chunks (64 KiB of poses and velocities: doubles that barely compress, frame ids and
/// protobuf tags that do) it takes about half the CPU time of level 1 for files about 5 % larger
/// (measured on the 10 000-body swarm: 0.45 s against 0.86 s for 226 MB, 163 MB against
/// 154 MB; docs/scale.md).
pub const ZSTD_LEVEL: i32 = -1;

/// LZ4 level of the chunks: -7, LZ4's fast mode with acceleration 8 (liblz4 `lz4frame.c`:
/// a level below zero compresses with `LZ4_compress_fast_continue` at acceleration
/// `-level + 1`). The acceleration makes the match search skip ahead faster after misses; on
/// tumble's chunks the misses are the doubles of poses and velocities, which no level
/// compresses, and the matches the frame ids, names and protobuf tags, which every level finds.
/// Measured on the 10 000-body swarm (1 s, 224 MB uncompressed): level 0 (acceleration 1)
/// 175.0 MB with LZ4 at 22.7 % of all the run's CPU samples, level -7 176.2 MB at 10.7 %
/// (docs/scale.md "MCAP at scale"). The lz4 crate takes the level as a `u32` and stores
/// it in liblz4's `int compressionLevel` unchanged, so the negative level goes through as its
/// two's complement ([`lz4_level_u32`]).
pub const LZ4_LEVEL: i32 = -7;

/// [`LZ4_LEVEL`] as the `u32` the lz4 crate's `EncoderBuilder::level` takes.
pub const fn lz4_level_u32() -> u32 {
    LZ4_LEVEL as u32
}

const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";

mod op {
    pub const HEADER: u8 = 0x01;
    pub const FOOTER: u8 = 0x02;
    pub const SCHEMA: u8 = 0x03;
    pub const CHANNEL: u8 = 0x04;
    pub const MESSAGE: u8 = 0x05;
    pub const CHUNK: u8 = 0x06;
    pub const MESSAGE_INDEX: u8 = 0x07;
    pub const CHUNK_INDEX: u8 = 0x08;
    pub const STATISTICS: u8 = 0x0B;
    pub const METADATA: u8 = 0x0C;
    pub const METADATA_INDEX: u8 = 0x0D;
    pub const SUMMARY_OFFSET: u8 = 0x0E;
    pub const DATA_END: u8 = 0x0F;
}

/// How the chunks' records are compressed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Codec {
    None,
    Lz4,
    Zstd,
}

impl Codec {
    /// The chunk record's `compression` field.
    fn name(self) -> &'static str {
        match self {
            Self::None => "",
            Self::Lz4 => "lz4",
            Self::Zstd => "zstd",
        }
    }
}

/// Little-endian field encoders appending to a record's content.
struct Fields<'a>(&'a mut Vec<u8>);

impl Fields<'_> {
    fn u16(&mut self, v: u16) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    fn u32(&mut self, v: u32) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    fn u64(&mut self, v: u64) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    fn u8(&mut self, v: u8) -> &mut Self {
        self.0.push(v);
        self
    }
    /// A `String`: u32 byte length, then UTF-8 bytes.
    fn string(&mut self, s: &str) -> &mut Self {
        self.u32(s.len() as u32);
        self.0.extend_from_slice(s.as_bytes());
        self
    }
    /// A `Bytes` field prefixed with its u32 length.
    fn bytes32(&mut self, b: &[u8]) -> &mut Self {
        self.u32(b.len() as u32);
        self.0.extend_from_slice(b);
        self
    }
    /// A `Map<String, String>`: u32 byte length of the entries, then key, value pairs.
    fn string_map(&mut self, map: &BTreeMap<String, String>) -> &mut Self {
        self.u32(string_map_len(map.iter()) as u32);
        for (k, v) in map {
            self.string(k);
            self.string(v);
        }
        self
    }
    /// A `Map<uint16, uint64>`.
    fn u16_u64_map(&mut self, map: &BTreeMap<u16, u64>) -> &mut Self {
        self.u32((map.len() * 10) as u32);
        for (k, v) in map {
            self.u16(*k);
            self.u64(*v);
        }
        self
    }
}

/// Bytes of the entries of a `Map<String, String>`: each key and value a u32 length and its bytes.
fn string_map_len<K: AsRef<str>, V: AsRef<str>>(entries: impl Iterator<Item = (K, V)>) -> usize {
    entries
        .map(|(k, v)| 8 + k.as_ref().len() + v.as_ref().len())
        .sum()
}

/// A record: opcode, u64 content length, content.
fn record(out: &mut Vec<u8>, opcode: u8, content: impl FnOnce(&mut Fields<'_>)) {
    out.push(opcode);
    let at = out.len();
    out.extend_from_slice(&[0; 8]);
    content(&mut Fields(out));
    let len = (out.len() - at - 8) as u64;
    out[at..at + 8].copy_from_slice(&len.to_le_bytes());
}

/// Where a chunk's (compressed) records go: the file itself, the bytes counted and hashed as
/// they pass (the data section's CRC is combined from the pieces once the chunk's header is
/// known).
struct ChunkSink<W> {
    out: W,
    written: u64,
    crc: crc32fast::Hasher,
}

impl<W: Write> Write for ChunkSink<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.out.write(buf)?;
        self.crc.update(&buf[..n]);
        self.written += n as u64;
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.out.flush()
    }
}

/// The compressor of the open chunk, writing straight to the file.
enum Encoder<W: Write> {
    None(ChunkSink<W>),
    Lz4(lz4::Encoder<ChunkSink<W>>),
    Zstd(zstd::stream::Encoder<'static, ChunkSink<W>>),
}

impl<W: Write> Encoder<W> {
    fn new(codec: Codec, sink: ChunkSink<W>) -> std::io::Result<Self> {
        Ok(match codec {
            Codec::None => Self::None(sink),
            Codec::Lz4 => Self::Lz4(
                lz4::EncoderBuilder::new()
                    .level(lz4_level_u32())
                    .checksum(lz4::ContentChecksum::NoChecksum)
                    .block_checksum(lz4::liblz4::BlockChecksum::NoBlockChecksum)
                    .build(sink)?,
            ),
            Codec::Zstd => Self::Zstd(zstd::stream::Encoder::new(sink, ZSTD_LEVEL)?),
        })
    }

    fn write_all(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        match self {
            Self::None(w) => w.write_all(bytes),
            Self::Lz4(w) => w.write_all(bytes),
            Self::Zstd(w) => w.write_all(bytes),
        }
    }

    fn finish(self) -> std::io::Result<ChunkSink<W>> {
        match self {
            Self::None(w) => Ok(w),
            Self::Lz4(w) => {
                let (sink, result) = w.finish();
                result.map(|()| sink)
            }
            Self::Zstd(w) => w.finish(),
        }
    }
}

/// The chunk being written: its header is a placeholder in the file until it is closed.
struct OpenChunk<W: Write> {
    encoder: Encoder<W>,
    /// File offset of the chunk record, and the length of its header.
    start: u64,
    header_len: u64,
    /// Bytes of records written so far (uncompressed), and their CRC-32.
    records: u64,
    records_crc: crc32fast::Hasher,
    start_ns: u64,
    end_ns: u64,
    /// Per channel: (log time, offset of the message record among the chunk's records).
    index: BTreeMap<u16, Vec<(u64, u64)>>,
}

/// The chunk record's header: opcode, length, times, sizes, CRC, compression, records length.
fn chunk_header(
    compression: &str,
    (start_ns, end_ns): (u64, u64),
    uncompressed: u64,
    uncompressed_crc: u32,
    compressed: u64,
) -> Vec<u8> {
    let mut head = Vec::with_capacity(64);
    let content_len = 8 + 8 + 8 + 4 + 4 + compression.len() as u64 + 8 + compressed;
    Fields(&mut head)
        .u8(op::CHUNK)
        .u64(content_len)
        .u64(start_ns)
        .u64(end_ns)
        .u64(uncompressed)
        .u32(uncompressed_crc)
        .string(compression)
        .u64(compressed);
    head
}

/// Writes an MCAP file to `W`; see the module doc.
pub struct McapWriter<W: Write + Seek> {
    /// The file; inside the open chunk's encoder while a chunk is open.
    out: Option<W>,
    /// Bytes written so far.
    position: u64,
    /// CRC-32 of the data section so far (the file from its magic on, up to the data end).
    data_crc: crc32fast::Hasher,
    codec: Codec,
    chunk_bytes: usize,
    chunk: Option<OpenChunk<W>>,
    /// Encoded schema and channel records, by id (repeated in the summary).
    schemas: BTreeMap<u16, Vec<u8>>,
    channels: BTreeMap<u16, Vec<u8>>,
    /// Encoded chunk index and metadata index records.
    chunk_indexes: Vec<u8>,
    chunk_count: u32,
    metadata_indexes: Vec<u8>,
    metadata_count: u32,
    channel_counts: BTreeMap<u16, u64>,
    /// Log times of the first and last message of the file.
    bounds: Option<(u64, u64)>,
}

impl<W: Write + Seek> McapWriter<W> {
    /// Starts the file: magic and header (`profile`, `library`). Chunks are closed once their
    /// records reach `chunk_bytes` and compressed with `codec`.
    pub fn new(
        out: W,
        profile: &str,
        library: &str,
        codec: Codec,
        chunk_bytes: usize,
    ) -> std::io::Result<Self> {
        let mut w = Self {
            out: Some(out),
            position: 0,
            data_crc: crc32fast::Hasher::new(),
            codec,
            chunk_bytes,
            chunk: None,
            schemas: BTreeMap::new(),
            channels: BTreeMap::new(),
            chunk_indexes: Vec::new(),
            chunk_count: 0,
            metadata_indexes: Vec::new(),
            metadata_count: 0,
            channel_counts: BTreeMap::new(),
            bounds: None,
        };
        let mut header = MAGIC.to_vec();
        record(&mut header, op::HEADER, |f| {
            f.string(profile).string(library);
        });
        w.put_data(&header)?;
        Ok(w)
    }

    /// The file (no chunk is open outside `write_message` and `finish_chunk`).
    fn out(&mut self) -> std::io::Result<&mut W> {
        self.out
            .as_mut()
            .ok_or_else(|| std::io::Error::other("the MCAP writer failed in a chunk"))
    }

    /// Writes `bytes` to the data section.
    fn put_data(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        self.out()?.write_all(bytes)?;
        self.data_crc.update(bytes);
        self.position += bytes.len() as u64;
        Ok(())
    }

    /// A metadata record `name` holding `entries` in the given order (MCAP readers expect the
    /// keys sorted, as a `BTreeMap` gives them), written outside chunks and indexed in the
    /// summary. The entries are written as they are, never copied into one buffer (the layout
    /// JSON of a 100 000-body scene is 30 MB).
    pub fn write_metadata(&mut self, name: &str, entries: &[(&str, &str)]) -> std::io::Result<()> {
        self.finish_chunk()?;
        let offset = self.position;
        let map_len = string_map_len(entries.iter().copied());
        let content_len = 4 + name.len() + 4 + map_len;
        let mut head = Vec::new();
        Fields(&mut head)
            .u8(op::METADATA)
            .u64(content_len as u64)
            .string(name)
            .u32(map_len as u32);
        self.put_data(&head)?;
        for (k, v) in entries {
            for s in [k, v] {
                self.put_data(&(s.len() as u32).to_le_bytes())?;
                self.put_data(s.as_bytes())?;
            }
        }
        let length = 9 + content_len as u64;
        record(&mut self.metadata_indexes, op::METADATA_INDEX, |f| {
            f.u64(offset).u64(length).string(name);
        });
        self.metadata_count += 1;
        Ok(())
    }

    /// Adds a schema (ids from 1); written at once, outside chunks.
    pub fn add_schema(&mut self, name: &str, encoding: &str, data: &[u8]) -> std::io::Result<u16> {
        let id = self.schemas.len() as u16 + 1;
        let mut rec = Vec::new();
        record(&mut rec, op::SCHEMA, |f| {
            f.u16(id).string(name).string(encoding).bytes32(data);
        });
        self.finish_chunk()?;
        self.put_data(&rec)?;
        self.schemas.insert(id, rec);
        Ok(id)
    }

    /// Adds a channel (ids from 0); written at once, outside chunks.
    pub fn add_channel(
        &mut self,
        schema_id: u16,
        topic: &str,
        message_encoding: &str,
        metadata: &BTreeMap<String, String>,
    ) -> std::io::Result<u16> {
        let id = self.channels.len() as u16;
        let mut rec = Vec::new();
        record(&mut rec, op::CHANNEL, |f| {
            f.u16(id)
                .u16(schema_id)
                .string(topic)
                .string(message_encoding)
                .string_map(metadata);
        });
        self.finish_chunk()?;
        self.put_data(&rec)?;
        self.channels.insert(id, rec);
        Ok(id)
    }

    /// Opens a chunk: a placeholder header in the file, then an encoder writing to the file.
    fn open_chunk(&mut self, log_time: u64) -> std::io::Result<()> {
        let compression = self.codec.name();
        let placeholder = chunk_header(compression, (0, 0), 0, 0, 0);
        let mut out = self
            .out
            .take()
            .ok_or_else(|| std::io::Error::other("no file"))?;
        out.write_all(&placeholder)?;
        let sink = ChunkSink {
            out,
            written: 0,
            crc: crc32fast::Hasher::new(),
        };
        self.chunk = Some(OpenChunk {
            encoder: Encoder::new(self.codec, sink)?,
            start: self.position,
            header_len: placeholder.len() as u64,
            records: 0,
            records_crc: crc32fast::Hasher::new(),
            start_ns: log_time,
            end_ns: log_time,
            index: BTreeMap::new(),
        });
        Ok(())
    }

    /// Appends a message to the open chunk (opening one if none is); closes the chunk once its
    /// records reach the chunk size.
    pub fn write_message(
        &mut self,
        channel_id: u16,
        sequence: u32,
        log_time: u64,
        publish_time: u64,
        data: &[u8],
    ) -> std::io::Result<()> {
        if self.chunk.is_none() {
            self.open_chunk(log_time)?;
        }
        let chunk = self.chunk.as_mut().expect("a chunk is open");
        chunk.start_ns = chunk.start_ns.min(log_time);
        chunk.end_ns = chunk.end_ns.max(log_time);
        chunk
            .index
            .entry(channel_id)
            .or_default()
            .push((log_time, chunk.records));
        let mut head = [0u8; 31];
        head[0] = op::MESSAGE;
        head[1..9].copy_from_slice(&(22 + data.len() as u64).to_le_bytes());
        head[9..11].copy_from_slice(&channel_id.to_le_bytes());
        head[11..15].copy_from_slice(&sequence.to_le_bytes());
        head[15..23].copy_from_slice(&log_time.to_le_bytes());
        head[23..31].copy_from_slice(&publish_time.to_le_bytes());
        chunk.encoder.write_all(&head)?;
        chunk.encoder.write_all(data)?;
        chunk.records_crc.update(&head);
        chunk.records_crc.update(data);
        chunk.records += (head.len() + data.len()) as u64;
        let full = chunk.records >= self.chunk_bytes as u64;
        *self.channel_counts.entry(channel_id).or_insert(0) += 1;
        self.bounds = Some(match self.bounds {
            Some((a, b)) => (a.min(log_time), b.max(log_time)),
            None => (log_time, log_time),
        });
        if full {
            self.finish_chunk()?;
        }
        Ok(())
    }

    /// Closes the open chunk (if any): finishes its compression, writes its header over the
    /// placeholder, then its message indexes.
    fn finish_chunk(&mut self) -> std::io::Result<()> {
        let Some(chunk) = self.chunk.take() else {
            return Ok(());
        };
        let sink = chunk.encoder.finish()?;
        let mut out = sink.out;
        let compression = self.codec.name();
        let header = chunk_header(
            compression,
            (chunk.start_ns, chunk.end_ns),
            chunk.records,
            chunk.records_crc.finalize(),
            sink.written,
        );
        debug_assert_eq!(header.len() as u64, chunk.header_len);
        out.seek(std::io::SeekFrom::Start(chunk.start))?;
        out.write_all(&header)?;
        out.seek(std::io::SeekFrom::Start(
            chunk.start + chunk.header_len + sink.written,
        ))?;
        self.out = Some(out);
        // The data section's CRC in file order: header, then the records as written.
        let mut header_crc = crc32fast::Hasher::new();
        header_crc.update(&header);
        self.data_crc.combine(&header_crc);
        self.data_crc.combine(&sink.crc);
        self.position = chunk.start + chunk.header_len + sink.written;
        let chunk_length = self.position - chunk.start;
        // One message index per channel of the chunk, in channel order.
        let mut indexes = Vec::new();
        let mut offsets = BTreeMap::new();
        for (channel, entries) in &chunk.index {
            offsets.insert(*channel, self.position + indexes.len() as u64);
            record(&mut indexes, op::MESSAGE_INDEX, |f| {
                f.u16(*channel).u32((entries.len() * 16) as u32);
                for (time, offset) in entries {
                    f.u64(*time).u64(*offset);
                }
            });
        }
        self.put_data(&indexes)?;
        record(&mut self.chunk_indexes, op::CHUNK_INDEX, |f| {
            f.u64(chunk.start_ns)
                .u64(chunk.end_ns)
                .u64(chunk.start)
                .u64(chunk_length)
                .u16_u64_map(&offsets)
                .u64(indexes.len() as u64)
                .string(compression)
                .u64(sink.written)
                .u64(chunk.records);
        });
        self.chunk_count += 1;
        Ok(())
    }

    /// Closes the last chunk, writes the data end, the summary and the footer, flushes, and
    /// hands back the writer.
    pub fn finish(mut self) -> std::io::Result<W> {
        self.finish_chunk()?;
        let mut end = Vec::new();
        let data_crc = std::mem::take(&mut self.data_crc).finalize();
        record(&mut end, op::DATA_END, |f| {
            f.u32(data_crc);
        });
        self.out()?.write_all(&end)?;
        self.position += end.len() as u64;
        let summary_start = self.position;
        // The summary groups, each with its summary offset.
        let mut summary = Vec::new();
        let mut offsets = Vec::new();
        let mut group = |summary: &mut Vec<u8>, opcode: u8, write: &mut dyn FnMut(&mut Vec<u8>)| {
            let start = summary.len();
            write(summary);
            if summary.len() > start {
                offsets.push((
                    opcode,
                    summary_start + start as u64,
                    (summary.len() - start) as u64,
                ));
            }
        };
        group(&mut summary, op::SCHEMA, &mut |s| {
            self.schemas.values().for_each(|r| s.extend_from_slice(r))
        });
        group(&mut summary, op::CHANNEL, &mut |s| {
            self.channels.values().for_each(|r| s.extend_from_slice(r))
        });
        let (start_ns, end_ns) = self.bounds.unwrap_or((0, 0));
        let message_count = self.channel_counts.values().sum();
        group(&mut summary, op::STATISTICS, &mut |s| {
            record(s, op::STATISTICS, |f| {
                f.u64(message_count)
                    .u16(self.schemas.len() as u16)
                    .u32(self.channels.len() as u32)
                    .u32(0)
                    .u32(self.metadata_count)
                    .u32(self.chunk_count)
                    .u64(start_ns)
                    .u64(end_ns)
                    .u16_u64_map(&self.channel_counts);
            })
        });
        group(&mut summary, op::CHUNK_INDEX, &mut |s| {
            s.extend_from_slice(&self.chunk_indexes)
        });
        group(&mut summary, op::METADATA_INDEX, &mut |s| {
            s.extend_from_slice(&self.metadata_indexes)
        });
        let summary_offset_start = summary_start + summary.len() as u64;
        for (opcode, start, length) in offsets {
            record(&mut summary, op::SUMMARY_OFFSET, |f| {
                f.u8(opcode).u64(start).u64(length);
            });
        }
        // The footer; the summary CRC covers the summary and the footer up to its CRC field.
        let footer_at = summary.len();
        record(&mut summary, op::FOOTER, |f| {
            f.u64(summary_start).u64(summary_offset_start).u32(0);
        });
        let crc = crc32fast::hash(&summary[..summary.len() - 4]);
        let n = summary.len();
        summary[n - 4..].copy_from_slice(&crc.to_le_bytes());
        debug_assert_eq!(summary.len() - footer_at, 1 + 8 + 20);
        summary.extend_from_slice(MAGIC);
        let mut out = self
            .out
            .take()
            .ok_or_else(|| std::io::Error::other("no file"))?;
        out.write_all(&summary)?;
        out.flush()?;
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader, LinearReaderOptions};
    use std::io::{Cursor, Read};

    /// Messages of a small file: (channel, sequence, log time, data), on three channels, in
    /// time order, some big enough to close a chunk alone.
    fn messages() -> Vec<(u16, u32, u64, Vec<u8>)> {
        (0..60u32)
            .map(|k| {
                let channel = (k % 3) as u16;
                let len = if k % 17 == 5 { 3000 } else { 40 + k as usize };
                let data = (0..len).map(|i| (i as u32 * 31 + k) as u8).collect();
                (channel, k / 3, 1_000 * u64::from(k / 3), data)
            })
            .collect()
    }

    fn write(codec: Codec) -> Vec<u8> {
        let mut w = McapWriter::new(Cursor::new(Vec::new()), "", "test", codec, 1024).unwrap();
        w.write_metadata("tumble", &[("a", "1"), ("layout_json", "{\"x\": [1, 2]}")])
            .unwrap();
        let s1 = w.add_schema("one", "protobuf", b"\x01\x02").unwrap();
        let s2 = w.add_schema("two", "protobuf", b"").unwrap();
        let mut meta = BTreeMap::new();
        meta.insert("k".to_string(), "v".to_string());
        assert_eq!(w.add_channel(s1, "/a", "protobuf", &meta).unwrap(), 0);
        assert_eq!(
            w.add_channel(s2, "/b", "protobuf", &BTreeMap::new())
                .unwrap(),
            1
        );
        assert_eq!(
            w.add_channel(s1, "/c", "protobuf", &BTreeMap::new())
                .unwrap(),
            2
        );
        for (channel, sequence, time, data) in messages() {
            w.write_message(channel, sequence, time, time + 7, &data)
                .unwrap();
        }
        w.finish().unwrap().into_inner()
    }

    /// The `mcap` crate's reader (written by others) reads back every message, the
    /// metadata, the statistics and the chunk and message indexes of each codec's file.
    #[test]
    fn the_mcap_crate_reads_back_every_message_and_index() {
        for codec in [Codec::None, Codec::Lz4, Codec::Zstd] {
            let file = write(codec);
            let read: Vec<_> = mcap::MessageStream::new(&file)
                .unwrap()
                .map(|m| {
                    let m = m.unwrap();
                    (
                        m.channel.id,
                        m.sequence,
                        m.log_time,
                        m.publish_time,
                        m.data.to_vec(),
                    )
                })
                .collect();
            let expected: Vec<_> = messages()
                .into_iter()
                .map(|(c, s, t, d)| (c, s, t, t + 7, d))
                .collect();
            assert!(read == expected, "{codec:?}: messages differ");
            let summary = mcap::Summary::read(&file).unwrap().expect("a summary");
            let stats = summary.stats.as_ref().unwrap();
            assert_eq!(stats.message_count, 60, "{codec:?}");
            assert_eq!((stats.schema_count, stats.channel_count), (2, 3));
            assert_eq!((stats.metadata_count, stats.attachment_count), (1, 0));
            assert_eq!(
                (stats.message_start_time, stats.message_end_time),
                (0, 19_000)
            );
            assert_eq!(
                stats
                    .channel_message_counts
                    .values()
                    .copied()
                    .collect::<Vec<_>>(),
                [20, 20, 20]
            );
            assert_eq!(stats.chunk_count as usize, summary.chunk_indexes.len());
            assert!(summary.chunk_indexes.len() > 5, "{codec:?}: several chunks");
            assert_eq!(summary.channels[&0].topic, "/a");
            assert_eq!(summary.channels[&0].metadata["k"], "v");
            assert_eq!(summary.channels[&1].schema.as_ref().unwrap().name, "two");
            let meta = mcap::read::metadata(&file, &summary.metadata_indexes[0]).unwrap();
            assert_eq!(meta.name, "tumble");
            assert_eq!(meta.metadata["layout_json"], "{\"x\": [1, 2]}");
            // Every chunk's message indexes point at its messages, in the chunk's time range.
            let mut seen = 0;
            for index in &summary.chunk_indexes {
                assert_eq!(index.compression, codec.name());
                let entries = summary.read_message_indexes(&file, index).unwrap();
                assert!(
                    !entries.is_empty(),
                    "{codec:?}: a chunk without message indexes"
                );
                for (channel, entries) in &entries {
                    for entry in entries {
                        assert!(
                            (index.message_start_time..=index.message_end_time)
                                .contains(&entry.log_time)
                        );
                        let m = summary.seek_message(&file, index, entry).unwrap();
                        assert_eq!((m.channel.id, m.log_time), (channel.id, entry.log_time));
                        seen += 1;
                    }
                }
            }
            assert_eq!(seen, 60, "{codec:?}: every message indexed once");
        }
    }

    /// The crate's validating reader checks the chunk, data section and summary CRCs (a zero
    /// CRC would pass unchecked: they are asserted non-zero too).
    #[test]
    fn every_crc_checks_out() {
        for codec in [Codec::None, Codec::Lz4, Codec::Zstd] {
            let file = write(codec);
            let mut reader = LinearReader::new_with_options(
                LinearReaderOptions::default()
                    .with_validate_chunk_crcs(true)
                    .with_validate_data_section_crc(true)
                    .with_validate_summary_section_crc(true),
            );
            let mut cursor = Cursor::new(&file);
            let mut opcodes = Vec::new();
            while let Some(event) = reader.next_event() {
                match event.unwrap_or_else(|e| panic!("{codec:?}: {e}")) {
                    LinearReadEvent::ReadRequest(n) => {
                        let written = cursor.read(reader.insert(n)).unwrap();
                        reader.notify_read(written);
                    }
                    LinearReadEvent::Record { data, opcode } => {
                        match mcap::parse_record(opcode, data).unwrap() {
                            mcap::records::Record::DataEnd(end) => {
                                assert_ne!(end.data_section_crc, 0)
                            }
                            mcap::records::Record::Footer(footer) => {
                                assert_ne!(footer.summary_crc, 0)
                            }
                            _ => {}
                        }
                        opcodes.push(opcode);
                    }
                }
            }
            assert_eq!(opcodes.first(), Some(&op::HEADER));
            assert_eq!(opcodes.last(), Some(&op::FOOTER));
            assert!(opcodes.contains(&op::DATA_END) && opcodes.contains(&op::SUMMARY_OFFSET));
        }
    }

    /// A channel's metadata map is prefixed with its length in bytes (MCAP `Map<String,
    /// String>`): 4 + 1 + 4 + 1 for `k`/`v` and 4 + 4 + 4 + 6 for `key2`/`value2`, 28, and the
    /// record ends right after the map. (The crate's reader stops at the first entry that
    /// reaches the length, so it would accept a shorter one: checked here on the bytes.)
    #[test]
    fn a_metadata_map_is_prefixed_with_its_byte_length() {
        let mut w = McapWriter::new(Cursor::new(Vec::new()), "", "t", Codec::None, 1024).unwrap();
        let schema = w.add_schema("s", "protobuf", b"").unwrap();
        let mut meta = BTreeMap::new();
        meta.insert("k".to_string(), "v".to_string());
        meta.insert("key2".to_string(), "value2".to_string());
        w.add_channel(schema, "/t", "protobuf", &meta).unwrap();
        let file = w.finish().unwrap().into_inner();
        // Walk the records after the magic up to the first channel record.
        let mut at = MAGIC.len();
        loop {
            let opcode = file[at];
            let len = u64::from_le_bytes(file[at + 1..at + 9].try_into().unwrap()) as usize;
            if opcode == op::CHANNEL {
                let content = &file[at + 9..at + 9 + len];
                // id, schema id, topic "/t" (4 + 2), encoding "protobuf" (4 + 8).
                let map_at = 2 + 2 + 6 + 12;
                let map_len = u32::from_le_bytes(content[map_at..map_at + 4].try_into().unwrap());
                assert_eq!(map_len, 28);
                assert_eq!(len, map_at + 4 + 28, "the record ends with the map");
                break;
            }
            at += 9 + len;
        }
    }

    /// A chunk is closed by the message that makes its records reach the chunk size (1024
    /// bytes here): every chunk but the last holds at least that much, and its last message
    /// starts below it.
    #[test]
    fn chunks_close_once_they_reach_the_chunk_size() {
        for codec in [Codec::None, Codec::Lz4, Codec::Zstd] {
            let file = write(codec);
            let summary = mcap::Summary::read(&file).unwrap().unwrap();
            let n = summary.chunk_indexes.len();
            for (k, index) in summary.chunk_indexes.iter().enumerate() {
                let last_offset = summary
                    .read_message_indexes(&file, index)
                    .unwrap()
                    .values()
                    .flat_map(|entries| entries.iter().map(|e| e.offset))
                    .max()
                    .unwrap();
                assert!(last_offset < 1024, "{codec:?} chunk {k}: closed late");
                if k + 1 < n {
                    assert!(
                        index.uncompressed_size >= 1024,
                        "{codec:?} chunk {k}: closed early"
                    );
                }
            }
        }
    }

    /// LZ4 chunks are LZ4 frames without content or block checksums (frame descriptor flags,
    /// LZ4 frame format 1.6.x: bit 2 content checksum, bit 4 block checksum).
    #[test]
    fn lz4_frames_carry_no_checksums() {
        let file = write(Codec::Lz4);
        let summary = mcap::Summary::read(&file).unwrap().unwrap();
        for index in &summary.chunk_indexes {
            let start = index.chunk_start_offset as usize;
            // Chunk record: opcode, length, 3 x u64, u32 crc, "lz4" (4 + 3), u64 records length.
            let data = start + 1 + 8 + 24 + 4 + 7 + 8;
            assert_eq!(
                &file[data..data + 4],
                &[0x04, 0x22, 0x4d, 0x18],
                "LZ4 frame magic"
            );
            let flags = file[data + 4];
            assert_eq!(flags & 0b0000_0100, 0, "no content checksum");
            assert_eq!(flags & 0b0001_0000, 0, "no block checksum");
        }
    }
}
