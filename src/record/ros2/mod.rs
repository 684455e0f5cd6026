//! ROS 2 recordings: an MCAP file that `ros2 bag play` replays and RViz2 shows
//! (`STEM.ros2.mcap`; see docs/ros2.md for replaying it).
//!
//! `ros2 bag play` refuses a file whose channels mix message encodings, so the ROS 2 recording
//! is a file of its own next to the protobuf `.mcap`: header profile `ros2`, every channel `cdr`
//! ([`cdr`]), every schema `ros2msg` ([`msgs`]), every channel with the
//! `offered_qos_profiles` metadata `rosbag2` writes (and reads back to create its publishers).
//!
//! | topic                 | type                          | QoS (durability, depth) | messages |
//! |-----------------------|-------------------------------|-------------------------|----------|
//! | `/tf`                 | `tf2_msgs/msg/TFMessage`      | volatile, 100           | one per recorded step: one `TransformStamped` per link frame, `header.frame_id = "world"`, `child_frame_id` = the frame id, the pose `world_from_link` (exactly the `/tf` of the `.mcap`) |
//! | `/robot_description`  | `std_msgs/msg/String`         | transient local, 1      | one at t = 0: the model's URDF with link names = frame ids and absolute `file://` meshes ([`crate::model::description`]) |
//! | `/bodies`             | `tumble_msgs/msg/BodyStates`  | volatile, 10            | one per recorded step: the values of the `.mcap`'s `/bodies` |
//!
//! All channels are reliable, keep-last, automatic liveliness. With several models each model
//! has its own description topic `/<model>/robot_description` ([`description_topics`]): RViz2's
//! RobotModel display shows one description topic, and a transient-local topic carrying several
//! messages would hand a late subscriber only the last one (depth 1). A scene of one model uses
//! `/robot_description`, the topic RViz2 and `robot_state_publisher` use by default. With
//! [`super::RecordingLayout::topic_groups`] the `/tf` and `/bodies` topics are repeated per
//! group under its prefix, as in the `.mcap`.
//!
//! Joint states of articulated models (`bodies = "articulated"`) go on `/joint_states` as
//! `sensor_msgs/msg/JointState` ([`msgs::joint_state`], QoS as `/bodies`): one
//! message per recorded step and topic group that holds joints, `name` = the joint names
//! prefixed as the frame ids are (`name/joint`, as the rewritten `/robot_description` names
//! them), `position` in rad or m, `velocity` in rad/s or m/s, `effort` empty. Only the joints
//! the scene keeps moving are listed (fixed and locked joints are merged into bodies; mimic
//! joints follow their leader, as `robot_state_publisher` computes them). A file without
//! articulated models has no `/joint_states` channel.
//!
//! Times: `log_time` = `publish_time` = the header stamps = simulation time from 0 (1970-01-01),
//! so replay with `ros2 bag play --clock` and run RViz2 with `use_sim_time:=true`. The metadata
//! record `tumble` (scene, settings, layout) is written before any schema or channel, so every
//! chunk holds messages and lists message indexes (Foxglove refuses chunks without them). The
//! file is written under `<path>.part` and renamed onto `path` only once complete.

pub mod cdr;
pub mod msgs;

use super::names::{
    BODIES_TOPIC, JOINT_STATES_TOPIC, METADATA_NAME, ROBOT_DESCRIPTION_TOPIC, TF_TOPIC, WORLD_FRAME,
};
use super::{Frame, RecordingLayout, Sink, TopicGroup};
use crate::fsutil::part_path;
use anyhow::Context;
use msgs::Stamp;
use std::collections::BTreeMap;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

/// File name suffix of ROS 2 recordings: `STEM.ros2.mcap`.
pub const EXTENSION: &str = "ros2.mcap";
/// Queue depth offered on `/tf` (what tf2's listener asks for).
pub const TF_DEPTH: u32 = 100;
/// Queue depth offered on `/bodies` and `/joint_states`.
pub const STATES_DEPTH: u32 = 10;

/// ROS 2 durability policy values as `rmw_qos_durability_policy_t` numbers them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Durability {
    /// A late subscriber gets the last `depth` messages (`/robot_description`).
    TransientLocal = 1,
    Volatile = 2,
}

/// The `offered_qos_profiles` channel metadata: a YAML list of one publisher's profile in the
/// form `rosbag2` writes (rosbag2_transport `qos.cpp`): policies as `rmw` enum integers
/// (history keep-last 1, reliability reliable 1, liveliness automatic 1) and durations
/// `{sec, nsec}`, here `0, 0` = unspecified (the `rmw` default, infinite).
pub fn offered_qos_profiles(durability: Durability, depth: u32) -> String {
    let zero = "\n    sec: 0\n    nsec: 0";
    format!(
        "- history: 1\n  depth: {depth}\n  reliability: 1\n  durability: {}\n  deadline:{zero}\n  \
         lifespan:{zero}\n  liveliness: 1\n  liveliness_lease_duration:{zero}\n  \
         avoid_ros_namespace_conventions: false\n",
        durability as u8
    )
}

/// The description topic of each of `layout`'s models, in order: `/robot_description` for a
/// single model; else `/<model>/robot_description`, the model's label made a valid ROS name
/// token (every character other than ASCII letters, digits and `_` replaced by `_`, a leading
/// digit or an empty label prefixed with `_`) and, when two labels map to the same token,
/// `_2`, `_3`, ... appended to the later ones.
pub fn description_topics(layout: &RecordingLayout) -> Vec<String> {
    if layout.robot_descriptions.len() == 1 {
        return vec![ROBOT_DESCRIPTION_TOPIC.to_string()];
    }
    let mut used = std::collections::HashSet::new();
    layout
        .robot_descriptions
        .iter()
        .map(|d| {
            let mut token: String = d
                .model
                .chars()
                .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
                .collect();
            if token.is_empty() || token.starts_with(|c: char| c.is_ascii_digit()) {
                token.insert(0, '_');
            }
            let mut candidate = token.clone();
            let mut n = 1;
            while !used.insert(candidate.clone()) {
                n += 1;
                candidate = format!("{token}_{n}");
            }
            format!("/{candidate}{ROBOT_DESCRIPTION_TOPIC}")
        })
        .collect()
}

/// The channels of one topic group.
struct ChannelGroup {
    tf_channel: u16,
    bodies_channel: u16,
    /// `/joint_states`, when the group holds joints.
    joints_channel: Option<u16>,
    group: TopicGroup,
}

/// Writes a ROS 2 MCAP file; see the module documentation for its layout.
pub struct Ros2Sink {
    writer: super::mcap::file::McapFileWriter,
    path: PathBuf,
    part: PathBuf,
    groups: Vec<ChannelGroup>,
    sequence: u32,
    frame_ids: Vec<String>,
    body_names: Vec<String>,
    joint_names: Vec<String>,
    /// Reused per message: the group's joint positions and velocities.
    positions: Vec<f64>,
    velocities: Vec<f64>,
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
            .chunk_size(Some(super::mcap::file::CHUNK_BYTES))
            .create(BufWriter::new(super::writeback::WritebackFile::new(file)))
            .with_context(|| format!("cannot write {}", part.display()))?;
        // First, before any schema or channel (see the module documentation).
        let mut metadata = layout.metadata.clone();
        metadata.insert(
            super::layout_json::LAYOUT_KEY.into(),
            super::layout_json::to_json(layout),
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
            groups.push(ChannelGroup {
                tf_channel,
                bodies_channel,
                joints_channel,
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
                msgs::joint_state(
                    &mut self.buf,
                    stamp,
                    &self.joint_names[joints],
                    &self.positions,
                    &self.velocities,
                    &[],
                )?;
                self.write_message(channel, time_ns)?;
            }
        }
        self.sequence = self.sequence.wrapping_add(1);
        Ok(())
    }

    fn finish(self: Box<Self>) -> anyhow::Result<()> {
        let Ros2Sink {
            writer, part, path, ..
        } = *self;
        super::mcap::file::finish_file(writer, &part, &path)
    }

    fn path(&self) -> Option<PathBuf> {
        Some(self.path.clone())
    }

    fn complete(self: Box<Self>) -> anyhow::Result<()> {
        let Ros2Sink { writer, part, .. } = *self;
        super::mcap::file::complete_file(writer, &part)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::RobotDescription;

    fn layout_of(models: &[&str]) -> RecordingLayout {
        RecordingLayout {
            robot_descriptions: models
                .iter()
                .map(|m| RobotDescription {
                    model: m.to_string(),
                    urdf_path: "r.urdf".into(),
                    urdf: Ok(String::new()),
                })
                .collect(),
            ..Default::default()
        }
    }

    /// One model: the standard topic; several: one valid, distinct topic per model, in order.
    #[test]
    fn description_topics_are_standard_for_one_model_and_distinct_for_several() {
        assert_eq!(
            description_topics(&layout_of(&["a-b"])),
            ["/robot_description"]
        );
        assert_eq!(
            description_topics(&layout_of(&["arm", "a-b", "a.b", "2x", ""])),
            [
                "/arm/robot_description",
                "/a_b/robot_description",
                "/a_b_2/robot_description",
                "/_2x/robot_description",
                "/_/robot_description",
            ]
        );
    }

    /// A description that could not be prepared stops the sink before any file exists, with a
    /// message naming the output, the model and the URDF.
    #[test]
    fn a_failed_description_is_reported_and_writes_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.ros2.mcap");
        let mut layout = layout_of(&["m"]);
        layout.robot_descriptions[0].urdf = Err("bad xml".into());
        let e = Ros2Sink::create(&path, &layout).err().unwrap().to_string();
        assert!(
            e.contains("x.ros2.mcap") && e.contains("\"m\"") && e.contains("r.urdf"),
            "{e}"
        );
        assert!(e.contains("bad xml"), "{e}");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
}
