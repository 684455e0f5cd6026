//! The static part of a recording, written once when the sink is created: the world frame and
//! view coordinates, the metadata, every visual's geometry and every body's inertia ellipsoid
//! (or the batched layout's shapes), and the series names of the plots.

use super::batched::Content;
use super::chunks::{static_batches_chunk, static_chunk};
use super::paths::{BodyTrack, FrameTrack};
use super::paths::{
    ENERGY_SERIES, angular_momentum_entity_path, energy_entity_path, entity, inertia_entity_path,
    scene_angmom_change_entity_path, scene_energy_change_entity_path, scene_energy_entity_path,
    transform_entity_path, visual_entity_path,
};
use super::sink::{RerunOptions, RerunSink};
use super::values::{color, f32x3, quat_xyzw};
use crate::model::geometry::mesh::TriangleMesh;
use crate::model::{Geometry, Visual};
use crate::record::names::WORLD_FRAME;
use crate::record::{BodyLayout, FrameLayout, RecordingLayout};
use anyhow::{Context, Result, anyhow, bail};
use nalgebra::Isometry3;
use rerun::{AsComponents, EntityPath, EntityPathPart, SerializedComponentBatch};
use std::collections::BTreeSet;

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

/// How far a link frame's visual geometry reaches from its origin, m
/// ([`FrameLayout::reach`]).
pub(super) fn frame_reach(frame: &FrameLayout) -> f64 {
    frame.reach()
}

impl RerunSink {
    pub(super) fn write_layout(
        &mut self,
        layout: &RecordingLayout,
        options: &RerunOptions,
    ) -> Result<()> {
        self.send(static_chunk(
            EntityPath::root(),
            &[
                &rerun::CoordinateFrame::new(WORLD_FRAME),
                &rerun::ViewCoordinates::RIGHT_HAND_Z_UP(),
            ],
        )?)?;
        self.write_metadata(layout)?;
        for chunk in self.contacts.static_chunks(layout)? {
            self.send(chunk)?;
        }
        if self.batched.is_some() {
            self.write_batched_layout(layout)?;
            return self.write_scene_plot_names(layout);
        }

        let mut used = BTreeSet::new();
        for (frame_index, frame) in layout.frames.iter().enumerate() {
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
                if self.write_visual(entity.clone(), frame, visual)? {
                    self.note_robot_visual(frame_index, entity);
                }
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

    /// The static part of the batched layout: each batch's shape ([`super::batched`]).
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

    /// Keeps `entity`, a visual drawn in frame `frame_index`, as the one the 3D view tracks
    /// when it is the robot's root frame's first visual (or, until one is, the first visual of
    /// the robot's frames).
    fn note_robot_visual(&mut self, frame_index: usize, entity: EntityPath) {
        let Some(robot) = &mut self.robot else {
            return;
        };
        let tracked_is_root = robot.tracked.as_ref().is_some_and(|_| robot.root_tracked);
        if tracked_is_root {
            return;
        }
        if frame_index == robot.root {
            robot.tracked = Some(entity);
            robot.root_tracked = true;
        } else if robot.tracked.is_none() && robot.frames.contains(&frame_index) {
            robot.tracked = Some(entity);
        }
    }

    /// Writes a visual's static chunk; `false` when it cannot be shown (a warning says why).
    fn write_visual(
        &mut self,
        entity: EntityPath,
        frame: &FrameLayout,
        visual: &Visual,
    ) -> Result<bool> {
        let Some(shape) = self.visual_shape(&entity, visual)? else {
            return Ok(false);
        };
        let frame_id = rerun::CoordinateFrame::new(frame.frame_id.as_str());
        let pose = instance_pose(&visual.link_from_visual, shape.scale);
        let mut batches = frame_id.as_serialized_batches();
        batches.extend(pose.as_serialized_batches());
        batches.extend(shape.batches);
        self.send(static_batches_chunk(entity, batches)?)?;
        Ok(true)
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
}
