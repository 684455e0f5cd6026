//! The Rerun series of driven joints ([`crate::record::RecordingLayout::drives`]; none without
//! drives, so a recording of undriven models is the one it was before drives existed), and of
//! the joints held by their limits ([`crate::record::RecordingLayout::limited`]; likewise none
//! without):
//!
//! | entity | `Scalars` (series name) | joints |
//! |---|---|---|
//! | `/plots/joints/effort/<joint>` | [`<joint>`] the effort applied, actuator plus damping, N m or N | every driven joint |
//! | `/plots/joints/position_target/<joint>` | [`<joint> target`] rad or m | position servos |
//! | `/plots/joints/velocity_target/<joint>` | [`<joint> target`] rad/s or m/s | velocity servos |
//! | `/plots/joints/saturated/<joint>` | [`<joint> saturated`] 1 while the effort limit clamps, else 0 | actuators with an effort limit |
//! | `/plots/joints/at_limit/<joint>` | [`<joint> at limit`] 1 while the joint is at a bound of its range, else 0 | joints whose URDF limit is enforced ([`RecordingLayout::limited`]) |
//!
//! Each servo's measured series (its position, or its velocity for a velocity servo) and its
//! target share a colour ([`PALETTE`], in joint order; not when batched), the target drawn wide
//! and translucent. The values are the frame's ([`crate::record::JointState`]). Targets sit in
//! trees of their own rather than under the joint's position entity, so no joint name can
//! collide with a target's path. The blueprint ([`DriveSeries::plot_views`]) draws each position target in
//! the joint positions plot, each velocity servo's velocity and target in a plot of their own,
//! and the efforts in another. With many models ([`super::joints::BATCH_MODELS_MAX`]) each
//! quantity is one entity (`/plots/joints/effort`, ...) with one instance per joint it covers,
//! in layout order (the series names say which).

use super::blueprint::PlotView;
use super::chunks::static_chunk;
use super::paths::named_path;
use super::values::f64c;
use super::writer::ChunkWriter;
use crate::record::{ActuatorLaw, DriveLayout, Frame, JointState, RecordingLayout};
use anyhow::Result;
use rerun::log::Chunk;
use rerun::{EntityPath, TimeColumn};

/// One quantity of the driven joints: which joints it covers, its entities and buffers.
struct Quantity {
    /// The joints (indices into the layout's joints).
    joints: Vec<usize>,
    /// One series name per joint.
    names: Vec<String>,
    /// One entity per joint, or the one batched entity.
    entities: Vec<EntityPath>,
    /// Per entity: the buffered rows' values (batched: one value per joint per row).
    values: Vec<Vec<f64>>,
    value: fn(&JointState) -> f64,
    /// A servo's target (drawn in its joint's colour, [`PALETTE`]).
    is_target: bool,
}

/// Entity of a driven joint's quantity `kind` (`effort`, `position_target`,
/// `velocity_target`, `saturated`, `at_limit`).
pub fn drive_entity_path(kind: &str, joint: &str) -> EntityPath {
    named_path(&["plots", "joints", kind], joint)
}

impl Quantity {
    fn new(
        layout: &RecordingLayout,
        kind: &str,
        covers: fn(&DriveLayout) -> bool,
        suffix: &str,
        value: fn(&JointState) -> f64,
        batched: bool,
    ) -> Self {
        let joints: Vec<usize> = layout
            .drives
            .iter()
            .filter(|d| covers(d))
            .map(|d| d.joint)
            .collect();
        Self::of_joints(layout, joints, kind, suffix, value, batched)
    }

    /// The quantity `kind` of the layout joints `joints` (increasing).
    fn of_joints(
        layout: &RecordingLayout,
        joints: Vec<usize>,
        kind: &str,
        suffix: &str,
        value: fn(&JointState) -> f64,
        batched: bool,
    ) -> Self {
        let names: Vec<String> = joints
            .iter()
            .map(|&j| format!("{}{suffix}", layout.joints[j].name))
            .collect();
        let entities: Vec<EntityPath> = if joints.is_empty() {
            Vec::new()
        } else if batched {
            vec![drive_entity_path(kind, "")]
        } else {
            joints
                .iter()
                .map(|&j| drive_entity_path(kind, &layout.joints[j].name))
                .collect()
        };
        Self {
            values: vec![Vec::new(); entities.len()],
            joints,
            names,
            entities,
            value,
            is_target: suffix == TARGET_SUFFIX,
        }
    }
}

/// Colours of the joints with a target, in layout order, cycled (Tableau 10): a servo's
/// measured series (its position, or its velocity for a velocity servo) and its target share
/// one, the target drawn wider and translucent, the band the joint should follow. Without them
/// the viewer's own colours (from the entity paths) may give both lines the same hue.
const PALETTE: [[u8; 3]; 10] = [
    [31, 119, 180],
    [255, 127, 14],
    [44, 160, 44],
    [214, 39, 40],
    [148, 103, 189],
    [140, 86, 75],
    [227, 119, 194],
    [127, 127, 127],
    [188, 189, 34],
    [23, 190, 207],
];
/// What a target's series name adds to its joint's.
const TARGET_SUFFIX: &str = " target";
/// Opacity and stroke width (UI points) of a target's line.
const TARGET_ALPHA: u8 = 120;
const TARGET_WIDTH: f32 = 3.0;

/// The driven joints' series (module doc).
pub(super) struct DriveSeries {
    batched: bool,
    /// Per joint with a target (sorted by joint): its law and its colour ([`PALETTE`]).
    colours: Vec<(usize, ActuatorLaw, [u8; 3])>,
    effort: Quantity,
    position_target: Quantity,
    velocity_target: Quantity,
    saturated: Quantity,
    at_limit: Quantity,
}

fn has_law(d: &DriveLayout, law: ActuatorLaw) -> bool {
    d.actuator == Some(law)
}

impl DriveSeries {
    /// The series of `layout`'s drives; `batched` as the joint series are.
    pub(super) fn new(layout: &RecordingLayout, batched: bool) -> Self {
        let target = |s: &JointState| f64c(s.target.unwrap_or(f64::NAN));
        let colours = layout
            .drives
            .iter()
            .filter_map(|d| match d.actuator {
                Some(law @ (ActuatorLaw::Position | ActuatorLaw::Velocity)) => Some((d.joint, law)),
                _ => None,
            })
            .enumerate()
            .map(|(k, (joint, law))| (joint, law, PALETTE[k % PALETTE.len()]))
            .collect();
        Self {
            batched,
            colours,
            effort: Quantity::new(layout, "effort", |_| true, "", |s| f64c(s.effort), batched),
            position_target: Quantity::new(
                layout,
                "position_target",
                |d| has_law(d, ActuatorLaw::Position),
                TARGET_SUFFIX,
                target,
                batched,
            ),
            velocity_target: Quantity::new(
                layout,
                "velocity_target",
                |d| has_law(d, ActuatorLaw::Velocity),
                TARGET_SUFFIX,
                target,
                batched,
            ),
            saturated: Quantity::new(
                layout,
                "saturated",
                |d| d.actuator.is_some() && d.effort_limit.is_some(),
                " saturated",
                |s| f64::from(u8::from(s.saturated)),
                batched,
            ),
            at_limit: Quantity::of_joints(
                layout,
                layout.limited.clone(),
                "at_limit",
                " at limit",
                |s| f64::from(u8::from(s.at_limit)),
                batched,
            ),
        }
    }

    fn quantities(&self) -> [&Quantity; 5] {
        [
            &self.effort,
            &self.position_target,
            &self.velocity_target,
            &self.saturated,
            &self.at_limit,
        ]
    }

    fn quantities_mut(&mut self) -> [&mut Quantity; 5] {
        [
            &mut self.effort,
            &mut self.position_target,
            &mut self.velocity_target,
            &mut self.saturated,
            &mut self.at_limit,
        ]
    }

    /// The static series names.
    pub(super) fn static_chunks(&self) -> Result<Vec<Chunk>> {
        let mut chunks = Vec::new();
        for q in self.quantities() {
            if self.batched {
                if let Some(entity) = q.entities.first() {
                    chunks.push(static_chunk(
                        entity.clone(),
                        &[&rerun::SeriesLines::new()
                            .with_names(q.names.iter().map(String::as_str))],
                    )?);
                }
                continue;
            }
            for ((entity, name), &joint) in q.entities.iter().zip(&q.names).zip(&q.joints) {
                let mut lines = rerun::SeriesLines::new().with_names([name.as_str()]);
                if let Some([r, g, b]) = self.colour(joint).filter(|_| q.is_target) {
                    lines = lines
                        .with_colors([rerun::Color::from_unmultiplied_rgba(r, g, b, TARGET_ALPHA)])
                        .with_widths([TARGET_WIDTH]);
                }
                chunks.push(static_chunk(entity.clone(), &[&lines])?);
            }
        }
        Ok(chunks)
    }

    fn colour(&self, joint: usize) -> Option<[u8; 3]> {
        self.colours
            .binary_search_by_key(&joint, |c| c.0)
            .ok()
            .map(|i| self.colours[i].2)
    }

    /// The colour of joint `joint`'s measured series of quantity `law` (its position for a
    /// position servo, its velocity for a velocity servo), when it has a target; `None`
    /// otherwise and when batched (the viewer's own colours then).
    pub(super) fn measured_colour(&self, joint: usize, law: ActuatorLaw) -> Option<rerun::Color> {
        if self.batched {
            return None;
        }
        let i = self.colours.binary_search_by_key(&joint, |c| c.0).ok()?;
        let (_, l, [r, g, b]) = self.colours[i];
        (l == law).then(|| rerun::Color::from_rgb(r, g, b))
    }

    /// Buffers one frame's values (`frame.joints` already checked against the layout).
    pub(super) fn push(&mut self, frame: &Frame<'_>) {
        let batched = self.batched;
        for q in self.quantities_mut() {
            for (k, &j) in q.joints.iter().enumerate() {
                let slot = if batched { 0 } else { k };
                q.values[slot].push((q.value)(&frame.joints[j]));
            }
        }
    }

    /// Sends the buffered rows and clears them.
    pub(super) fn send(
        &mut self,
        rec: &ChunkWriter<'_>,
        times: &dyn Fn() -> [TimeColumn; 2],
        rows: usize,
    ) -> Result<()> {
        if rows == 0 {
            return Ok(());
        }
        let batched = self.batched;
        for q in self.quantities_mut() {
            let per_row = if batched { q.joints.len() } else { 1 };
            for (entity, values) in q.entities.iter().zip(&mut q.values) {
                rec.send_columns(
                    entity.clone(),
                    times(),
                    rerun::Scalars::new(values.iter().copied())
                        .columns(std::iter::repeat_n(per_row, rows))?,
                )?;
                values.clear();
            }
        }
        Ok(())
    }

    /// The query expressions the joint positions plot adds (the position targets).
    pub(super) fn position_plot_contents(&self) -> Vec<String> {
        let q = &self.position_target;
        if q.joints.is_empty() {
            return Vec::new();
        }
        vec![
            format!("+ {}", drive_entity_path("position_target", ""))
                + if self.batched { "" } else { "/**" },
        ]
    }

    /// The blueprint's plots of the drives: the velocity servos' velocities (`velocities`: the
    /// joint velocity entities, one per joint or the one batched) against their targets, and
    /// the efforts.
    pub(super) fn plot_views(&self, velocities: &[EntityPath]) -> Vec<PlotView> {
        let mut views = Vec::new();
        let all = |kind: &str| {
            format!("+ {}", drive_entity_path(kind, "")) + if self.batched { "" } else { "/**" }
        };
        if !self.velocity_target.joints.is_empty() {
            let mut contents: Vec<String> = if self.batched {
                velocities.iter().map(|e| format!("+ {e}")).collect()
            } else {
                self.velocity_target
                    .joints
                    .iter()
                    .map(|&j| format!("+ {}", velocities[j]))
                    .collect()
            };
            contents.push(all("velocity_target"));
            let contents: Vec<&str> = contents.iter().map(String::as_str).collect();
            views.push(PlotView::new(
                "velocity servos: velocity and target (rad/s, m/s)",
                &contents,
            ));
        }
        if !self.effort.joints.is_empty() {
            views.push(PlotView::new(
                "joint efforts, actuator + damping (N m, N)",
                &[all("effort").as_str()],
            ));
        }
        if !self.at_limit.joints.is_empty() {
            views.push(PlotView::new(
                "joints at their limit (1: at a bound of the URDF range)",
                &[all("at_limit").as_str()],
            ));
        }
        views
    }
}
