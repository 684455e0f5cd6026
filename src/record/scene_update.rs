//! The geometry of a recording as Foxglove `SceneUpdate` messages (the `/scene` and `/inertia`
//! topics of [`super::mcap`]).
//!
//! Foxglove's 3D panel draws a `foxglove.SceneUpdate` entity in the frame its `frame_id` names,
//! and with `frame_locked = true` the entity follows that frame as `/tf` moves it, so one message
//! at t = 0 places the geometry for the whole file (seeking backfills it). Here:
//!
//! | topic      | entity `id`        | `frame_id`         | primitives                                    |
//! |------------|--------------------|--------------------|-----------------------------------------------|
//! | `/scene`   | the link frame id  | the link frame id  | one per URDF `<visual>`, placed at its `<origin>` in the link frame |
//! | `/inertia` | `inertia/<body>`   | the body's link frame | one sphere primitive: the body's equivalent uniform ellipsoid ([`BodyLayout::inertia_ellipsoid_radii`]) in its principal frame, translucent |
//! | `/scene`   | `ground`           | `world`            | with a ground ([`super::RecordingLayout::ground`]): one cube, the slab of [`super::contacts::ground_pose`], grey |
//! | `/contacts/scene` | `contacts`  | `world`            | one message per recorded step when the run can have contacts: per contact a sphere at its point (red) and an arrow along the force on body `a` (yellow, [`super::contacts::force_scale`] m per N, at most [`super::contacts::ARROW_MAX_M`]; none for a zero force); the entity replaces the previous step's, so a step without contacts shows none |
//!
//! URDF geometry → primitives: `<box>` → `CubePrimitive` (size = the box's sides), `<sphere>` →
//! `SpherePrimitive` (size = diameter), `<cylinder>` → `CylinderPrimitive` (Foxglove's cylinder
//! axis is z, as URDF's), `<capsule>` → a cylinder and two spheres, `<mesh>` →
//! `TriangleListPrimitive` with the file's vertices scaled by the mesh `scale` (mirrored meshes
//! re-wound) and an index list. Meshes go in as triangle lists, not `ModelPrimitive` files:
//! Foxglove shows STL/OBJ model data rotated +90° about x under its default "mesh up axis", a
//! triangle list has no such ambiguity. Collada files are read as for mass properties: `<unit>` and node
//! transforms applied, `<up_axis>` ignored as RViz does ([`crate::model::geometry::mesh_io`]). Colours are the URDF material's,
//! else light grey. A mesh that cannot be read is left out with a warning; each distinct file is
//! read once per recording ([`MeshCache`]).

use super::contacts::{
    FORCE_COLOR, GROUND_COLOR, POINT_COLOR, POINT_RADIUS_M, SHAFT_RADIUS_M, ground_pose,
    ground_size,
};
use super::names::WORLD_FRAME;
use super::{BodyLayout, ContactState, FrameLayout, GroundLayout};
use crate::model::geometry::mesh::TriangleMesh;
use crate::model::geometry::mesh_io::{load_mesh, load_mesh_file};
use crate::model::{Geometry, Visual};
use foxglove::messages::{
    ArrowPrimitive, Color, CubePrimitive, CylinderPrimitive, KeyValuePair, Point3, Pose,
    Quaternion, SceneEntity, SceneUpdate, SpherePrimitive, Timestamp, TriangleListPrimitive,
    Vector3,
};
use nalgebra::{Isometry3, Translation3};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Colour of geometry whose URDF gives no material.
pub const DEFAULT_COLOR: [f64; 4] = [0.8, 0.8, 0.8, 1.0];
/// Colour of the inertia ellipsoids: translucent orange, so the geometry shows through.
pub const INERTIA_COLOR: [f64; 4] = [1.0, 0.55, 0.1, 0.35];

/// Meshes read so far, by resolved path (a mesh shared by many links or model copies is read
/// once). Failures are kept too, so a missing file is reported once.
#[derive(Default)]
pub struct MeshCache {
    meshes: HashMap<PathBuf, Result<Arc<TriangleMesh>, String>>,
    files: HashMap<PathBuf, Result<Arc<Vec<u8>>, String>>,
}

impl MeshCache {
    /// The mesh at `path`, read on first use.
    pub fn get(&mut self, path: &Path) -> Result<Arc<TriangleMesh>, String> {
        self.meshes
            .entry(path.to_path_buf())
            .or_insert_with(|| load_mesh(path).map(Arc::new).map_err(|e| e.to_string()))
            .clone()
    }

    /// The bytes of the mesh file at `path`, to embed as the file itself (Rerun's `Asset3D`),
    /// read on first use: read once, and given only when tumble's own reader accepts those very
    /// bytes as a mesh with triangles ([`load_mesh_file`]). A file that is not a mesh tumble
    /// reads (a text file named `.obj`, an empty mesh, a format tumble does not read) is an
    /// error, never embedded.
    pub fn get_file(&mut self, path: &Path) -> Result<Arc<Vec<u8>>, String> {
        self.files
            .entry(path.to_path_buf())
            .or_insert_with(|| {
                load_mesh_file(path)
                    .map(|(bytes, _)| Arc::new(bytes))
                    .map_err(|e| e.to_string())
            })
            .clone()
    }
}

fn color(rgba: [f64; 4]) -> Option<Color> {
    Some(Color {
        r: rgba[0],
        g: rgba[1],
        b: rgba[2],
        a: rgba[3],
    })
}

fn pose(p: &Isometry3<f64>) -> Option<Pose> {
    let t = p.translation.vector;
    let q = p.rotation.quaternion().coords;
    Some(Pose {
        position: Some(Vector3 {
            x: t.x,
            y: t.y,
            z: t.z,
        }),
        orientation: Some(Quaternion {
            x: q.x,
            y: q.y,
            z: q.z,
            w: q.w,
        }),
    })
}

fn vector3(v: &nalgebra::Vector3<f64>) -> Option<Vector3> {
    Some(Vector3 {
        x: v.x,
        y: v.y,
        z: v.z,
    })
}

fn sphere(
    link_from: &Isometry3<f64>,
    diameter: nalgebra::Vector3<f64>,
    rgba: [f64; 4],
) -> SpherePrimitive {
    SpherePrimitive {
        pose: pose(link_from),
        size: vector3(&diameter),
        color: color(rgba),
    }
}

/// Adds the primitives of one visual to `entity`; a mesh that cannot be read gives a warning.
fn add_visual(
    entity: &mut SceneEntity,
    visual: &Visual,
    frame_id: &str,
    meshes: &mut MeshCache,
    warnings: &mut Vec<String>,
) {
    let rgba = visual.rgba.map_or(DEFAULT_COLOR, |c| c.map(f64::from));
    let link_from_visual = &visual.link_from_visual;
    match &visual.geometry {
        Geometry::Box { size } => entity.cubes.push(CubePrimitive {
            pose: pose(link_from_visual),
            size: vector3(size),
            color: color(rgba),
        }),
        Geometry::Sphere { radius } => entity.spheres.push(sphere(
            link_from_visual,
            nalgebra::Vector3::repeat(2.0 * radius),
            rgba,
        )),
        Geometry::Cylinder { radius, length } => {
            entity
                .cylinders
                .push(cylinder(link_from_visual, *radius, *length, rgba))
        }
        Geometry::Capsule { radius, length } => {
            entity
                .cylinders
                .push(cylinder(link_from_visual, *radius, *length, rgba));
            for end in [-0.5, 0.5] {
                let cap = link_from_visual * Translation3::new(0.0, 0.0, end * length);
                entity
                    .spheres
                    .push(sphere(&cap, nalgebra::Vector3::repeat(2.0 * radius), rgba));
            }
        }
        Geometry::Mesh { uri, path, scale } => {
            let Some(path) = path else {
                warnings.push(format!(
                    "{frame_id}: mesh {uri:?} not found: left out of the /scene topic"
                ));
                return;
            };
            match meshes.get(path) {
                Ok(mesh) => entity.triangles.push(triangle_list(
                    &mesh.scaled(scale),
                    link_from_visual,
                    rgba,
                )),
                Err(e) => warnings.push(format!("{frame_id}: {e}: left out of the /scene topic")),
            }
        }
    }
}

fn cylinder(
    link_from: &Isometry3<f64>,
    radius: f64,
    length: f64,
    rgba: [f64; 4],
) -> CylinderPrimitive {
    CylinderPrimitive {
        pose: pose(link_from),
        size: vector3(&nalgebra::Vector3::new(2.0 * radius, 2.0 * radius, length)),
        bottom_scale: 1.0,
        top_scale: 1.0,
        color: color(rgba),
    }
}

/// A mesh as an indexed triangle list in the visual frame (counter-clockwise from outside).
///
/// Vertex coordinates are rounded to the nearest `f32` (the precision mesh files carry: binary
/// STL stores `f32`, and Rerun's `Mesh3D` takes `f32` too), then written as the schema's
/// doubles: the four low bytes of each mantissa are then zero, which the chunk compression
/// removes. On a UR5's Collada meshes (47 874 vertices) this makes a 1 s run's MCAP 1.17 MB
/// instead of 1.67 MB; the shapes move by at most 2⁻²⁴ of a coordinate (60 nm at 1 m).
pub fn triangle_list(
    mesh: &TriangleMesh,
    link_from_visual: &Isometry3<f64>,
    rgba: [f64; 4],
) -> TriangleListPrimitive {
    TriangleListPrimitive {
        pose: pose(link_from_visual),
        points: mesh
            .vertices
            .iter()
            .map(|v| Point3 {
                x: f64::from(v.x as f32),
                y: f64::from(v.y as f32),
                z: f64::from(v.z as f32),
            })
            .collect(),
        color: color(rgba),
        colors: Vec::new(),
        indices: mesh.triangles.iter().flatten().copied().collect(),
    }
}

fn entity(id: String, frame_id: &str, timestamp: Timestamp) -> SceneEntity {
    SceneEntity {
        timestamp: Some(timestamp),
        frame_id: frame_id.to_string(),
        id,
        lifetime: None,
        frame_locked: true,
        ..Default::default()
    }
}

/// The `/scene` message: one entity per link frame that has visual geometry.
pub fn geometry_update(
    frames: &[FrameLayout],
    timestamp: Timestamp,
    meshes: &mut MeshCache,
    warnings: &mut Vec<String>,
) -> SceneUpdate {
    let entities = frames
        .iter()
        .filter(|f| !f.visuals.is_empty())
        .map(|f| {
            let mut e = entity(f.frame_id.clone(), &f.frame_id, timestamp);
            for visual in f.visuals.iter() {
                add_visual(&mut e, visual, &f.frame_id, meshes, warnings);
            }
            e
        })
        .collect();
    SceneUpdate {
        deletions: Vec::new(),
        entities,
    }
}

/// The `/inertia` message: one entity per body, its equivalent uniform ellipsoid.
/// `frames` is the whole layout's frame list (bodies refer to it by index).
pub fn inertia_update(
    frames: &[FrameLayout],
    bodies: &[BodyLayout],
    timestamp: Timestamp,
) -> SceneUpdate {
    let entities = bodies
        .iter()
        .map(|b| {
            let frame_id = &frames[b.frame].frame_id;
            let mut e = entity(format!("inertia/{}", b.name), frame_id, timestamp);
            e.spheres.push(sphere(
                &b.link_from_principal,
                2.0 * b.inertia_ellipsoid_radii(),
                INERTIA_COLOR,
            ));
            e
        })
        .collect();
    SceneUpdate {
        deletions: Vec::new(),
        entities,
    }
}

/// The ground's entity of `/scene` (module doc): appended to the frames' entities.
pub fn ground_update(ground: &GroundLayout, timestamp: Timestamp) -> SceneUpdate {
    let mut e = entity("ground".to_string(), WORLD_FRAME, timestamp);
    e.cubes.push(CubePrimitive {
        pose: pose(&ground_pose(ground)),
        size: vector3(&ground_size()),
        color: color(GROUND_COLOR),
    });
    SceneUpdate {
        deletions: Vec::new(),
        entities: vec![e],
    }
}

/// Longest head of a force arrow, m (a quarter of the arrow when shorter).
pub const ARROW_HEAD_MAX_M: f64 = 0.05;

/// The arrow of force `force` (N) at `point`, `scale` m per N ([`super::contacts::force_scale`]):
/// its tail at the point, pointing along the force, `|force| · scale` long (head included; at
/// most [`super::contacts::ARROW_MAX_M`], [`super::contacts::arrow_vector`]); `None` for a zero
/// or non-finite force.
pub fn force_arrow(
    point: &nalgebra::Vector3<f64>,
    force: &nalgebra::Vector3<f64>,
    scale: f64,
) -> Option<ArrowPrimitive> {
    let length = super::contacts::arrow_vector(force, scale).norm();
    if !(length.is_finite() && length > 0.0) {
        return None;
    }
    let x = nalgebra::Vector3::x();
    let rotation = nalgebra::UnitQuaternion::rotation_between(&x, force).unwrap_or_else(|| {
        // Along −x: half a turn about z.
        nalgebra::UnitQuaternion::from_axis_angle(
            &nalgebra::Vector3::z_axis(),
            std::f64::consts::PI,
        )
    });
    let head = (0.25 * length).min(ARROW_HEAD_MAX_M);
    Some(ArrowPrimitive {
        pose: pose(&Isometry3::from_parts(Translation3::from(*point), rotation)),
        shaft_length: length - head,
        shaft_diameter: 2.0 * SHAFT_RADIUS_M,
        head_length: head,
        head_diameter: 4.0 * SHAFT_RADIUS_M,
        color: color(FORCE_COLOR),
    })
}

/// Metadata key of the `/contacts/scene` entity holding the arrows' scale, m per N.
pub const FORCE_SCALE_KEY: &str = "force_scale_m_per_n";

/// The `/contacts/scene` message of one recorded step (module doc).
pub fn contacts_update<'a>(
    contacts: impl Iterator<Item = &'a ContactState>,
    scale: f64,
    timestamp: Timestamp,
) -> SceneUpdate {
    let mut e = entity("contacts".to_string(), WORLD_FRAME, timestamp);
    e.frame_locked = false;
    e.metadata.push(KeyValuePair {
        key: FORCE_SCALE_KEY.into(),
        value: format!("{scale:e}"),
    });
    for c in contacts {
        e.spheres.push(sphere(
            &Isometry3::from_parts(Translation3::from(c.point_world), Default::default()),
            nalgebra::Vector3::repeat(2.0 * POINT_RADIUS_M),
            POINT_COLOR,
        ));
        e.arrows
            .extend(force_arrow(&c.point_world, &c.force_world, scale));
    }
    SceneUpdate {
        deletions: Vec::new(),
        entities: vec![e],
    }
}
