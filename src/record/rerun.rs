//! Rerun `.rrd` recordings (rerun 0.36; view with Rerun 0.36/0.37).
//!
//! # Timelines
//!
//! Exactly two, both on every time-varying row; there is no wall-clock timeline (`log_time`,
//! `log_tick`):
//!
//! | timeline   | kind     | value                                                          |
//! |------------|----------|----------------------------------------------------------------|
//! | `sim_time` | duration | [`Frame::time_ns`], integer nanoseconds (bit-identical to MCAP) |
//! | `step`     | sequence | [`Frame::step`], the integrator step index                     |
//!
//! # Transform frames
//!
//! Named frames, as in ROS and in the MCAP `/tf` channel: every recorded link frame is a child of
//! `world`, and its frame id is exactly [`FrameLayout::frame_id`]. The viewer's root entity `/`
//! is placed in the `world` frame, so the default 3D view shows everything.
//!
//! # Entities
//!
//! `<model>` is [`FrameLayout::model`], `<link>` is [`FrameLayout::link`], `<body>` is
//! [`BodyLayout::name`] split at `/` (so `arm/link1` gives two path parts). Each name is one entity
//! path part (special characters are escaped, as Rerun does for URDF names).
//!
//! | entity                                        | archetypes                                   | time     |
//! |-----------------------------------------------|----------------------------------------------|----------|
//! | `/`                                           | `CoordinateFrame("world")`, `ViewCoordinates` (right-handed, Z up) | static |
//! | `/__properties`                               | `RecordingInfo` (name only, no start time)    | static   |
//! | `/__properties/metadata`                      | one text field per [`RecordingLayout::metadata`] entry | static |
//! | `/metadata`                                   | `TextDocument` (Markdown list of the metadata) | static  |
//! | `/<model>/visual_geometries/<link>/<visual>`  | `CoordinateFrame(frame_id)`, `InstancePoses3D` (visual origin, mesh scale), and one of `Boxes3D`, `Ellipsoids3D` (sphere), `Cylinders3D`, `Capsules3D`, `Asset3D` (stl, obj), `Mesh3D` (dae) | static |
//! | `/<model>/inertia/<link>`                     | `CoordinateFrame(frame_id)`, `InstancePoses3D` (principal frame), `Ellipsoids3D` (equivalent uniform ellipsoid, wireframe) | static |
//! | `/<model>/world_from_link/<link>`             | `Transform3D` (translation, quaternion xyzw, `parent_frame = "world"`, `child_frame = frame_id`), f32 | both timelines |
//! | `/plots/energy/<body>`                        | `Scalars` [kinetic, potential, total] (J), `SeriesLines` names (static) | both timelines |
//! | `/plots/angular_momentum/<body>`              | `Scalars` [\|L\|] about the body's centre of mass (kg m²/s), `SeriesLines` (static) | both timelines |
//! | `/plots/scene/energy`                         | `Scalars` [kinetic, potential, total] summed over all bodies (J), `SeriesLines` (static) | both timelines |
//! | `/plots/scene/energy_change`                  | `Scalars` [(E − E₀)/\|E₀\|], E the total above, E₀ its first recorded value | both timelines |
//! | `/plots/scene/angular_momentum_change`        | `Scalars` [max over bodies \|L − L₀\|/\|L₀\|] | both timelines |
//! | `/plots/joints/…`, `/plots/mechanisms/<model>/…` | articulated models only: joint positions and velocities, each model's energy, momenta and constraint residual ([`joints`]) | both timelines |
//!
//! # Blueprint
//!
//! The file also holds a blueprint store ([`super::rerun_blueprint`]): the 3D view framed on
//! the run, beside the two change plots and the energies, activated when the file opens.
//!
//! `<visual>` is the URDF `<visual name=...>`, else `visual_<i>` with `i` the index among the
//! link's visuals: the same paths and frame attachment (a `CoordinateFrame` naming the link frame
//! plus an `InstancePoses3D` for the visual origin) as Rerun 0.36's own URDF importer, so a URDF
//! dropped into the viewer lines up with the recording. Differences from the importer: URDF
//! capsules are centred on their origin (the importer leaves `Capsules3D`'s one end at the
//! origin); DAE meshes (which Rerun cannot read) are read by tumble and sent as `Mesh3D`
//! (unit and node transforms applied, up axis ignored, as for mass properties); STL and OBJ files
//! are embedded as `Asset3D` only when tumble's own reader accepts them as meshes with triangles,
//! and then the very bytes it read ([`MeshCache::get_file`]: a text file named `.obj` is never
//! embedded); glTF/GLB files, which tumble does not read, are left out; meshes whose file was not
//! found or was refused ([`crate::model::confine`]) are skipped with a warning (see
//! [`RerunSink::warnings`]).
//! Colours come from the URDF material (linear RGBA), white when there is none, as in the importer.
//!
//! Inertia ellipsoids ([`BodyLayout::inertia_ellipsoid_radii`]) are on their own entities so they
//! can be toggled in the viewer; [`RerunOptions::ellipsoids`] `= false` leaves them out.
//!
//! # Writing
//!
//! Time-varying data is buffered and sent by columns every [`batch_frames`] frames (about
//! [`BATCH_BYTES`] of columns) and on [`Sink::finish`]. Every chunk is encoded and written on
//! the sink's own thread as it is sent ([`ChunkWriter`]), so memory stays bounded however fast
//! frames arrive; Rerun's `RecordingStream` writes only the store info and the properties at
//! the start (its batcher and forwarding thread had cost an Arrow round trip per chunk). The file is written
//! as `<path>.part` and renamed onto `<path>` by [`Sink::finish`] after the footer is written and
//! the file synced; on error, or when the sink is dropped unfinished, `<path>.part` is removed
//! and nothing appears under `<path>`.
//!
//! # Reproducibility
//!
//! Same layout and frames give the same bytes (tested across runs and processes). Plain
//! `RecordingStream::save` cannot: every row and chunk carries a Rerun TUID (wall-clock
//! nanoseconds plus a random per-thread counter), the `SetStoreInfo` message has one too, the
//! properties chunk holds `Timestamp::now()`, rows logged with `log` are grouped into chunks by a
//! timer, and the RRD footer lists its columns in hash-map order. So this module (1) writes every
//! chunk itself, never row by row, (2) records the name but no start time in the properties,
//! (3) writes through its own [`LogSink`] that renumbers TUIDs with a counter (time part 0,
//! increasing in send order, so Rerun's ordering semantics are kept) before encoding, and (4)
//! rewrites the footer with its columns sorted ([`super::rrd_footer`]). The recording id is the
//! layout name plus a hash of the name and metadata: the same inputs give the same id, different
//! scenes or settings do not get merged by the viewer.

mod joints;

pub use joints::{joint_position_entity_path, joint_velocity_entity_path, mechanism_entity_path};

use super::rerun_batched::{Batches, Content, is_batched};
use super::rerun_blueprint::{
    PlotView, SceneBounds, blueprint_chunks, blueprint_messages, default_plot_views,
};
use super::rrd_footer::{FooterHold, FooterWriter};
use super::scene_update::MeshCache;
use super::{BodyLayout, Frame, FrameLayout, RecordingLayout, Sink};
use crate::fsutil::part_path;
use crate::model::geometry::mesh::TriangleMesh;
use crate::model::{Geometry, Visual};
use anyhow::{Context, Result, anyhow, bail};
use nalgebra::Isometry3;
use rerun::external::re_log_encoding::{CrateVersion, Encoder, EncodingOptions};
use rerun::external::re_log_types::StoreId;
use rerun::log::{Chunk, ChunkComponents, ChunkId, LogMsg, RowId};
use rerun::sink::{LogSink, SinkFlushError};
use rerun::{
    AsComponents, EntityPath, EntityPathPart, RecordingStream, RecordingStreamBuilder,
    SerializedComponentBatch, SerializedComponentColumn, TimeColumn, TimePoint,
};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

/// Name of the duration timeline (integer nanoseconds of simulated time).
pub const SIM_TIME_TIMELINE: &str = "sim_time";
/// Name of the sequence timeline (integrator step index).
pub const STEP_TIMELINE: &str = "step";
/// The parent frame of every link frame.
pub const WORLD_FRAME: &str = "world";
/// Bytes of columns buffered before a batch is sent (see [`batch_frames`]).
pub const BATCH_BYTES: usize = 1 << 20;
/// Fewest and most frames per batch.
pub const BATCH_FRAMES_MIN: usize = 256;
pub const BATCH_FRAMES_MAX: usize = 65_536;

/// Frames per batch for a layout: about [`BATCH_BYTES`] of buffered columns (per frame: 28 bytes
/// of f32 pose per link, 32 of f64 plots per body, 16 of times), within [`BATCH_FRAMES_MIN`] ..
/// [`BATCH_FRAMES_MAX`]. Every batch becomes one Rerun chunk per entity, and Rerun's footer keeps
/// a manifest row per chunk, so large batches keep long recordings' footers (and the memory
/// that builds them) small, while the byte bound keeps the buffer small for many bodies.
pub fn batch_frames(frames: usize, bodies: usize) -> usize {
    let row_bytes = 16 + 28 * frames + 32 * bodies + 24;
    (BATCH_BYTES / row_bytes).clamp(BATCH_FRAMES_MIN, BATCH_FRAMES_MAX)
}
/// Series names of the energy plots, in the order of the values.
pub const ENERGY_SERIES: [&str; 3] = ["kinetic", "potential", "total"];

/// What to write besides the trajectories.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RerunOptions {
    /// Write the equivalent inertia ellipsoid of every body (`/<model>/inertia/<link>`).
    pub ellipsoids: bool,
}

impl Default for RerunOptions {
    fn default() -> Self {
        Self { ellipsoids: true }
    }
}

/// Entity of visual `index` of a link: `/<model>/visual_geometries/<link>/<name or visual_<index>>`.
pub fn visual_entity_path(model: &str, link: &str, index: usize, name: Option<&str>) -> EntityPath {
    let leaf = match name {
        Some(name) if !name.is_empty() => name.to_owned(),
        _ => format!("visual_{index}"),
    };
    entity(&[model, "visual_geometries", link, &leaf])
}

/// Entity of a body's inertia ellipsoid: `/<model>/inertia/<link>`.
pub fn inertia_entity_path(model: &str, link: &str) -> EntityPath {
    entity(&[model, "inertia", link])
}

/// Entity holding the `world -> frame_id` transforms of a link: `/<model>/world_from_link/<link>`.
pub fn transform_entity_path(model: &str, link: &str) -> EntityPath {
    entity(&[model, "world_from_link", link])
}

/// Entity of a body's energy plot: `/plots/energy/<body split at '/'>`.
pub fn energy_entity_path(body: &str) -> EntityPath {
    plot_path("energy", body)
}

/// Entity of a body's angular momentum plot: `/plots/angular_momentum/<body split at '/'>`.
pub fn angular_momentum_entity_path(body: &str) -> EntityPath {
    plot_path("angular_momentum", body)
}

/// Entity of the whole scene's energy plot: `/plots/scene/energy`.
pub fn scene_energy_entity_path() -> EntityPath {
    entity(&["plots", "scene", "energy"])
}

/// Entity of the scene's relative energy change `(E − E₀)/|E₀|` (`E₀` the first recorded
/// total; divided by 1 J instead when `E₀ = 0`): `/plots/scene/energy_change`.
pub fn scene_energy_change_entity_path() -> EntityPath {
    entity(&["plots", "scene", "energy_change"])
}

/// Entity of the largest relative angular momentum change over the bodies,
/// `max_i |L_i − L_i0| / |L_i0|` (about each body's centre of mass, world; divided by
/// 1 kg m²/s instead where `L_i0 = 0`): `/plots/scene/angular_momentum_change`.
pub fn scene_angmom_change_entity_path() -> EntityPath {
    entity(&["plots", "scene", "angular_momentum_change"])
}

fn entity(parts: &[&str]) -> EntityPath {
    EntityPath::new(parts.iter().map(|p| EntityPathPart::new(*p)).collect())
}

fn plot_path(kind: &str, body: &str) -> EntityPath {
    let mut parts = vec![EntityPathPart::new("plots"), EntityPathPart::new(kind)];
    parts.extend(
        body.split('/')
            .filter(|p| !p.is_empty())
            .map(EntityPathPart::new),
    );
    EntityPath::new(parts)
}

/// Application id accepted by Rerun: ASCII letters, digits, `_ - space [ ] :`, at most 180 chars.
fn application_id(name: &str) -> String {
    let id: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "_- []:".contains(c) {
                c
            } else {
                '_'
            }
        })
        .take(180)
        .collect();
    if id.trim().is_empty() {
        "tumble".to_owned()
    } else {
        id
    }
}

/// Deterministic recording id: the app id and a 64-bit FNV-1a hash of name and metadata.
fn recording_id(layout: &RecordingLayout) -> String {
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |bytes: &[u8]| {
        for &b in bytes.iter().chain(&[0xff]) {
            hash ^= u64::from(b);
            hash = hash.wrapping_mul(0x0100_0000_01b3);
        }
    };
    eat(layout.name.as_bytes());
    for (key, value) in &layout.metadata {
        eat(key.as_bytes());
        eat(value.as_bytes());
    }
    format!("{}-{hash:016x}", application_id(&layout.name))
}

/// `x` as f32 with a negative zero made positive. A zero's sign carries no meaning here, and
/// MCAP's protobuf drops it (proto3 omits a field equal to its default, and `-0.0 == 0.0`), so
/// without this a recording replayed from MCAP would differ in a bit.
fn f32c(x: f64) -> f32 {
    x as f32 + 0.0
}

/// `x` with a negative zero made positive (see [`f32c`]).
fn f64c(x: f64) -> f64 {
    x + 0.0
}

pub(super) fn f32x3(v: &nalgebra::Vector3<f64>) -> [f32; 3] {
    [f32c(v.x), f32c(v.y), f32c(v.z)]
}

/// Quaternion as `[x, y, z, w]` in f32.
pub(super) fn quat_xyzw(iso: &Isometry3<f64>) -> [f32; 4] {
    let q = iso.rotation.quaternion();
    [f32c(q.i), f32c(q.j), f32c(q.k), f32c(q.w)]
}

fn color(rgba: Option<[f32; 4]>) -> rerun::Rgba32 {
    match rgba {
        Some([r, g, b, a]) => rerun::Rgba32::from_linear_unmultiplied_rgba_f32(r, g, b, a),
        None => rerun::Rgba32::WHITE,
    }
}

// ---------------------------------------------------------------------------------------------
// The file writer: a LogSink that renumbers TUIDs, then encodes.

/// Where the encoded stream goes; shared between the [`RerunSink`] and the [`RrdFileSink`] that
/// the recording stream's forwarding thread owns.
struct FileState {
    encoder: Option<Encoder<FooterWriter>>,
    /// Last TUID handed out (counter part; the time part is 0).
    last_id: u64,
    /// First error met by the forwarding thread (it cannot return errors).
    error: Option<String>,
}

impl FileState {
    fn next_id(&mut self) -> u128 {
        self.last_id += 1;
        u128::from(self.last_id)
    }

    fn write(&mut self, msg: LogMsg) -> Result<()> {
        let msg = match msg {
            LogMsg::SetStoreInfo(mut info) => {
                info.row_id = *RowId::from_u128(self.next_id());
                LogMsg::SetStoreInfo(info)
            }
            LogMsg::ArrowMsg(store_id, arrow_msg) => {
                let chunk = Chunk::from_arrow_msg(&arrow_msg)?;
                let (timelines, components) =
                    (chunk.timelines().clone(), chunk.components().clone());
                return self.write_chunk(
                    &store_id,
                    chunk.entity_path().clone(),
                    timelines,
                    components,
                );
            }
            other => other,
        };
        self.append(&msg)
    }

    /// Writes a chunk of these columns, its ids renumbered (chunk id first, then one row id
    /// per row, from the counter). A chunk without components is dropped, as Rerun's batcher
    /// drops it.
    fn write_chunk(
        &mut self,
        store_id: &StoreId,
        entity: EntityPath,
        timelines: rerun::external::nohash_hasher::IntMap<rerun::time::TimelineName, TimeColumn>,
        components: ChunkComponents,
    ) -> Result<()> {
        if components.0.is_empty() {
            return Ok(());
        }
        let rows = components
            .list_arrays()
            .next()
            .map_or(0, arrow_array::Array::len);
        let chunk_id = ChunkId::from_u128(self.next_id());
        let row_ids: Vec<RowId> = (0..rows)
            .map(|_| RowId::from_u128(self.next_id()))
            .collect();
        let chunk =
            Chunk::from_native_row_ids(chunk_id, entity, None, &row_ids, timelines, components)?;
        self.append(&LogMsg::ArrowMsg(store_id.clone(), chunk.to_arrow_msg()?))
    }

    fn append(&mut self, msg: &LogMsg) -> Result<()> {
        let encoder = self
            .encoder
            .as_mut()
            .ok_or_else(|| anyhow!("message after the recording was closed"))?;
        encoder.append(msg)?;
        Ok(())
    }
}

/// Writes chunks into the file on the calling thread ([`FileState::write_chunk`]): after the
/// recording stream has written its store info and properties, every chunk goes this way,
/// not through the stream's batcher and forwarding thread, which turned each chunk into an
/// Arrow message that [`RrdFileSink`] had to turn back into a chunk to renumber its ids (the
/// same bytes; two threads and an Arrow round trip per chunk less).
pub(super) struct ChunkWriter<'a> {
    state: &'a Mutex<FileState>,
    store_id: &'a StoreId,
    path: &'a Path,
}

impl ChunkWriter<'_> {
    /// A chunk of `columns` on `entity` at the times of `indexes` (what
    /// `RecordingStream::send_columns` sends).
    pub(super) fn send_columns(
        &self,
        entity: EntityPath,
        indexes: impl IntoIterator<Item = TimeColumn>,
        columns: impl IntoIterator<Item = SerializedComponentColumn>,
    ) -> Result<()> {
        let timelines = indexes
            .into_iter()
            .map(|column| (*column.timeline().name(), column))
            .collect();
        let components: ChunkComponents = columns
            .into_iter()
            .map(|column| (column.descriptor, column.list_array))
            .collect();
        self.write(entity, timelines, components)
    }

    fn send(&self, chunk: Chunk) -> Result<()> {
        let (timelines, components) = (chunk.timelines().clone(), chunk.components().clone());
        self.write(chunk.entity_path().clone(), timelines, components)
    }

    fn write(
        &self,
        entity: EntityPath,
        timelines: rerun::external::nohash_hasher::IntMap<rerun::time::TimelineName, TimeColumn>,
        components: ChunkComponents,
    ) -> Result<()> {
        let mut state = lock(self.state);
        if let Some(err) = &state.error {
            bail!("writing {}: {err}", self.path.display());
        }
        state
            .write_chunk(self.store_id, entity, timelines, components)
            .with_context(|| format!("writing {}", self.path.display()))
    }
}

fn lock(state: &Mutex<FileState>) -> MutexGuard<'_, FileState> {
    state
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// [`LogSink`] writing a reproducible `.rrd` (see the module doc).
struct RrdFileSink {
    state: Arc<Mutex<FileState>>,
}

impl LogSink for RrdFileSink {
    fn send(&self, msg: LogMsg) {
        let mut state = lock(&self.state);
        if state.error.is_none()
            && let Err(err) = state.write(msg)
        {
            state.error = Some(format!("{err:#}"));
        }
    }

    fn flush_blocking(&self, _timeout: Duration) -> Result<(), SinkFlushError> {
        let mut state = lock(&self.state);
        if let Some(err) = &state.error {
            return Err(SinkFlushError::failed(err.clone()));
        }
        if let Some(encoder) = state.encoder.as_mut() {
            encoder
                .flush_blocking()
                .map_err(|err| SinkFlushError::failed(err.to_string()))?;
        }
        Ok(())
    }

    fn defers_finalization_to_shutdown(&self) -> bool {
        true
    }
}

// ---------------------------------------------------------------------------------------------
// The sink.

/// Per link frame: where its transforms go.
struct FrameTrack {
    entity: EntityPath,
    frame_id: String,
}

/// Per body: where its plots go.
struct BodyTrack {
    energy: EntityPath,
    angular_momentum: EntityPath,
}

/// Columns of the frames not yet sent.
#[derive(Default)]
struct Buffer {
    time_ns: Vec<i64>,
    step: Vec<i64>,
    /// `[frame][row]`
    translation: Vec<Vec<[f32; 3]>>,
    quaternion: Vec<Vec<[f32; 4]>>,
    /// `[body]`: kinetic, potential, total per row, flattened.
    energy: Vec<Vec<f64>>,
    angular_momentum: Vec<Vec<f64>>,
    scene_energy: Vec<f64>,
    scene_energy_change: Vec<f64>,
    scene_angmom_change: Vec<f64>,
}

impl Buffer {
    fn new(frames: usize, bodies: usize) -> Self {
        Self {
            translation: vec![Vec::new(); frames],
            quaternion: vec![Vec::new(); frames],
            energy: vec![Vec::new(); bodies],
            angular_momentum: vec![Vec::new(); bodies],
            ..Self::default()
        }
    }

    fn len(&self) -> usize {
        self.time_ns.len()
    }

    fn clear(&mut self) {
        self.time_ns.clear();
        self.step.clear();
        self.scene_energy.clear();
        self.scene_energy_change.clear();
        self.scene_angmom_change.clear();
        for v in &mut self.translation {
            v.clear();
        }
        for v in &mut self.quaternion {
            v.clear();
        }
        for v in &mut self.energy {
            v.clear();
        }
        for v in &mut self.angular_momentum {
            v.clear();
        }
    }
}

/// Writes a [`RecordingLayout`] and its frames as a Rerun `.rrd` file (see the module doc).
pub struct RerunSink {
    rec: Option<RecordingStream>,
    state: Arc<Mutex<FileState>>,
    part_path: PathBuf,
    final_path: PathBuf,
    frames: Vec<FrameTrack>,
    bodies: Vec<BodyTrack>,
    buffer: Buffer,
    /// [`batch_frames`] of the layout.
    batch_frames: usize,
    last_time_ns: Option<i64>,
    warnings: Vec<String>,
    /// Holds the encoder's footer back for [`super::rrd_footer`].
    footer_hold: FooterHold,
    /// Entities of [`RerunSink::write_series`] whose series names were sent.
    series_named: BTreeSet<EntityPath>,
    /// Meshes read so far (each file once): Collada triangles, and the accepted bytes of STL
    /// and OBJ files.
    meshes: MeshCache,
    /// The recording's store, from which the blueprint store's id derives.
    store_info: rerun::external::re_log_types::StoreInfo,
    /// Per frame: how far its geometry reaches from the frame origin, m (for [`SceneBounds`]).
    frame_reach: Vec<f64>,
    /// Every frame origin of every recorded step, with its reach: what the 3D view frames.
    bounds: SceneBounds,
    /// The blueprint's plots ([`Self::set_plot_views`]).
    plot_views: Vec<PlotView>,
    /// First recorded total energy and angular momenta: the reference of the change plots.
    energy0: Option<f64>,
    angmom0: Vec<nalgebra::Vector3<f64>>,
    /// The series of articulated models ([`joints`]).
    joint_plots: joints::JointPlots,
    /// Link frames and bodies of the layout.
    frame_count: usize,
    body_count: usize,
    /// The big-scene layout ([`super::rerun_batched`]), when the layout is big.
    batched: Option<Batches>,
    done: bool,
}

/// A triangle mesh as a Rerun `Mesh3D` (f32 positions, per-vertex normals averaged from the
/// area-weighted face normals, so the viewer shades it).
fn mesh3d(mesh: &TriangleMesh) -> rerun::Mesh3D {
    let mut normals = vec![nalgebra::Vector3::<f64>::zeros(); mesh.vertices.len()];
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| mesh.vertices[i as usize]);
        let n = (b - a).cross(&(c - a));
        for &i in t {
            normals[i as usize] += n;
        }
    }
    rerun::Mesh3D::new(mesh.vertices.iter().map(f32x3))
        .with_vertex_normals(normals.iter().map(|n| {
            let len = n.norm();
            // A vertex only on degenerate triangles has no normal: any unit vector will do.
            f32x3(&if len > 0.0 {
                n / len
            } else {
                nalgebra::Vector3::z()
            })
        }))
        .with_triangle_indices(
            mesh.triangles
                .iter()
                .map(|t| rerun::TriangleIndices::from(*t)),
        )
}

/// `x`, or 1 when it is zero (the reference of a relative change that has none).
fn nonzero(x: f64) -> f64 {
    if x == 0.0 { 1.0 } else { x }
}

/// How far a link frame's visual geometry reaches from its origin, m: the largest distance of
/// a visual origin plus the shape's bounding radius (a mesh counts 0.1 m per unit of scale).
fn frame_reach(frame: &FrameLayout) -> f64 {
    frame
        .visuals
        .iter()
        .map(|v| {
            let shape = match &v.geometry {
                Geometry::Box { size } => size.norm() / 2.0,
                Geometry::Sphere { radius } => *radius,
                Geometry::Cylinder { radius, length } => radius.hypot(length / 2.0),
                Geometry::Capsule { radius, length } => radius + length / 2.0,
                Geometry::Mesh { scale, .. } => 0.1 * scale.amax(),
            };
            v.link_from_visual.translation.vector.norm() + shape
        })
        .fold(0.0, f64::max)
}

/// The 64-bit seed of the blueprint's UUIDs: an FNV-1a hash of the recording id.
fn recording_seed(info: &rerun::external::re_log_types::StoreInfo) -> u64 {
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    for b in info.store_id.recording_id().as_str().bytes() {
        hash ^= u64::from(b);
        hash = hash.wrapping_mul(0x0100_0000_01b3);
    }
    hash
}

/// Opens `<path>.part` and writes the static layout. See the module doc for what is written.
impl RerunSink {
    /// Replaces the time series views of the blueprint (default: [`default_plot_views`]);
    /// `tumble diff` shows its error plots this way.
    pub fn set_plot_views(&mut self, views: Vec<PlotView>) {
        self.plot_views = views;
    }

    /// Opens `<path>.part` and writes the static layout. See the module doc for what is written.
    pub fn create(path: &Path, layout: &RecordingLayout, options: &RerunOptions) -> Result<Self> {
        create(path, layout, options)
    }
}

/// Opens `<path>.part` and writes the static layout. See the module doc for what is written.
pub fn create(path: &Path, layout: &RecordingLayout, options: &RerunOptions) -> Result<RerunSink> {
    let part_path = part_path(path);
    let file = crate::fsutil::create_part(path)?;
    let (footer_writer, footer_hold) = FooterWriter::new(file);
    let encoder = Encoder::new_eager(
        CrateVersion::LOCAL,
        EncodingOptions::PROTOBUF_COMPRESSED,
        footer_writer,
    );
    let state = Arc::new(Mutex::new(FileState {
        encoder: None,
        last_id: 0,
        error: None,
    }));
    let batched = is_batched(layout).then(|| Batches::new(layout, options.ellipsoids));
    // From here on, an early return drops `sink`, which removes the part file.
    let mut sink = RerunSink {
        rec: None,
        state: state.clone(),
        part_path,
        final_path: path.to_owned(),
        frames: Vec::new(),
        bodies: Vec::new(),
        buffer: if batched.is_some() {
            Buffer::new(0, 0)
        } else {
            Buffer::new(layout.frames.len(), layout.bodies.len())
        },
        batch_frames: match &batched {
            Some(b) => b.rows_per_send,
            None => batch_frames(layout.frames.len(), layout.bodies.len()),
        },
        last_time_ns: None,
        warnings: Vec::new(),
        footer_hold,
        series_named: BTreeSet::new(),
        meshes: MeshCache::default(),
        store_info: rerun::external::re_log_types::StoreInfo::new(
            rerun::external::re_log_types::StoreId::recording("tumble", "tumble"),
            rerun::external::re_log_types::StoreSource::Unknown,
        ),
        frame_reach: layout.frames.iter().map(frame_reach).collect(),
        bounds: SceneBounds::default(),
        plot_views: default_plot_views(),
        energy0: None,
        angmom0: Vec::new(),
        joint_plots: joints::JointPlots::new(layout),
        frame_count: layout.frames.len(),
        body_count: layout.bodies.len(),
        batched,
        done: false,
    };
    let extra_views = sink.joint_plots.plot_views(layout);
    sink.plot_views.extend(extra_views);
    lock(&state).encoder = Some(encoder.context("cannot write the .rrd header")?);

    let app_id = rerun::ApplicationId::try_new(application_id(&layout.name))
        .map_err(|e| anyhow!("recording name {:?}: {e}", layout.name))?;
    let builder = RecordingStreamBuilder::new(app_id)
        .enabled(true)
        .recording_id(recording_id(layout))
        .send_properties(true);
    let (_enabled, store_info, _properties, batcher_config, batcher_hooks, _blueprint) =
        builder.into_args();
    // The builder's properties hold `Timestamp::now()`: replace them by the name alone.
    let properties = rerun::RecordingInfo::new().with_name(layout.name.clone());
    sink.store_info = store_info.clone();
    let rec = RecordingStream::new(
        store_info,
        Some(properties),
        batcher_config,
        batcher_hooks,
        Box::new(RrdFileSink { state }),
    )
    .context("cannot start the Rerun recording stream")?;
    rec.set_log_time_enabled(false);
    rec.set_log_tick_enabled(false);
    // The store info and properties are in the file before the first chunk ([`ChunkWriter`]).
    rec.flush_blocking()
        .with_context(|| format!("writing {}", sink.part_path.display()))?;
    sink.rec = Some(rec);
    sink.check_sink()?;

    sink.write_layout(layout, options)?;
    Ok(sink)
}

/// A static chunk with one row holding all the given archetypes.
pub(super) fn static_chunk(entity: EntityPath, archetypes: &[&dyn AsComponents]) -> Result<Chunk> {
    let batches: Vec<SerializedComponentBatch> = archetypes
        .iter()
        .flat_map(|a| a.as_serialized_batches())
        .collect();
    static_batches_chunk(entity, batches)
}

/// A static chunk with one row holding the given component batches.
pub(super) fn static_batches_chunk(
    entity: EntityPath,
    batches: Vec<SerializedComponentBatch>,
) -> Result<Chunk> {
    Ok(Chunk::builder(entity)
        .with_serialized_batches(RowId::new(), TimePoint::default(), batches)
        .build()?)
}

/// A visual's shape ([`RerunSink::visual_shape`]).
pub(super) struct Shape {
    pub batches: Vec<SerializedComponentBatch>,
    /// The mesh scale, for meshes.
    pub scale: Option<[f32; 3]>,
}

fn instance_pose(iso: &Isometry3<f64>, scale: Option<[f32; 3]>) -> rerun::InstancePoses3D {
    let pose = rerun::InstancePoses3D::new()
        .with_translations([f32x3(&iso.translation.vector)])
        .with_quaternions([rerun::Quaternion::from_xyzw(quat_xyzw(iso))]);
    match scale {
        Some(scale) => pose.with_scales([scale]),
        None => pose,
    }
}

impl RerunSink {
    /// Meshes that were skipped (DAE, unresolved or unreadable files), one line each.
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }

    fn send(&self, chunk: Chunk) -> Result<()> {
        self.writer().send(chunk)
    }

    /// Where chunks go ([`ChunkWriter`]).
    fn writer(&self) -> ChunkWriter<'_> {
        ChunkWriter {
            state: &self.state,
            store_id: &self.store_info.store_id,
            path: &self.part_path,
        }
    }

    /// Surfaces an error the recording stream's forwarding thread met writing the store info,
    /// the properties or the blueprint ([`RrdFileSink`]); chunks report theirs directly
    /// ([`ChunkWriter`]).
    fn check_sink(&self) -> Result<()> {
        match &lock(&self.state).error {
            Some(err) => bail!("writing {}: {err}", self.part_path.display()),
            None => Ok(()),
        }
    }

    fn warn(&mut self, message: String) {
        eprintln!("warning: {message}");
        self.warnings.push(message);
    }

    fn write_layout(&mut self, layout: &RecordingLayout, options: &RerunOptions) -> Result<()> {
        self.send(static_chunk(
            EntityPath::root(),
            &[
                &rerun::CoordinateFrame::new(WORLD_FRAME),
                &rerun::ViewCoordinates::RIGHT_HAND_Z_UP(),
            ],
        )?)?;
        self.write_metadata(layout)?;
        if self.batched.is_some() {
            self.write_batched_layout(layout)?;
            return self.write_scene_plot_names(layout);
        }

        let mut used = BTreeSet::new();
        for frame in &layout.frames {
            let entity = transform_entity_path(&frame.model, &frame.link);
            if !used.insert(entity.clone()) {
                bail!(
                    "two recorded frames share model {:?} and link {:?}",
                    frame.model,
                    frame.link
                );
            }
            for (index, visual) in frame.visuals.iter().enumerate() {
                let mut entity =
                    visual_entity_path(&frame.model, &frame.link, index, visual.name.as_deref());
                if !used.insert(entity.clone()) {
                    // Two visuals of one link with the same name: keep both.
                    entity = visual_entity_path(
                        &frame.model,
                        &frame.link,
                        index,
                        Some(&format!(
                            "{}_{index}",
                            visual.name.as_deref().unwrap_or("visual")
                        )),
                    );
                    used.insert(entity.clone());
                }
                self.write_visual(entity, frame, visual)?;
            }
            self.frames.push(FrameTrack {
                entity,
                frame_id: frame.frame_id.clone(),
            });
        }

        let mut used_inertia = BTreeSet::new();
        for (i, body) in layout.bodies.iter().enumerate() {
            let frame = layout.frames.get(body.frame).with_context(|| {
                format!(
                    "body {:?} refers to frame {} of {}",
                    body.name,
                    body.frame,
                    layout.frames.len()
                )
            })?;
            if options.ellipsoids {
                let mut entity = inertia_entity_path(&frame.model, &frame.link);
                if !used_inertia.insert(entity.clone()) {
                    entity = inertia_entity_path(&frame.model, &format!("{}_{i}", frame.link));
                    used_inertia.insert(entity.clone());
                }
                self.write_inertia(entity, frame, body)?;
            }
            let track = BodyTrack {
                energy: energy_entity_path(&body.name),
                angular_momentum: angular_momentum_entity_path(&body.name),
            };
            self.send(static_chunk(
                track.energy.clone(),
                &[&rerun::SeriesLines::new().with_names(ENERGY_SERIES)],
            )?)?;
            self.send(static_chunk(
                track.angular_momentum.clone(),
                &[&rerun::SeriesLines::new().with_names(["|L|"])],
            )?)?;
            self.bodies.push(track);
        }
        self.write_scene_plot_names(layout)
    }

    /// The static series names of the scene-level plots.
    fn write_scene_plot_names(&mut self, layout: &RecordingLayout) -> Result<()> {
        if !layout.bodies.is_empty() {
            self.send(static_chunk(
                scene_energy_entity_path(),
                &[&rerun::SeriesLines::new().with_names(ENERGY_SERIES)],
            )?)?;
            self.send(static_chunk(
                scene_energy_change_entity_path(),
                &[&rerun::SeriesLines::new().with_names(["(E − E₀)/|E₀|"])],
            )?)?;
            self.send(static_chunk(
                scene_angmom_change_entity_path(),
                &[&rerun::SeriesLines::new().with_names(["max |L − L₀|/|L₀|"])],
            )?)?;
        }
        for chunk in self.joint_plots.static_chunks()? {
            self.send(chunk)?;
        }
        Ok(())
    }

    /// The static part of the batched layout: each batch's shape ([`super::rerun_batched`]).
    fn write_batched_layout(&mut self, layout: &RecordingLayout) -> Result<()> {
        let batches = self.batched.take().context("no batched layout")?;
        let result = (|| -> Result<()> {
            for batch in &batches.list {
                let frame = &layout.frames[batch.first_frame];
                let shape = match batch.content {
                    Content::Visual { index } => {
                        match self.visual_shape(&batch.entity, &frame.visuals[index])? {
                            Some(shape) => shape.batches,
                            None => continue,
                        }
                    }
                    Content::Inertia { body } => {
                        let radii = layout.bodies[body].inertia_ellipsoid_radii();
                        rerun::Ellipsoids3D::from_half_sizes([f32x3(&radii)])
                            .with_colors([rerun::Rgba32::from_unmultiplied_rgba(255, 160, 0, 255)])
                            .with_fill_mode(rerun::FillMode::MajorWireframe)
                            .as_serialized_batches()
                    }
                };
                // In the world frame: an entity without a `CoordinateFrame` sits in its implicit
                // frame `tf#/<path>`, which is not connected to "world".
                let mut batches = rerun::CoordinateFrame::new(WORLD_FRAME).as_serialized_batches();
                batches.extend(shape);
                self.send(static_batches_chunk(batch.entity.clone(), batches)?)?;
            }
            Ok(())
        })();
        self.batched = Some(batches);
        result
    }

    fn write_metadata(&mut self, layout: &RecordingLayout) -> Result<()> {
        if layout.metadata.is_empty() {
            return Ok(());
        }
        let mut values = rerun::AnyValues::default();
        let mut markdown = format!("# {}\n", layout.name);
        for (key, value) in &layout.metadata {
            let field = rerun::ComponentIdentifier::try_new(key)
                .map_err(|e| anyhow!("metadata key {key:?}: {e}"))?;
            values = values.with_component::<rerun::components::Text>(field, [value.as_str()]);
            if value.contains('\n') {
                markdown.push_str(&format!("\n## {key}\n\n```\n{value}\n```\n"));
            } else {
                markdown.push_str(&format!("\n- **{key}**: {value}\n"));
            }
        }
        self.send(static_chunk(
            EntityPath::properties() / EntityPathPart::new("metadata"),
            &[&values],
        )?)?;
        self.send(static_chunk(
            entity(&["metadata"]),
            &[&rerun::TextDocument::from_markdown(markdown)],
        )?)
    }

    fn write_visual(
        &mut self,
        entity: EntityPath,
        frame: &FrameLayout,
        visual: &Visual,
    ) -> Result<()> {
        let Some(shape) = self.visual_shape(&entity, visual)? else {
            return Ok(());
        };
        let frame_id = rerun::CoordinateFrame::new(frame.frame_id.as_str());
        let pose = instance_pose(&visual.link_from_visual, shape.scale);
        let mut batches = frame_id.as_serialized_batches();
        batches.extend(pose.as_serialized_batches());
        batches.extend(shape.batches);
        self.send(static_batches_chunk(entity, batches)?)
    }

    /// The component batches drawing `visual` at its own origin (the caller places it: by a
    /// `CoordinateFrame` and its origin as an instance pose, or by per-step instance poses in
    /// the batched layout), and the mesh scale the instance pose must carry. `None`, with a
    /// warning, for a mesh that cannot be shown.
    pub(super) fn visual_shape(
        &mut self,
        entity: &EntityPath,
        visual: &Visual,
    ) -> Result<Option<Shape>> {
        let colors = [color(visual.rgba)];
        let primitive = |a: &dyn AsComponents| Shape {
            batches: a.as_serialized_batches(),
            scale: None,
        };
        let shape = match &visual.geometry {
            Geometry::Box { size } => {
                primitive(&rerun::Boxes3D::from_sizes([f32x3(size)]).with_colors(colors))
            }
            Geometry::Sphere { radius } => {
                primitive(&rerun::Ellipsoids3D::from_radii([*radius as f32]).with_colors(colors))
            }
            Geometry::Cylinder { radius, length } => primitive(
                &rerun::Cylinders3D::from_lengths_and_radii([*length as f32], [*radius as f32])
                    .with_colors(colors),
            ),
            // Rerun's capsule runs from the origin to +z; URDF's is centred.
            Geometry::Capsule { radius, length } => primitive(
                &rerun::Capsules3D::from_lengths_and_radii([*length as f32], [*radius as f32])
                    .with_translations([[0.0, 0.0, -0.5 * *length as f32]])
                    .with_colors(colors),
            ),
            Geometry::Mesh { uri, path, scale } => {
                let Some(path) = path else {
                    self.warn(format!(
                        "{entity}: mesh {uri:?} was not found, is not a readable regular file or is outside the folders meshes are read from (`tumble inspect` says which), left out of the Rerun recording"
                    ));
                    return Ok(None);
                };
                if let Err(err) = crate::input::check(path, crate::input::MESH_MAX_BYTES) {
                    self.warn(format!(
                        "{entity}: cannot read mesh {}: {err}, left out of the Rerun recording",
                        path.display()
                    ));
                    return Ok(None);
                }
                let ext = path
                    .extension()
                    .and_then(|e| e.to_str())
                    .unwrap_or("")
                    .to_ascii_lowercase();
                let batches = if ext == "dae" {
                    // Rerun reads no Collada: tumble's own reader gives the triangles (its
                    // `<unit>` and node transforms applied, `<up_axis>` ignored as RViz does), sent
                    // as a `Mesh3D`.
                    let mesh = match self.meshes.get(path) {
                        Ok(mesh) => mesh,
                        Err(err) => {
                            self.warn(format!("{entity}: {err}, left out of the Rerun recording"));
                            return Ok(None);
                        }
                    };
                    mesh3d(&mesh)
                        .with_albedo_factor(color(visual.rgba))
                        .as_serialized_batches()
                } else {
                    if !matches!(ext.as_str(), "stl" | "obj") {
                        self.warn(format!(
                            "{entity}: mesh {uri:?} has a format tumble does not read (.{ext}; \
                             STL, OBJ and DAE are read), left out of the Rerun recording"
                        ));
                        return Ok(None);
                    }
                    // The file itself, as `from_file_path` would send it, but only bytes
                    // tumble's own reader accepted as a mesh, read once: a file that is no
                    // mesh (a text file named `.obj`) is never embedded.
                    match self.meshes.get_file(path) {
                        Ok(bytes) => rerun::Asset3D::from_file_contents(
                            bytes.as_ref().clone(),
                            rerun::components::MediaType::guess_from_path(path),
                        )
                        .with_albedo_factor(color(visual.rgba))
                        .as_serialized_batches(),
                        Err(err) => {
                            self.warn(format!("{entity}: {err}, left out of the Rerun recording"));
                            return Ok(None);
                        }
                    }
                };
                Shape {
                    batches,
                    scale: Some(f32x3(scale)),
                }
            }
        };
        Ok(Some(shape))
    }

    fn write_inertia(
        &mut self,
        entity: EntityPath,
        frame: &FrameLayout,
        body: &BodyLayout,
    ) -> Result<()> {
        let radii = body.inertia_ellipsoid_radii();
        self.send(static_chunk(
            entity,
            &[
                &rerun::CoordinateFrame::new(frame.frame_id.as_str()),
                &instance_pose(&body.link_from_principal, None),
                &rerun::Ellipsoids3D::from_half_sizes([f32x3(&radii)])
                    .with_colors([rerun::Rgba32::from_unmultiplied_rgba(255, 160, 0, 255)])
                    .with_fill_mode(rerun::FillMode::MajorWireframe),
            ],
        )?)
    }

    /// Sends the buffered frames as one chunk per entity.
    fn flush_buffer(&mut self) -> Result<()> {
        if self.buffer.len() == 0 {
            return Ok(());
        }
        let writer = ChunkWriter {
            state: &self.state,
            store_id: &self.store_info.store_id,
            path: &self.part_path,
        };
        let buffer = &self.buffer;
        let n = buffer.len();
        let times = || {
            [
                TimeColumn::new_duration_nanos(SIM_TIME_TIMELINE, buffer.time_ns.iter().copied()),
                TimeColumn::new_sequence(STEP_TIMELINE, buffer.step.iter().copied()),
            ]
        };
        if let Some(batched) = &mut self.batched {
            for b in 0..batched.list.len() {
                let columns = super::rerun_batched::pose_columns(batched, b, n)?;
                writer.send_columns(batched.list[b].entity.clone(), times(), columns)?;
            }
        }
        for (i, track) in self.frames.iter().enumerate() {
            let transforms = rerun::Transform3D::update_fields()
                .with_many_translation(buffer.translation[i].iter().copied())
                .with_many_quaternion(
                    buffer.quaternion[i]
                        .iter()
                        .map(|q| rerun::Quaternion::from_xyzw(*q)),
                )
                .with_many_parent_frame(std::iter::repeat_n(WORLD_FRAME, n))
                .with_many_child_frame(std::iter::repeat_n(track.frame_id.as_str(), n));
            writer.send_columns(
                track.entity.clone(),
                times(),
                transforms.columns_of_unit_batches()?,
            )?;
        }
        for (i, track) in self.bodies.iter().enumerate() {
            writer.send_columns(
                track.energy.clone(),
                times(),
                rerun::Scalars::new(buffer.energy[i].iter().copied())
                    .columns(std::iter::repeat_n(3, n))?,
            )?;
            writer.send_columns(
                track.angular_momentum.clone(),
                times(),
                rerun::Scalars::new(buffer.angular_momentum[i].iter().copied())
                    .columns_of_unit_batches()?,
            )?;
        }
        if self.body_count > 0 {
            writer.send_columns(
                scene_energy_entity_path(),
                times(),
                rerun::Scalars::new(buffer.scene_energy.iter().copied())
                    .columns(std::iter::repeat_n(3, n))?,
            )?;
            writer.send_columns(
                scene_energy_change_entity_path(),
                times(),
                rerun::Scalars::new(buffer.scene_energy_change.iter().copied())
                    .columns_of_unit_batches()?,
            )?;
            writer.send_columns(
                scene_angmom_change_entity_path(),
                times(),
                rerun::Scalars::new(buffer.scene_angmom_change.iter().copied())
                    .columns_of_unit_batches()?,
            )?;
        }
        self.joint_plots.send(&writer, &times, n)?;
        self.buffer.clear();
        if let Some(batched) = &mut self.batched {
            batched.clear();
        }
        self.check_sink()
    }

    /// Sends extra scalar series (e.g. `tumble diff`'s errors) to `entity` on both timelines:
    /// `values` holds `names.len()` values per row, rows at `time_ns` / `step`. The series names
    /// are sent once per entity as a static `SeriesLines`. Frames buffered so far are sent first,
    /// so every entity's rows stay in time order.
    pub fn write_series(
        &mut self,
        entity: &EntityPath,
        names: &[&str],
        time_ns: &[i64],
        step: &[i64],
        values: &[f64],
    ) -> Result<()> {
        if time_ns.len() != step.len() || values.len() != time_ns.len() * names.len() {
            bail!(
                "series {entity}: {} times, {} steps, {} values for {} names",
                time_ns.len(),
                step.len(),
                values.len(),
                names.len()
            );
        }
        if self.series_named.insert(entity.clone()) {
            self.send(static_chunk(
                entity.clone(),
                &[&rerun::SeriesLines::new().with_names(names.iter().copied())],
            )?)?;
        }
        if time_ns.is_empty() {
            return Ok(());
        }
        self.flush_buffer()?;
        self.writer().send_columns(
            entity.clone(),
            [
                TimeColumn::new_duration_nanos(SIM_TIME_TIMELINE, time_ns.iter().copied()),
                TimeColumn::new_sequence(STEP_TIMELINE, step.iter().copied()),
            ],
            rerun::Scalars::new(values.iter().copied())
                .columns(std::iter::repeat_n(names.len(), time_ns.len()))?,
        )?;
        self.check_sink()
    }

    /// Flushes, closes the stream, writes the footer and syncs `<path>.part` (a complete file).
    fn close(&mut self) -> Result<()> {
        self.flush_buffer()?;
        let rec = self.rec.take().context("the Rerun recording is closed")?;
        rec.flush_blocking()
            .with_context(|| format!("flushing {}", self.part_path.display()))?;
        // Dropping the last handle joins Rerun's threads; the file sink is dropped with them.
        drop(rec);
        // The blueprint store, after the recording (so its bytes do not depend on thread timing).
        let chunks = blueprint_chunks(
            recording_seed(&self.store_info),
            &self.bounds,
            &self.plot_views,
        )?;
        {
            let mut state = lock(&self.state);
            for msg in blueprint_messages(&self.store_info, chunks)? {
                state
                    .write(msg)
                    .with_context(|| format!("writing {}", self.part_path.display()))?;
            }
        }
        let encoder = {
            let mut state = lock(&self.state);
            if let Some(err) = &state.error {
                bail!("writing {}: {err}", self.part_path.display());
            }
            state.encoder.take().context("the .rrd encoder is gone")?
        };
        let mut encoder = encoder;
        encoder.flush_blocking()?;
        self.footer_hold.hold();
        encoder
            .finish()
            .with_context(|| format!("writing the footer of {}", self.part_path.display()))?;
        let file = encoder
            .into_inner()?
            .finish()
            .with_context(|| format!("writing the footer of {}", self.part_path.display()))?;
        file.sync_all()
            .with_context(|| format!("syncing {}", self.part_path.display()))?;
        drop(file);
        self.done = true;
        Ok(())
    }

    /// [`Self::close`], then publishes `<path>.part` onto `<path>`
    /// ([`crate::fsutil::publish`]).
    fn close_and_rename(&mut self) -> Result<()> {
        self.close()?;
        crate::fsutil::publish(&[&self.final_path])
    }
}

impl Sink for RerunSink {
    fn write(&mut self, frame: &Frame<'_>) -> Result<()> {
        if frame.world_from_link.len() != self.frame_count {
            bail!(
                "frame has {} link poses, the layout {}",
                frame.world_from_link.len(),
                self.frame_count
            );
        }
        if frame.bodies.len() != self.body_count {
            bail!(
                "frame has {} body states, the layout {}",
                frame.bodies.len(),
                self.body_count
            );
        }
        if let Some(last) = self.last_time_ns
            && frame.time_ns <= last
        {
            bail!("frame time {} ns is not after {} ns", frame.time_ns, last);
        }
        self.last_time_ns = Some(frame.time_ns);
        let buffer = &mut self.buffer;
        buffer.time_ns.push(frame.time_ns);
        buffer
            .step
            .push(i64::try_from(frame.step).context("step does not fit an i64")?);
        let per_body = self.batched.is_none();
        if let Some(batched) = &mut self.batched {
            batched.push(frame);
        }
        for (i, pose) in frame.world_from_link.iter().enumerate() {
            if per_body {
                buffer.translation[i].push(f32x3(&pose.translation.vector));
                buffer.quaternion[i].push(quat_xyzw(pose));
            }
            self.bounds
                .add(&pose.translation.vector, self.frame_reach[i]);
        }
        let angmom_change = if self.joint_plots.is_empty() {
            if self.angmom0.is_empty() {
                self.angmom0 = frame.bodies.iter().map(|b| b.angmom_world).collect();
            }
            frame
                .bodies
                .iter()
                .zip(&self.angmom0)
                .map(|(b, l0)| (b.angmom_world - l0).norm() / nonzero(l0.norm()))
                .fold(0.0, f64::max)
        } else {
            self.joint_plots.push(frame)?;
            let angmom = self.joint_plots.conserved_angmom(frame);
            if self.angmom0.is_empty() {
                self.angmom0 = angmom.clone();
            }
            angmom
                .iter()
                .zip(&self.angmom0)
                .map(|(l, l0)| (l - l0).norm() / nonzero(l0.norm()))
                .fold(0.0, f64::max)
        };
        let (mut kinetic, mut potential) = (0.0, 0.0);
        for (i, body) in frame.bodies.iter().enumerate() {
            if per_body {
                let total = body.kinetic_energy + body.potential_energy;
                buffer.energy[i].extend([
                    f64c(body.kinetic_energy),
                    f64c(body.potential_energy),
                    f64c(total),
                ]);
                buffer.angular_momentum[i].push(f64c(body.angmom_world.norm()));
            }
            kinetic += body.kinetic_energy;
            potential += body.potential_energy;
        }
        buffer
            .scene_energy
            .extend([kinetic, potential, kinetic + potential]);
        let energy0 = *self.energy0.get_or_insert(kinetic + potential);
        buffer.scene_energy_change.push(f64c(
            (kinetic + potential - energy0) / nonzero(energy0.abs()),
        ));
        buffer.scene_angmom_change.push(f64c(angmom_change));
        if buffer.len() >= self.batch_frames {
            self.flush_buffer()?;
        }
        Ok(())
    }

    fn finish(mut self: Box<Self>) -> Result<()> {
        self.close_and_rename()
    }

    fn path(&self) -> Option<PathBuf> {
        Some(self.final_path.clone())
    }

    fn complete(mut self: Box<Self>) -> Result<()> {
        self.close()
    }
}

impl Drop for RerunSink {
    fn drop(&mut self) {
        if !self.done {
            // Unfinished (error or early return): stop Rerun's threads, then remove the part file.
            drop(self.rec.take());
            lock(&self.state).encoder = None;
            crate::fsutil::discard(&[&self.final_path]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entity_paths_follow_the_urdf_importer_and_document() {
        assert_eq!(
            visual_entity_path("robot", "base_link", 0, Some("shell")).to_string(),
            "/robot/visual_geometries/base_link/shell"
        );
        assert_eq!(
            visual_entity_path("robot", "base_link", 2, None).to_string(),
            "/robot/visual_geometries/base_link/visual_2"
        );
        assert_eq!(
            visual_entity_path("robot", "base_link", 1, Some("")).to_string(),
            "/robot/visual_geometries/base_link/visual_1"
        );
        assert_eq!(
            inertia_entity_path("arm", "link1").to_string(),
            "/arm/inertia/link1"
        );
        assert_eq!(
            transform_entity_path("arm", "link1").to_string(),
            "/arm/world_from_link/link1"
        );
        assert_eq!(
            energy_entity_path("arm/link1").to_string(),
            "/plots/energy/arm/link1"
        );
        assert_eq!(
            angular_momentum_entity_path("box").to_string(),
            "/plots/angular_momentum/box"
        );
        assert_eq!(
            scene_energy_entity_path().to_string(),
            "/plots/scene/energy"
        );
        // A name with a slash stays one part (escaped), as in Rerun's URDF importer.
        let odd = visual_entity_path("my robot", "a/b", 0, None);
        assert_eq!(odd.len(), 4);
        assert_eq!(odd.as_slice()[2].unescaped_str(), "a/b");
    }

    #[test]
    fn ids_are_valid_and_deterministic() {
        assert_eq!(application_id("two.boxes/v1"), "two_boxes_v1");
        assert_eq!(application_id(""), "tumble");
        let mut layout = RecordingLayout {
            name: "scene".into(),
            ..Default::default()
        };
        let a = recording_id(&layout);
        assert_eq!(a, recording_id(&layout.clone()));
        assert!(a.starts_with("scene-"));
        layout.metadata.insert("dt".into(), "0.001".into());
        assert_ne!(a, recording_id(&layout));
    }
}
