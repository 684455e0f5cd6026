//! MCAP recordings with Foxglove's well-known protobuf schemas.
//!
//! Layout of a file written by [`McapSink`] ([`sink`]):
//!
//! | topic      | schema (protobuf)          | one message per recorded step holding                      |
//! |------------|----------------------------|------------------------------------------------------------|
//! | `/tf`      | `foxglove.FrameTransforms` | one `FrameTransform` per link frame: `parent_frame_id = "world"`, `child_frame_id` = frame id, the pose `world_from_link` |
//! | `/bodies`  | `tumble.BodyStates`        | per body: linear and angular velocity (world), angular momentum about the centre of mass (world), kinetic and potential energy; plus the totals |
//! | `/joints`  | `tumble.JointStates`       | articulated models only: per joint its name, position and velocity ([`mechanism_proto`]) |
//! | `/mechanisms` | `tumble.MechanismStates` | articulated models only: per model its momenta, centre of mass, energies and constraint residual |
//!
//! With [`super::RecordingLayout::topic_groups`] the two topics are repeated per group under its prefix
//! (`/rk4/tf`, `/rk4/bodies`, ...), each holding only the group's frames and bodies.
//!
//! Every message's `timestamp` = log time = publish time = simulation time in integer ns.
//! The schema of `/bodies` is a self-contained `FileDescriptorSet` (it includes
//! `google/protobuf/timestamp.proto`), so generic protobuf readers decode it.
//! A metadata record named `tumble` holds the scene, integrator settings and tool version
//! (see [`super::RecordingLayout::metadata`]) and, under `layout_json`, the recording layout (frames,
//! visuals, bodies, topic groups; [`super::layout_json`]) from which `tumble convert` replays the
//! file into Rerun. The file is written by [`writer`]; chunks are zstd-compressed,
//! or LZ4 or uncompressed ([`ChunkCompression`]); the summary and indexes are written when the
//! sink finishes, which is always explicit. The file is written under `<path>.part` (its bytes
//! handed to the disk's writeback as they are written, [`super::writeback`]) and renamed onto
//! `path` only once it is complete.
//!
//! Files: [`sink`] the sink and its options, [`writer`] tumble's own MCAP writer,
//! [`encode`] the hand-written encoders of the per-step messages, [`proto`] the `/bodies`
//! messages and their descriptors, [`mechanism_proto`] those of `/joints` and `/mechanisms`,
//! [`file`] the completion of a file written by the mcap crate's writer (shared with the ROS 2
//! recordings). The topic names are in [`super::names`].

pub mod contact_proto;
pub mod encode;
pub mod file;
pub mod mechanism_proto;
pub mod proto;
pub mod sink;
pub mod writer;

pub use file::CHUNK_BYTES;
pub use proto::BODY_STATES_SCHEMA;
pub use sink::{AUTO_LZ4_BODIES, ChunkCompression, McapOptions, McapSink};
pub use writer::{LZ4_LEVEL, ZSTD_LEVEL};
