//! `tumble diff`'s joint comparison: joint positions matched by joint name between two
//! recordings, for instance a simulated run against the log that drove it.
//!
//! # Where the joints are
//!
//! A joints topic is a channel of `tumble.JointStates` (protobuf, a tumble MCAP's `/joints`,
//! [`crate::record::mcap::mechanism_proto`]) or of `sensor_msgs/msg/JointState` (CDR, a ROS 2
//! recording's `/joint_states`, tumble's or any robot's; [`msgs::decode_joint_state`]). Each file
//! is read on the topic named by `--joint-topic`, or by default on the first of `/joints` and
//! `/joint_states` it has with one of those two schemas. A joint is compared when both files
//! name it; the others are listed. Values are positions: rad (continuous joints as recorded:
//! tumble unwraps them, a robot driver may not) or m.
//!
//! # Aligning time
//!
//! The messages' log times, as for frames ([`super::diff`]): inside the span both cover, the
//! shared timestamps when they are at least half of the coarser recording's samples, else the
//! coarser recording's times with the other interpolated linearly between its two neighbouring
//! samples (the report counts the interpolated values). A log whose clock is not the
//! simulation's (a robot's wall-clock stamps) does not overlap a run's span: with `--zero-start`
//! each file's times are taken from its joints topic's first message, the clock a scene's `log`
//! signal reads a log on (so a run driven by a log is compared with it sample for sample).
//!
//! # Reported
//!
//! Per joint the largest absolute difference `|θ_A − θ_B|` and the time it occurs, the RMS over
//! the comparison times and the value at the last one. With a tolerance
//! ([`super::diff::DiffSettings::joint_tolerance`]) the joints pass when every compared joint's
//! largest difference is within it.
//!
//! # Bounded memory
//!
//! The first pass ([`super::diff`]'s scan) keeps the joints topic's timestamps (8 bytes a
//! sample) and the first message's names; the comparison streams both files again on their
//! joints topic, holding two samples of each ([`JointCursor`]).

use super::stream::{Item, McapStream};
use crate::record::mcap::mechanism_proto as mp;
use crate::record::ros2::msgs;
use anyhow::{Context, bail};
use prost::Message as _;
use std::collections::HashMap;
use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

/// The topics looked for when no `--joint-topic` is given, in order.
pub const DEFAULT_JOINT_TOPICS: [&str; 2] = ["/joints", "/joint_states"];

/// Whether a channel's schema is one of the joint states read here.
pub fn is_joint_schema(schema: &str) -> bool {
    schema == mp::JOINT_STATES_SCHEMA || schema == msgs::JOINT_STATE
}

/// The `(name, position)` pairs of one joint-states message of schema `schema`.
pub fn decode_positions(schema: &str, data: &[u8]) -> anyhow::Result<Vec<(String, f64)>> {
    if schema == mp::JOINT_STATES_SCHEMA {
        let message =
            mp::JointStates::decode(data).context("a message is not a tumble.JointStates")?;
        return Ok(message
            .joints
            .into_iter()
            .map(|j| (j.name, j.position))
            .collect());
    }
    if schema == msgs::JOINT_STATE {
        let message = msgs::decode_joint_state(data)
            .context("a message is not a CDR sensor_msgs/msg/JointState")?;
        if message.position.len() != message.name.len() {
            bail!(
                "a sensor_msgs/msg/JointState names {} joints and holds {} positions",
                message.name.len(),
                message.position.len()
            );
        }
        return Ok(message.name.into_iter().zip(message.position).collect());
    }
    bail!(
        "schema {schema:?} is not a joint state ({} or {})",
        mp::JOINT_STATES_SCHEMA,
        msgs::JOINT_STATE
    )
}

/// What the first pass learns of a file's joints topic.
#[derive(Debug, Clone, PartialEq)]
pub struct JointScan {
    pub topic: String,
    pub schema: String,
    /// Log times of its messages, increasing, less [`Self::offset_ns`].
    pub times: Vec<u64>,
    /// The joints of its first message, in order.
    pub names: Vec<String>,
    /// Subtracted from every log time ([`Self::start_at_zero`]; 0 otherwise).
    pub offset_ns: u64,
}

impl JointScan {
    /// Takes a message of the first pass: the joints topic's (the requested one, else the
    /// first of [`DEFAULT_JOINT_TOPICS`] seen with a joint-states schema) is recorded in
    /// `scan`, other messages are ignored.
    pub fn offer(
        scan: &mut Option<JointScan>,
        requested: Option<&str>,
        path: &Path,
        (topic, schema, log_time, data): (&str, &str, u64, &[u8]),
    ) -> anyhow::Result<()> {
        match scan {
            Some(s) if s.topic != topic => return Ok(()),
            None => {
                let wanted = match requested {
                    Some(r) => r == topic,
                    None => DEFAULT_JOINT_TOPICS.contains(&topic) && is_joint_schema(schema),
                };
                if !wanted {
                    return Ok(());
                }
                if !is_joint_schema(schema) {
                    bail!(
                        "{}: topic {topic} has schema {schema:?}, not joint states ({} or {})",
                        path.display(),
                        mp::JOINT_STATES_SCHEMA,
                        msgs::JOINT_STATE
                    );
                }
                let names = decode_positions(schema, data)
                    .with_context(|| format!("{}: {topic}", path.display()))?
                    .into_iter()
                    .map(|(name, _)| name)
                    .collect();
                *scan = Some(JointScan {
                    topic: topic.to_string(),
                    schema: schema.to_string(),
                    times: Vec::new(),
                    names,
                    offset_ns: 0,
                });
            }
            Some(_) => {}
        }
        let s = scan.as_mut().expect("set above");
        if let Some(&last) = s.times.last()
            && log_time <= last
        {
            bail!(
                "{}: {topic} message at {log_time} ns follows one at {last} ns (times must \
                 increase)",
                path.display()
            );
        }
        s.times.push(log_time);
        Ok(())
    }

    /// Takes the times from the topic's first message (`--zero-start`: the clock a scene's
    /// `log` signal reads a log on, `docs/scenes.md`).
    pub fn start_at_zero(&mut self) {
        let first = self.times.first().copied().unwrap_or(0);
        for t in &mut self.times {
            *t -= first;
        }
        self.offset_ns += first;
    }
}

/// One sample of the compared joints.
struct Sample {
    t: u64,
    positions: Vec<Option<f64>>,
}

/// The second pass over one file: the compared joints' positions at requested times.
pub struct JointCursor {
    path: PathBuf,
    stream: McapStream<BufReader<File>>,
    topic: String,
    /// joint name -> slot among the compared joints
    slots: HashMap<String, usize>,
    names: Vec<String>,
    /// Subtracted from every log time ([`JointScan::offset_ns`]).
    offset_ns: u64,
    prev: Option<Sample>,
    next: Option<Sample>,
    /// Values obtained by interpolation.
    pub interpolated: usize,
}

impl JointCursor {
    /// Reads `scan`'s topic of `path` for the joints `compared`.
    pub fn open(path: &Path, scan: &JointScan, compared: &[String]) -> anyhow::Result<Self> {
        let topic = scan.topic.as_str();
        Ok(Self {
            path: path.to_owned(),
            stream: McapStream::open(path)?,
            topic: topic.to_owned(),
            slots: compared
                .iter()
                .enumerate()
                .map(|(i, n)| (n.clone(), i))
                .collect(),
            names: compared.to_vec(),
            offset_ns: scan.offset_ns,
            prev: None,
            next: None,
            interpolated: 0,
        })
    }

    fn read(&mut self) -> anyhow::Result<Option<Sample>> {
        while let Some(item) = self.stream.next_item() {
            let Item::Message {
                topic,
                schema,
                log_time,
                data,
            } = item
            else {
                continue;
            };
            if *topic != *self.topic {
                continue;
            }
            let mut positions = vec![None; self.slots.len()];
            for (name, p) in decode_positions(&schema, &data)
                .with_context(|| format!("{}: {topic}", self.path.display()))?
            {
                if let Some(&slot) = self.slots.get(&name) {
                    positions[slot] = Some(p);
                }
            }
            return Ok(Some(Sample {
                t: log_time.saturating_sub(self.offset_ns),
                positions,
            }));
        }
        Ok(None)
    }

    fn positions(&self, sample: &Sample) -> anyhow::Result<Vec<f64>> {
        sample
            .positions
            .iter()
            .zip(&self.names)
            .map(|(p, name)| {
                p.with_context(|| {
                    format!(
                        "{}: joint {name:?} is missing at t = {} s",
                        self.path.display(),
                        sample.t as f64 / 1e9
                    )
                })
            })
            .collect()
    }

    /// The compared joints' positions at `t`: the sample at `t`, or linear between the two
    /// samples around it.
    pub fn at(&mut self, t: u64) -> anyhow::Result<Vec<f64>> {
        if self.next.is_none() {
            self.next = self.read()?;
        }
        while self.next.as_ref().is_some_and(|n| n.t < t) {
            self.prev = self.next.take();
            self.next = self.read()?;
        }
        let next = self.next.as_ref().with_context(|| {
            format!(
                "{}: no {} sample at or after t = {} s (file ended)",
                self.path.display(),
                self.topic,
                t as f64 / 1e9
            )
        })?;
        if next.t == t {
            return self.positions(next);
        }
        let prev = self.prev.as_ref().with_context(|| {
            format!(
                "{}: no {} sample before t = {} s",
                self.path.display(),
                self.topic,
                t as f64 / 1e9
            )
        })?;
        let s = (t - prev.t) as f64 / (next.t - prev.t) as f64;
        let (a, b) = (self.positions(prev)?, self.positions(next)?);
        self.interpolated += a.len();
        Ok(a.iter().zip(&b).map(|(a, b)| a + s * (b - a)).collect())
    }
}

/// One joint's differences (the `joints` of the diff's JSON `joints` object).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct JointDiff {
    pub name: String,
    /// Largest `|θ_A − θ_B|`, rad or m, and when, s.
    pub err_max: f64,
    pub err_max_time: f64,
    pub err_rms: f64,
    /// At the last comparison time.
    pub err_end: f64,
}

/// Running statistics of one joint.
#[derive(Debug, Default, Clone)]
pub struct JointAccumulator {
    max: f64,
    max_t: u64,
    sq: f64,
    end: f64,
}

impl JointAccumulator {
    /// Adds the difference `err` at `t`; a NaN becomes the maximum (and fails any tolerance).
    pub fn add(&mut self, t: u64, err: f64) {
        if err > self.max || err.is_nan() {
            self.max = err;
            self.max_t = t;
        }
        self.sq += err * err;
        self.end = err;
    }

    /// The statistics over `n` comparison times.
    pub fn report(&self, name: &str, n: usize) -> JointDiff {
        JointDiff {
            name: name.to_string(),
            err_max: self.max,
            err_max_time: self.max_t as f64 / 1e9,
            err_rms: (self.sq / n as f64).sqrt(),
            err_end: self.end,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The largest difference, its time, the RMS and the last value; a NaN wins the maximum.
    #[test]
    fn the_accumulator_keeps_the_maximum_and_its_time() {
        let mut acc = JointAccumulator::default();
        for (t, e) in [(0, 0.0), (10, 3.0), (20, 4.0), (30, 1.0)] {
            acc.add(t, e);
        }
        let r = acc.report("j", 4);
        assert_eq!((r.err_max, r.err_max_time, r.err_end), (4.0, 2e-8, 1.0));
        assert_eq!(r.err_rms, (26.0f64 / 4.0).sqrt());
        acc.add(40, f64::NAN);
        assert!(acc.report("j", 5).err_max.is_nan());
    }

    /// Both encodings decode to name and position; another schema is refused by name.
    #[test]
    fn protobuf_and_cdr_joint_states_decode() {
        let message = mp::joint_states(
            0,
            0,
            &["a".to_string(), "b".to_string()],
            &[
                crate::record::JointState {
                    position: 1.5,
                    ..Default::default()
                },
                crate::record::JointState {
                    position: -2.0,
                    ..Default::default()
                },
            ],
            &[],
        );
        let got = decode_positions(mp::JOINT_STATES_SCHEMA, &message.encode_to_vec()).unwrap();
        assert_eq!(got, [("a".to_string(), 1.5), ("b".to_string(), -2.0)]);
        let mut buf = Vec::new();
        let stamp = msgs::Stamp { sec: 0, nanosec: 0 };
        msgs::joint_state(&mut buf, stamp, &["c".into()], &[0.25], &[], &[]).unwrap();
        let got = decode_positions(msgs::JOINT_STATE, &buf).unwrap();
        assert_eq!(got, [("c".to_string(), 0.25)]);
        msgs::joint_state(&mut buf, stamp, &["c".into()], &[], &[1.0], &[]).unwrap();
        let err = decode_positions(msgs::JOINT_STATE, &buf).unwrap_err();
        assert!(
            err.to_string().contains("1 joints and holds 0 positions"),
            "{err}"
        );
        let err = decode_positions("foxglove.FrameTransforms", &buf).unwrap_err();
        assert!(err.to_string().contains("not a joint state"), "{err}");
    }
}
