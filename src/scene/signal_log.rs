//! A signal read from a recorded MCAP log (`{ log = "run.mcap", topic = "/joint_states" }`):
//! one joint's positions, velocities or efforts over time, as a [`Signal::Table`].
//!
//! The topic must carry `sensor_msgs/msg/JointState` (CDR: a ROS 2 bag, or tumble's
//! `--ros2` recording) or `tumble.JointStates` (protobuf: tumble's `/joints`)
//! ([`super::joint_states`]). Every message naming the joint is a row: its time is the
//! message's log time minus the log time of the topic's first message (so every signal read
//! from one log shares one clock, starting at 0), its value the joint's quantity. Times must
//! increase strictly from row to row and values be finite.
//!
//! The file is read front to back with `mcap`'s linear reader: one record (or decompressed
//! chunk, at most [`RECORD_MAX_BYTES`]) in memory at a time, chunk CRCs checked, whatever the
//! file's length up to [`LOG_MAX_BYTES`]; the signal holds at most [`LOG_MAX_ROWS`] rows. A
//! file cut short or damaged is an error (a signal is read whole or not at all).

use super::joint_states::{Form, Quantity, Sample};
use crate::sim::signal::Signal;
use anyhow::{Context, bail};
use mcap::records::Record;
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};
use std::collections::{BTreeSet, HashMap};
use std::io::Read;
use std::path::Path;

/// Largest log file read, bytes.
pub const LOG_MAX_BYTES: u64 = 16 << 30;
/// Largest record (a chunk, decompressed) read, bytes.
pub const RECORD_MAX_BYTES: u64 = 1 << 28;
/// Most rows of a signal read from a log (64 MiB of times and values).
pub const LOG_MAX_ROWS: usize = 1 << 22;

/// What a log signal picks: the joint's name in the log and the quantity.
#[derive(Debug, Clone, Copy)]
pub struct Pick<'a> {
    pub joint: &'a str,
    pub quantity: Quantity,
}

/// The channels of the wanted topic, and every topic seen (for the error of a missing one).
#[derive(Default)]
struct Channels {
    wanted: HashMap<u16, Form>,
    topics: BTreeSet<String>,
    schemas: HashMap<u16, String>,
}

/// The rows read so far.
struct Rows {
    /// Log time of the topic's first message, ns.
    start_ns: Option<u64>,
    /// Log time of the last row, ns.
    last_ns: Option<u64>,
    times_secs: Vec<f64>,
    values: Vec<f64>,
    /// Messages on the topic so far.
    messages: u64,
    /// Joint names seen on the topic (a few).
    names: Vec<String>,
}

/// Reads `pick` from the messages on `topic` of the MCAP file `path` (see the module doc).
pub fn read(path: &Path, topic: &str, pick: Pick<'_>) -> anyhow::Result<Signal> {
    crate::input::check(path, LOG_MAX_BYTES)?;
    let file = std::fs::File::open(path)?;
    // The object opened may differ from the one checked (a rename in between): check again.
    if !file.metadata()?.is_file() {
        bail!("not a regular file (only regular files are read)");
    }
    read_from(
        std::io::BufReader::with_capacity(1 << 16, file),
        topic,
        pick,
    )
}

/// [`read`] from any reader of an MCAP file's bytes.
pub fn read_from(mut source: impl Read, topic: &str, pick: Pick<'_>) -> anyhow::Result<Signal> {
    let mut magic = [0u8; 8];
    let mut filled = 0;
    while filled < magic.len() {
        match source.read(&mut magic[filled..])? {
            0 => break,
            n => filled += n,
        }
    }
    if magic[..filled] != mcap::MAGIC[..] {
        bail!("not an MCAP file (it does not start with the MCAP magic bytes)");
    }
    let options = LinearReaderOptions::default()
        .with_validate_chunk_crcs(true)
        .with_prevalidate_chunk_crcs(true)
        .with_record_length_limit(RECORD_MAX_BYTES as usize);
    let mut reader = LinearReader::new_with_options(options);
    // The magic already read, handed to the reader first.
    reader.insert(magic.len()).copy_from_slice(&magic);
    reader.notify_read(magic.len());
    let mut channels = Channels::default();
    let mut rows = Rows {
        start_ns: None,
        last_ns: None,
        times_secs: Vec::new(),
        values: Vec::new(),
        messages: 0,
        names: Vec::new(),
    };
    let mut bytes_read = magic.len() as u64;
    while let Some(event) = reader.next_event() {
        let event = event.map_err(|e| {
            anyhow::anyhow!("the file is damaged or cut short after {bytes_read} bytes: {e}")
        })?;
        match event {
            LinearReadEvent::ReadRequest(n) => {
                let read = source.read(reader.insert(n))?;
                bytes_read += read as u64;
                reader.notify_read(read);
            }
            LinearReadEvent::Record { data, opcode } => {
                let record = mcap::parse_record(opcode, data).map_err(|e| {
                    anyhow::anyhow!(
                        "malformed record (opcode {opcode:#04x}) after {bytes_read} bytes: {e}"
                    )
                })?;
                take(record, topic, pick, &mut channels, &mut rows)?;
            }
        }
    }
    if channels.wanted.is_empty() {
        let listed: Vec<&str> = channels
            .topics
            .iter()
            .map(String::as_str)
            .take(20)
            .collect();
        bail!(
            "no topic `{topic}` in the log (its topics: {})",
            if listed.is_empty() {
                "none".to_string()
            } else {
                listed.join(", ")
            }
        );
    }
    if rows.times_secs.is_empty() {
        bail!(
            "no message on `{topic}` names joint `{}` ({} messages; the joints they name: {}); \
             give the log's name of the joint with `joint = \"...\"` in the log table{}",
            pick.joint,
            rows.messages,
            if rows.names.is_empty() {
                "none".to_string()
            } else {
                rows.names.join(", ")
            },
            crate::message::did_you_mean(pick.joint, rows.names.iter().map(|n| n.as_ref()))
        );
    }
    Ok(Signal::Table {
        times_secs: rows.times_secs,
        values: rows.values,
    })
}

/// One record: schemas and channels remembered, the topic's messages made rows.
fn take(
    record: Record<'_>,
    topic: &str,
    pick: Pick<'_>,
    channels: &mut Channels,
    rows: &mut Rows,
) -> anyhow::Result<()> {
    match record {
        Record::Schema { header, .. } => {
            channels.schemas.insert(header.id, header.name);
        }
        Record::Channel(channel) => {
            if channel.topic != topic {
                if channels.topics.len() < 1000 {
                    channels.topics.insert(channel.topic);
                }
                return Ok(());
            }
            let schema = channels
                .schemas
                .get(&channel.schema_id)
                .map_or("", String::as_str);
            let Some(form) = Form::of(schema, &channel.message_encoding) else {
                bail!(
                    "topic `{topic}` carries `{schema}` messages ({} encoding): a log signal \
                     reads {} (cdr) or {} (protobuf)",
                    channel.message_encoding,
                    super::joint_states::ROS2_SCHEMA,
                    super::joint_states::TUMBLE_SCHEMA
                );
            };
            channels.wanted.insert(channel.id, form);
        }
        Record::Message { header, data } => {
            let Some(&form) = channels.wanted.get(&header.channel_id) else {
                return Ok(());
            };
            rows.messages += 1;
            let n = rows.messages;
            let start = *rows.start_ns.get_or_insert(header.log_time);
            let sample = form
                .sample(&data, pick.joint, pick.quantity, &mut rows.names)
                .with_context(|| format!("message {n} on `{topic}`"))?;
            let value = match sample {
                Sample::Absent => return Ok(()),
                Sample::NoValue => bail!(
                    "message {n} on `{topic}` names joint `{}` but carries no {} for it",
                    pick.joint,
                    pick.quantity.name()
                ),
                Sample::Value(v) => v,
            };
            if !value.is_finite() {
                bail!(
                    "message {n} on `{topic}`: joint `{}`'s {} is {value}: every value must be \
                     finite",
                    pick.joint,
                    pick.quantity.name()
                );
            }
            // Correctly rounded: 250 ms is 0.25 exactly, 10 ms the double nearest 0.01.
            let seconds = |ns: u64| ns as f64 / 1e9;
            if header.log_time < start || rows.last_ns.is_some_and(|l| header.log_time <= l) {
                bail!(
                    "message {n} on `{topic}` has log time {} s, not after the previous row's \
                     ({} s): a log signal needs increasing times",
                    seconds(header.log_time.saturating_sub(start)),
                    seconds(rows.last_ns.unwrap_or(start).saturating_sub(start)),
                );
            }
            if rows.times_secs.len() >= LOG_MAX_ROWS {
                bail!("more than {LOG_MAX_ROWS} messages on `{topic}` name the joint");
            }
            rows.last_ns = Some(header.log_time);
            rows.times_secs.push(seconds(header.log_time - start));
            rows.values.push(value);
        }
        _ => {}
    }
    Ok(())
}
