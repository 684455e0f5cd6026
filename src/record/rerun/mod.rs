//! Rerun `.rrd` recordings (rerun 0.36; view with Rerun 0.36/0.37).
//!
//! # Timelines
//!
//! Exactly two, both on every time-varying row; there is no wall-clock timeline (`log_time`,
//! `log_tick`):
//!
//! | timeline   | kind     | value                                                          |
//! |------------|----------|----------------------------------------------------------------|
//! | `sim_time` | duration | [`crate::record::Frame::time_ns`], integer nanoseconds (bit-identical to MCAP) |
//! | `step`     | sequence | [`crate::record::Frame::step`], the integrator step index                     |
//!
//! # Transform frames
//!
//! Named frames, as in ROS and in the MCAP `/tf` channel: every recorded link frame is a child of
//! `world`, and its frame id is exactly [`crate::record::FrameLayout::frame_id`]. The viewer's root entity `/`
//! is placed in the `world` frame, so the default 3D view shows everything.
//!
//! # Entities
//!
//! `<model>` is [`crate::record::FrameLayout::model`], `<link>` is [`crate::record::FrameLayout::link`], `<body>` is
//! [`crate::record::BodyLayout::name`] split at `/` (so `arm/link1` gives two path parts). Each name is one entity
//! path part (special characters are escaped, as Rerun does for URDF names).
//!
//! | entity                                        | archetypes                                   | time     |
//! |-----------------------------------------------|----------------------------------------------|----------|
//! | `/`                                           | `CoordinateFrame("world")`, `ViewCoordinates` (right-handed, Z up) | static |
//! | `/__properties`                               | `RecordingInfo` (name only, no start time)    | static   |
//! | `/__properties/metadata`                      | one text field per [`crate::record::RecordingLayout::metadata`] entry | static |
//! | `/metadata`                                   | `TextDocument` (Markdown list of the metadata) | static  |
//! | `/<model>/visual_geometries/<link>/<visual>`  | `CoordinateFrame(frame_id)`, `InstancePoses3D` (visual origin, mesh scale), and one of `Boxes3D`, `Ellipsoids3D` (sphere), `Cylinders3D`, `Capsules3D`, `Asset3D` (stl, obj), `Mesh3D` (dae) | static |
//! | `/<model>/inertia/<link>`                     | `CoordinateFrame(frame_id)`, `InstancePoses3D` (principal frame), `Ellipsoids3D` (equivalent uniform ellipsoid, wireframe) | static |
//! | `/<model>/world_from_link/<link>`             | `Transform3D` (translation, quaternion xyzw, `parent_frame = "world"`, `child_frame = frame_id`), f32 | both timelines |
//! | `/plots/energy/<body>`                        | `Scalars` [kinetic, potential, total] (J), `SeriesLines` names (static) | both timelines |
//! | `/plots/angular_momentum/<body>`              | `Scalars` [\|L\|] about the body's centre of mass (kg m²/s), `SeriesLines` (static) | both timelines |
//! | `/plots/scene/energy`                         | `Scalars` [kinetic, potential, total] summed over all bodies (J), `SeriesLines` (static) | both timelines |
//! | `/plots/scene/energy_change`                  | `Scalars` [(E − E₀)/\|E₀\|], E the total above, E₀ its first recorded value | both timelines |
//! | `/plots/scene/angular_momentum_change`        | `Scalars` [max over bodies \|L − L₀\|/\|L₀\|] | both timelines |
//! | `/plots/joints/…`, `/plots/mechanisms/<model>/…` | articulated models only: joint positions and velocities, each model's energy, momenta and constraint residual ([`joints`]); driven joints' efforts, targets and saturation ([`drives`]) | both timelines |
//! | `/world/ground`, `/world/contacts/points`, `/world/contacts/forces` | with a ground, in runs that can have contacts: the ground as a static slab, each step's contact points and force arrows ([`contacts`]) | static / both timelines |
//!
//! # Blueprint
//!
//! The file also holds a blueprint store ([`blueprint`]): the 3D view framed on
//! the run, beside the two change plots and the energies, activated when the file opens. With a
//! robot ([`crate::record::RecordingLayout::robot_root`]: an articulated model, or a model with
//! meshes) the 3D view is framed on the robot at its first recorded step instead, and its eye
//! tracks (`EyeControls3D::tracking_entity`) the first visual entity of the robot's root frame, so
//! the robot stays in view wherever it goes (not in the batched layout of big scenes).
//!
//! `<visual>` is the URDF `<visual name=...>`, else `visual_<i>` with `i` the index among the
//! link's visuals: the same paths and frame attachment (a `CoordinateFrame` naming the link frame
//! plus an `InstancePoses3D` for the visual origin) as Rerun 0.36's own URDF importer, so a URDF
//! dropped into the viewer lines up with the recording. Differences from the importer: URDF
//! capsules are centred on their origin (the importer leaves `Capsules3D`'s one end at the
//! origin); DAE meshes (which Rerun cannot read) are read by tumble and sent as `Mesh3D`
//! (unit and node transforms applied, up axis ignored, as for mass properties); STL and OBJ files
//! are embedded as `Asset3D` only when tumble's own reader accepts them as meshes with triangles,
//! and then the very bytes it read ([`crate::record::scene_update::MeshCache::get_file`]: a text file named `.obj` is never
//! embedded); glTF/GLB files, which tumble does not read, are left out; meshes whose file was not
//! found or was refused ([`crate::model::confine`]) are skipped with a warning (see
//! [`RerunSink::warnings`]).
//! Colours come from the URDF material (linear RGBA), white when there is none, as in the importer.
//!
//! Inertia ellipsoids ([`crate::record::BodyLayout::inertia_ellipsoid_radii`]) are on their own entities so they
//! can be toggled in the viewer; [`RerunOptions::ellipsoids`] `= false` leaves them out (what
//! `simulate` and `convert` choose by default when a model has meshes,
//! [`crate::record::RecordingLayout::default_ellipsoids`]).
//!
//! # Writing
//!
//! Time-varying data is buffered and sent by columns every [`columns::batch_frames`] frames (about
//! [`columns::BATCH_BYTES`] of columns) and on [`crate::record::Sink::finish`]. Every chunk is encoded and written on
//! the sink's own thread as it is sent ([`writer::ChunkWriter`]), so memory stays bounded however fast
//! frames arrive; Rerun's `RecordingStream` writes only the store info and the properties at
//! the start (its batcher and forwarding thread had cost an Arrow round trip per chunk). The file is written
//! as `<path>.part` and renamed onto `<path>` by [`crate::record::Sink::finish`] after the footer is written and
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
//! (3) writes through its own [`rerun::sink::LogSink`] that renumbers TUIDs with a counter (time
//! part 0, increasing in send order, so Rerun's ordering semantics are kept) before encoding, and (4)
//! rewrites the footer with its columns sorted ([`footer`]). The recording id is the
//! layout name plus a hash of the name and metadata: the same inputs give the same id, different
//! scenes or settings do not get merged by the viewer.
//!
//! # Files
//!
//! [`paths`] the entity paths, timelines and ids; [`values`] the f32 conversions and colours;
//! [`chunks`] the static chunks; [`writer`] the file writer (the [`rerun::sink::LogSink`]
//! renumbering ids, and [`writer::ChunkWriter`]); [`statics`] the static layout (geometry,
//! inertia, metadata, series names); [`columns`] the buffered time-varying columns and their
//! sending; [`sink`] the [`RerunSink`] itself; [`joints`] the series of articulated models;
//! [`drives`] the driven joints' series; [`contacts`] the ground and the contacts;
//! [`batched`] the layout of big scenes; [`blueprint`] the viewer's blueprint; [`footer`] the
//! sorted `.rrd` footer.

pub mod batched;
pub mod blueprint;
pub mod chunks;
pub mod columns;
pub mod contacts;
pub mod drives;
pub mod footer;
pub mod joints;
pub mod paths;
pub mod sink;
pub mod statics;
pub mod values;
pub mod writer;

pub use columns::{BATCH_BYTES, BATCH_FRAMES_MAX, BATCH_FRAMES_MIN, batch_frames};
pub use joints::{joint_position_entity_path, joint_velocity_entity_path, mechanism_entity_path};
pub use paths::{
    ENERGY_SERIES, SIM_TIME_TIMELINE, STEP_TIMELINE, angular_momentum_entity_path,
    energy_entity_path, inertia_entity_path, scene_angmom_change_entity_path,
    scene_energy_change_entity_path, scene_energy_entity_path, transform_entity_path,
    visual_entity_path,
};
pub use sink::{RerunOptions, RerunSink, create};
