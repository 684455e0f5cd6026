//! The Rerun series of articulated models (recorded only when the layout has them):
//!
//! | entity | `Scalars` (series names, static `SeriesLines`) |
//! |---|---|
//! | `/plots/joints/position/<joint>` | [position] rad or m (continuous joints unwrapped) |
//! | `/plots/joints/velocity/<joint>` | [velocity] rad/s or m/s |
//! | `/plots/mechanisms/<model>/energy` | [kinetic, potential, total] J |
//! | `/plots/mechanisms/<model>/energy_change` | [(E − E₀)/\|E₀\|] |
//! | `/plots/mechanisms/<model>/linear_momentum` | [x, y, z] kg m/s, world |
//! | `/plots/mechanisms/<model>/angular_momentum` | [x, y, z] kg m²/s about the model's centre of mass, world |
//! | `/plots/mechanisms/<model>/constraint_residual` | [gap (m), misalignment (rad)] |
//!
//! `<joint>` and `<model>` are the layout's names split at `/` (one path part each), as for
//! bodies. Driven joints add their effort, target and saturation series ([`super::drives`]).
//!
//! **Many models** (more than [`BATCH_MODELS_MAX`], e.g. `copies = 1000` of a robot): an entity
//! per joint and per model series made Rerun's start-up, chunk store and footer cost about 4 ms
//! per copy (1000 double pendulums: 4.0 s and 218 MB before the first step), and a blueprint of
//! two plots per model. Then the series are batched, one entity per quantity with one instance
//! per joint or model, in layout order (the series names say which):
//!
//! | entity | instances (series names) |
//! |---|---|
//! | `/plots/joints/position`, `/plots/joints/velocity` | one per joint (`<joint>`) |
//! | `/plots/mechanisms/<series>` (the five above) | per model, its values (`<model> <value name>`) |
//!
//! and the blueprint has three plots: all joint positions, every model's energy change, every
//! model's constraint residual. The values are the frame's: projected momenta, joint coordinates read back from the
//! poses ([`crate::sim::mechanism::project`]). With articulated models, the scene's angular
//! momentum change plot (`/plots/scene/angular_momentum_change`) is taken over the quantities
//! that are conserved: every free body's angular momentum and every floating model's total
//! (a mechanism's bodies exchange momentum through their joints; a fixed base takes some).

use super::blueprint::PlotView;
use super::chunks::static_chunk;
use super::drives::DriveSeries;
use super::paths::{ENERGY_SERIES, named_path as path};
use super::values::nonzero;
use super::writer::ChunkWriter;
use crate::record::{ActuatorLaw, Frame, RecordingLayout};
use anyhow::Result;
use rerun::log::Chunk;
use rerun::{EntityPath, EntityPathPart, TimeColumn};

/// Entity of a joint's position series.
pub fn joint_position_entity_path(joint: &str) -> EntityPath {
    path(&["plots", "joints", "position"], joint)
}

/// Entity of a joint's velocity series.
pub fn joint_velocity_entity_path(joint: &str) -> EntityPath {
    path(&["plots", "joints", "velocity"], joint)
}

/// Entity of one of a model's series (`energy`, `energy_change`, `linear_momentum`,
/// `angular_momentum`, `constraint_residual`).
pub fn mechanism_entity_path(model: &str, series: &str) -> EntityPath {
    let mut p = path(&["plots", "mechanisms"], model);
    p = p.join(&EntityPath::new(vec![EntityPathPart::new(series)]));
    p
}

/// The model series, their names, values per row.
const MECHANISM_SERIES: [(&str, &[&str]); 5] = [
    ("energy", &ENERGY_SERIES),
    ("energy_change", &["(E − E₀)/|E₀|"]),
    ("linear_momentum", &["x", "y", "z"]),
    ("angular_momentum", &["x", "y", "z"]),
    ("constraint_residual", &["gap (m)", "misalignment (rad)"]),
];

/// Above this many articulated models the series are batched (module doc).
pub const BATCH_MODELS_MAX: usize = 16;

/// Buffered columns and entities of the articulated series.
pub(super) struct JointPlots {
    /// One entity per quantity (module doc); the buffers then hold one `[joint]` (`[model]`)
    /// vector per row, in `position[0]`, `velocity[0]` and `series[0][i]`.
    batched: bool,
    /// Per model: its name (for the batched series names).
    model_names: Vec<String>,
    /// The joints' recorded names: their series' names, so a plot of several joints tells
    /// them apart in the legend.
    names: Vec<String>,
    positions: Vec<EntityPath>,
    velocities: Vec<EntityPath>,
    /// Per model, per [`MECHANISM_SERIES`] entry: the entity.
    models: Vec<Vec<EntityPath>>,
    /// Per model: its bodies (batch indices) and whether its base floats.
    model_bodies: Vec<(std::ops::Range<usize>, bool)>,
    /// `[joint]` values of the buffered rows.
    position: Vec<Vec<f64>>,
    velocity: Vec<Vec<f64>>,
    /// `[model][series]` flattened values of the buffered rows.
    series: Vec<Vec<Vec<f64>>>,
    energy0: Vec<Option<f64>>,
    in_mechanism: Vec<bool>,
    /// The driven joints' series ([`super::drives`]).
    drives: DriveSeries,
}

impl JointPlots {
    pub(super) fn new(layout: &RecordingLayout) -> Self {
        let mut in_mechanism = vec![false; layout.bodies.len()];
        for m in &layout.mechanisms {
            for i in m.bodies.clone() {
                if let Some(b) = in_mechanism.get_mut(i) {
                    *b = true;
                }
            }
        }
        let batched = layout.mechanisms.len() > BATCH_MODELS_MAX;
        let (positions, velocities, models) = if batched {
            (
                vec![path(&["plots", "joints", "position"], "")],
                vec![path(&["plots", "joints", "velocity"], "")],
                vec![
                    MECHANISM_SERIES
                        .iter()
                        .map(|(s, _)| path(&["plots", "mechanisms", s], ""))
                        .collect(),
                ],
            )
        } else {
            (
                layout
                    .joints
                    .iter()
                    .map(|j| joint_position_entity_path(&j.name))
                    .collect(),
                layout
                    .joints
                    .iter()
                    .map(|j| joint_velocity_entity_path(&j.name))
                    .collect(),
                layout
                    .mechanisms
                    .iter()
                    .map(|m| {
                        MECHANISM_SERIES
                            .iter()
                            .map(|(s, _)| mechanism_entity_path(&m.name, s))
                            .collect()
                    })
                    .collect::<Vec<Vec<EntityPath>>>(),
            )
        };
        Self {
            batched,
            model_names: layout.mechanisms.iter().map(|m| m.name.clone()).collect(),
            names: layout.joints.iter().map(|j| j.name.clone()).collect(),
            position: vec![Vec::new(); positions.len()],
            velocity: vec![Vec::new(); velocities.len()],
            series: vec![vec![Vec::new(); MECHANISM_SERIES.len()]; models.len()],
            positions,
            velocities,
            models,
            model_bodies: layout
                .mechanisms
                .iter()
                .map(|m| (m.bodies.clone(), m.floating))
                .collect(),
            energy0: vec![None; layout.mechanisms.len()],
            in_mechanism,
            drives: DriveSeries::new(layout, batched),
        }
    }

    pub(super) fn is_empty(&self) -> bool {
        self.positions.is_empty() && self.models.is_empty()
    }

    /// The static series names.
    pub(super) fn static_chunks(&self) -> Result<Vec<Chunk>> {
        let mut chunks = Vec::new();
        if self.batched {
            for entity in [&self.positions[0], &self.velocities[0]] {
                chunks.push(static_chunk(
                    entity.clone(),
                    &[
                        &rerun::SeriesLines::new()
                            .with_names(self.names.iter().map(String::as_str)),
                    ],
                )?);
            }
            for (entity, (_, names)) in self.models[0].iter().zip(MECHANISM_SERIES) {
                let labels: Vec<String> = self
                    .model_names
                    .iter()
                    .flat_map(|m| names.iter().map(move |n| format!("{m} {n}")))
                    .collect();
                chunks.push(static_chunk(
                    entity.clone(),
                    &[&rerun::SeriesLines::new().with_names(labels.iter().map(String::as_str))],
                )?);
            }
            chunks.extend(self.drives.static_chunks()?);
            return Ok(chunks);
        }
        for (j, ((p, v), name)) in self
            .positions
            .iter()
            .zip(&self.velocities)
            .zip(&self.names)
            .enumerate()
        {
            for (entity, law) in [(p, ActuatorLaw::Position), (v, ActuatorLaw::Velocity)] {
                let mut lines = rerun::SeriesLines::new().with_names([name.as_str()]);
                // A servo's measured series in its target's colour ([`super::drives`]).
                if let Some(colour) = self.drives.measured_colour(j, law) {
                    lines = lines.with_colors([colour]);
                }
                chunks.push(static_chunk(entity.clone(), &[&lines])?);
            }
        }
        for entities in &self.models {
            for (entity, (_, names)) in entities.iter().zip(MECHANISM_SERIES) {
                chunks.push(static_chunk(
                    entity.clone(),
                    &[&rerun::SeriesLines::new().with_names(names.iter().copied())],
                )?);
            }
        }
        chunks.extend(self.drives.static_chunks()?);
        Ok(chunks)
    }

    /// Buffers one frame's values. `frame.joints`/`frame.mechanisms` must match the layout.
    pub(super) fn push(&mut self, frame: &Frame<'_>) -> Result<()> {
        if frame.joints.len() != self.names.len()
            || frame.mechanisms.len() != self.model_names.len()
        {
            anyhow::bail!(
                "frame has {} joint and {} model states, the layout {} and {}",
                frame.joints.len(),
                frame.mechanisms.len(),
                self.names.len(),
                self.model_names.len()
            );
        }
        // One buffer per joint (model), or the one batched buffer.
        let batched = self.batched;
        let slot = move |i: usize| if batched { 0 } else { i };
        for (j, s) in frame.joints.iter().enumerate() {
            self.position[slot(j)].push(s.position + 0.0);
            self.velocity[slot(j)].push(s.velocity + 0.0);
        }
        for (k, m) in frame.mechanisms.iter().enumerate() {
            let e = m.kinetic_energy + m.potential_energy;
            let e0 = *self.energy0[k].get_or_insert(e);
            let s = &mut self.series[slot(k)];
            s[0].extend([m.kinetic_energy, m.potential_energy, e]);
            s[1].push((e - e0) / nonzero(e0.abs()) + 0.0);
            s[2].extend(m.linear_momentum.iter().map(|x| x + 0.0));
            s[3].extend(m.angular_momentum.iter().map(|x| x + 0.0));
            s[4].extend([m.residual_m, m.residual_rad]);
        }
        self.drives.push(frame);
        Ok(())
    }

    /// Whether the layout has an angular momentum that is conserved (a floating model or a
    /// body outside the models): without one (fixed-base models only) the scene's angular
    /// momentum change plot would be a meaningless flat line, and the blueprint omits it.
    pub(super) fn conserves_angmom(&self) -> bool {
        self.model_bodies.iter().any(|(_, floating)| *floating)
            || self.in_mechanism.iter().any(|m| !*m)
    }

    /// The angular momenta conserved in this frame (see the module doc).
    pub(super) fn conserved_angmom(&self, frame: &Frame<'_>) -> Vec<nalgebra::Vector3<f64>> {
        let mut out: Vec<_> = self
            .model_bodies
            .iter()
            .zip(frame.mechanisms)
            .filter(|((_, floating), _)| *floating)
            .map(|(_, m)| m.angular_momentum)
            .collect();
        out.extend(
            frame
                .bodies
                .iter()
                .zip(&self.in_mechanism)
                .filter(|(_, m)| !**m)
                .map(|(b, _)| b.angmom_world),
        );
        out
    }

    /// Sends the buffered rows (`times` builds the two time columns) and clears them.
    pub(super) fn send(
        &mut self,
        rec: &ChunkWriter<'_>,
        times: &dyn Fn() -> [TimeColumn; 2],
        rows: usize,
    ) -> Result<()> {
        if rows == 0 {
            return Ok(());
        }
        if self.batched {
            let (joints, models) = (self.names.len(), self.model_names.len());
            for (entity, values) in [
                (&self.positions[0], &mut self.position[0]),
                (&self.velocities[0], &mut self.velocity[0]),
            ] {
                rec.send_columns(
                    entity.clone(),
                    times(),
                    rerun::Scalars::new(values.iter().copied())
                        .columns(std::iter::repeat_n(joints, rows))?,
                )?;
                values.clear();
            }
            for (i, (entity, (_, names))) in self.models[0].iter().zip(MECHANISM_SERIES).enumerate()
            {
                rec.send_columns(
                    entity.clone(),
                    times(),
                    rerun::Scalars::new(self.series[0][i].iter().copied())
                        .columns(std::iter::repeat_n(models * names.len(), rows))?,
                )?;
                self.series[0][i].clear();
            }
            return self.drives.send(rec, times, rows);
        }
        for (j, (p, v)) in self.positions.iter().zip(&self.velocities).enumerate() {
            rec.send_columns(
                p.clone(),
                times(),
                rerun::Scalars::new(self.position[j].iter().copied()).columns_of_unit_batches()?,
            )?;
            rec.send_columns(
                v.clone(),
                times(),
                rerun::Scalars::new(self.velocity[j].iter().copied()).columns_of_unit_batches()?,
            )?;
            self.position[j].clear();
            self.velocity[j].clear();
        }
        for (k, entities) in self.models.iter().enumerate() {
            for (i, (entity, (_, names))) in entities.iter().zip(MECHANISM_SERIES).enumerate() {
                rec.send_columns(
                    entity.clone(),
                    times(),
                    rerun::Scalars::new(self.series[k][i].iter().copied())
                        .columns(std::iter::repeat_n(names.len(), rows))?,
                )?;
                self.series[k][i].clear();
            }
        }
        self.drives.send(rec, times, rows)
    }

    /// The blueprint's plots for articulated models: all joint positions (with the position
    /// servos' targets), the drives' plots ([`super::drives`]), each model's energy change and
    /// constraint residual.
    pub(super) fn plot_views(&self, layout: &RecordingLayout) -> Vec<PlotView> {
        let mut views = Vec::new();
        let targets = self.drives.position_plot_contents();
        let with_targets = |first: &str| -> Vec<String> {
            std::iter::once(first.to_string())
                .chain(targets.iter().cloned())
                .collect()
        };
        let positions_plot = |first: &str| {
            let contents = with_targets(first);
            let contents: Vec<&str> = contents.iter().map(String::as_str).collect();
            PlotView::new(
                if targets.is_empty() {
                    "joint positions (rad, m)"
                } else {
                    "joint positions and targets (rad, m)"
                },
                &contents,
            )
        };
        if self.batched {
            views.push(positions_plot("+ /plots/joints/position"));
            views.extend(self.drives.plot_views(&self.velocities));
            views.push(PlotView::new(
                "every model's energy change (E − E₀)/|E₀|",
                &["+ /plots/mechanisms/energy_change"],
            ));
            views.push(PlotView::new(
                "every model's constraint residual",
                &["+ /plots/mechanisms/constraint_residual"],
            ));
            return views;
        }
        if !self.positions.is_empty() {
            views.push(positions_plot("+ /plots/joints/position/**"));
        }
        views.extend(self.drives.plot_views(&self.velocities));
        for m in &layout.mechanisms {
            let change = format!("+ {}", mechanism_entity_path(&m.name, "energy_change"));
            let residual = format!(
                "+ {}",
                mechanism_entity_path(&m.name, "constraint_residual")
            );
            views.push(PlotView::new(
                &format!("{}: energy change (E − E₀)/|E₀|", m.name),
                &[change.as_str()],
            ));
            views.push(PlotView::new(
                &format!("{}: constraint residual", m.name),
                &[residual.as_str()],
            ));
        }
        views
    }
}
