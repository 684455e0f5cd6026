//! [`McapSink`]: writes a recording as MCAP with Foxglove's well-known protobuf schemas (the
//! file layout is in [`super`]), and its options ([`McapOptions`], [`ChunkCompression`]).

use super::file::{CHUNK_BYTES, sync_file};
use super::proto::{BODY_STATES_SCHEMA, body_states_descriptor};
use super::writer::{Codec, McapWriter};
use crate::fsutil::part_path;
use crate::record::names::{
    BODIES_TOPIC, CONTACTS_SCENE_TOPIC, CONTACTS_TOPIC, INERTIA_TOPIC, JOINTS_TOPIC,
    MECHANISMS_TOPIC, METADATA_NAME, SCENE_TOPIC, TF_TOPIC, WORLD_FRAME,
};
use crate::record::scene_update::{
    MeshCache, contacts_update, geometry_update, ground_update, inertia_update,
};
use crate::record::writeback::WritebackFile;
use crate::record::{Frame, RecordingLayout, Sink};
use anyhow::Context;
use foxglove::Encode;
use foxglove::messages::{FrameTransforms, SceneUpdate, Timestamp};
use prost::Message;
use std::collections::BTreeMap;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

/// Frames (or bodies) per slice of the `/scene` (`/inertia`) message built at a time.
const SCENE_SLICE: usize = 1024;

/// Which geometry message a `SceneUpdate` channel carries.
enum SceneKind {
    /// `/scene`: the visuals of the group's link frames.
    Geometry,
    /// `/inertia`: the equivalent inertia ellipsoids of the group's bodies.
    Inertia,
}

/// The channels of one topic group.
struct ChannelGroup {
    tf_channel: u16,
    bodies_channel: u16,
    /// `/joints` and `/mechanisms` ([`super::mechanism_proto`]), for groups with articulated
    /// models.
    joints_channel: Option<u16>,
    mechanisms_channel: Option<u16>,
    /// `/contacts` and `/contacts/scene` ([`super::contact_proto`]), in runs that can have
    /// contacts.
    contacts_channels: Option<(u16, u16)>,
    /// The group's `/tf` frame id fields and `/bodies` name fields, encoded once.
    tf_ids: super::encode::EncodedFields,
    body_names: super::encode::EncodedFields,
    group: crate::record::TopicGroup,
}

/// What to write besides the trajectories, and how.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct McapOptions {
    /// Write the `/inertia` topic (equivalent inertia ellipsoids).
    pub ellipsoids: bool,
    /// How chunks are compressed (default zstd).
    pub compression: ChunkCompression,
}

impl Default for McapOptions {
    fn default() -> Self {
        Self {
            ellipsoids: true,
            compression: ChunkCompression::Zstd,
        }
    }
}

/// Scenes with at least this many bodies get LZ4 chunks from [`ChunkCompression::Auto`].
///
/// Measured on the bundled swarm (10 000 bodies, 1 s, both files, `--threads 1`): zstd 1.07 s
/// wall and 168.1 MB, LZ4 0.82 s and 177.5 MB (5.5 % larger: poses and velocities are doubles
/// that neither compresses much), no compression 0.75 s and 226.5 MB; the MCAP thread's zstd
/// was a quarter of all CPU. On small scenes the time is negligible and zstd's files are
/// 13-16 % smaller (default scene 259 kB against 302 kB, double pendulum 1.04 MB against
/// 1.18 MB), so they keep zstd.
pub const AUTO_LZ4_BODIES: usize = 1000;

/// Chunk compression (`simulate --mcap-compression`). Every MCAP reader reads all three.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ChunkCompression {
    /// zstd level [`ZSTD_LEVEL`]: the smallest files (the default of the writers other than
    /// `simulate`'s).
    #[default]
    Zstd,
    /// LZ4 frames: a fraction of zstd's time on incompressible float data, larger files.
    Lz4,
    /// Uncompressed chunks: no compression time at all, the largest files.
    None,
    /// `simulate`'s default: [`Self::Lz4`] for scenes of [`AUTO_LZ4_BODIES`] bodies or more,
    /// else [`Self::Zstd`] ([`Self::resolve`]).
    Auto,
}

impl ChunkCompression {
    pub fn parse(s: &str) -> Result<Self, String> {
        match s {
            "zstd" => Ok(Self::Zstd),
            "lz4" => Ok(Self::Lz4),
            "none" => Ok(Self::None),
            "auto" => Ok(Self::Auto),
            _ => Err(format!("expected auto, zstd, lz4 or none, got {s:?}")),
        }
    }

    /// The compression a scene of `bodies` bodies is written with ([`Self::Auto`] decided).
    pub fn resolve(self, bodies: usize) -> Self {
        match self {
            Self::Auto if bodies >= AUTO_LZ4_BODIES => Self::Lz4,
            Self::Auto => Self::Zstd,
            other => other,
        }
    }
}

/// Writes an MCAP file; see the module documentation for its layout.
pub struct McapSink {
    writer: McapWriter<BufWriter<WritebackFile>>,
    path: PathBuf,
    part: PathBuf,
    groups: Vec<ChannelGroup>,
    sequence: u32,
    joint_names: Vec<String>,
    /// Per joint: whether it is driven (its `/joints` entries carry the drive fields); empty
    /// without drives.
    driven: Vec<bool>,
    mechanism_names: Vec<String>,
    /// Every body's name (a contact names its bodies), in runs that can have contacts.
    body_names: Vec<String>,
    /// Metres of force arrow per newton ([`crate::record::contacts::force_scale`]).
    force_scale: f64,
    buf: Vec<u8>,
    warnings: Vec<String>,
}

/// Simulation time in ns as a Foxglove timestamp (seconds since t = 0).
fn foxglove_time(time_ns: i64) -> Timestamp {
    let ns = time_ns.max(0) as u64;
    Timestamp::new((ns / 1_000_000_000) as u32, (ns % 1_000_000_000) as u32)
}

impl McapSink {
    /// [`Self::create_with`] with the default options.
    pub fn create(path: &Path, layout: &RecordingLayout) -> anyhow::Result<Self> {
        Self::create_with(path, layout, &McapOptions::default())
    }

    /// Creates `<path>.part`, writes the metadata, schemas and channels, and builds the
    /// geometry messages (meshes read here; unreadable ones listed in [`Self::warnings`]).
    pub fn create_with(
        path: &Path,
        layout: &RecordingLayout,
        options: &McapOptions,
    ) -> anyhow::Result<Self> {
        let part = part_path(path);
        let file = crate::fsutil::create_part(path)?;
        let codec = match options.compression {
            ChunkCompression::Zstd | ChunkCompression::Auto => Codec::Zstd,
            ChunkCompression::Lz4 => Codec::Lz4,
            ChunkCompression::None => Codec::None,
        };
        let mut writer = McapWriter::new(
            BufWriter::new(WritebackFile::new(file)),
            "",
            &format!("tumble {}", crate::VERSION),
            codec,
            CHUNK_BYTES as usize,
        )
        .with_context(|| format!("cannot write {}", part.display()))?;
        // The metadata record goes first, before the schemas and channels (the order every
        // tumble MCAP has had; the writer keeps metadata, schemas and channels outside chunks,
        // so every chunk holds messages: Foxglove refuses chunks without message indexes,
        // tests/recordings/recordings.rs checks every chunk index). Keys in order, as a map gives them.
        let layout_json = crate::record::layout_json::to_json(layout);
        let mut entries: Vec<(&str, &str)> = layout
            .metadata
            .iter()
            .filter(|(k, _)| k.as_str() != crate::record::layout_json::LAYOUT_KEY)
            .map(|(k, v)| (k.as_str(), v.as_str()))
            .collect();
        entries.push((crate::record::layout_json::LAYOUT_KEY, &layout_json));
        entries.sort_by(|a, b| a.0.cmp(b.0));
        writer.write_metadata(METADATA_NAME, &entries)?;
        drop(entries);
        drop(layout_json);
        let tf_schema =
            FrameTransforms::get_schema().context("foxglove.FrameTransforms has no schema")?;
        let tf_schema_id =
            writer.add_schema(&tf_schema.name, &tf_schema.encoding, &tf_schema.data)?;
        let bodies_schema_id =
            writer.add_schema(BODY_STATES_SCHEMA, "protobuf", &body_states_descriptor())?;
        let scene_schema =
            SceneUpdate::get_schema().context("foxglove.SceneUpdate has no schema")?;
        let scene_schema_id = writer.add_schema(
            &scene_schema.name,
            &scene_schema.encoding,
            &scene_schema.data,
        )?;
        let articulated = if layout.joints.is_empty() && layout.mechanisms.is_empty() {
            None
        } else {
            use super::mechanism_proto as mp;
            Some((
                writer.add_schema(
                    mp::JOINT_STATES_SCHEMA,
                    "protobuf",
                    &mp::joint_states_descriptor(
                        !layout.drives.is_empty(),
                        !layout.limited.is_empty(),
                    ),
                )?,
                writer.add_schema(
                    mp::MECHANISM_STATES_SCHEMA,
                    "protobuf",
                    &mp::mechanism_states_descriptor(),
                )?,
            ))
        };
        let contacts_schema = if layout.contacts {
            use super::contact_proto as cp;
            Some(writer.add_schema(cp::CONTACTS_SCHEMA, "protobuf", &cp::contacts_descriptor())?)
        } else {
            None
        };
        let mut groups = Vec::new();
        let mut scene_updates = Vec::new();
        let mut meshes = MeshCache::default();
        let mut warnings = Vec::new();
        let t0 = foxglove_time(0);
        for group in layout.groups() {
            let tf_topic = format!("{}{TF_TOPIC}", group.prefix);
            let bodies_topic = format!("{}{BODIES_TOPIC}", group.prefix);
            let tf_channel =
                writer.add_channel(tf_schema_id, &tf_topic, "protobuf", &BTreeMap::new())?;
            let bodies_channel = writer.add_channel(
                bodies_schema_id,
                &bodies_topic,
                "protobuf",
                &BTreeMap::new(),
            )?;
            let no_metadata = BTreeMap::new();
            let scene_topic = format!("{}{SCENE_TOPIC}", group.prefix);
            let scene_channel =
                writer.add_channel(scene_schema_id, &scene_topic, "protobuf", &no_metadata)?;
            scene_updates.push((scene_channel, SceneKind::Geometry, group.clone()));
            if options.ellipsoids {
                let topic = format!("{}{INERTIA_TOPIC}", group.prefix);
                let channel =
                    writer.add_channel(scene_schema_id, &topic, "protobuf", &no_metadata)?;
                scene_updates.push((channel, SceneKind::Inertia, group.clone()));
            }
            let (mut joints_channel, mut mechanisms_channel) = (None, None);
            if let Some((joints_schema, mechanisms_schema)) = articulated {
                if !group.joints.is_empty() {
                    let topic = format!("{}{JOINTS_TOPIC}", group.prefix);
                    joints_channel = Some(writer.add_channel(
                        joints_schema,
                        &topic,
                        "protobuf",
                        &no_metadata,
                    )?);
                }
                if !group.mechanisms.is_empty() {
                    let topic = format!("{}{MECHANISMS_TOPIC}", group.prefix);
                    mechanisms_channel = Some(writer.add_channel(
                        mechanisms_schema,
                        &topic,
                        "protobuf",
                        &no_metadata,
                    )?);
                }
            }
            let contacts_channels = match contacts_schema {
                Some(schema) => Some((
                    writer.add_channel(
                        schema,
                        &format!("{}{CONTACTS_TOPIC}", group.prefix),
                        "protobuf",
                        &no_metadata,
                    )?,
                    writer.add_channel(
                        scene_schema_id,
                        &format!("{}{CONTACTS_SCENE_TOPIC}", group.prefix),
                        "protobuf",
                        &no_metadata,
                    )?,
                )),
                None => None,
            };
            let frame_ids: Vec<String> = layout.frames[group.frames.clone()]
                .iter()
                .map(|f| f.frame_id.clone())
                .collect();
            groups.push(ChannelGroup {
                tf_channel,
                bodies_channel,
                joints_channel,
                mechanisms_channel,
                contacts_channels,
                tf_ids: super::encode::EncodedFields::frame_ids(WORLD_FRAME, &frame_ids),
                body_names: super::encode::EncodedFields::names(
                    &layout.bodies[group.bodies.clone()]
                        .iter()
                        .map(|b| b.name.clone())
                        .collect::<Vec<_>>(),
                ),
                group,
            });
        }
        // The geometry, once, stamped t = 0 like its entities (the first recorded step is
        // step 0), each message written as soon as it is encoded and then dropped: at 100 000
        // bodies `/scene` and `/inertia` are about 20 MB each, and held until the first frame
        // they were a fifth of the run's peak memory. Encoded a slice of frames at a time: a
        // `SceneUpdate`'s entities are a repeated field, so the concatenated encodings are the
        // encoding of the whole message, and the entities (hundreds of bytes each as structs)
        // never all exist at once.
        for (channel, kind, group) in scene_updates {
            let mut update = Vec::new();
            match kind {
                SceneKind::Geometry => {
                    for frames in layout.frames[group.frames.clone()].chunks(SCENE_SLICE) {
                        Message::encode(
                            &geometry_update(frames, t0, &mut meshes, &mut warnings),
                            &mut update,
                        )?;
                    }
                    // The ground, in every group's scene (each group's run has it).
                    if let Some(ground) = &layout.ground {
                        Message::encode(&ground_update(ground, t0), &mut update)?;
                    }
                }
                SceneKind::Inertia => {
                    for bodies in layout.bodies[group.bodies.clone()].chunks(SCENE_SLICE) {
                        Message::encode(&inertia_update(&layout.frames, bodies, t0), &mut update)?;
                    }
                }
            }
            writer.write_message(channel, 0, 0, 0, &update)?;
        }
        Ok(Self {
            writer,
            path: path.to_path_buf(),
            part,
            groups,
            sequence: 0,
            joint_names: layout.joints.iter().map(|j| j.name.clone()).collect(),
            driven: if layout.drives.is_empty() {
                Vec::new()
            } else {
                (0..layout.joints.len())
                    .map(|j| layout.drive_of(j).is_some())
                    .collect()
            },
            mechanism_names: layout.mechanisms.iter().map(|m| m.name.clone()).collect(),
            body_names: if layout.contacts {
                layout.bodies.iter().map(|b| b.name.clone()).collect()
            } else {
                Vec::new()
            },
            force_scale: crate::record::contacts::force_scale(layout),
            buf: Vec::new(),
            warnings,
        })
    }

    /// Meshes left out of the `/scene` topic (unresolved or unreadable files), one line each.
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }

    fn write_message(&mut self, channel_id: u16, time_ns: u64) -> anyhow::Result<()> {
        self.writer
            .write_message(channel_id, self.sequence, time_ns, time_ns, &self.buf)
            .with_context(|| format!("cannot write {}", self.part.display()))
    }
}

impl Sink for McapSink {
    fn write(&mut self, frame: &Frame<'_>) -> anyhow::Result<()> {
        let time_ns = u64::try_from(frame.time_ns).context("negative simulation time")?;
        if self.groups.iter().any(|g| g.contacts_channels.is_some()) {
            crate::record::contacts::check(frame.contacts, self.body_names.len())?;
        }
        for g in 0..self.groups.len() {
            let (tf_channel, bodies_channel) =
                (self.groups[g].tf_channel, self.groups[g].bodies_channel);
            let frames = self.groups[g].group.frames.clone();
            let bodies = self.groups[g].group.bodies.clone();
            self.buf.clear();
            super::encode::frame_transforms_with(
                &mut self.buf,
                time_ns,
                &self.groups[g].tf_ids,
                &frame.world_from_link[frames],
            );
            self.write_message(tf_channel, time_ns)?;
            if let Some((contacts_channel, scene_channel)) = self.groups[g].contacts_channels {
                let contacts = || crate::record::contacts::in_group(frame.contacts, &bodies);
                let message = super::contact_proto::contacts(
                    time_ns,
                    frame.step,
                    &self.body_names,
                    contacts(),
                );
                self.buf.clear();
                message.encode(&mut self.buf)?;
                self.write_message(contacts_channel, time_ns)?;
                let update =
                    contacts_update(contacts(), self.force_scale, foxglove_time(frame.time_ns));
                self.buf.clear();
                Message::encode(&update, &mut self.buf)?;
                self.write_message(scene_channel, time_ns)?;
            }

            let states = &frame.bodies[bodies.clone()];
            let total_energy = states
                .iter()
                .map(|b| b.kinetic_energy + b.potential_energy)
                .sum();
            self.buf.clear();
            super::encode::body_states_with(
                &mut self.buf,
                time_ns,
                frame.step,
                states,
                &self.groups[g].body_names,
                total_energy,
            );
            self.write_message(bodies_channel, time_ns)?;
            if let Some(channel) = self.groups[g].joints_channel {
                let joints = self.groups[g].group.joints.clone();
                let message = super::mechanism_proto::joint_states(
                    time_ns,
                    frame.step,
                    &self.joint_names[joints.clone()],
                    &frame.joints[joints.clone()],
                    self.driven.get(joints).unwrap_or(&[]),
                );
                self.buf.clear();
                message.encode(&mut self.buf)?;
                self.write_message(channel, time_ns)?;
            }
            if let Some(channel) = self.groups[g].mechanisms_channel {
                let mechanisms = self.groups[g].group.mechanisms.clone();
                let message = super::mechanism_proto::mechanism_states(
                    time_ns,
                    frame.step,
                    &self.mechanism_names[mechanisms.clone()],
                    &frame.mechanisms[mechanisms],
                );
                self.buf.clear();
                message.encode(&mut self.buf)?;
                self.write_message(channel, time_ns)?;
            }
        }
        self.sequence = self.sequence.wrapping_add(1);
        Ok(())
    }

    fn write_summary(&mut self, entries: &[(String, String)]) -> anyhow::Result<()> {
        let entries: Vec<(&str, &str)> = entries
            .iter()
            .map(|(k, v)| (k.as_str(), v.as_str()))
            .collect();
        self.writer
            .write_metadata(crate::record::names::SUMMARY_METADATA_NAME, &entries)?;
        Ok(())
    }

    fn finish(self: Box<Self>) -> anyhow::Result<()> {
        let McapSink {
            writer, part, path, ..
        } = *self;
        complete_own_file(writer, &part)?;
        crate::fsutil::publish(&[&path])
    }

    fn path(&self) -> Option<PathBuf> {
        Some(self.path.clone())
    }

    fn complete(self: Box<Self>) -> anyhow::Result<()> {
        let McapSink { writer, part, .. } = *self;
        complete_own_file(writer, &part)
    }
}

/// Ends a file of [`McapWriter`] written under `part` (summary, indexes, footer), flushes and
/// syncs it; it stays under `part`.
fn complete_own_file(
    writer: McapWriter<BufWriter<WritebackFile>>,
    part: &Path,
) -> anyhow::Result<()> {
    let buffered = writer
        .finish()
        .with_context(|| format!("cannot finish {}", part.display()))?;
    sync_file(buffered, part)
}
