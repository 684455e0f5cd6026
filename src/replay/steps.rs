//! A tumble MCAP recording read back step by step: the layout from the `tumble` metadata record
//! ([`crate::record::layout_json`]), then one [`RecordedStep`] per recorded step, rebuilt from the
//! `/tf` and `/bodies` messages of every topic group (see [`crate::record::mcap`]), and with
//! articulated models their `/joints` and `/mechanisms` ([`crate::record::mcap::mechanism_proto`]),
//! and in runs that can have contacts their `/contacts` ([`crate::record::mcap::contact_proto`]).
//!
//! A step is handed out only when every frame's pose and every body's state at that time were
//! read; a step missing some (the file was cut between its messages) is dropped and counted in
//! [`StepReader::incomplete_steps`].

use super::stream::{Item, McapStream, Message, StreamEnd};
use crate::record::layout_json::{LAYOUT_KEY, from_json};
use crate::record::mcap::mechanism_proto as mp;
use crate::record::mcap::proto;
use crate::record::names::{
    BODIES_TOPIC, CONTACTS_TOPIC, JOINTS_TOPIC, MECHANISMS_TOPIC, METADATA_NAME, TF_TOPIC,
};
use crate::record::{BodyState, ContactState, JointState, MechanismState, RecordingLayout};
use anyhow::{Context, bail};
use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion, Vector3};
use prost::Message as _;
use std::collections::HashMap;
use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

/// One recorded step: what a [`crate::record::Frame`] held when it was recorded.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordedStep {
    pub step: u64,
    pub time_ns: i64,
    /// In the order of the layout's frames.
    pub world_from_link: Vec<Isometry3<f64>>,
    /// In the order of the layout's bodies.
    pub bodies: Vec<BodyState>,
    /// In the order of the layout's joints (articulated models).
    pub joints: Vec<JointState>,
    /// In the order of the layout's mechanisms.
    pub mechanisms: Vec<MechanismState>,
    /// The step's contacts, every group's in group order.
    pub contacts: Vec<ContactState>,
}

/// Fails for a ROS 2 recording (header profile `ros2`, [`crate::record::ros2`]): its messages
/// are CDR, and tumble reads its recordings back from the protobuf file written beside it.
pub fn refuse_ros2<R: std::io::Read>(stream: &McapStream<R>, path: &Path) -> anyhow::Result<()> {
    if stream.profile() == Some("ros2") {
        bail!(
            "{}: a ROS 2 recording (profile ros2, CDR messages); tumble reads back the protobuf \
             recording written beside it (STEM.mcap)",
            path.display()
        );
    }
    Ok(())
}

/// Decodes a `/tf` message into `(child_frame_id, world_from_child)` pairs.
pub fn decode_transforms(data: &[u8]) -> anyhow::Result<Vec<(String, Isometry3<f64>)>> {
    let message = foxglove::messages::FrameTransforms::decode(data)
        .context("a /tf message is not a foxglove.FrameTransforms")?;
    message
        .transforms
        .into_iter()
        .map(|t| {
            let p = t.translation.unwrap_or_default();
            let q = t.rotation.unwrap_or_default();
            let q = Quaternion::new(q.w, q.x, q.y, q.z);
            let norm = q.norm();
            let finite = p.x.is_finite() && p.y.is_finite() && p.z.is_finite();
            if !(finite && norm.is_finite() && norm > 0.0) {
                bail!("frame {:?} has a non-finite pose", t.child_frame_id);
            }
            // Recorded quaternions are unit to round-off; use them as stored when they are, so a
            // replay reproduces the recording exactly.
            let rotation = if (norm - 1.0).abs() < 1e-12 {
                UnitQuaternion::new_unchecked(q)
            } else {
                UnitQuaternion::from_quaternion(q)
            };
            let iso = Isometry3::from_parts(Translation3::new(p.x, p.y, p.z), rotation);
            Ok((t.child_frame_id, iso))
        })
        .collect()
}

fn vec3(v: &Option<proto::Vector3>) -> Vector3<f64> {
    v.as_ref()
        .map_or_else(Vector3::zeros, |v| Vector3::new(v.x, v.y, v.z))
}

/// A step being assembled from its messages.
struct Pending {
    time_ns: u64,
    step: Option<u64>,
    poses: Vec<Option<Isometry3<f64>>>,
    bodies: Vec<Option<BodyState>>,
    joints: Vec<Option<JointState>>,
    mechanisms: Vec<Option<MechanismState>>,
    contacts: Vec<ContactState>,
    /// `/contacts` messages still to come (one per topic group in runs that can have contacts).
    contact_messages_missing: usize,
}

impl Pending {
    fn new(time_ns: u64, layout: &RecordingLayout) -> Self {
        Self {
            time_ns,
            step: None,
            poses: vec![None; layout.frames.len()],
            bodies: vec![None; layout.bodies.len()],
            joints: vec![None; layout.joints.len()],
            mechanisms: vec![None; layout.mechanisms.len()],
            contacts: Vec::new(),
            contact_messages_missing: if layout.contacts {
                layout.groups().len()
            } else {
                0
            },
        }
    }

    fn complete(self) -> Option<RecordedStep> {
        if self.contact_messages_missing > 0 {
            return None;
        }
        Some(RecordedStep {
            step: self.step?,
            time_ns: i64::try_from(self.time_ns).ok()?,
            world_from_link: self.poses.into_iter().collect::<Option<Vec<_>>>()?,
            bodies: self.bodies.into_iter().collect::<Option<Vec<_>>>()?,
            joints: self.joints.into_iter().collect::<Option<Vec<_>>>()?,
            mechanisms: self.mechanisms.into_iter().collect::<Option<Vec<_>>>()?,
            contacts: self.contacts,
        })
    }
}

/// Reads a tumble MCAP recording step by step; see the module doc.
pub struct StepReader {
    path: PathBuf,
    stream: McapStream<BufReader<File>>,
    layout: RecordingLayout,
    frame_index: HashMap<String, usize>,
    body_index: HashMap<String, usize>,
    joint_index: HashMap<String, usize>,
    mechanism_index: HashMap<String, usize>,
    pending: Option<Pending>,
    steps_read: u64,
    incomplete: u64,
    first_time_ns: Option<i64>,
    last_time_ns: Option<i64>,
}

impl StepReader {
    /// Opens `path` and reads up to its `tumble` metadata record (written before any message).
    /// The layout's metadata map is the record's, without [`LAYOUT_KEY`].
    pub fn open(path: &Path) -> anyhow::Result<Self> {
        let mut stream = McapStream::open(path)?;
        let layout = loop {
            match stream.next_item() {
                Some(Item::Metadata(m)) if m.name == METADATA_NAME => {
                    let mut metadata = m.metadata;
                    let json = metadata.remove(LAYOUT_KEY).with_context(|| {
                        format!(
                            "{}: the `tumble` metadata has no layout (written by an older tumble?)",
                            path.display()
                        )
                    })?;
                    refuse_ros2(&stream, path)?;
                    let mut layout = from_json(&json)
                        .with_context(|| format!("{}: recording layout", path.display()))?;
                    layout.metadata = metadata;
                    break layout;
                }
                Some(_) => continue,
                None => match stream.end() {
                    StreamEnd::Truncated { error, .. } => bail!(
                        "{}: not a readable MCAP file, or cut before its `tumble` metadata \
                         ({error})",
                        path.display()
                    ),
                    _ => bail!(
                        "{}: not a tumble recording (no `tumble` metadata record); for other MCAP \
                         files use `rerun mcap convert`",
                        path.display()
                    ),
                },
            }
        };
        let frame_index = layout
            .frames
            .iter()
            .enumerate()
            .map(|(i, f)| (f.frame_id.clone(), i))
            .collect();
        let body_index = layout
            .bodies
            .iter()
            .enumerate()
            .map(|(i, b)| (b.name.clone(), i))
            .collect();
        let index = |names: Vec<String>| -> HashMap<String, usize> {
            names.into_iter().enumerate().map(|(i, n)| (n, i)).collect()
        };
        let joint_index = index(layout.joints.iter().map(|j| j.name.clone()).collect());
        let mechanism_index = index(layout.mechanisms.iter().map(|m| m.name.clone()).collect());
        Ok(Self {
            path: path.to_owned(),
            stream,
            layout,
            frame_index,
            body_index,
            joint_index,
            mechanism_index,
            pending: None,
            steps_read: 0,
            incomplete: 0,
            first_time_ns: None,
            last_time_ns: None,
        })
    }

    /// The recording's layout (with its metadata).
    pub fn layout(&self) -> &RecordingLayout {
        &self.layout
    }

    /// How the file ended (once [`Self::next_step`] returned `Ok(None)`).
    pub fn end(&self) -> &StreamEnd {
        self.stream.end()
    }

    /// Steps handed out so far.
    pub fn steps_read(&self) -> u64 {
        self.steps_read
    }

    /// Steps dropped because some of their messages were missing.
    pub fn incomplete_steps(&self) -> u64 {
        self.incomplete
    }

    /// Simulation time of the first and last step handed out, ns.
    pub fn time_range_ns(&self) -> Option<(i64, i64)> {
        Some((self.first_time_ns?, self.last_time_ns?))
    }

    /// Bytes of the file read so far.
    pub fn bytes_read(&self) -> u64 {
        self.stream.bytes_read()
    }

    fn hand_out(&mut self, pending: Pending) -> Option<RecordedStep> {
        match pending.complete() {
            Some(step) => {
                self.steps_read += 1;
                self.first_time_ns.get_or_insert(step.time_ns);
                self.last_time_ns = Some(step.time_ns);
                Some(step)
            }
            None => {
                self.incomplete += 1;
                None
            }
        }
    }

    /// The next complete step; `Ok(None)` at the end of the readable data. A message that does
    /// not decode, or names a frame or body the layout does not have, is an error.
    pub fn next_step(&mut self) -> anyhow::Result<Option<RecordedStep>> {
        loop {
            let Some(Message {
                topic,
                log_time,
                data,
            }) = self.stream.next_message()
            else {
                return Ok(match self.pending.take() {
                    Some(pending) => self.hand_out(pending),
                    None => None,
                });
            };
            let mut finished = None;
            match &self.pending {
                Some(p) if p.time_ns == log_time => {}
                Some(p) if p.time_ns > log_time => bail!(
                    "{}: message at {log_time} ns after one at {} ns (not in time order)",
                    self.path.display(),
                    p.time_ns
                ),
                _ => {
                    finished = self.pending.replace(Pending::new(log_time, &self.layout));
                }
            }
            self.decode_into(&topic, &data)?;
            if let Some(pending) = finished
                && let Some(step) = self.hand_out(pending)
            {
                return Ok(Some(step));
            }
        }
    }

    fn decode_into(&mut self, topic: &str, data: &[u8]) -> anyhow::Result<()> {
        let path = &self.path;
        let Some(pending) = self.pending.as_mut() else {
            return Ok(());
        };
        if topic.ends_with(TF_TOPIC) {
            for (frame_id, pose) in
                decode_transforms(data).with_context(|| format!("{}", path.display()))?
            {
                let i = *self.frame_index.get(&frame_id).with_context(|| {
                    format!(
                        "{}: /tf names frame {frame_id:?}, which the layout does not have",
                        path.display()
                    )
                })?;
                pending.poses[i] = Some(pose);
            }
        } else if topic.ends_with(BODIES_TOPIC) {
            let message = proto::BodyStates::decode(data).with_context(|| {
                format!(
                    "{}: a {topic} message is not a tumble.BodyStates",
                    path.display()
                )
            })?;
            pending.step = Some(message.step);
            for b in message.bodies {
                let i = *self.body_index.get(&b.name).with_context(|| {
                    format!(
                        "{}: {topic} names body {:?}, which the layout does not have",
                        path.display(),
                        b.name
                    )
                })?;
                pending.bodies[i] = Some(BodyState {
                    linvel_world: vec3(&b.linear_velocity),
                    angvel_world: vec3(&b.angular_velocity),
                    angmom_world: vec3(&b.angular_momentum),
                    kinetic_energy: b.kinetic_energy,
                    potential_energy: b.potential_energy,
                });
            }
        } else if topic.ends_with(JOINTS_TOPIC) {
            let message = mp::JointStates::decode(data).with_context(|| {
                format!(
                    "{}: a {topic} message is not a {}",
                    path.display(),
                    mp::JOINT_STATES_SCHEMA
                )
            })?;
            pending.step = Some(message.step);
            for j in message.joints {
                let i = *self.joint_index.get(&j.name).with_context(|| {
                    format!(
                        "{}: {topic} names joint {:?}, which the layout does not have",
                        path.display(),
                        j.name
                    )
                })?;
                pending.joints[i] = Some(JointState {
                    position: j.position,
                    velocity: j.velocity,
                    effort: j.effort.unwrap_or(0.0),
                    target: j.target,
                    saturated: j.saturated,
                    at_limit: j.at_limit,
                });
            }
        } else if topic.ends_with(MECHANISMS_TOPIC) {
            let message = mp::MechanismStates::decode(data).with_context(|| {
                format!(
                    "{}: a {topic} message is not a {}",
                    path.display(),
                    mp::MECHANISM_STATES_SCHEMA
                )
            })?;
            pending.step = Some(message.step);
            for m in &message.mechanisms {
                let i = *self.mechanism_index.get(&m.name).with_context(|| {
                    format!(
                        "{}: {topic} names model {:?}, which the layout does not have",
                        path.display(),
                        m.name
                    )
                })?;
                pending.mechanisms[i] = Some(mp::from_proto(m));
            }
        } else if topic.ends_with(CONTACTS_TOPIC) && self.layout.contacts {
            use crate::record::mcap::contact_proto as cp;
            let message = cp::Contacts::decode(data).with_context(|| {
                format!(
                    "{}: a {topic} message is not a {}",
                    path.display(),
                    cp::CONTACTS_SCHEMA
                )
            })?;
            pending.step = Some(message.step);
            pending.contact_messages_missing = pending.contact_messages_missing.saturating_sub(1);
            let index = |name: &str| self.body_index.get(name).copied();
            for c in &message.contacts {
                let state = cp::from_proto(c, index).map_err(|what| {
                    anyhow::anyhow!(
                        "{}: {topic} names {what}, which the layout does not have",
                        path.display()
                    )
                })?;
                pending.contacts.push(state);
            }
        }
        Ok(())
    }
}
