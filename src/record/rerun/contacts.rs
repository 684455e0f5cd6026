//! The ground and the contacts in a Rerun recording (issue 31; nothing without them, so a
//! recording of a run without contact is the one it was before contact existed):
//!
//! | entity | archetypes | time |
//! |---|---|---|
//! | `/world/ground` | `CoordinateFrame("world")`, `Boxes3D`: the slab of [`crate::record::contacts::ground_pose`] ([`crate::record::contacts::GROUND_SIZE_M`] square, [`crate::record::contacts::GROUND_THICKNESS_M`] thick, its top face the ground's surface), grey | static |
//! | `/world/contacts/points` | `Points3D`: the contact points of the step that ended at the row's time (m), red; `CoordinateFrame("world")`, radius and colour static | both timelines |
//! | `/world/contacts/forces` | `Arrows3D`: from each contact point, the force on body `a` times [`crate::record::contacts::force_scale`] (m per N: the median model's weight is [`crate::record::contacts::REFERENCE_ARROW_M`] long; at most [`crate::record::contacts::ARROW_MAX_M`]), yellow; `CoordinateFrame("world")`, radius and colour static | both timelines |
//!
//! Every recorded row holds the step's list, empty when nothing touches (so the viewer shows
//! no stale contact). The values are the frame's ([`crate::record::ContactState`]), as f32.

use super::chunks::static_chunk;
use super::paths::entity;
use super::values::f32x3;
use super::writer::ChunkWriter;
use crate::record::contacts::{
    FORCE_COLOR, GROUND_COLOR, POINT_COLOR, POINT_RADIUS_M, SHAFT_RADIUS_M, arrow_vector,
    force_scale, ground_pose, ground_size,
};
use crate::record::names::WORLD_FRAME;
use crate::record::{Frame, RecordingLayout};
use anyhow::Result;
use rerun::log::Chunk;
use rerun::{EntityPath, TimeColumn};

/// Entity of the ground: `/world/ground`.
pub fn ground_entity_path() -> EntityPath {
    entity(&["world", "ground"])
}

/// Entity of the contact points: `/world/contacts/points`.
pub fn contact_points_entity_path() -> EntityPath {
    entity(&["world", "contacts", "points"])
}

/// Entity of the contact force arrows: `/world/contacts/forces`.
pub fn contact_forces_entity_path() -> EntityPath {
    entity(&["world", "contacts", "forces"])
}

fn rgba(c: [f64; 4]) -> rerun::Rgba32 {
    rerun::Rgba32::from_linear_unmultiplied_rgba_f32(
        c[0] as f32,
        c[1] as f32,
        c[2] as f32,
        c[3] as f32,
    )
}

/// The contacts' buffered rows (module doc).
pub(super) struct ContactSeries {
    /// Whether the run can have contacts (else nothing is buffered or sent).
    enabled: bool,
    /// m per N.
    scale: f64,
    /// Per row: how many contacts.
    counts: Vec<usize>,
    points: Vec<[f32; 3]>,
    vectors: Vec<[f32; 3]>,
}

impl ContactSeries {
    pub(super) fn new(layout: &RecordingLayout) -> Self {
        Self {
            enabled: layout.contacts,
            scale: force_scale(layout),
            counts: Vec::new(),
            points: Vec::new(),
            vectors: Vec::new(),
        }
    }

    /// The static chunks: the ground, and the contacts' frame, radii and colours.
    pub(super) fn static_chunks(&self, layout: &RecordingLayout) -> Result<Vec<Chunk>> {
        let mut chunks = Vec::new();
        let world = rerun::CoordinateFrame::new(WORLD_FRAME);
        if let Some(ground) = &layout.ground {
            let pose = ground_pose(ground);
            let q = pose.rotation.quaternion().coords;
            chunks.push(static_chunk(
                ground_entity_path(),
                &[
                    &world,
                    &rerun::Boxes3D::from_centers_and_sizes(
                        [f32x3(&pose.translation.vector)],
                        [f32x3(&ground_size())],
                    )
                    .with_quaternions([rerun::Quaternion::from_xyzw([
                        q.x as f32, q.y as f32, q.z as f32, q.w as f32,
                    ])])
                    .with_colors([rgba(GROUND_COLOR)])
                    .with_fill_mode(rerun::FillMode::Solid),
                ],
            )?);
        }
        if self.enabled {
            chunks.push(static_chunk(
                contact_points_entity_path(),
                &[
                    &world,
                    &rerun::Points3D::update_fields()
                        .with_radii([POINT_RADIUS_M as f32])
                        .with_colors([rgba(POINT_COLOR)]),
                ],
            )?);
            chunks.push(static_chunk(
                contact_forces_entity_path(),
                &[
                    &world,
                    &rerun::Arrows3D::update_fields()
                        .with_radii([SHAFT_RADIUS_M as f32])
                        .with_colors([rgba(FORCE_COLOR)]),
                ],
            )?);
        }
        Ok(chunks)
    }

    /// Buffers one frame's contacts.
    pub(super) fn push(&mut self, frame: &Frame<'_>) {
        if !self.enabled {
            return;
        }
        self.counts.push(frame.contacts.len());
        for c in frame.contacts {
            self.points.push(f32x3(&c.point_world));
            self.vectors
                .push(f32x3(&arrow_vector(&c.force_world, self.scale)));
        }
    }

    /// Sends the buffered rows and clears them.
    pub(super) fn send(
        &mut self,
        rec: &ChunkWriter<'_>,
        times: &dyn Fn() -> [TimeColumn; 2],
    ) -> Result<()> {
        if !self.enabled || self.counts.is_empty() {
            return Ok(());
        }
        rec.send_columns(
            contact_points_entity_path(),
            times(),
            rerun::Points3D::update_fields()
                .with_positions(self.points.iter().copied())
                .columns(self.counts.iter().copied())?,
        )?;
        rec.send_columns(
            contact_forces_entity_path(),
            times(),
            rerun::Arrows3D::update_fields()
                .with_origins(self.points.iter().copied())
                .with_vectors(self.vectors.iter().copied())
                .columns(self.counts.iter().copied())?,
        )?;
        self.counts.clear();
        self.points.clear();
        self.vectors.clear();
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entity_paths_are_the_documented_ones() {
        assert_eq!(ground_entity_path().to_string(), "/world/ground");
        assert_eq!(
            contact_points_entity_path().to_string(),
            "/world/contacts/points"
        );
        assert_eq!(
            contact_forces_entity_path().to_string(),
            "/world/contacts/forces"
        );
    }
}
