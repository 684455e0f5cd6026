//! Reading an MCAP file front to back with bounded memory, surviving truncation.
//!
//! [`McapStream`] drives `mcap`'s sans-io linear reader from any [`Read`]: only the current
//! record (or chunk) is held in memory, whatever the file's length. Chunks are CRC-checked whole
//! before any of their messages is handed out (`prevalidate_chunk_crcs`), so a file cut in the
//! middle of a chunk yields every message of every complete chunk and none of the broken one.
//! The stream then ends and [`McapStream::end`] says what happened: [`StreamEnd::Complete`]
//! (footer and closing magic read), or [`StreamEnd::Truncated`] with the byte offset where
//! reading stopped and the reader's error.

use anyhow::Context;
use mcap::records::{Metadata, Record, Statistics};
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};
use std::collections::HashMap;
use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::Path;
use std::sync::Arc;

/// One item of the stream.
#[derive(Debug)]
pub enum Item {
    /// A message with its channel's topic and schema name. `log_time` is simulation time in ns
    /// for tumble's recordings.
    Message {
        topic: Arc<str>,
        schema: Arc<str>,
        log_time: u64,
        data: Vec<u8>,
    },
    /// A metadata record.
    Metadata(Metadata),
}

/// How the stream ended.
#[derive(Debug, Clone, PartialEq)]
pub enum StreamEnd {
    /// Not at the end yet.
    Reading,
    /// The whole file was read: data, summary, footer and closing magic.
    Complete,
    /// Reading stopped early: the file is cut short or damaged there.
    Truncated {
        /// Bytes read from the file before the error (the damage is at or after this offset,
        /// within the record being read).
        bytes_read: u64,
        /// Whether the data-end record had been reached (then only the summary is missing or
        /// damaged, and no message was lost).
        data_complete: bool,
        /// The reader's error, e.g. "unexpected end of file".
        error: String,
    },
}

/// A front-to-back MCAP reader; see the module doc.
pub struct McapStream<R: Read> {
    reader: LinearReader,
    source: R,
    /// channel id -> (topic, schema name)
    channels: HashMap<u16, (Arc<str>, Arc<str>)>,
    schemas: HashMap<u16, Arc<str>>,
    bytes_read: u64,
    in_summary: bool,
    statistics: Option<Statistics>,
    library: Option<String>,
    profile: Option<String>,
    end: StreamEnd,
}

/// Opens `path` for reading if it is a regular file (links followed), without blocking on a
/// FIFO or a device: "`path` is not a regular file but a FIFO (named pipe)".
pub fn open_regular(path: &Path) -> anyhow::Result<File> {
    use std::os::unix::fs::OpenOptionsExt;
    let nonblock = rustix::fs::OFlags::NONBLOCK.bits() as i32;
    let file = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(nonblock)
        .open(path)
        .with_context(|| format!("cannot open {}", path.display()))?;
    let meta = file
        .metadata()
        .with_context(|| format!("cannot read {}", path.display()))?;
    if !meta.is_file() {
        anyhow::bail!(
            "{} is not a regular file but {} (only regular files are read)",
            path.display(),
            crate::input::describe(&meta.file_type())
        );
    }
    Ok(file)
}

impl McapStream<BufReader<File>> {
    /// Opens `path` for streaming.
    pub fn open(path: &Path) -> anyhow::Result<Self> {
        // Opened without blocking (a FIFO would wait for a writer for ever) and judged by what
        // was opened: anything but a regular file is refused before a byte is read.
        let mut file = open_regular(path)?;
        let mut magic = [0u8; 8];
        let n = read_up_to(&mut file, &mut magic)
            .with_context(|| format!("cannot read {}", path.display()))?;
        if magic[..n] != mcap::MAGIC[..n] || n < mcap::MAGIC.len() {
            anyhow::bail!(
                "{} is not an MCAP file (it does not start with the MCAP magic bytes)",
                path.display()
            );
        }
        file.seek(SeekFrom::Start(0))
            .with_context(|| format!("cannot read {}", path.display()))?;
        Ok(Self::new(BufReader::with_capacity(1 << 16, file)))
    }
}

impl<R: Read> McapStream<R> {
    /// Streams from `source` (which must start with the MCAP magic).
    pub fn new(source: R) -> Self {
        let options = LinearReaderOptions::default()
            .with_validate_chunk_crcs(true)
            .with_prevalidate_chunk_crcs(true)
            // Nothing of tumble's is bigger; a damaged length field cannot make us allocate more.
            .with_record_length_limit(1 << 32);
        Self {
            reader: LinearReader::new_with_options(options),
            source,
            channels: HashMap::new(),
            schemas: HashMap::new(),
            bytes_read: 0,
            in_summary: false,
            statistics: None,
            library: None,
            profile: None,
            end: StreamEnd::Reading,
        }
    }

    /// How the stream ended ([`StreamEnd::Reading`] until the iterator returned `None`).
    pub fn end(&self) -> &StreamEnd {
        &self.end
    }

    /// Bytes read from the source so far.
    pub fn bytes_read(&self) -> u64 {
        self.bytes_read
    }

    /// The summary's statistics record, once read (complete files only).
    pub fn statistics(&self) -> Option<&Statistics> {
        self.statistics.as_ref()
    }

    /// The header's `library` field (e.g. "tumble 0.1.0"), once read.
    pub fn library(&self) -> Option<&str> {
        self.library.as_deref()
    }

    /// The header's `profile` field (`""` for tumble's protobuf files, `"ros2"` for its ROS 2
    /// recordings), once read.
    pub fn profile(&self) -> Option<&str> {
        self.profile.as_deref()
    }

    /// Every channel seen so far: id -> (topic, schema name).
    pub fn channels(&self) -> impl Iterator<Item = (u16, &str, &str)> {
        self.channels
            .iter()
            .map(|(id, (topic, schema))| (*id, &**topic, &**schema))
    }

    fn stop(&mut self, error: String) {
        self.end = StreamEnd::Truncated {
            bytes_read: self.bytes_read,
            data_complete: self.in_summary,
            error,
        };
    }

    /// The next message or metadata record; `None` at the end of the file or at the first
    /// damaged byte (see [`Self::end`]).
    pub fn next_item(&mut self) -> Option<Item> {
        if self.end != StreamEnd::Reading {
            return None;
        }
        loop {
            let event = match self.reader.next_event() {
                None => {
                    self.end = StreamEnd::Complete;
                    return None;
                }
                Some(Err(e)) => {
                    self.stop(e.to_string());
                    return None;
                }
                Some(Ok(event)) => event,
            };
            match event {
                LinearReadEvent::ReadRequest(n) => {
                    let buf = self.reader.insert(n);
                    match self.source.read(buf) {
                        Ok(read) => {
                            self.bytes_read += read as u64;
                            self.reader.notify_read(read);
                        }
                        Err(e) => {
                            self.reader.notify_read(0);
                            self.stop(format!("read error: {e}"));
                            return None;
                        }
                    }
                }
                LinearReadEvent::Record { data, opcode } => {
                    let record = match mcap::parse_record(opcode, data) {
                        Ok(record) => record,
                        Err(e) => {
                            let error = format!("malformed record (opcode {opcode:#04x}): {e}");
                            self.stop(error);
                            return None;
                        }
                    };
                    match record {
                        Record::Header(header) => {
                            self.library = Some(header.library);
                            self.profile = Some(header.profile);
                        }
                        Record::Schema { header, .. } => {
                            self.schemas.insert(header.id, header.name.as_str().into());
                        }
                        Record::Channel(channel) => {
                            let schema = self
                                .schemas
                                .get(&channel.schema_id)
                                .cloned()
                                .unwrap_or_else(|| "".into());
                            self.channels
                                .insert(channel.id, (channel.topic.as_str().into(), schema));
                        }
                        Record::Message { header, data } if !self.in_summary => {
                            let Some((topic, schema)) = self.channels.get(&header.channel_id)
                            else {
                                let id = header.channel_id;
                                self.stop(format!("message on unknown channel {id}"));
                                return None;
                            };
                            return Some(Item::Message {
                                topic: topic.clone(),
                                schema: schema.clone(),
                                log_time: header.log_time,
                                data: data.into_owned(),
                            });
                        }
                        Record::Metadata(metadata) if !self.in_summary => {
                            return Some(Item::Metadata(metadata));
                        }
                        Record::DataEnd(_) => self.in_summary = true,
                        Record::Statistics(statistics) => self.statistics = Some(statistics),
                        _ => {}
                    }
                }
            }
        }
    }
}

/// Reads until `buf` is full or the end of the file; returns the bytes read.
fn read_up_to(file: &mut File, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut filled = 0;
    while filled < buf.len() {
        match file.read(&mut buf[filled..])? {
            0 => break,
            n => filled += n,
        }
    }
    Ok(filled)
}

/// A message of the stream (see [`Item::Message`]).
#[derive(Debug)]
pub struct Message {
    pub topic: Arc<str>,
    pub log_time: u64,
    pub data: Vec<u8>,
}

impl<R: Read> McapStream<R> {
    /// The next message, metadata records skipped; `None` as for [`Self::next_item`].
    pub fn next_message(&mut self) -> Option<Message> {
        loop {
            if let Item::Message {
                topic,
                log_time,
                data,
                ..
            } = self.next_item()?
            {
                return Some(Message {
                    topic,
                    log_time,
                    data,
                });
            }
        }
    }
}

impl<R: Read> Iterator for McapStream<R> {
    type Item = Item;
    fn next(&mut self) -> Option<Item> {
        self.next_item()
    }
}
