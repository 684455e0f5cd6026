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
use super::solve::{self, Response, Row, SolveStats, contact_frame};
use super::{ContactModel, ContactPoint, GROUND, combine_friction, combine_restitution};
use crate::sim::Bodies;
use nalgebra::{Isometry3, Matrix3, Translation3, UnitQuaternion, Vector3};

/// A contact whose gap at the end of the step is at most this, or at most the distance
/// gravity moves a body in one step (`|g| h²`: the linear prediction of a turning body's
/// gap is that far off), is closed: held by the end projection, m.
const CLOSED_M: f64 = 1e-9;

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
    responses: Vec<Response>,
    bounds: Vec<Bound>,
    pairs: Vec<(u32, u32)>,
    sweep: Sweep,
    raw: Vec<RawContact>,
    between: Vec<Between>,
    rows: Vec<Row>,
    /// Per row of the start solve: whether its contact is closed at the end of the step.
    closing: Vec<bool>,
    end_rows: Vec<Row>,
    end_responses: Vec<Response>,
    keys: Vec<Key>,
    /// The last step's impulses (world) by contact, sorted by key: the next solve's start.
    previous: Vec<(Key, Vector3<f64>, Vector3<f64>)>,
    scratch: Scratch,
}

/// Whom a narrow-phase contact is between: colliders `a` and `b` (`GROUND` for the ground).
#[derive(Debug, Clone, Copy)]
struct Between {
    a: u32,
    b: u32,
}

impl ContactPhase {
    /// The phase of `model`; an error names a collider parry cannot build.
    pub fn new(model: ContactModel) -> anyhow::Result<Self> {
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
        Ok(Self {
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
            responses: Vec::new(),
            bounds: Vec::new(),
            pairs: Vec::new(),
            sweep: Sweep::default(),
            raw: Vec::new(),
            between: Vec::new(),
            rows: Vec::new(),
            closing: Vec::new(),
            end_rows: Vec::new(),
            end_responses: Vec::new(),
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
    /// step of `dt_secs` in `gravity`, with the scheme's free drift
    /// `c_{k+1} = c_k + h v_k + alpha h² g`. [`ContactPhase::end`] follows the step.
    pub fn start(
        &mut self,
        parts: &mut [&mut Bodies],
        starts: &[usize],
        dt_secs: f64,
        gravity: &Vector3<f64>,
        alpha: f64,
    ) {
        let h = dt_secs;
        let locate = |i: usize| {
            let k = starts.partition_point(|&s| s <= i) - 1;
            (k, i - starts[k])
        };
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
            self.responses
                .push(Response::new(1.0 / b.mass[j], inv_inertia_world));
        }
        self.find_contacts(h);
        self.build_rows(h, gravity);
        self.stats = solve::solve(
            &mut self.rows,
            &mut self.responses,
            self.rel_tol,
            self.max_sweeps,
        );
        // The impulses onto the bodies' momenta, and their energy.
        for (s, &body) in self.slot_body.iter().enumerate() {
            let r = &self.responses[s];
            if r.dv == Vector3::zeros() && r.dl == Vector3::zeros() {
                continue;
            }
            let (k, j) = locate(body);
            let b = &mut *parts[k];
            let ke0 = b.kinetic_energy(j);
            b.linvel_world[j] += r.dv;
            b.angmom_body[j] += b.world_from_body[j].inverse_transform_vector(&r.dl);
            self.work += b.kinetic_energy(j) - ke0;
        }
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
    /// an impact would not end at the contact (`docs/contact.md`).
    pub fn end(&mut self, parts: &mut [&mut Bodies], starts: &[usize]) {
        let locate = |i: usize| {
            let k = starts.partition_point(|&s| s <= i) - 1;
            (k, i - starts[k])
        };
        self.end_rows.clear();
        self.end_responses.clear();
        let mut velocities = Vec::with_capacity(self.slot_body.len());
        for &body in &self.slot_body {
            let (k, j) = locate(body);
            let b = &*parts[k];
            let rot = b.world_from_body[j].to_rotation_matrix();
            let inv_inertia_world =
                rot * Matrix3::from_diagonal(&b.inv_inertia_body[j]) * rot.transpose();
            self.end_responses
                .push(Response::new(1.0 / b.mass[j], inv_inertia_world));
            velocities.push((b.linvel_world[j], b.angvel_world(j)));
        }
        for (i, row) in self.rows.iter().enumerate() {
            if !self.closing[i] {
                continue;
            }
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
            if end.prepare(&self.end_responses) {
                let key = &self.keys[row.source];
                if let Ok(k) = self.previous.binary_search_by(|p| p.0.cmp(key)) {
                    end.warm_start(&self.previous[k].2, &mut self.end_responses);
                }
                self.end_rows.push(end);
            }
        }
        let end_stats = solve::solve(
            &mut self.end_rows,
            &mut self.end_responses,
            self.rel_tol,
            self.max_sweeps,
        );
        self.stats.sweeps += end_stats.sweeps;
        self.stats.converged &= end_stats.converged;
        for (s, &body) in self.slot_body.iter().enumerate() {
            let r = &self.end_responses[s];
            if r.dv == Vector3::zeros() && r.dl == Vector3::zeros() {
                continue;
            }
            let (k, j) = locate(body);
            let b = &mut *parts[k];
            let ke0 = b.kinetic_energy(j);
            b.linvel_world[j] += r.dv;
            b.angmom_body[j] += b.world_from_body[j].inverse_transform_vector(&r.dl);
            self.work += b.kinetic_energy(j) - ke0;
        }
        self.record();
    }

    /// The contacts at the start of the step within reach of the step's motion.
    fn find_contacts(&mut self, h: f64) {
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
            self.sweep.pairs(&self.bounds, &mut self.pairs);
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

    /// One row per contact: its frame, arms, free velocity, target and friction, warm-started
    /// from the last step's impulse on the same contact (projected into its cone).
    fn build_rows(&mut self, h: f64, gravity: &Vector3<f64>) {
        self.rows.clear();
        // Below this approach speed a contact does not bounce: a resting body's free normal
        // velocity is about |g| h / 2, and a bounce off that would never settle.
        let bounce_min = 2.0 * gravity.norm() * h + 1e-9;
        self.bounce_min = bounce_min;
        for (source, ((raw, between), key)) in self
            .raw
            .iter()
            .zip(&self.between)
            .zip(&self.keys)
            .enumerate()
        {
            let ca = between.a as usize;
            let sa = self.collider_slot[ca];
            let a = &self.slots[sa];
            let r_a = raw.point_a - a.com;
            let dx_a = a.com_next + a.rotation_next * (a.rotation.inverse() * r_a) - (a.com + r_a);
            let collider_a = &self.model.colliders[ca];
            let (b, r_b, dx_b, mu, e) = if between.b == GROUND {
                let g = self.model.ground.as_ref().expect("ground contact");
                (
                    None,
                    Vector3::zeros(),
                    Vector3::zeros(),
                    combine_friction(collider_a.friction, g.friction),
                    combine_restitution(collider_a.restitution, g.restitution),
                )
            } else {
                let cb = between.b as usize;
                let sb = self.collider_slot[cb];
                let bs = &self.slots[sb];
                let r_b = raw.point_b - bs.com;
                let dx_b =
                    bs.com_next + bs.rotation_next * (bs.rotation.inverse() * r_b) - (bs.com + r_b);
                let collider_b = &self.model.colliders[cb];
                (
                    Some(sb),
                    r_b,
                    dx_b,
                    combine_friction(collider_a.friction, collider_b.friction),
                    combine_restitution(collider_a.restitution, collider_b.restitution),
                )
            };
            let frame = contact_frame(&raw.normal);
            let u_free = frame.transpose() * (dx_a - dx_b) / h;
            // Non-penetration at the end of the step; with restitution, an approach faster
            // than `bounce_min` leaves at `e` times its speed from the moment of impact
            // (the fraction `s` of the step spent closing the gap).
            let mut target_n = -raw.gap_m / h;
            let approach = -u_free.x;
            let mut leave_n = 0.0;
            if e > 0.0 && approach > bounce_min {
                let s = (raw.gap_m.max(0.0) / (approach * h)).min(1.0);
                if s < 1.0 {
                    target_n += e * approach * (1.0 - s);
                    leave_n = e * approach;
                }
            }
            let mut row = Row {
                source,
                a: sa,
                b,
                r_a,
                r_b,
                frame,
                u_free,
                target_n,
                mu,
                restitution: e,
                leave_n,
                w: Matrix3::zeros(),
                w_inv: Matrix3::zeros(),
                lambda: Vector3::zeros(),
            };
            if !row.prepare(&self.responses) {
                continue;
            }
            if let Ok(k) = self.previous.binary_search_by(|p| p.0.cmp(key)) {
                row.warm_start(&self.previous[k].1, &mut self.responses);
            }
            self.rows.push(row);
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
