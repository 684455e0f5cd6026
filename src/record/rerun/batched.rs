//! The big-scene layout of the Rerun recording: every copy of a shape in one entity.
//!
//! Rerun keeps per entity a set of chunks, columns and their indexes, in the viewer and in the
//! `.rrd` footer (a manifest row per chunk and column): the per-body layout of [`super`]
//! (an entity per link frame, per visual, per ellipsoid, two per-body plots) has about six
//! entities per body, so 10 000 bodies make 60 000 entities: the footer overflows the
//! flatbuffer verifier's table limit (`TooManyTables`, the file is lost) and the viewer crawls.
//! Rerun's guidance for many objects is to log them as batches in few entities; above
//! [`BATCHED_MIN_FRAMES`] link frames the sink does that:
//!
//! | entity                                               | archetypes | time |
//! |------------------------------------------------------|------------|------|
//! | `/<group>/visual_geometries/<link>/<visual>`         | the shape at its own origin (`Boxes3D`, `Ellipsoids3D`, `Cylinders3D`, `Capsules3D`, `Asset3D`, `Mesh3D`) | static |
//! | same                                                 | `InstancePoses3D`: one pose `world_from_visual` per member frame (f32 translation, quaternion xyzw; mesh scale) | both timelines |
//! | `/<group>/inertia/<link>`                            | `Ellipsoids3D` (equivalent uniform ellipsoid, wireframe) | static |
//! | same                                                 | `InstancePoses3D`: `world_from_principal` of every member body | both timelines |
//! | `/plots/scene/...`                                   | as in the per-body layout | both timelines |
//!
//! A *group* is the set of link frames with the same link name and identical visual geometry
//! (every copy of a `[[model]]`, and every table using the same URDF): each visual of the group
//! is drawn once per member by instancing ("if there are more instance poses than boxes, the
//! last box is repeated", Rerun's `Boxes3D` documentation; the same for the other shapes and
//! meshes). Bodies with the same mass properties in a group share an ellipsoid entity. The
//! group's name is its first frame's model label, with a copy index `_<digits>` removed when
//! the group has more than one member (`box_0000` → `box`); a second group with the same
//! name and link gets `_2`, `_3`, ... There are no named link frames, no per-body plots and no
//! `Transform3D` in this layout: the poses of a single copy are in the MCAP file (`/tf`), the
//! per-body series in `/bodies`. Entities are in member order, so the bytes depend on the
//! layout and the frames alone, as in the per-body layout.

use super::values::{f32x3, quat_xyzw};
use crate::record::{BodyLayout, Frame, FrameLayout, RecordingLayout};
use nalgebra::Isometry3;
use rerun::{EntityPath, EntityPathPart};
use std::collections::{BTreeSet, HashMap};

/// Recordings with more link frames than this use the batched layout.
pub const BATCHED_MIN_FRAMES: usize = 256;

/// Bytes of buffered poses per batch sent (see [`Batches::rows_per_send`]).
pub const BATCHED_SEND_BYTES: usize = 4 << 20;

/// Whether `layout` is recorded in the batched layout.
pub fn is_batched(layout: &RecordingLayout) -> bool {
    layout.frames.len() > BATCHED_MIN_FRAMES
}

/// What one batched entity holds.
#[derive(Debug, Clone, PartialEq)]
pub enum Content {
    /// Visual `index` of the group's link.
    Visual { index: usize },
    /// The inertia ellipsoid of the group's bodies with these mass properties.
    Inertia { body: usize },
}

/// One entity holding every instance of a shape.
#[derive(Debug, Clone)]
pub struct Batch {
    pub entity: EntityPath,
    /// A frame of the group (whose visuals or body describe the shape).
    pub first_frame: usize,
    pub content: Content,
    /// The member frames: one instance each, at `world_from_link · offset`.
    pub frames: Vec<u32>,
    /// The instance's pose in its link frame (visual origin, or principal frame); `None`: identity.
    pub offset: Option<Isometry3<f64>>,
    /// Mesh scale, sent with every pose (an `InstancePoses3D` row replaces the whole pose).
    pub scale: Option<[f32; 3]>,
}

/// The batched entities and their buffered poses.
pub struct Batches {
    pub list: Vec<Batch>,
    /// Per batch, per buffered row and member: translation, quaternion xyzw (f32).
    pub translations: Vec<Vec<[f32; 3]>>,
    pub quaternions: Vec<Vec<[f32; 4]>>,
    /// Rows to buffer before sending (about [`BATCHED_SEND_BYTES`]).
    pub rows_per_send: usize,
}

fn entity(parts: &[&str]) -> EntityPath {
    EntityPath::new(parts.iter().map(|p| EntityPathPart::new(*p)).collect())
}

/// `label` without a trailing `_<digits>`.
fn without_copy_index(label: &str) -> &str {
    match label.rsplit_once('_') {
        Some((base, index))
            if !base.is_empty()
                && !index.is_empty()
                && index.bytes().all(|b| b.is_ascii_digit()) =>
        {
            base
        }
        _ => label,
    }
}

/// The shapes of frames: two frames have the same shape when their link names and their visuals
/// (compared by their full `Debug` text, every field and digit) are equal. The visuals' text is
/// made once per shared list (the copies of a model share one `Arc`), not once per frame: at
/// 10 000 copies that text was a fifth of `simulate`'s start-up.
#[derive(Default)]
struct ShapeKeys {
    /// A visual list's text id, by the list's address.
    by_list: HashMap<*const crate::model::Visual, usize>,
    /// Text ids by text.
    by_text: HashMap<String, usize>,
}

impl ShapeKeys {
    /// The key of `frame`'s shape: its link name and its visuals' text id.
    fn key<'a>(&mut self, frame: &'a FrameLayout) -> (&'a str, usize) {
        let list = frame.visuals.as_ptr();
        let next = self.by_text.len();
        let id = *self.by_list.entry(list).or_insert_with(|| {
            *self
                .by_text
                .entry(format!("{:?}", frame.visuals))
                .or_insert(next)
        });
        (frame.link.as_str(), id)
    }
}

/// A stable text key of a body's ellipsoid.
fn inertia_key(body: &BodyLayout) -> String {
    format!(
        "{:?}{:?}{:?}",
        body.mass, body.principal_moments, body.link_from_principal
    )
}

impl Batches {
    /// Groups `layout`'s frames and bodies (see the module doc); `ellipsoids` adds the inertia
    /// entities.
    pub fn new(layout: &RecordingLayout, ellipsoids: bool) -> Self {
        // Groups in order of their first frame.
        let mut shapes = ShapeKeys::default();
        let mut group_of: HashMap<(&str, usize), usize> = HashMap::new();
        let mut groups: Vec<Vec<u32>> = Vec::new();
        let mut frame_group = Vec::with_capacity(layout.frames.len());
        for (i, frame) in layout.frames.iter().enumerate() {
            let next = groups.len();
            let g = *group_of.entry(shapes.key(frame)).or_insert(next);
            if g == next {
                groups.push(Vec::new());
            }
            groups[g].push(i as u32);
            frame_group.push(g);
        }
        let mut used = BTreeSet::new();
        let names: Vec<String> = groups
            .iter()
            .map(|members| {
                let frame = &layout.frames[members[0] as usize];
                let base = if members.len() > 1 {
                    without_copy_index(&frame.model)
                } else {
                    frame.model.as_str()
                };
                let mut name = base.to_string();
                let mut k = 1;
                while !used.insert((name.clone(), frame.link.clone())) {
                    k += 1;
                    name = format!("{base}_{k}");
                }
                name
            })
            .collect();
        let mut list = Vec::new();
        for (g, members) in groups.iter().enumerate() {
            let first = members[0] as usize;
            let frame = &layout.frames[first];
            let mut leaves = BTreeSet::new();
            for (index, visual) in frame.visuals.iter().enumerate() {
                let mut leaf = match &visual.name {
                    Some(name) if !name.is_empty() => name.clone(),
                    _ => format!("visual_{index}"),
                };
                if !leaves.insert(leaf.clone()) {
                    leaf = format!("{leaf}_{index}");
                    leaves.insert(leaf.clone());
                }
                let scale = match &visual.geometry {
                    crate::model::Geometry::Mesh { scale, .. } => {
                        Some([scale.x as f32, scale.y as f32, scale.z as f32])
                    }
                    _ => None,
                };
                let origin = visual.link_from_visual;
                list.push(Batch {
                    entity: entity(&[&names[g], "visual_geometries", &frame.link, &leaf]),
                    first_frame: first,
                    content: Content::Visual { index },
                    frames: members.clone(),
                    offset: (origin != Isometry3::identity()).then_some(origin),
                    scale,
                });
            }
        }
        if ellipsoids {
            // Per group, bodies with the same mass properties share an entity, in body order.
            let mut batch_of: HashMap<(usize, String), usize> = HashMap::new();
            let mut per_group: HashMap<usize, usize> = HashMap::new();
            for (b, body) in layout.bodies.iter().enumerate() {
                let g = frame_group[body.frame];
                let key = (g, inertia_key(body));
                let index = match batch_of.get(&key) {
                    Some(&index) => index,
                    None => {
                        let count = per_group.entry(g).or_insert(0);
                        *count += 1;
                        let link = &layout.frames[body.frame].link;
                        let leaf = match *count {
                            1 => link.clone(),
                            k => format!("{link}_{k}"),
                        };
                        list.push(Batch {
                            entity: entity(&[&names[g], "inertia", &leaf]),
                            first_frame: body.frame,
                            content: Content::Inertia { body: b },
                            frames: Vec::new(),
                            offset: Some(body.link_from_principal),
                            scale: None,
                        });
                        batch_of.insert(key, list.len() - 1);
                        list.len() - 1
                    }
                };
                list[index].frames.push(body.frame as u32);
            }
        }
        let instances: usize = list.iter().map(|b| b.frames.len()).sum();
        let rows_per_send = (BATCHED_SEND_BYTES / (28 * instances.max(1) + 64)).clamp(1, 4096);
        let n = list.len();
        Self {
            list,
            translations: vec![Vec::new(); n],
            quaternions: vec![Vec::new(); n],
            rows_per_send,
        }
    }

    /// Appends the poses of `frame` (one row per batch).
    pub fn push(&mut self, frame: &Frame<'_>) {
        for (b, batch) in self.list.iter().enumerate() {
            let (t, q) = (&mut self.translations[b], &mut self.quaternions[b]);
            // A batch's buffers go to the columns whole ([`pose_columns`]): sized here once
            // for the rows of a send.
            if t.capacity() == 0 {
                t.reserve_exact(self.rows_per_send * batch.frames.len());
                q.reserve_exact(self.rows_per_send * batch.frames.len());
            }
            t.reserve(batch.frames.len());
            q.reserve(batch.frames.len());
            for &f in &batch.frames {
                let world_from_link = &frame.world_from_link[f as usize];
                let pose = match &batch.offset {
                    Some(offset) => world_from_link * offset,
                    None => *world_from_link,
                };
                t.push(f32x3(&pose.translation.vector));
                q.push(quat_xyzw(&pose));
            }
        }
    }

    pub fn clear(&mut self) {
        for v in &mut self.translations {
            v.clear();
        }
        for v in &mut self.quaternions {
            v.clear();
        }
    }
}

/// The `InstancePoses3D` columns of batch `b`'s buffered `rows` rows (translations,
/// quaternions, and the mesh scale when there is one), `batch.frames.len()` instances per row.
/// The buffers move into the columns (Arrow takes a `Vec` without a copy), leaving batch `b`
/// empty.
///
/// The component arrays are built straight from the buffered f32 values: a
/// `FixedSizeList<Float32>` of 3 (translations, scales) or 4 (quaternions) per instance, the
/// data types of `Translation3D`, `RotationQuat` and `Scale3D` (`Vec3D`, `Quaternion`: checked
/// against rerun's own in the tests). Rerun's generic serialisation of the same values (an
/// iterator over every float of every instance) was a third of the Rerun thread's time at 10 000
/// bodies; the values and the columns are the same.
pub fn pose_columns(
    batches: &mut Batches,
    b: usize,
    rows: usize,
) -> anyhow::Result<Vec<rerun::SerializedComponentColumn>> {
    let batch = &batches.list[b];
    let per_row = batch.frames.len();
    anyhow::ensure!(
        batches.translations[b].len() == rows * per_row,
        "batch {b}: {} poses buffered for {rows} rows of {per_row}",
        batches.translations[b].len()
    );
    let lengths = || std::iter::repeat_n(per_row, rows);
    let translations = std::mem::take(&mut batches.translations[b]).into_flattened();
    let quaternions = std::mem::take(&mut batches.quaternions[b]).into_flattened();
    let mut columns = vec![
        f32_lists(
            translations,
            3,
            rerun::InstancePoses3D::descriptor_translations(),
        )
        .partitioned(lengths())?,
        f32_lists(
            quaternions,
            4,
            rerun::InstancePoses3D::descriptor_quaternions(),
        )
        .partitioned(lengths())?,
    ];
    if let Some(scale) = batch.scale {
        let scales: Vec<f32> = std::iter::repeat_n(scale, rows * per_row)
            .flatten()
            .collect();
        columns.push(
            f32_lists(scales, 3, rerun::InstancePoses3D::descriptor_scales())
                .partitioned(lengths())?,
        );
    }
    Ok(columns)
}

/// `values` as a component batch of fixed-size lists of `size` f32 (non-null items named
/// `item`, the layout of Rerun's `Vec3D` and `Quaternion` data types).
fn f32_lists(
    values: Vec<f32>,
    size: i32,
    descriptor: rerun::ComponentDescriptor,
) -> rerun::SerializedComponentBatch {
    use rerun::external::arrow::array::{FixedSizeListArray, Float32Array};
    use rerun::external::arrow::datatypes::{DataType, Field};
    use std::sync::Arc;
    let item = Arc::new(Field::new("item", DataType::Float32, false));
    let array = FixedSizeListArray::new(item, size, Arc::new(Float32Array::from(values)), None);
    rerun::SerializedComponentBatch::new(Arc::new(array), descriptor)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The columns built from the f32 values are those Rerun's own serialisation makes of the
    /// same poses (data types, descriptors, row partition, values), with and without a scale.
    #[test]
    fn pose_columns_are_rerun_s_own() {
        use rerun::external::arrow::array::Array;
        let translations = vec![
            [1.0, 2.0, 3.0],
            [4.0, 5.0, -6.5],
            [7.0, 8.0, 9.0],
            [0.0, -0.0, 1e-30],
        ];
        let quaternions = vec![
            [0.0, 0.0, 0.0, 1.0],
            [0.5, 0.5, 0.5, 0.5],
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 0.6, 0.0, 0.8],
        ];
        for scale in [None, Some([2.0f32, 3.0, 4.0])] {
            let mut batches = Batches {
                list: vec![Batch {
                    entity: entity(&["a", "b"]),
                    first_frame: 0,
                    content: Content::Visual { index: 0 },
                    frames: vec![0, 1],
                    offset: None,
                    scale,
                }],
                translations: vec![translations.clone()],
                quaternions: vec![quaternions.clone()],
                rows_per_send: 2,
            };
            let ours = pose_columns(&mut batches, 0, 2).unwrap();
            assert!(batches.translations[0].is_empty() && batches.quaternions[0].is_empty());
            assert!(
                pose_columns(&mut batches, 0, 2).is_err(),
                "rows without poses"
            );
            let mut poses = rerun::InstancePoses3D::update_fields()
                .with_translations(translations.iter().copied())
                .with_quaternions(quaternions.iter().map(|q| rerun::Quaternion::from_xyzw(*q)));
            if let Some(scale) = scale {
                poses = poses.with_scales(std::iter::repeat_n(scale, 4));
            }
            let theirs: Vec<_> = poses.columns(std::iter::repeat_n(2, 2)).unwrap().collect();
            assert_eq!(ours.len(), theirs.len());
            for (a, b) in ours.iter().zip(&theirs) {
                assert_eq!(a.descriptor, b.descriptor);
                assert_eq!(a.list_array.data_type(), b.list_array.data_type());
                assert_eq!(a.list_array.offsets(), b.list_array.offsets());
                assert_eq!(
                    a.list_array.to_data(),
                    b.list_array.to_data(),
                    "{:?}",
                    a.descriptor
                );
            }
        }
    }

    /// A batch's pose buffers are sized for a whole send on the first push after a send (they
    /// move into the columns), so the rows of a send never make them grow again.
    #[test]
    fn pose_buffers_are_sized_for_a_send() {
        let pose = Isometry3::identity();
        let poses = vec![pose; 3];
        let frame = Frame {
            step: 0,
            time_ns: 0,
            world_from_link: &poses,
            bodies: &[],
            joints: &[],
            mechanisms: &[],
            contacts: &[],
        };
        let mut batches = Batches {
            list: vec![Batch {
                entity: entity(&["a"]),
                first_frame: 0,
                content: Content::Visual { index: 0 },
                frames: vec![0, 1, 2],
                offset: None,
                scale: None,
            }],
            translations: vec![Vec::new()],
            quaternions: vec![Vec::new()],
            rows_per_send: 5,
        };
        for _ in 0..2 {
            batches.push(&frame);
            // 5 rows of 3 poses.
            assert_eq!(batches.translations[0].capacity(), 15);
            assert_eq!(batches.quaternions[0].capacity(), 15);
            assert_eq!(batches.translations[0].len(), 3);
            pose_columns(&mut batches, 0, 1).unwrap();
        }
    }

    #[test]
    fn copy_indices_are_removed_from_group_names() {
        assert_eq!(without_copy_index("box_0042"), "box");
        assert_eq!(without_copy_index("my_arm_7"), "my_arm");
        assert_eq!(without_copy_index("box"), "box");
        assert_eq!(without_copy_index("box_"), "box_");
        assert_eq!(without_copy_index("_12"), "_12");
        assert_eq!(without_copy_index("v2_x"), "v2_x");
    }
}
