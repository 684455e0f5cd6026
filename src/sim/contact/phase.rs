//! The contact phase of a step: the contacts at `q_k`, their impulses, applied as the start
//! impulse `f_d⁻` of the discrete Lagrange-d'Alembert principle (`docs/contact.md`).
//!
//! A body's free motion over the step is predicted as the integrators take it in uniform
//! gravity, `c_{k+1} = c_k + h v_k + α h² g` (`α` the scheme's, [`ContactPhase::run`]) and
//! `R_{k+1} = R_k exp(h Ω_k)`; a contact's gap at the end of the step is its gap now plus the
//! normal part of the two material points' displacements, linear in the impulses
//! ([`super::solve`]). The impulses change the linear momenta and the body-frame angular
//! momenta before the integrators step: the step that follows moves the bodies with them.

use super::broad::{Bound, Sweep};
use super::narrow::{self, Prepared, RawContact, Scratch};
use super::robots::Robot;
use super::solve::{self, Group, Response, Responses, Row, SolveStats, contact_frame};
use super::{ContactModel, ContactPoint, GROUND, combine_friction, combine_restitution};
use crate::sim::Bodies;
use crate::sim::integrators::VariationalSettings;
use crate::sim::loads::Loads;
use crate::sim::mechanism::constrained::Impulse6;
use nalgebra::{DMatrix, DVector, Isometry3, Matrix3, Translation3, UnitQuaternion, Vector3};
use rayon::prelude::*;

/// A contact whose gap at the end of the step is at most this, or at most the distance
/// gravity moves a body in one step (`|g| h²`: the linear prediction of a turning body's
/// gap is that far off), is closed: held by the end projection, m.
const CLOSED_M: f64 = 1e-9;

/// The fastest a penetration is pushed out, m/s (see [`ContactPhase::start`]'s targets).
const PUSH_OUT_M_PER_S: f64 = 1.0;

/// Fewest contacts whose rows are set up side by side on the stepping pool (below it the
/// threads' meeting costs more than the set-up).
const MIN_ROWS_ON_POOL: usize = 512;

/// A contact's identity from one step to the next: its colliders and touching features.
type Key = (u32, u32, u64);

/// One body with colliders, as the phase reads it at the start of a step.
#[derive(Debug, Clone, Copy, Default)]
struct Slot {
    com: Vector3<f64>,
    rotation: UnitQuaternion<f64>,
    /// Predicted free pose at the end of the step.
    com_next: Vector3<f64>,
    rotation_next: UnitQuaternion<f64>,
    /// How far a point of the body's colliders can move in the step, m.
    motion_m: f64,
}

/// The contact phase of every step of a batch: its model, the last step's contacts and the
/// energy the impulses changed.
pub struct ContactPhase {
    pub model: ContactModel,
    /// The contacts of the last step with a non-zero impulse.
    pub contacts: Vec<ContactPoint>,
    /// The kinetic energy the impulses changed so far, J.
    pub work: f64,
    /// The last solve.
    pub stats: SolveStats,
    /// Below this approach speed a contact does not bounce, m/s (`2 |g| h`).
    bounce_min: f64,
    /// Stop when no impulse changes by more than this times the largest.
    pub rel_tol: f64,
    /// Sweeps at most.
    pub max_sweeps: u32,
    prepared: Vec<Prepared>,
    /// The bodies with colliders, ascending, and each collider's index among them.
    slot_body: Vec<usize>,
    collider_slot: Vec<usize>,
    slot_reach_m: Vec<f64>,
    slots: Vec<Slot>,
    responses: Responses,
    bounds: Vec<Bound>,
    pairs: Vec<(u32, u32)>,
    sweep: Sweep,
    raw: Vec<RawContact>,
    between: Vec<Between>,
    rows: Vec<Row>,
    /// Per row of the start solve: whether its contact is closed at the end of the step.
    closing: Vec<bool>,
    end_rows: Vec<Row>,
    end_responses: Responses,
    keys: Vec<Key>,
    /// The last step's impulses (world) by contact, sorted by key: the next solve's start.
    previous: Vec<(Key, Vector3<f64>, Vector3<f64>)>,
    scratch: Scratch,
    /// The mechanisms with colliders, and per slot its robot and body there.
    robots: Vec<Robot>,
    slot_robot: Vec<Option<(usize, usize)>>,
    /// The robots' prediction step's settings.
    settings: VariationalSettings,
    /// Per robot: whether one of its bodies touches in this step.
    robot_touches: Vec<bool>,
    /// Per slot: whether one of the step's rows acts on it.
    slot_touches: Vec<bool>,
    /// Rows set up before their warm starts ([`ContactPhase::build_rows`], the end's rows).
    candidates: Vec<Option<Row>>,
}

/// Whom a narrow-phase contact is between: colliders `a` and `b` (`GROUND` for the ground).
#[derive(Debug, Clone, Copy)]
struct Between {
    a: u32,
    b: u32,
}

impl ContactPhase {
    /// The phase of `model` over free bodies and the mechanisms `robots` (those with colliders;
    /// their predictions stepped with `settings`); an error names a collider parry cannot
    /// build.
    pub fn new(
        model: ContactModel,
        robots: Vec<Robot>,
        settings: VariationalSettings,
    ) -> anyhow::Result<Self> {
        let mut prepared = Vec::with_capacity(model.colliders.len());
        for (i, c) in model.colliders.iter().enumerate() {
            prepared.push(Prepared::new(c).ok_or_else(|| {
                anyhow::anyhow!("collider {i} (body {}): not a convex shape", c.body)
            })?);
        }
        let mut slot_body: Vec<usize> = model.colliders.iter().map(|c| c.body).collect();
        slot_body.sort_unstable();
        slot_body.dedup();
        let collider_slot: Vec<usize> = model
            .colliders
            .iter()
            .map(|c| slot_body.binary_search(&c.body).expect("listed"))
            .collect();
        let mut slot_reach_m = vec![0.0f64; slot_body.len()];
        for (p, &s) in prepared.iter().zip(&collider_slot) {
            slot_reach_m[s] = slot_reach_m[s].max(p.reach_m);
        }
        let slot_robot = slot_body
            .iter()
            .map(|&b| {
                robots
                    .iter()
                    .position(|r| r.bodies().contains(&b))
                    .map(|r| (r, b - robots[r].first))
            })
            .collect();
        Ok(Self {
            robot_touches: vec![false; robots.len()],
            slot_touches: vec![false; slot_body.len()],
            candidates: Vec::new(),
            robots,
            slot_robot,
            settings,
            model,
            contacts: Vec::new(),
            work: 0.0,
            stats: SolveStats::default(),
            bounce_min: 0.0,
            rel_tol: 1e-10,
            max_sweeps: 500,
            prepared,
            slots: vec![Slot::default(); slot_body.len()],
            slot_body,
            collider_slot,
            slot_reach_m,
            responses: Responses::default(),
            bounds: Vec::new(),
            pairs: Vec::new(),
            sweep: Sweep::default(),
            raw: Vec::new(),
            between: Vec::new(),
            rows: Vec::new(),
            closing: Vec::new(),
            end_rows: Vec::new(),
            end_responses: Responses::default(),
            keys: Vec::new(),
            previous: Vec::new(),
            scratch: Scratch::default(),
        })
    }

    /// Whether body `i` has colliders.
    pub fn collides(&self, i: usize) -> bool {
        self.slot_body.binary_search(&i).is_ok()
    }

    /// The start of a step: the impulses that keep every gap non-negative at the end of the
    /// step, onto the bodies of `parts` (part `k` holds the bodies from `starts[k]`), for a
    /// step of `dt_secs` under `loads` (the batch's, at the step's start), with the scheme's
    /// free drift `c_{k+1} = c_k + h v_k + alpha h² g` for free bodies and a prediction step
    /// for robots ([`super::robots`]). [`ContactPhase::end`] follows the step.
    pub fn start(
        &mut self,
        parts: &mut [&mut Bodies],
        starts: &[usize],
        dt_secs: f64,
        loads: &Loads,
        alpha: f64,
        pool: Option<&rayon::ThreadPool>,
    ) {
        let h = dt_secs;
        let gravity = *loads.gravity();
        let locate = |i: usize| locate(starts, i);
        // The bodies at the start of the step and their free motion.
        self.responses.clear();
        for (s, &body) in self.slot_body.iter().enumerate() {
            let (k, j) = locate(body);
            let b = &*parts[k];
            let rotation = b.world_from_body[j];
            let omega_body = b.angmom_body[j].component_mul(&b.inv_inertia_body[j]);
            let com = b.com_world[j];
            let v = b.linvel_world[j];
            let rot = rotation.to_rotation_matrix();
            let inv_inertia_world =
                rot * Matrix3::from_diagonal(&b.inv_inertia_body[j]) * rot.transpose();
            self.slots[s] = Slot {
                com,
                rotation,
                com_next: com + v * h + gravity * (alpha * h * h),
                rotation_next: rotation * UnitQuaternion::from_scaled_axis(omega_body * h),
                motion_m: h * (v.norm() + omega_body.norm() * self.slot_reach_m[s])
                    + h * h * gravity.norm(),
            };
            self.responses.bodies.push(match self.slot_robot[s] {
                None => Response::new(1.0 / b.mass[j], inv_inertia_world),
                Some((r, local)) => Response::member(r, local),
            });
        }
        self.find_contacts(h, pool);
        self.robot_groups(parts, true);
        self.build_rows(pool);
        self.predict_robots(parts, starts, h, loads);
        self.free_velocities(h, &gravity);
        self.stats = solve::solve(
            &mut self.rows,
            &mut self.responses,
            self.rel_tol,
            self.max_sweeps,
            pool,
        );
        self.work += self.apply(parts, starts);
        // Which contacts close at the end of the step: those the end projection holds.
        let closed_m = CLOSED_M.max(gravity.norm() * h * h);
        self.closing.clear();
        for row in &self.rows {
            let u = row.velocity(&self.responses);
            let gap_end = self.raw[row.source].gap_m + dt_secs * u.x;
            // A bounce inside the step is held too: its end velocity is set to leave.
            self.closing
                .push(row.lambda.x > 0.0 && (gap_end <= closed_m || row.leave_n > 0.0));
        }
    }

    /// The end of a step (after the integrators moved the bodies of `parts`): the velocity
    /// projection of RATTLE for the contacts that closed, `n · v_rel ≥ 0` at every one of them
    /// under the same friction cone, with sticking contacts brought to rest. Without it a body
    /// resting on the ground would carry the velocity `g h / 2` of the step's second half, and
    /// an impact would not end at the contact (`docs/contact.md`). A robot's velocities are
    /// its projected ones, its response `M_c⁻¹` at the new poses.
    pub fn end(
        &mut self,
        parts: &mut [&mut Bodies],
        starts: &[usize],
        pool: Option<&rayon::ThreadPool>,
    ) {
        let locate = |i: usize| locate(starts, i);
        self.end_rows.clear();
        // The slots the closing rows act on, for the robots' columns.
        for t in self.slot_touches.iter_mut() {
            *t = false;
        }
        for (row, &closing) in self.rows.iter().zip(&self.closing) {
            if closing {
                self.slot_touches[row.a] = true;
                if let Some(b) = row.b {
                    self.slot_touches[b] = true;
                }
            }
        }
        std::mem::swap(&mut self.responses, &mut self.end_responses);
        self.responses.clear();
        let mut velocities = Vec::with_capacity(self.slot_body.len());
        for (s, &body) in self.slot_body.iter().enumerate() {
            let (k, j) = locate(body);
            let b = &*parts[k];
            let rot = b.world_from_body[j].to_rotation_matrix();
            let inv_inertia_world =
                rot * Matrix3::from_diagonal(&b.inv_inertia_body[j]) * rot.transpose();
            self.responses.bodies.push(match self.slot_robot[s] {
                None => Response::new(1.0 / b.mass[j], inv_inertia_world),
                Some((r, local)) => Response::member(r, local),
            });
            velocities.push((b.linvel_world[j], b.angvel_world(j)));
        }
        self.robot_groups(parts, false);
        // A robot's bodies move as its joints let them: the projected velocities.
        let mut twists = Vec::new();
        for (r, robot) in self.robots.iter_mut().enumerate() {
            if !self.robot_touches[r] {
                continue;
            }
            twists.resize(robot.body_count(), (Vector3::zeros(), Vector3::zeros()));
            robot.twists(parts[robot.part], &mut twists);
            for (s, slot_robot) in self.slot_robot.iter().enumerate() {
                if let Some((rr, local)) = slot_robot
                    && *rr == r
                {
                    velocities[s] = twists[*local];
                }
            }
        }
        // The closing rows set up side by side (as the start's, [`ContactPhase::build_rows`]),
        // then warm-started in their order.
        let mut candidates = std::mem::take(&mut self.candidates);
        candidates.clear();
        let this = &*self;
        let make = |i: usize| this.end_row(i, &velocities);
        match pool {
            Some(pool) if self.rows.len() >= MIN_ROWS_ON_POOL => pool
                .install(|| candidates.par_extend((0..this.rows.len()).into_par_iter().map(make))),
            _ => candidates.extend((0..this.rows.len()).map(make)),
        }
        for mut end in candidates.drain(..).flatten() {
            let key = &self.keys[self.rows[end.source].source];
            if let Ok(k) = self.previous.binary_search_by(|p| p.0.cmp(key)) {
                end.warm_start(&self.previous[k].2, &mut self.responses);
            }
            self.end_rows.push(end);
        }
        self.candidates = candidates;
        let end_stats = solve::solve(
            &mut self.end_rows,
            &mut self.responses,
            self.rel_tol,
            self.max_sweeps,
            pool,
        );
        self.stats.sweeps += end_stats.sweeps;
        self.stats.converged &= end_stats.converged;
        self.work += self.apply(parts, starts);
        std::mem::swap(&mut self.responses, &mut self.end_responses);
        self.record();
    }

    /// One [`Group`] per robot in `self.responses` (as many as robots, empty for those that
    /// touch nothing): for a robot with a body in a contact (found in this step's narrow
    /// phase at the start, `at_start`, else the closing rows), its response `M_c⁻¹` at the
    /// partition's poses for the bodies that touch.
    fn robot_groups(&mut self, parts: &mut [&mut Bodies], at_start: bool) {
        if at_start {
            for t in self.slot_touches.iter_mut() {
                *t = false;
            }
            for (between, _) in self.between.iter().zip(&self.raw) {
                self.slot_touches[self.collider_slot[between.a as usize]] = true;
                if between.b != GROUND {
                    self.slot_touches[self.collider_slot[between.b as usize]] = true;
                }
            }
        }
        for t in self.robot_touches.iter_mut() {
            *t = false;
        }
        for (s, touches) in self.slot_touches.iter().enumerate() {
            if let (true, Some((r, _))) = (*touches, self.slot_robot[s]) {
                self.robot_touches[r] = true;
            }
        }
        self.responses.groups.clear();
        for (r, robot) in self.robots.iter_mut().enumerate() {
            let n = robot.body_count();
            let mut group = Group {
                local: (0..n).collect(),
                columns: vec![DMatrix::zeros(0, 0); n],
                twist: DVector::zeros(6 * n),
                predicted: at_start,
            };
            if self.robot_touches[r] {
                robot.load(parts[robot.part]);
                for (s, slot_robot) in self.slot_robot.iter().enumerate() {
                    if let Some((rr, local)) = slot_robot
                        && *rr == r
                        && self.slot_touches[s]
                    {
                        group.columns[*local] = robot.columns(*local);
                    }
                }
            }
            self.responses.groups.push(group);
        }
    }

    /// The robots that touch stepped once with the rows' warm-start impulses on them: their
    /// bodies' predicted poses replace the free drift.
    fn predict_robots(
        &mut self,
        parts: &mut [&mut Bodies],
        starts: &[usize],
        h: f64,
        loads: &Loads,
    ) {
        for (r, robot) in self.robots.iter_mut().enumerate() {
            if !self.robot_touches[r] {
                continue;
            }
            let slots = &self.slots;
            gather_kicks(robot, r, &self.slot_robot, &self.responses, |s| {
                slots[s].rotation
            });
            let k = robot.part;
            let range = starts[k]..starts[k] + parts[k].len();
            let part_loads = loads.part(range);
            robot.predict(parts[k], h, &part_loads, &self.settings);
            for (s, slot_robot) in self.slot_robot.iter().enumerate() {
                if let Some((rr, local)) = slot_robot
                    && *rr == r
                {
                    let (com, rotation) = robot.predicted[*local];
                    self.slots[s].com_next = com;
                    self.slots[s].rotation_next = rotation;
                }
            }
        }
    }

    /// The impulses the solve put in `self.responses` onto the bodies' momenta: a free body's
    /// `v += Δv`, `M += Rᵀ ΔL`; a robot's bodies their impulses (its joints carry them in the
    /// step that follows). Returns the kinetic energy they changed, J.
    fn apply(&mut self, parts: &mut [&mut Bodies], starts: &[usize]) -> f64 {
        let mut work = apply(&self.responses, &self.slot_body, parts, starts);
        for (r, robot) in self.robots.iter_mut().enumerate() {
            if !self.robot_touches[r] {
                continue;
            }
            let slot_body = &self.slot_body;
            gather_kicks(robot, r, &self.slot_robot, &self.responses, |s| {
                let (k, j) = locate(starts, slot_body[s]);
                parts[k].world_from_body[j]
            });
            work += robot.apply_kicks(parts[robot.part]);
        }
        work
    }

    /// The contacts at the start of the step within reach of the step's motion.
    fn find_contacts(&mut self, h: f64, pool: Option<&rayon::ThreadPool>) {
        let _ = h;
        self.raw.clear();
        self.keys.clear();
        let mut between = std::mem::take(&mut self.between);
        between.clear();
        let world_from_parry = |phase: &Self, c: usize| -> Isometry3<f64> {
            let slot = &phase.slots[phase.collider_slot[c]];
            Isometry3::from_parts(Translation3::from(slot.com), slot.rotation)
                * phase.prepared[c].body_from_parry
        };
        // A margin beyond the motion bound: contacts a hair apart are found a step early.
        const MARGIN_M: f64 = 1e-4;
        if let Some(ground) = &self.model.ground {
            for c in 0..self.prepared.len() {
                let s = self.collider_slot[c];
                let slot = &self.slots[s];
                let reach = self.slot_reach_m[s];
                let prediction = slot.motion_m + MARGIN_M;
                if ground.height_of(&slot.com) - reach > prediction {
                    continue;
                }
                let pose = world_from_parry(self, c);
                let n0 = self.raw.len();
                narrow::with_ground(
                    &pose,
                    &self.prepared[c].shape,
                    ground,
                    prediction,
                    &mut self.scratch,
                    &mut self.raw,
                );
                for r in &self.raw[n0..] {
                    between.push(Between {
                        a: c as u32,
                        b: GROUND,
                    });
                    self.keys.push((c as u32, GROUND, r.features));
                }
            }
        }
        if self.prepared.len() > 1 {
            self.bounds.clear();
            for c in 0..self.prepared.len() {
                let slot = &self.slots[self.collider_slot[c]];
                let centre =
                    slot.com + slot.rotation * self.prepared[c].body_from_parry.translation.vector;
                self.bounds.push(Bound {
                    centre,
                    radius_m: self.prepared[c].radius_m + slot.motion_m + MARGIN_M,
                });
            }
            self.sweep.pairs(&self.bounds, &mut self.pairs, pool);
            let pairs = std::mem::take(&mut self.pairs);
            for &(i, j) in &pairs {
                let (ci, cj) = (
                    &self.model.colliders[i as usize],
                    &self.model.colliders[j as usize],
                );
                if !self.model.may_touch(ci, cj) {
                    continue;
                }
                // `a` the later collider, `b` the earlier: one orientation for every pair.
                let (a, b) = (j as usize, i as usize);
                let prediction = self.slots[self.collider_slot[a]].motion_m
                    + self.slots[self.collider_slot[b]].motion_m
                    + MARGIN_M;
                let pose_a = world_from_parry(self, a);
                let pose_b = world_from_parry(self, b);
                let n0 = self.raw.len();
                narrow::pair(
                    &pose_a,
                    &self.prepared[a].shape,
                    &pose_b,
                    &self.prepared[b].shape,
                    prediction,
                    &mut self.scratch,
                    &mut self.raw,
                );
                for r in &self.raw[n0..] {
                    between.push(Between {
                        a: a as u32,
                        b: b as u32,
                    });
                    self.keys.push((a as u32, b as u32, r.features));
                }
            }
            self.pairs = pairs;
        }
        self.between = between;
    }

    /// One row per contact: its frame, arms and friction, warm-started from the last step's
    /// impulse on the same contact (projected into its cone); the free velocities and targets
    /// follow ([`ContactPhase::free_velocities`]).
    ///
    /// The rows' set-up (frame, Delassus block, its inverse and eigen-decomposition) reads the
    /// bodies' masses and inertias only, not the impulses the warm starts add: with `pool` and
    /// at least [`MIN_ROWS_ON_POOL`] contacts it runs side by side, then the warm starts in the
    /// contacts' order. The same bits.
    fn build_rows(&mut self, pool: Option<&rayon::ThreadPool>) {
        self.rows.clear();
        let mut candidates = std::mem::take(&mut self.candidates);
        candidates.clear();
        let this = &*self;
        let make = |source: usize| this.start_row(source);
        match pool {
            Some(pool) if self.raw.len() >= MIN_ROWS_ON_POOL => pool
                .install(|| candidates.par_extend((0..this.raw.len()).into_par_iter().map(make))),
            _ => candidates.extend((0..this.raw.len()).map(make)),
        }
        for mut row in candidates.drain(..).flatten() {
            let key = &self.keys[row.source];
            if let Ok(k) = self.previous.binary_search_by(|p| p.0.cmp(key)) {
                row.warm_start(&self.previous[k].1, &mut self.responses);
            }
            self.rows.push(row);
        }
        self.candidates = candidates;
    }

    /// The row of contact `source` at the start of the step, set up ([`Row::prepare`]);
    /// `None` when the bodies cannot move along its normal.
    fn start_row(&self, source: usize) -> Option<Row> {
        let (raw, between) = (&self.raw[source], &self.between[source]);
        let ca = between.a as usize;
        let sa = self.collider_slot[ca];
        let r_a = raw.point_a - self.slots[sa].com;
        let collider_a = &self.model.colliders[ca];
        let (b, r_b, mu, e) = if between.b == GROUND {
            let g = self.model.ground.as_ref().expect("ground contact");
            (
                None,
                Vector3::zeros(),
                combine_friction(collider_a.friction, g.friction),
                combine_restitution(collider_a.restitution, g.restitution),
            )
        } else {
            let cb = between.b as usize;
            let sb = self.collider_slot[cb];
            let collider_b = &self.model.colliders[cb];
            (
                Some(sb),
                raw.point_b - self.slots[sb].com,
                combine_friction(collider_a.friction, collider_b.friction),
                combine_restitution(collider_a.restitution, collider_b.restitution),
            )
        };
        let mut row = Row {
            source,
            a: sa,
            b,
            r_a,
            r_b,
            frame: contact_frame(&raw.normal),
            u_free: Vector3::zeros(),
            target_n: 0.0,
            mu,
            restitution: e,
            leave_n: 0.0,
            w: Matrix3::zeros(),
            w_inv: Matrix3::zeros(),
            tangent_eigen: Default::default(),
            lambda: Vector3::zeros(),
        };
        row.prepare(&self.responses).then_some(row)
    }

    /// The end projection's row of start row `i` if it closes, set up ([`Row::prepare`]) at
    /// the bodies' end `velocities` (per slot, linear and angular); `None` for a row that does
    /// not close or whose bodies cannot move along its normal. Its `source` is `i`.
    fn end_row(&self, i: usize, velocities: &[(Vector3<f64>, Vector3<f64>)]) -> Option<Row> {
        if !self.closing[i] {
            return None;
        }
        let row = &self.rows[i];
        // The arms of the start: where the contact is relative to the centres of mass
        // (for a ball, exactly where it is at the end; for a face, to O(h ω)).
        let point_velocity = |slot: usize, r: &Vector3<f64>| {
            let (v, w) = velocities[slot];
            v + w.cross(r)
        };
        let mut rel = point_velocity(row.a, &row.r_a);
        if let Some(b) = row.b {
            rel -= point_velocity(b, &row.r_b);
        }
        let u_free = row.frame.transpose() * rel;
        // An impact that ends exactly at the end of the step leaves with the restitution
        // here (one that ends inside the step left in the start solve's target).
        let approach = -u_free.x;
        let target_n = if row.restitution > 0.0 && approach > self.bounce_min {
            row.restitution * approach
        } else {
            0.0
        }
        .max(row.leave_n);
        let mut end = Row {
            source: i,
            u_free,
            target_n,
            lambda: Vector3::zeros(),
            ..*row
        };
        end.prepare(&self.responses).then_some(end)
    }

    /// Each row's free velocity over the step (the two material points' predicted
    /// displacements over `h`) and its target: non-penetration at the end of the step; with
    /// restitution, an approach faster than `bounce_min` leaves at `e` times its speed from
    /// the moment of impact (the fraction `s` of the step spent closing the gap).
    fn free_velocities(&mut self, h: f64, gravity: &Vector3<f64>) {
        // Below this approach speed a contact does not bounce: a resting body's free normal
        // velocity is about |g| h / 2, and a bounce off that would never settle.
        let bounce_min = 2.0 * gravity.norm() * h + 1e-9;
        self.bounce_min = bounce_min;
        let displacement = |slot: &Slot, r: &Vector3<f64>| {
            slot.com_next + slot.rotation_next * (slot.rotation.inverse() * r) - (slot.com + r)
        };
        for row in self.rows.iter_mut() {
            let raw = &self.raw[row.source];
            let dx_a = displacement(&self.slots[row.a], &row.r_a);
            let dx_b = row
                .b
                .map_or(Vector3::zeros(), |b| displacement(&self.slots[b], &row.r_b));
            row.u_free = row.frame.transpose() * (dx_a - dx_b) / h;
            // A penetration (bodies placed overlapping) is pushed out at most at
            // `PUSH_OUT_M_PER_S`: a 1 mm overlap in one step of 1 ms, a deep one over several
            // steps, not in one step at `gap / h` (10 cm in 1 ms would be 100 m/s).
            let mut target_n = (-raw.gap_m / h).min(PUSH_OUT_M_PER_S);
            let approach = -row.u_free.x;
            let mut leave_n = 0.0;
            if row.restitution > 0.0 && approach > bounce_min {
                let s = (raw.gap_m.max(0.0) / (approach * h)).min(1.0);
                if s < 1.0 {
                    target_n += row.restitution * approach * (1.0 - s);
                    leave_n = row.restitution * approach;
                }
            }
            row.target_n = target_n;
            row.leave_n = leave_n;
        }
    }

    /// The step's contacts with an impulse, for the recordings, and the impulses by contact
    /// for the next step's start.
    fn record(&mut self) {
        self.contacts.clear();
        self.previous.clear();
        let mut end = self.end_rows.iter().peekable();
        for (r, row) in self.rows.iter().enumerate() {
            let end_lambda = end
                .next_if(|e| e.source == r)
                .map_or(Vector3::zeros(), |e| e.lambda);
            let lambda = row.lambda + end_lambda;
            if lambda == Vector3::zeros() {
                continue;
            }
            let i = row.source;
            let raw = &self.raw[i];
            let impulse = row.frame * lambda;
            self.previous
                .push((self.keys[i], row.frame * row.lambda, row.frame * end_lambda));
            let between = self.between[i];
            self.contacts.push(ContactPoint {
                body_a: self.slot_body[row.a] as u32,
                body_b: if between.b == GROUND {
                    GROUND
                } else {
                    self.slot_body[self.collider_slot[between.b as usize]] as u32
                },
                point_world: raw.point_b,
                normal_world: raw.normal,
                impulse_world: impulse,
                gap_m: raw.gap_m,
            });
        }
        self.previous.sort_unstable_by_key(|p| p.0);
    }
}

/// Robot `r`'s kicks from the impulses the solve put on its slots (`slot_robot`: each slot's
/// robot and body there): `[ΔP; Rᵀ ΔL]` per body, `rotation(s)` the rotation `R` of slot `s`'s
/// body now; zero on the bodies nothing touched.
fn gather_kicks(
    robot: &mut Robot,
    r: usize,
    slot_robot: &[Option<(usize, usize)>],
    responses: &Responses,
    rotation: impl Fn(usize) -> UnitQuaternion<f64>,
) {
    for k in robot.kicks.iter_mut() {
        *k = Impulse6::zeros();
    }
    for (s, slot) in slot_robot.iter().enumerate() {
        if let Some((rr, local)) = slot
            && *rr == r
        {
            let resp = &responses.bodies[s];
            let body_l = rotation(s).inverse_transform_vector(&resp.dl);
            robot.kicks[*local] = Impulse6::new(
                resp.df.x, resp.df.y, resp.df.z, body_l.x, body_l.y, body_l.z,
            );
        }
    }
}

/// Body `i`'s partition and its index there (part `k` holds the bodies from `starts[k]`).
fn locate(starts: &[usize], i: usize) -> (usize, usize) {
    let k = starts.partition_point(|&s| s <= i) - 1;
    (k, i - starts[k])
}

/// The impulses the solve put in `responses` (one per body of `slot_body`) onto the bodies'
/// momenta: `v += Δv`, `M += Rᵀ ΔL`; returns the kinetic energy they changed, J.
fn apply(
    responses: &Responses,
    slot_body: &[usize],
    parts: &mut [&mut Bodies],
    starts: &[usize],
) -> f64 {
    let mut work = 0.0;
    for (r, &body) in responses.bodies.iter().zip(slot_body) {
        // A robot's bodies take their impulses through `Robot::apply_kicks`.
        if r.member.is_some() || (r.dv == Vector3::zeros() && r.dl == Vector3::zeros()) {
            continue;
        }
        let (k, j) = locate(starts, body);
        let b = &mut *parts[k];
        let ke0 = b.kinetic_energy(j);
        b.linvel_world[j] += r.dv;
        b.angmom_body[j] += b.world_from_body[j].inverse_transform_vector(&r.dl);
        work += b.kinetic_energy(j) - ke0;
    }
    work
}
