//! What acts on the bodies during a step: [`Loads`] (uniform gravity, applied forces and torques
//! on bodies, the time of the step), and the forcing kicks of the variational family.

use crate::sim::Bodies;
use crate::sim::signal::Signal;
use nalgebra::{UnitQuaternion, Vector3};
use std::ops::Range;
use std::sync::Arc;

/// The axes a [`BodyLoad`]'s components are given in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LoadFrame {
    /// World axes.
    World,
    /// The link frame's axes (they turn with the body).
    Link,
}

/// A force and a torque applied to one body of the batch (a scene's `[[model.load]]` on a
/// link): the force acts at the link frame's origin.
#[derive(Debug, Clone, PartialEq)]
pub struct BodyLoad {
    /// Batch index of the body (local to a partition after [`Loads::part`]).
    pub body: usize,
    /// The link frame's origin relative to the body's centre of mass, in the body's principal
    /// axes, m.
    pub point_body: Vector3<f64>,
    /// The link frame's axes in the body's principal axes (`body_from_link`).
    pub body_from_link: UnitQuaternion<f64>,
    /// Force components (N) and torque components (N m), in `frame`'s axes.
    pub force: [Signal; 3],
    pub torque: [Signal; 3],
    pub frame: LoadFrame,
}

impl BodyLoad {
    /// The force (world axes, N) and the torque about the centre of mass (body principal axes,
    /// N m, the force's moment included) at `t_secs` with the body turned by `world_from_body`.
    pub fn wrench(
        &self,
        t_secs: f64,
        world_from_body: &UnitQuaternion<f64>,
    ) -> (Vector3<f64>, Vector3<f64>) {
        let f = Vector3::new(
            self.force[0].at(t_secs),
            self.force[1].at(t_secs),
            self.force[2].at(t_secs),
        );
        let tau = Vector3::new(
            self.torque[0].at(t_secs),
            self.torque[1].at(t_secs),
            self.torque[2].at(t_secs),
        );
        let (f_body, tau_body) = match self.frame {
            LoadFrame::World => (
                world_from_body.inverse_transform_vector(&f),
                world_from_body.inverse_transform_vector(&tau),
            ),
            LoadFrame::Link => (self.body_from_link * f, self.body_from_link * tau),
        };
        (
            world_from_body * f_body,
            tau_body + self.point_body.cross(&f_body),
        )
    }
}

/// The loads acting on a batch of bodies during a step, passed as `&Loads` to every integrator
/// ([`crate::sim::Integrator::step`]), mechanism step, reference and energy in `sim/`.
///
/// - Uniform gravity ([`Loads::gravity`]): every body gets the force `m g` at its centre of
///   mass, and the potential energy `V = -m g · c`.
/// - Applied loads on bodies ([`BodyLoad`], [`Loads::with_body_loads`]), functions of time and
///   of the body's orientation (link-frame components).
/// - The time at the start of the step being taken ([`Loads::time_secs`]), set by the stepping
///   loop before each step ([`Loads::set_time`]); a composition's stages read theirs with
///   [`Loads::at_offset`].
///
/// Joint efforts (actuators, damping) belong to the mechanisms
/// ([`crate::sim::mechanism::JointDrive`]); they read the time from here.
///
/// A partition stepping bodies `range` of the batch gets its own `Loads` for its local body
/// indices from [`Loads::part`] (as [`crate::sim::partition::rebase`] re-bases mechanisms).
#[derive(Debug, Clone, PartialEq)]
pub struct Loads {
    /// Uniform gravitational acceleration, world frame, m/s².
    gravity: Vector3<f64>,
    /// Time at the start of the step, s.
    time_secs: f64,
    /// Applied loads, sorted by body.
    bodies: Arc<[BodyLoad]>,
}

impl Loads {
    /// Uniform gravity `g` (m/s², world frame) and nothing else.
    pub fn uniform_gravity(gravity: Vector3<f64>) -> Self {
        Self {
            gravity,
            time_secs: 0.0,
            bodies: Arc::from(Vec::new()),
        }
    }

    /// No loads: zero gravity (torque-free, force-free motion).
    pub fn none() -> Self {
        Self::uniform_gravity(Vector3::zeros())
    }

    /// These loads with `loads` applied to bodies as well (sorted here by body).
    pub fn with_body_loads(mut self, mut loads: Vec<BodyLoad>) -> Self {
        loads.sort_by_key(|l| l.body);
        self.bodies = Arc::from(loads);
        self
    }

    /// The uniform gravitational acceleration `g`, m/s², world frame.
    #[inline(always)]
    pub fn gravity(&self) -> &Vector3<f64> {
        &self.gravity
    }

    /// The time at the start of the step, s.
    #[inline(always)]
    pub fn time_secs(&self) -> f64 {
        self.time_secs
    }

    /// Sets the time at the start of the next step.
    pub fn set_time(&mut self, t_secs: f64) {
        self.time_secs = t_secs;
    }

    /// These loads with the time moved on by `dt_secs` (a composition's stage).
    pub fn at_offset(&self, dt_secs: f64) -> Self {
        let mut out = self.clone();
        out.time_secs += dt_secs;
        out
    }

    /// The applied loads on bodies (sorted by body).
    pub fn body_loads(&self) -> &[BodyLoad] {
        &self.bodies
    }

    /// Whether any applied load acts on a body in `range`.
    pub fn loads_any(&self, range: &Range<usize>) -> bool {
        let k = self.bodies.partition_point(|l| l.body < range.start);
        self.bodies.get(k).is_some_and(|l| l.body < range.end)
    }

    /// The loads of the bodies `range` of the batch, indexed from `range.start` (a partition's
    /// view).
    pub fn part(&self, range: Range<usize>) -> Self {
        if self.bodies.is_empty() {
            // Gravity only: a copy (the empty list shared), nothing allocated.
            return self.clone();
        }
        let bodies: Vec<BodyLoad> = self
            .bodies
            .iter()
            .filter(|l| range.contains(&l.body))
            .map(|l| BodyLoad {
                body: l.body - range.start,
                ..l.clone()
            })
            .collect();
        Self {
            gravity: self.gravity,
            time_secs: self.time_secs,
            bodies: Arc::from(bodies),
        }
    }

    /// The forcing kick of the discrete Lagrange-d'Alembert principle with the trapezoid
    /// rule (Marsden & West 2001, §3.2: `f_d⁻ = (h/2) F(q_k, t_k)`, `f_d⁺ = (h/2) F(q_{k+1},
    /// t_{k+1})`): every loaded body of `range` gets the impulse `half_h · F(t_secs)` on its
    /// linear momentum and `half_h · τ(t_secs)` (body axes, about its centre of mass) on its
    /// angular momentum. A step is `kick(t_k); unforced step; kick(t_{k+1})`; both kicks use the
    /// body's pose at their end of the step, so the step stays symmetric. Returns the impulses'
    /// power terms for the work ([`KickLedger`]).
    pub fn kick(
        &self,
        bodies: &mut Bodies,
        range: &Range<usize>,
        t_secs: f64,
        half_h: f64,
        ledger: &mut KickLedger,
    ) {
        let k = self.bodies.partition_point(|l| l.body < range.start);
        for load in self.bodies[k..].iter().take_while(|l| l.body < range.end) {
            let i = load.body;
            let (f_world, tau_body) = load.wrench(t_secs, &bodies.world_from_body[i]);
            bodies.linvel_world[i] += f_world * (half_h / bodies.mass[i]);
            bodies.angmom_body[i] += tau_body * half_h;
            ledger.push(i, bodies, f_world, tau_body);
        }
    }
}

impl Loads {
    /// Runs `step` (an unforced step of `h` of the bodies `range`) between the two trapezoid
    /// kicks of [`Loads::kick`] at `t_k` and `t_k + h`, recording their work in `ledger`;
    /// without applied loads on `range`, just runs it.
    pub fn forced_step<R>(
        &self,
        bodies: &mut Bodies,
        range: &Range<usize>,
        h: f64,
        ledger: &mut KickLedger,
        step: impl FnOnce(&mut Bodies) -> R,
    ) -> R {
        if !self.loads_any(range) {
            return step(bodies);
        }
        let t0 = self.time_secs;
        ledger.begin();
        self.kick(bodies, range, t0, 0.5 * h, ledger);
        let out = step(bodies);
        ledger.end();
        self.kick(bodies, range, t0 + h, 0.5 * h, ledger);
        out
    }

    /// The total force (world axes, N) and torque about the centre of mass (body axes, N m)
    /// of the applied loads on body `i` at `t_secs` with orientation `world_from_body`.
    pub fn wrench_on(
        &self,
        i: usize,
        t_secs: f64,
        world_from_body: &UnitQuaternion<f64>,
    ) -> (Vector3<f64>, Vector3<f64>) {
        let k = self.bodies.partition_point(|l| l.body < i);
        let mut f = Vector3::zeros();
        let mut tau = Vector3::zeros();
        for load in self.bodies[k..].iter().take_while(|l| l.body == i) {
            let (fl, tl) = load.wrench(t_secs, world_from_body);
            f += fl;
            tau += tl;
        }
        (f, tau)
    }

    /// The distinct bodies in `range` that carry applied loads, in order.
    pub fn loaded_bodies(&self, range: &Range<usize>) -> impl Iterator<Item = usize> + '_ {
        let k = self.bodies.partition_point(|l| l.body < range.start);
        let end = range.end;
        let mut last = None;
        self.bodies[k..]
            .iter()
            .take_while(move |l| l.body < end)
            .filter_map(move |l| {
                if last == Some(l.body) {
                    None
                } else {
                    last = Some(l.body);
                    Some(l.body)
                }
            })
    }
}

/// What a start kick recorded of one body: its index, centre of mass, orientation, force
/// (world axes) and torque (body axes).
type KickRecord = (
    usize,
    Vector3<f64>,
    UnitQuaternion<f64>,
    Vector3<f64>,
    Vector3<f64>,
);

/// The work of applied loads over a step, by the trapezoid rule: the kicks at both ends record
/// each loaded body's pose and wrench; `W = ½ (F_k + F_{k+1}) · (c_{k+1} − c_k) + ½ (τ_k +
/// τ_{k+1}) · log(R_kᵀ R_{k+1})` (torques in body axes), O(h²) from the exact work over a run.
#[derive(Debug, Clone, Default)]
pub struct KickLedger {
    start: Vec<KickRecord>,
    cursor: usize,
    at_end: bool,
    /// Work done so far, J.
    pub work: f64,
}

impl KickLedger {
    /// Marks the start of a step (the next kicks are the start kicks).
    pub fn begin(&mut self) {
        self.start.clear();
        self.at_end = false;
    }

    /// Marks the end of a step (the next kicks are the end kicks).
    pub fn end(&mut self) {
        self.cursor = 0;
        self.at_end = true;
    }

    fn push(&mut self, i: usize, bodies: &Bodies, f: Vector3<f64>, tau: Vector3<f64>) {
        let (c, q) = (bodies.com_world[i], bodies.world_from_body[i]);
        if !self.at_end {
            self.start.push((i, c, q, f, tau));
            return;
        }
        if let Some(&(j, c0, q0, f0, tau0)) = self.start.get(self.cursor)
            && j == i
        {
            let turn = (q0.inverse() * q).scaled_axis();
            self.work += 0.5 * (f0 + f).dot(&(c - c0)) + 0.5 * (tau0 + tau).dot(&turn);
        }
        self.cursor += 1;
    }
}

impl Default for Loads {
    /// [`Loads::none`].
    fn default() -> Self {
        Self::none()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn constant(v: [f64; 3]) -> [Signal; 3] {
        v.map(Signal::Constant)
    }

    #[test]
    fn uniform_gravity_is_read_back_and_the_same_in_every_part() {
        let g = Vector3::new(0.5, -1.0, -9.81);
        let loads = Loads::uniform_gravity(g);
        assert_eq!(*loads.gravity(), g);
        assert_eq!(loads.part(3..7), loads);
        assert_eq!(*Loads::default().gravity(), Vector3::zeros());
        assert_eq!(Loads::none(), Loads::default());
    }

    /// A part keeps the loads of its range, re-based; the others are dropped.
    #[test]
    fn a_part_rebases_its_body_loads() {
        let load = |body| BodyLoad {
            body,
            point_body: Vector3::zeros(),
            body_from_link: UnitQuaternion::identity(),
            force: constant([1.0, 0.0, 0.0]),
            torque: constant([0.0; 3]),
            frame: LoadFrame::World,
        };
        let loads = Loads::none().with_body_loads(vec![load(9), load(2), load(5)]);
        let part = loads.part(4..9);
        assert_eq!(part.body_loads().len(), 1);
        assert_eq!(part.body_loads()[0].body, 1);
        assert!(loads.loads_any(&(5..6)) && !loads.loads_any(&(6..9)) && loads.loads_any(&(0..3)));
        let mut t = loads.at_offset(0.25);
        assert_eq!(t.time_secs(), 0.25);
        t.set_time(2.0);
        assert_eq!(t.time_secs(), 2.0);
    }

    /// A force at a point off the centre of mass: world-axes force unchanged, torque `r × F`
    /// in body axes; link-frame components turn with the body.
    #[test]
    fn the_wrench_of_a_force_off_the_centre() {
        let q = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_2);
        let world = BodyLoad {
            body: 0,
            point_body: Vector3::new(1.0, 0.0, 0.0),
            body_from_link: UnitQuaternion::identity(),
            force: constant([0.0, 0.0, 2.0]),
            torque: constant([0.0, 0.0, 0.5]),
            frame: LoadFrame::World,
        };
        let (f, tau) = world.wrench(0.0, &q);
        assert!((f - Vector3::new(0.0, 0.0, 2.0)).norm() < 1e-15);
        // r = x_body, F_body = (0, 0, 2): r × F = (0, −2, 0); τ_body = (0, 0, 0.5).
        assert!((tau - Vector3::new(0.0, -2.0, 0.5)).norm() < 1e-15);
        let link = BodyLoad {
            frame: LoadFrame::Link,
            force: constant([1.0, 0.0, 0.0]),
            torque: constant([0.0; 3]),
            point_body: Vector3::zeros(),
            ..world
        };
        let (f, _) = link.wrench(0.0, &q);
        // Link x turned by 90° about z: world y.
        assert!((f - Vector3::new(0.0, 1.0, 0.0)).norm() < 1e-15);
    }
}
