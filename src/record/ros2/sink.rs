//! [`Ros2Sink`]: writes a recording as a ROS 2 MCAP file (the channels are in [`super`]).

use super::msgs::{self, Stamp};
use super::{Durability, STATES_DEPTH, TF_DEPTH, description_topics, offered_qos_profiles};
use crate::fsutil::part_path;
use crate::record::names::{
    BODIES_TOPIC, CONTACTS_TOPIC, JOINT_STATES_TOPIC, METADATA_NAME, TF_TOPIC, WORLD_FRAME,
};
use crate::record::{Frame, RecordingLayout, Sink, TopicGroup};
use anyhow::Context;
use std::collections::BTreeMap;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

/// The channels of one topic group.
struct ChannelGroup {
    tf_channel: u16,
    bodies_channel: u16,
    /// `/joint_states`, when the group holds joints.
    joints_channel: Option<u16>,
    /// `/contacts`, in runs that can have contacts.
    contacts_channel: Option<u16>,
    group: TopicGroup,
}

/// Writes a ROS 2 MCAP file; see the module documentation for its layout.
pub struct Ros2Sink {
    writer: crate::record::mcap::file::McapFileWriter,
    path: PathBuf,
    part: PathBuf,
    groups: Vec<ChannelGroup>,
    sequence: u32,
    frame_ids: Vec<String>,
    body_names: Vec<String>,
    joint_names: Vec<String>,
    /// Reused per message: the group's joint positions, velocities and efforts.
    positions: Vec<f64>,
    velocities: Vec<f64>,
    efforts: Vec<f64>,
    /// Whether a joint is driven: then `effort` is filled (0 for an undriven joint), else it
    /// is left empty as before drives existed.
    driven: bool,
    buf: Vec<u8>,
}

impl Ros2Sink {
    /// Creates `<path>.part` and writes the metadata, schemas, channels and the robot
    /// descriptions (at t = 0). Fails, naming the URDF, when a model's description could not be
    /// prepared.
    pub fn create(path: &Path, layout: &RecordingLayout) -> anyhow::Result<Self> {
        let descriptions: Vec<&str> = layout
            .robot_descriptions
            .iter()
            .map(|d| {
                d.urdf.as_deref().map_err(|e| {
                    anyhow::anyhow!(
                        "cannot write {}: model {:?} ({}): its URDF cannot be rewritten for /robot_description: {e}",
                        path.display(),
                        d.model,
                        d.urdf_path.display()
                    )
                })
            })
            .collect::<anyhow::Result<_>>()?;
        let part = part_path(path);
        let file = crate::fsutil::create_part(path)?;
        let mut writer = mcap::WriteOptions::new()
            .profile("ros2")
            .library(format!("tumble {}", crate::VERSION))
            .chunk_size(Some(crate::record::mcap::file::CHUNK_BYTES))
            .create(BufWriter::new(
                crate::record::writeback::WritebackFile::new(file),
            ))
            .with_context(|| format!("cannot write {}", part.display()))?;
        // First, before any schema or channel (see the module documentation).
        let mut metadata = layout.metadata.clone();
        metadata.insert(
            crate::record::layout_json::LAYOUT_KEY.into(),
            crate::record::layout_json::to_json(layout),
        );
        writer.write_metadata(&mcap::records::Metadata {
            name: METADATA_NAME.into(),
            metadata,
        })?;
        let schema = |writer: &mut mcap::Writer<_>, name: &str, text: String| {
            writer.add_schema(name, "ros2msg", text.as_bytes())
        };
        let tf_schema = schema(&mut writer, msgs::TF_MESSAGE, msgs::tf_message_schema())?;
        let bodies_schema = schema(&mut writer, msgs::BODY_STATES, msgs::body_states_schema())?;
        let joints_schema = if layout.joints.is_empty() {
            None
        } else {
            Some(schema(
                &mut writer,
                msgs::JOINT_STATE,
                msgs::joint_state_schema(),
            )?)
        };
        let contacts_schema = if layout.contacts {
            Some(schema(
                &mut writer,
                msgs::CONTACTS,
                msgs::contacts_schema(),
            )?)
        } else {
            None
        };
        let qos = |durability, depth| {
            BTreeMap::from([(
                "offered_qos_profiles".to_string(),
                offered_qos_profiles(durability, depth),
            )])
        };
        let mut groups = Vec::new();
        for group in layout.groups() {
            let tf_channel = writer.add_channel(
                tf_schema,
                &format!("{}{TF_TOPIC}", group.prefix),
                "cdr",
                &qos(Durability::Volatile, TF_DEPTH),
            )?;
            let bodies_channel = writer.add_channel(
                bodies_schema,
                &format!("{}{BODIES_TOPIC}", group.prefix),
                "cdr",
                &qos(Durability::Volatile, STATES_DEPTH),
            )?;
            let joints_channel = match joints_schema {
                Some(schema) if !group.joints.is_empty() => Some(writer.add_channel(
                    schema,
                    &format!("{}{JOINT_STATES_TOPIC}", group.prefix),
                    "cdr",
                    &qos(Durability::Volatile, STATES_DEPTH),
                )?),
                _ => None,
            };
            let contacts_channel = match contacts_schema {
                Some(schema) => Some(writer.add_channel(
                    schema,
                    &format!("{}{CONTACTS_TOPIC}", group.prefix),
                    "cdr",
                    &qos(Durability::Volatile, STATES_DEPTH),
                )?),
                None => None,
            };
            groups.push(ChannelGroup {
                tf_channel,
                bodies_channel,
                joints_channel,
                contacts_channel,
                group,
            });
        }
        let mut buf = Vec::new();
        if !descriptions.is_empty() {
            let string_schema = schema(&mut writer, msgs::STRING, msgs::string_schema())?;
            for (topic, urdf) in description_topics(layout).iter().zip(descriptions) {
                let channel = writer.add_channel(
                    string_schema,
                    topic,
                    "cdr",
                    &qos(Durability::TransientLocal, 1),
                )?;
                msgs::string_message(&mut buf, urdf)?;
                let header = mcap::records::MessageHeader {
                    channel_id: channel,
                    sequence: 0,
                    log_time: 0,
                    publish_time: 0,
                };
                writer.write_to_known_channel(&header, &buf)?;
            }
        }
        Ok(Self {
            writer,
            path: path.to_path_buf(),
            part,
            groups,
            sequence: 0,
            frame_ids: layout.frames.iter().map(|f| f.frame_id.clone()).collect(),
            body_names: layout.bodies.iter().map(|b| b.name.clone()).collect(),
            joint_names: layout.joints.iter().map(|j| j.name.clone()).collect(),
            positions: Vec::new(),
            velocities: Vec::new(),
            efforts: Vec::new(),
            driven: !layout.drives.is_empty(),
            buf,
        })
    }

    fn write_message(&mut self, channel_id: u16, time_ns: u64) -> anyhow::Result<()> {
        let header = mcap::records::MessageHeader {
            channel_id,
            sequence: self.sequence,
            log_time: time_ns,
            publish_time: time_ns,
        };
        self.writer.write_to_known_channel(&header, &self.buf)?;
        Ok(())
    }
}

impl Sink for Ros2Sink {
    fn write(&mut self, frame: &Frame<'_>) -> anyhow::Result<()> {
        let stamp = Stamp::from_ns(frame.time_ns)?;
        let time_ns = frame.time_ns as u64; // not negative: Stamp::from_ns checked it
        for g in 0..self.groups.len() {
            let (tf_channel, bodies_channel) =
                (self.groups[g].tf_channel, self.groups[g].bodies_channel);
            let frames = self.groups[g].group.frames.clone();
            let bodies = self.groups[g].group.bodies.clone();
            let transforms = self.frame_ids[frames.clone()]
                .iter()
                .map(String::as_str)
                .zip(&frame.world_from_link[frames]);
            msgs::tf_message(&mut self.buf, stamp, WORLD_FRAME, transforms)?;
            self.write_message(tf_channel, time_ns)?;
            if let Some(channel) = self.groups[g].contacts_channel {
                crate::record::contacts::check(frame.contacts, self.body_names.len())?;
                msgs::contacts(
                    &mut self.buf,
                    stamp,
                    frame.step,
                    &self.body_names,
                    crate::record::contacts::in_group(frame.contacts, &bodies),
                )?;
                self.write_message(channel, time_ns)?;
            }
            msgs::body_states(
                &mut self.buf,
                stamp,
                frame.step,
                &self.body_names[bodies.clone()],
                &frame.bodies[bodies],
            )?;
            self.write_message(bodies_channel, time_ns)?;
            if let Some(channel) = self.groups[g].joints_channel {
                let joints = self.groups[g].group.joints.clone();
                let states = frame.joints.get(joints.clone()).ok_or_else(|| {
                    anyhow::anyhow!(
                        "frame has {} joint states, the layout {}",
                        frame.joints.len(),
                        self.joint_names.len()
                    )
                })?;
                self.positions.clear();
                self.positions.extend(states.iter().map(|j| j.position));
                self.velocities.clear();
                self.velocities.extend(states.iter().map(|j| j.velocity));
                self.efforts.clear();
                if self.driven {
                    self.efforts.extend(states.iter().map(|j| j.effort));
                }
                msgs::joint_state(
                    &mut self.buf,
                    stamp,
                    &self.joint_names[joints],
                    &self.positions,
                    &self.velocities,
                    &self.efforts,
                )?;
                self.write_message(channel, time_ns)?;
            }
        }
        self.sequence = self.sequence.wrapping_add(1);
        Ok(())
    }

    fn write_summary(&mut self, entries: &[(String, String)]) -> anyhow::Result<()> {
        self.writer.write_metadata(&mcap::records::Metadata {
            name: crate::record::names::SUMMARY_METADATA_NAME.into(),
            metadata: entries.iter().cloned().collect(),
        })?;
        Ok(())
    }

    fn finish(self: Box<Self>) -> anyhow::Result<()> {
        let Ros2Sink {
            writer, part, path, ..
        } = *self;
        crate::record::mcap::file::finish_file(writer, &part, &path)
    }

    fn path(&self) -> Option<PathBuf> {
        Some(self.path.clone())
    }

    fn complete(self: Box<Self>) -> anyhow::Result<()> {
        let Ros2Sink { writer, part, .. } = *self;
        crate::record::mcap::file::complete_file(writer, &part)
    }
}
