//! One step of a tree in joint coordinates: the discrete Euler-Lagrange equations of the
//! restricted discrete Lagrangian (see [`super`]), solved by Newton's method whose matrix, the
//! residual's exact derivative plus the drives' diagonal, is eliminated in linear time
//! ([`super::aba`]), factorised at the predictor and again only where the iterate moves far
//! from it.
//!
//! Unknowns: the joints' `θ_{k+1}` and, for a floating root, `ξ_0` (`R_0' = R_0 exp(ξ_0)`) and
//! `Δc_0`. Residual at an iterate (generalized momentum, one entry per coordinate):
//!
//! ```text
//! r(q') = Σ_i J_i(q_k)ᵀ (μ_i⁺(q_k, q') − μ_i) − (h/2) τ̄(θ_k, θ')
//! ```
//!
//! with `μ_i = (p_i, M_i)` the momenta the batch carries (the last step's end momenta, plus
//! whatever kicked them since: applied loads, contact), the body's post-momentum of the
//! free-body discrete Lagrangian (`ξ_i = log(R_iᵀ R_i')`, `Δc_i = c_i' − c_i`):
//!
//! ```text
//! p_i⁺ = m_i (Δc_i / h − α h g),        M_i⁺ = T(ξ_i)⁻ᵀ J_i ξ_i / h = (I + ½ ξ^ + D ξ^²) J_i ξ_i / h
//! p_i⁻ = m_i (Δc_i / h + (1 − α) h g),  M_i⁻ = exp(ξ_i)ᵀ M_i⁺ = (I − ½ ξ^ + D ξ^²) J_i ξ_i / h
//! ```
//!
//! (`T(ξ) = exp(ξ) T(−ξ)`; `D` of `crate::sim::so3::d_coefficient`), and `J_iᵀ` applied by one
//! pass from the leaves ([`super::kinematics::JointAxis::force`]). The update solves
//! `K δq = −h r` with `K = h ∂r/∂q'` ([`super::aba`]: `Σ J_i(q_k)ᵀ A_i J_i(q')`, plus
//! `c_j = −(h²/2) ∂τ̄_j/∂θ'_j ≥ 0`, the drive's implicit stiffness and damping, so a stiff
//! servo stays stable at any `h² kp / I`). `K` is factorised at the first iterate (the warm
//! start's extrapolation, within O(h³) of the solution), and again when the iterate has
//! moved more than [`REFACTOR_MOVE`] from where it was factorised, when an update contracts
//! by less than [`REFACTOR_RATE`], or when a drive's slope changes (an effort limit reached
//! or left): the iteration contracts by about the distance moved since the factorisation,
//! so a warm step typically takes one or two updates.
//!
//! Stopping rule: with the update norm `‖δq‖` scaled per coordinate by its tolerance
//! (`κ newton_tol` rad for angles, `κ newton_tol L` m for lengths, each with the round-off of
//! its value), the iterate is accepted when `‖δq_n‖ ≤ 1`, or, for an update from a matrix
//! factorised at its own iterate, when `10 c ‖δq_n‖² ≤ 1` with `c` the curvature
//! `‖δq_n‖ / ‖δq_{n−1}‖²` measured in this same solve (Newton's quadratic convergence).
//! `ρ = ‖δq_n‖ / ‖δq_{n−1}‖ ≥ 1` fails unless the update is already at round-off. Estimates
//! carried from the last step (its contraction `ρ/(1−ρ) ‖δq‖ ≤ 1`, its curvature) predicted
//! the remaining error badly: a servo step accepted iterates 1e-8 rad off, and a stiff servo
//! under gravity settled 2e-6 rad from its balance (tests/mechanism/balance.rs); the rule
//! measures in the solve itself, at some 1.3x the cost per step on chain7.
//!
//! At the accepted iterate, the end momenta `μ_i⁻` are written to the batch with the drives'
//! end impulses `(h/2) τ̄` (a couple along a hinge's axis, a force pair along a slider's), the
//! poses from forward kinematics. For a floating root the residual of its own six equations
//! (the total momentum's change, by discrete Noether) is taken off the root's end momentum, so
//! the total linear and angular momentum of a free-floating tree are exact to round-off
//! whatever the tolerance; the step then solves the discrete equations with a start impulse
//! and the opposite end impulse, both of the size of the Newton residual.
//!
//! Guards, as for the maximal step: a warm start that fails is retried cold (no increment),
//! then the step is split in `2, 4, …, max_substeps` substeps.

use super::aba::{Jacobian, body_block, root_maps};
use super::kinematics::{HalfAngles, JointAxis, Pose, forward};
use super::model::{TreeJointKind, TreeModel};
use super::stops::{MAX_SWITCHES, TreeStops};
use crate::sim::Bodies;
use crate::sim::integrators::{StepStats, VariationalSettings};
use crate::sim::loads::{KickLedger, Loads};
use crate::sim::mechanism::Mechanism;
use crate::sim::mechanism::drive::StepEffort;
use crate::sim::mechanism::step::{DriveWork, Failure};
use crate::sim::so3::d_coefficient;
use nalgebra::{Quaternion, UnitQuaternion, Vector3, Vector6};

/// Warm start of one step size: the last three accepted increments (joints, root `ξ_0`,
/// `Δc_0`), newest first.
#[derive(Debug, Clone)]
pub struct TreeWarm {
    dtheta: [Vec<f64>; 3],
    root: [[Vector3<f64>; 2]; 3],
    /// How many of the increments are set (0: no warm start).
    depth: usize,
}

/// The extrapolation of the last `depth` increments to the next one: constant, linear,
/// quadratic (errors O(h²), O(h³), O(h⁴) of the increment).
const EXTRAPOLATION: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [2.0, -1.0, 0.0], [3.0, -3.0, 1.0]];

impl TreeWarm {
    pub fn new(tree: &TreeModel) -> Self {
        let n = tree.joints.len();
        Self {
            dtheta: std::array::from_fn(|_| vec![0.0; n]),
            root: [[Vector3::zeros(); 2]; 3],
            depth: 0,
        }
    }

    fn valid(&self) -> bool {
        self.depth > 0
    }

    fn invalidate(&mut self) {
        self.depth = 0;
    }

    fn push(&mut self, dtheta: &[f64], root: [Vector3<f64>; 2]) {
        self.dtheta.rotate_right(1);
        self.root.rotate_right(1);
        self.dtheta[0].copy_from_slice(dtheta);
        self.root[0] = root;
        self.depth = (self.depth + 1).min(3);
    }

    /// Keeps only the newest increment, times `factor` (a substepped step's last substep
    /// scaled to the full step).
    fn scale(&mut self, factor: f64) {
        self.depth = self.depth.min(1);
        self.dtheta[0].iter_mut().for_each(|d| *d *= factor);
        self.root[0].iter_mut().for_each(|r| *r *= factor);
    }

    /// The predicted increment of joint `j`.
    fn joint(&self, j: usize) -> f64 {
        let w = &EXTRAPOLATION[self.depth - 1];
        w[0] * self.dtheta[0][j] + w[1] * self.dtheta[1][j] + w[2] * self.dtheta[2][j]
    }

    /// The predicted root increment (`ξ_0`, `Δc_0`).
    fn root(&self, k: usize) -> Vector3<f64> {
        let w = &EXTRAPOLATION[self.depth - 1];
        self.root[0][k] * w[0] + self.root[1][k] * w[1] + self.root[2][k] * w[2]
    }
}

/// One body's saved state (for the substep guard).
type Saved = (
    UnitQuaternion<f64>,
    Vector3<f64>,
    Vector3<f64>,
    Vector3<f64>,
);

/// The state of a tree between steps (`θ_k`, the poses at `q_k`) and the step's buffers.
#[derive(Debug, Clone)]
pub struct TreeState {
    pub tree: TreeModel,
    /// `θ_k` per joint (rad or m): carried from step to step, never read back from the poses.
    pub theta: Vec<f64>,
    poses: Vec<Pose>,
    axes: Vec<JointAxis>,
    world: Pose,
    theta_next: Vec<f64>,
    root_xi: Vector3<f64>,
    root_dc: Vector3<f64>,
    poses_next: Vec<Pose>,
    axes_next: Vec<JointAxis>,
    /// Per body: `ξ_i` at the iterate, and the momenta read at the start (`p`, `M`).
    xi: Vec<Vector3<f64>>,
    momenta: Vec<(Vector3<f64>, Vector3<f64>)>,
    /// Per body: the subtree's wrench `(n_o, f)`.
    wrench: Vec<(Vector3<f64>, Vector3<f64>)>,
    jacobian: Jacobian,
    diag: Vec<f64>,
    residual: Vec<f64>,
    delta: Vec<f64>,
    /// Per joint: the index of its drive in `MechanismModel::drives`.
    drive_of_joint: Vec<Option<usize>>,
    /// Per joint: the drive's step effort at the iterate.
    effort: Vec<StepEffort>,
    /// Per joint: whether the drive's effort depends on time alone (an undamped motor).
    time_only: Vec<bool>,
    time0_secs: f64,
    pub drive_work: DriveWork,
    pub load_work: KickLedger,
    saved: Vec<Saved>,
    saved_theta: Vec<f64>,
    /// The largest position coordinate of the tree's bodies at `q_k` (m).
    c_max: f64,
    /// Per joint, `(sin, cos)(θ/2)` at `θ_k` and at the iterate.
    half: Vec<(f64, f64)>,
    half_next: Vec<(f64, f64)>,
    /// The joint limits and friction ([`super::stops`]).
    stops: TreeStops,
    /// Per joint, a stop's position tolerance at this step (rad, or m).
    stop_slack: Vec<f64>,
}

type Attempt = Result<u32, (Failure, u32)>;

/// The iteration is allowed this many times `newton_max_iters` updates (the maximal step's
/// setting, which counts its own full Newton updates).
const ITERATION_FACTOR: u32 = 2;

/// The iteration stops when the error it predicts is below this fraction of the tolerance
/// (with the matrix kept from an earlier iterate the iteration converges linearly: the last
/// update's size says little of the remaining error, the contraction does). Small, so that
/// two runs that differ by round-off stop at iterates that differ by little more than
/// round-off.
const KAPPA: f64 = 1e-2;

/// An update this many targets large that no longer shrinks is taken as round-off.
const ROUNDOFF_NORM: f64 = 100.0;

/// The Newton matrix is refactorised when the iterate has moved this far (rad, or lengths
/// over `L`) from where it was factorised: its entries change by O(1) of themselves per
/// radian, so the iteration then contracts by about this much per update.
const REFACTOR_MOVE: f64 = 1e-2;

/// … or when an update contracted by less than this.
const REFACTOR_RATE: f64 = 0.05;

/// An update from a matrix factorised at its own iterate leaves an error of about
/// `c ‖δ‖²` (Newton's quadratic convergence, `c` the curvature measured in the same solve):
/// the iterate is accepted when this many times that is below the tolerance.
const CURVATURE_SAFETY: f64 = 10.0;

/// The curvature is measured only from updates this many targets large (smaller ones are
/// too near round-off for their square to mean anything).
const CURVATURE_MIN_NORM: f64 = 30.0;

impl TreeState {
    pub fn new(mechanism: &Mechanism, tree: TreeModel) -> Self {
        let nb = mechanism.body_count;
        let nj = tree.joints.len();
        let mut drive_of_joint = vec![None; nj];
        let mut time_only = vec![false; nj];
        for (k, d) in mechanism.drives.iter().enumerate() {
            let j = tree.coordinate_joint[d.coordinate];
            drive_of_joint[j] = Some(k);
            time_only[j] = crate::sim::mechanism::step::time_only(mechanism, d);
        }
        let identity = Pose::new(UnitQuaternion::identity(), Vector3::zeros());
        Self {
            theta: mechanism
                .joints
                .iter()
                .enumerate()
                .map(|(j, _)| mechanism.coordinates[tree.joints[j].coordinate].initial)
                .collect(),
            poses: vec![identity; nb],
            axes: vec![JointAxis::default(); nj],
            world: Pose::of_body(&mechanism.world_pose),
            theta_next: vec![0.0; nj],
            root_xi: Vector3::zeros(),
            root_dc: Vector3::zeros(),
            poses_next: vec![identity; nb],
            axes_next: vec![JointAxis::default(); nj],
            xi: vec![Vector3::zeros(); nb],
            momenta: vec![(Vector3::zeros(), Vector3::zeros()); nb],
            wrench: vec![(Vector3::zeros(), Vector3::zeros()); nb],
            jacobian: Jacobian::new(&tree, nb),
            diag: vec![0.0; nj],
            residual: vec![0.0; tree.dofs()],
            delta: vec![0.0; tree.dofs()],
            drive_of_joint,
            effort: vec![StepEffort::default(); nj],
            time_only,
            time0_secs: 0.0,
            drive_work: DriveWork::default(),
            load_work: KickLedger::default(),
            saved: Vec::new(),
            saved_theta: vec![0.0; nj],
            c_max: 0.0,
            half: vec![(0.0, 1.0); nj],
            half_next: vec![(0.0, 1.0); nj],
            stops: TreeStops::new(mechanism, &tree),
            stop_slack: vec![0.0; nj],
            tree,
        }
    }

    /// The joint coordinates (the step's state), written in the model's coordinate order.
    pub fn coordinates_into(&self, out: &mut [f64]) {
        for (value, &j) in out.iter_mut().zip(&self.tree.coordinate_joint) {
            *value = self.theta[j];
        }
    }

    /// Reads `q` from the batch's poses (each angle on the branch nearest the coordinate's
    /// current value, the start value at first); the step starts from where forward
    /// kinematics places the bodies at `q` (the batch's poses to round-off), and the first
    /// step writes them.
    pub fn init(&mut self, mechanism: &Mechanism, bodies: &Bodies) {
        let first = mechanism.first_body;
        let body_pose = |i: usize| crate::sim::mechanism::BodyPose {
            rot: bodies.world_from_body[first + i]
                .to_rotation_matrix()
                .into_inner(),
            com: bodies.com_world[first + i],
        };
        for (j, joint) in self.tree.joints.iter().enumerate() {
            let a = match joint.parent {
                Some(p) => body_pose(p),
                None => mechanism.world_pose,
            };
            let b = body_pose(joint.child);
            let c = &mechanism.coordinates[joint.coordinate];
            if let Some(v) = c.kind.value(&a, &b, self.theta[j]) {
                self.theta[j] = v;
            }
        }
        let root = Pose::new(bodies.world_from_body[first], bodies.com_world[first]);
        self.forward_at_k(&root);
        if !self.stops.is_empty() {
            let rates = self.joint_rates(mechanism, bodies);
            self.stops.set_initial_rates(&rates);
        }
    }

    /// Each joint's rate from the batch's velocities: the relative angular velocity along a
    /// hinge's axis, the relative velocity of the anchor point along a slider's (the rates
    /// the initial state was set from).
    fn joint_rates(&self, mechanism: &Mechanism, bodies: &Bodies) -> Vec<f64> {
        let first = mechanism.first_body;
        let motion = |i: Option<usize>, point: &Vector3<f64>| match i {
            Some(i) => {
                let gi = first + i;
                let r = bodies.world_from_body[gi];
                let w = r * bodies.inv_inertia_body[gi].component_mul(&bodies.angmom_body[gi]);
                let v = bodies.linvel_world[gi] + w.cross(&(point - bodies.com_world[gi]));
                (w, v)
            }
            None => (Vector3::zeros(), Vector3::zeros()),
        };
        self.tree
            .joints
            .iter()
            .enumerate()
            .map(|(j, joint)| {
                let a = &self.axes[j];
                let (wc, vc) = motion(Some(joint.child), &a.point);
                let (wp, vp) = motion(joint.parent, &a.point);
                match joint.kind {
                    TreeJointKind::Hinge => a.axis.dot(&(wc - wp)),
                    TreeJointKind::Slider => a.axis.dot(&(vc - vp)),
                }
            })
            .collect()
    }
}

/// Advances the tree by `h` between the applied loads' trapezoid kicks (see the module doc).
pub fn step(
    mechanism: &Mechanism,
    state: &mut TreeState,
    warm: &mut TreeWarm,
    bodies: &mut Bodies,
    h: f64,
    loads: &Loads,
    settings: &VariationalSettings,
) -> StepStats {
    let t0 = loads.time_secs();
    let range = mechanism.bodies();
    let kicked = loads.loads_any(&range);
    if kicked {
        state.load_work.begin();
        loads.kick(bodies, &range, t0, 0.5 * h, &mut state.load_work);
    }
    state.time0_secs = t0;
    let stats = step_unforced(mechanism, state, warm, bodies, h, loads, settings);
    if kicked {
        state.load_work.end();
        loads.kick(bodies, &range, t0 + h, 0.5 * h, &mut state.load_work);
    }
    stats
}

fn step_unforced(
    mechanism: &Mechanism,
    st: &mut TreeState,
    warm: &mut TreeWarm,
    bodies: &mut Bodies,
    h: f64,
    loads: &Loads,
    settings: &VariationalSettings,
) -> StepStats {
    let mut stats = StepStats::default();
    let first = st.attempt(
        mechanism,
        bodies,
        h,
        loads,
        settings,
        warm.valid().then_some(&*warm),
    );
    let outcome = match first {
        Err((_, it)) if warm.valid() => {
            stats.newton_iters_max = it;
            st.attempt(mechanism, bodies, h, loads, settings, None)
        }
        other => other,
    };
    match outcome {
        Ok(it) => {
            stats.newton_iters_max = stats.newton_iters_max.max(it);
            st.commit(mechanism, bodies, h, loads, settings, warm);
        }
        Err((_, it)) => {
            stats.newton_iters_max = stats.newton_iters_max.max(it);
            if !settings.substep {
                st.commit(mechanism, bodies, h, loads, settings, warm);
                warm.invalidate();
                stats.add_solve(mechanism.first_body, it, false);
                return stats;
            }
            split(mechanism, st, warm, bodies, h, loads, settings, &mut stats);
            st.time0_secs = loads.time_secs();
        }
    }
    stats
}

/// The substep guard: `n = 2, 4, …` steps of `h/n`, the first split at which every substep
/// converges kept.
#[allow(clippy::too_many_arguments)]
#[cold]
fn split(
    mechanism: &Mechanism,
    st: &mut TreeState,
    warm: &mut TreeWarm,
    bodies: &mut Bodies,
    h: f64,
    loads: &Loads,
    settings: &VariationalSettings,
    stats: &mut StepStats,
) {
    st.save(mechanism, bodies);
    let work = st.drive_work;
    stats.substepped += 1;
    let mut n = 2u32;
    while n <= settings.max_substeps {
        let hs = h / f64::from(n);
        let mut sub_warm = TreeWarm::new(&st.tree);
        let mut ok = true;
        for s in 0..n {
            st.time0_secs = loads.time_secs() + f64::from(s) * hs;
            let start = sub_warm.valid().then_some(&sub_warm);
            let mut result = st.attempt(mechanism, bodies, hs, loads, settings, start);
            if result.is_err() && sub_warm.valid() {
                result = st.attempt(mechanism, bodies, hs, loads, settings, None);
            }
            match result {
                Ok(it) => {
                    stats.newton_iters_max = stats.newton_iters_max.max(it);
                    st.commit(mechanism, bodies, hs, loads, settings, &mut sub_warm);
                }
                Err(_) => {
                    ok = false;
                    break;
                }
            }
        }
        if ok {
            stats.substep_factor_max = stats.substep_factor_max.max(n);
            sub_warm.scale(f64::from(n));
            *warm = sub_warm;
            return;
        }
        st.restore(mechanism, bodies);
        st.drive_work = work;
        n *= 2;
    }
    stats.substep_factor_max = stats.substep_factor_max.max(settings.max_substeps);
    warm.invalidate();
    stats.add_solve(mechanism.first_body, settings.newton_max_iters, false);
}

/// `log(q)` for a unit quaternion: the rotation vector of the shorter way.
#[inline]
fn log_quaternion(q: &Quaternion<f64>) -> Vector3<f64> {
    let (w, v) = if q.w < 0.0 {
        (-q.w, -q.imag())
    } else {
        (q.w, q.imag())
    };
    let s = v.norm();
    // 2 atan2(s, w) / s = (2/w) atan(x)/x with x = s/w, by series where x ≤ 0.05 (the first
    // omitted term, x¹⁴/15, is below 5e-20 there).
    let k = if s <= 0.05 * w {
        let x = s / w;
        let x2 = x * x;
        (2.0 / w)
            * (1.0
                + x2 * (-1.0 / 3.0
                    + x2 * (1.0 / 5.0
                        + x2 * (-1.0 / 7.0 + x2 * (1.0 / 9.0 + x2 * (-1.0 / 11.0 + x2 / 13.0))))))
    } else {
        2.0 * s.atan2(w) / s
    };
    v * k
}

impl TreeState {
    fn save(&mut self, mechanism: &Mechanism, bodies: &Bodies) {
        self.saved.clear();
        for i in mechanism.bodies() {
            self.saved.push((
                bodies.world_from_body[i],
                bodies.com_world[i],
                bodies.linvel_world[i],
                bodies.angmom_body[i],
            ));
        }
        self.saved_theta.copy_from_slice(&self.theta);
        self.stops.save();
    }

    fn restore(&mut self, mechanism: &Mechanism, bodies: &mut Bodies) {
        for (k, i) in mechanism.bodies().enumerate() {
            let s = self.saved[k];
            bodies.world_from_body[i] = s.0;
            bodies.com_world[i] = s.1;
            bodies.linvel_world[i] = s.2;
            bodies.angmom_body[i] = s.3;
        }
        self.theta.copy_from_slice(&self.saved_theta);
        self.stops.restore();
        let root = Pose::new(self.saved[0].0, self.saved[0].1);
        self.forward_at_k(&root);
    }

    /// The step's drive efforts at the iterate `θ'` (all but the time-only ones), and whether
    /// any slope changed from `diag` (a refactorisation is due).
    fn drive_efforts(&mut self, mechanism: &Mechanism, h: f64) -> bool {
        let mut changed = false;
        for (j, d) in self.drive_of_joint.iter().enumerate() {
            let Some(k) = *d else { continue };
            if self.time_only[j] {
                continue;
            }
            let e = mechanism.drives[k].step_effort(
                self.time0_secs,
                h,
                self.theta[j],
                self.theta_next[j],
            );
            let a = -0.5 * h * h * e.slope;
            if a != self.diag[j] {
                self.diag[j] = a;
                changed = true;
            }
            self.effort[j] = e;
        }
        changed
    }

    /// The residual of each driven joint less the drive's impulse `½ h τ` (the discrete
    /// Lagrange-d'Alembert force at the iterate, [`Self::drive_efforts`]).
    fn subtract_drive_efforts(&mut self, h: f64) {
        let nb = self.tree.base_dofs();
        for (j, d) in self.drive_of_joint.iter().enumerate() {
            if d.is_some() {
                self.residual[nb + j] -= 0.5 * h * self.effort[j].effort.total();
            }
        }
    }

    /// What a step reads at its start: the momenta the batch carries, the positions' size,
    /// the left twists (at `q_k`, about `o`).
    fn begin(&mut self, mechanism: &Mechanism, bodies: &Bodies) {
        let first = mechanism.first_body;
        let o = self.poses[0].com;
        for i in 0..self.poses.len() {
            let gi = first + i;
            self.momenta[i] = (
                bodies.linvel_world[gi] * bodies.mass[gi],
                bodies.angmom_body[gi],
            );
        }
        self.c_max = self.poses.iter().fold(0.0, |m, p| m.max(p.com.amax()));
        for (j, joint) in self.tree.joints.iter().enumerate() {
            let (w, v) = self.axes[j].twist(joint.kind, &o);
            self.jacobian.left[j] = Vector6::new(w.x, w.y, w.z, v.x, v.y, v.z);
        }
    }

    /// The Newton matrix at the iterate (`poses_next`, `axes_next`, `xi`: after
    /// [`Self::residuals`]), factorised; `false` when it is singular there.
    fn factor_at_iterate(&mut self, bodies: &Bodies, first: usize, o: &Vector3<f64>) -> bool {
        for i in 0..self.poses.len() {
            let gi = first + i;
            self.jacobian.articulated[i] = body_block(
                &self.poses[i],
                &self.poses_next[i],
                &self.xi[i],
                &bodies.inertia_body[gi],
                bodies.mass[gi],
                o,
            );
        }
        for (j, joint) in self.tree.joints.iter().enumerate() {
            let (w, v) = self.axes_next[j].twist(joint.kind, o);
            self.jacobian.right[j] = Vector6::new(w.x, w.y, w.z, v.x, v.y, v.z);
        }
        if self.tree.floating {
            let (left, right) = root_maps(&self.poses[0], &self.poses_next[0], &self.root_xi, o);
            self.jacobian.root_left = left;
            self.jacobian.root_right = right;
        }
        self.jacobian
            .factor(&self.tree, &self.diag, &self.stops.locked)
    }

    /// One attempt at the step from `warm` (or from no increment): the Newton iterations
    /// (see the module doc); the accepted iterate is left in `theta_next`, `root_*`,
    /// `poses_next`, `xi`.
    fn attempt(
        &mut self,
        mechanism: &Mechanism,
        bodies: &Bodies,
        h: f64,
        loads: &Loads,
        settings: &VariationalSettings,
        warm: Option<&TreeWarm>,
    ) -> Attempt {
        let first = mechanism.first_body;
        let nb = self.tree.base_dofs();
        let o = self.poses[0].com;
        let alpha = settings.potential.alpha();
        let g = *loads.gravity();
        self.begin(mechanism, bodies);
        // The predictor: the last increments extrapolated, or none.
        match warm {
            Some(w) => {
                for j in 0..self.theta.len() {
                    self.theta_next[j] = self.theta[j] + w.joint(j);
                }
                self.root_xi = w.root(0);
                self.root_dc = w.root(1);
            }
            None => {
                self.theta_next.copy_from_slice(&self.theta);
                self.root_xi = Vector3::zeros();
                self.root_dc = Vector3::zeros();
            }
        }
        let t0 = self.time0_secs;
        for (j, d) in self.drive_of_joint.iter().enumerate() {
            match *d {
                Some(k) if self.time_only[j] => {
                    self.effort[j] =
                        mechanism.drives[k].step_effort(t0, h, self.theta[j], self.theta[j]);
                    self.diag[j] = 0.0;
                }
                _ => self.diag[j] = 0.0,
            }
        }
        let tol = settings.newton_tol;
        let length = mechanism.length_scale;
        // The stops: their position tolerance, their impulses' scale (the momenta and a
        // step's weight), the committed modes applied to the predictor.
        let mut switches = 0;
        let mut nu_scale = 0.0;
        if !self.stops.is_empty() {
            for (j, joint) in self.tree.joints.iter().enumerate() {
                self.stop_slack[j] = match joint.kind {
                    TreeJointKind::Hinge => tol + 4.0 * f64::EPSILON * self.theta[j].abs(),
                    TreeJointKind::Slider => {
                        tol * length + 4.0 * f64::EPSILON * self.theta[j].abs()
                    }
                };
            }
            for (i, (p, m)) in self.momenta.iter().enumerate() {
                let mass = bodies.mass[first + i];
                nu_scale += p.norm() * length + m.norm() + h.abs() * mass * g.norm() * length;
            }
            let slack = &self.stop_slack;
            self.stops.begin(
                &mechanism.stops,
                &self.theta,
                &mut self.theta_next,
                h,
                |j| slack[j],
            );
        }
        let mut previous = f64::INFINITY;
        // The contraction and the curvature, measured in this solve (none yet).
        let mut rate = 1.0;
        let mut curvature = f64::INFINITY;
        // Whether this update's and the last update's matrix was factorised at its iterate.
        let mut fresh = false;
        // The matrix is factorised at the first iterate (the predictor) and again wherever
        // the iterate has moved far from where it was factorised or the iteration contracts
        // slowly: Newton's method with the derivative refreshed as needed.
        let mut refactor = true;
        let mut moved: f64 = 0.0;
        let max_iters = ITERATION_FACTOR * settings.newton_max_iters;
        for it in 1..=max_iters {
            self.forward_next(false);
            self.residuals(mechanism, bodies, h, alpha, &g, &o);
            refactor |= self.drive_efforts(mechanism, h);
            let fresh_before = fresh;
            fresh = refactor;
            if refactor {
                if !self.factor_at_iterate(bodies, first, &o) {
                    return Err((Failure::Singular, it));
                }
                moved = 0.0;
            }
            self.subtract_drive_efforts(h);
            self.stops.residual(&mut self.residual, nb);
            if self.residual.iter().any(|r| !r.is_finite()) {
                return Err((Failure::NonFinite, it));
            }
            for r in self.residual.iter_mut() {
                *r *= -h;
            }
            self.jacobian
                .solve(&self.tree, &self.residual, &mut self.delta);
            // Apply, and the scaled norm.
            let mut norm: f64 = 0.0;
            // Per coordinate, the target `κ tol` (rad, or m through `L`) plus the round-off
            // of the positions the residual is computed from (`8 ε |c|`, m; over `L`, rad).
            let c_floor = 8.0 * f64::EPSILON * self.c_max;
            let (target_rad, target_m) = (
                KAPPA * tol + c_floor / length,
                KAPPA * tol * length + c_floor,
            );
            if self.tree.floating {
                let dxi = Vector3::new(self.delta[0], self.delta[1], self.delta[2]);
                let dc = Vector3::new(self.delta[3], self.delta[4], self.delta[5]);
                self.root_xi += dxi;
                self.root_dc += dc;
                norm = norm.max(dxi.amax() / target_rad).max(dc.amax() / target_m);
                moved = moved.max(dxi.amax()).max(dc.amax() / length);
            }
            for (j, joint) in self.tree.joints.iter().enumerate() {
                let d = self.delta[nb + j];
                self.theta_next[j] += d;
                let own = 4.0 * f64::EPSILON * self.theta_next[j].abs();
                let (scale, size) = match joint.kind {
                    TreeJointKind::Hinge => (target_rad + own, d.abs()),
                    TreeJointKind::Slider => (target_m + own, d.abs() / length),
                };
                norm = norm.max(d.abs() / scale);
                moved = moved.max(size);
            }
            if !norm.is_finite() {
                return Err((Failure::NonFinite, it));
            }
            if it > 1 {
                if fresh_before && previous >= CURVATURE_MIN_NORM {
                    curvature = norm / (previous * previous);
                }
                rate = norm / previous;
                if rate >= 1.0 && norm > ROUNDOFF_NORM {
                    return Err((Failure::Diverging, it));
                }
            }
            // Updates that stop shrinking near the target are round-off. The curvature
            // predicts the remaining error only when measured in this solve: carried from the
            // last step (as the contraction once was too) it came from another iterate's
            // regime, and accepted updates some 1e8 targets large (a stiff servo under gravity
            // then settled 2e-6 rad off its balance; tests/mechanism/balance.rs).
            let stalled = it > 1 && rate >= 1.0;
            if stalled
                || norm <= 1.0
                || (fresh && CURVATURE_SAFETY * curvature * norm * norm <= 1.0)
            {
                if !self.switch_stops(mechanism, h, tol, nu_scale, &mut switches) {
                    self.held_impulses_at_iterate(mechanism, bodies, h, alpha, &g, &o);
                    return Ok(it);
                }
                // A stop changed mode: the step is solved again from here, with the matrix of
                // the new locks.
                refactor = true;
                previous = f64::INFINITY;
                continue;
            }
            refactor = moved > REFACTOR_MOVE || (it > 1 && rate > REFACTOR_RATE);
            previous = norm;
        }
        Err((Failure::NotConverged, max_iters))
    }

    /// The impulses of the held coordinates at the accepted iterate: their equations evaluated
    /// once more after the last update (each `ν_j = r_j` was read before it, and a held
    /// coordinate's impulse moves with the others' updates: a limit's impact then booked the
    /// wrong work, 0.7 % on a two-link arm whose elbow slid as its shoulder hit its stop).
    fn held_impulses_at_iterate(
        &mut self,
        mechanism: &Mechanism,
        bodies: &Bodies,
        h: f64,
        alpha: f64,
        g: &Vector3<f64>,
        o: &Vector3<f64>,
    ) {
        if !self.stops.any_locked() {
            return;
        }
        self.forward_next(false);
        self.residuals(mechanism, bodies, h, alpha, g, o);
        self.drive_efforts(mechanism, h);
        self.subtract_drive_efforts(h);
        let nb = self.tree.base_dofs();
        self.stops.residual(&mut self.residual, nb);
    }

    /// The stops' active set at a converged iterate ([`TreeStops::switch`]): whether a mode
    /// switched, at most [`MAX_SWITCHES`] times per attempt (then the iterate is accepted).
    fn switch_stops(
        &mut self,
        mechanism: &Mechanism,
        h: f64,
        tol: f64,
        nu_scale: f64,
        switches: &mut u32,
    ) -> bool {
        if self.stops.is_empty() || *switches >= MAX_SWITCHES {
            return false;
        }
        let slack = &self.stop_slack;
        let changed = self.stops.switch(
            &mechanism.stops,
            &self.theta,
            &mut self.theta_next,
            h,
            |j| slack[j],
            nu_scale,
            tol,
        );
        *switches += u32::from(changed);
        changed
    }

    /// The poses, axes and half angles at `θ_k` with the root at `root`, exactly.
    fn forward_at_k(&mut self, root: &Pose) {
        forward(
            &self.tree,
            &self.world,
            root,
            &self.theta,
            HalfAngles::Exact,
            &mut self.poses,
            &mut self.axes,
            &mut self.half,
        );
    }

    /// Forward kinematics at the iterate: `exact` for the accepted step (its half angles kept
    /// for the next step), else near `θ_k`.
    fn forward_next(&mut self, exact: bool) {
        let root = if self.tree.floating {
            let p = &self.poses[0];
            Pose::new(
                p.quat * crate::sim::so3::exp_quaternion(&self.root_xi),
                p.com + self.root_dc,
            )
        } else {
            self.poses[0]
        };
        let half = if exact {
            HalfAngles::Exact
        } else {
            HalfAngles::Near {
                theta0: &self.theta,
                half0: &self.half,
            }
        };
        forward(
            &self.tree,
            &self.world,
            &root,
            &self.theta_next,
            half,
            &mut self.poses_next,
            &mut self.axes_next,
            &mut self.half_next,
        );
    }

    /// `ξ_i` at the iterate and the residual `Σ J_iᵀ (μ_i⁺ − μ_i)` (no drive term).
    fn residuals(
        &mut self,
        mechanism: &Mechanism,
        bodies: &Bodies,
        h: f64,
        alpha: f64,
        g: &Vector3<f64>,
        o: &Vector3<f64>,
    ) {
        let first = mechanism.first_body;
        let inv_h = 1.0 / h;
        for i in 0..self.poses.len() {
            let gi = first + i;
            let (p0, p1) = (&self.poses[i], &self.poses_next[i]);
            let xi = if i == 0 && self.tree.floating {
                self.root_xi
            } else {
                log_quaternion(&(p0.quat.conjugate() * p1.quat).into_inner())
            };
            self.xi[i] = xi;
            let m = bodies.mass[gi];
            let y = bodies.inertia_body[gi].component_mul(&xi) * inv_h;
            let xy = xi.cross(&y);
            let d = d_coefficient(xi.norm_squared());
            let m_plus = y + xy * 0.5 + xi.cross(&xy) * d;
            let p_plus = ((p1.com - p0.com) * inv_h - g * (alpha * h)) * m;
            let (p, mb) = &self.momenta[i];
            let dp = p_plus - p;
            let dm = m_plus - mb;
            self.wrench[i] = (p0.rot * dm + (p0.com - o).cross(&dp), dp);
        }
        let nb = self.tree.base_dofs();
        for (j, joint) in self.tree.joints.iter().enumerate().rev() {
            let (n, f) = self.wrench[joint.child];
            self.residual[nb + j] = self.axes[j].force(joint.kind, o, &n, &f);
            if let Some(p) = joint.parent {
                self.wrench[p].0 += n;
                self.wrench[p].1 += f;
            }
        }
        if self.tree.floating {
            let (n, f) = self.wrench[0];
            let t = self.poses[0].rot.transpose() * n;
            self.residual[..3].copy_from_slice(t.as_slice());
            self.residual[3..6].copy_from_slice(f.as_slice());
        }
    }

    /// Writes the accepted iterate into the batch (see the module doc) and the warm start.
    fn commit(
        &mut self,
        mechanism: &Mechanism,
        bodies: &mut Bodies,
        h: f64,
        loads: &Loads,
        settings: &VariationalSettings,
        warm: &mut TreeWarm,
    ) {
        let first = mechanism.first_body;
        let alpha = settings.potential.alpha();
        let g = *loads.gravity();
        let o = self.poses[0].com;
        self.forward_next(true);
        let inv_h = 1.0 / h;
        if self.tree.floating {
            // The root's translation equations are linear in `Δc_0`: shifting the whole tree
            // by `δ` changes their residual `Σ (p_i⁺ − p_i)` by `m δ / h`. Solved exactly, so
            // the centre of mass moves with the total momentum it carries.
            let (mut f, mut mass) = (Vector3::zeros(), 0.0);
            for i in 0..self.poses.len() {
                let m = bodies.mass[first + i];
                let dc = self.poses_next[i].com - self.poses[i].com;
                f += (dc * inv_h - g * (alpha * h)) * m - self.momenta[i].0;
                mass += m;
            }
            let shift = f * (-h / mass);
            self.root_dc += shift;
            for p in self.poses_next.iter_mut() {
                p.com += shift;
            }
            for a in self.axes_next.iter_mut() {
                a.point += shift;
            }
        }
        let mut total = (Vector3::zeros(), Vector3::zeros());
        for i in 0..self.poses.len() {
            let gi = first + i;
            let (p0, p1) = (&self.poses[i], &self.poses_next[i]);
            let xi = if i == 0 && self.tree.floating {
                self.root_xi
            } else {
                log_quaternion(&(p0.quat.conjugate() * p1.quat).into_inner())
            };
            let m = bodies.mass[gi];
            let y = bodies.inertia_body[gi].component_mul(&xi) * inv_h;
            let xy = xi.cross(&y);
            let d = d_coefficient(xi.norm_squared());
            let x2y = xi.cross(&xy) * d;
            let velocity = (p1.com - p0.com) * inv_h;
            if self.tree.floating {
                // μ⁺ − μ: the root equations' residual, summed (world, about o).
                let m_plus = y + xy * 0.5 + x2y;
                let p_plus = (velocity - g * (alpha * h)) * m;
                let (p, mb) = &self.momenta[i];
                let dp = p_plus - p;
                total.0 += p0.rot * (m_plus - mb) + (p0.com - o).cross(&dp);
                total.1 += dp;
            }
            bodies.world_from_body[gi] = UnitQuaternion::new_normalize(p1.quat.into_inner());
            bodies.com_world[gi] = p1.com;
            bodies.angmom_body[gi] = y - xy * 0.5 + x2y;
            bodies.linvel_world[gi] = velocity + g * ((1.0 - alpha) * h);
        }
        if self.tree.floating {
            let (n, f) = total;
            let root = &self.poses_next[0];
            let torque = root.rot.transpose() * ((root.com - o).cross(&f) - n);
            bodies.angmom_body[first] += torque;
            bodies.linvel_world[first] -= f / bodies.mass[first];
        }
        // The drives' end impulses and work.
        for (j, d) in self.drive_of_joint.iter().enumerate() {
            if d.is_none() {
                continue;
            }
            let joint = &self.tree.joints[j];
            let e = &self.effort[j];
            let nu = 0.5 * h * e.effort.total();
            let axis = &self.axes_next[j];
            let child = &self.poses_next[joint.child];
            let gc = first + joint.child;
            match joint.kind {
                TreeJointKind::Hinge => {
                    bodies.angmom_body[gc] += child.rot.transpose() * (axis.axis * nu);
                    if let Some(p) = joint.parent {
                        let parent = &self.poses_next[p];
                        bodies.angmom_body[first + p] -= parent.rot.transpose() * (axis.axis * nu);
                    }
                }
                TreeJointKind::Slider => {
                    let force = axis.axis * nu;
                    bodies.linvel_world[gc] += force / bodies.mass[gc];
                    bodies.angmom_body[gc] +=
                        child.rot.transpose() * (axis.point - child.com).cross(&force);
                    if let Some(p) = joint.parent {
                        let parent = &self.poses_next[p];
                        let gp = first + p;
                        bodies.linvel_world[gp] -= force / bodies.mass[gp];
                        bodies.angmom_body[gp] -=
                            parent.rot.transpose() * (axis.point - parent.com).cross(&force);
                    }
                }
            }
            let dtheta = self.theta_next[j] - self.theta[j];
            self.drive_work.actuators += e.effort.actuator * dtheta;
            self.drive_work.damping -= e.effort.damping * dtheta;
        }
        self.stops
            .commit(&self.theta, &self.theta_next, h, &mut self.drive_work);
        for j in 0..self.theta.len() {
            self.delta[j] = self.theta_next[j] - self.theta[j];
        }
        let nj = self.theta.len();
        warm.push(&self.delta[..nj], [self.root_xi, self.root_dc]);
        std::mem::swap(&mut self.theta, &mut self.theta_next);
        std::mem::swap(&mut self.poses, &mut self.poses_next);
        std::mem::swap(&mut self.axes, &mut self.axes_next);
        std::mem::swap(&mut self.half, &mut self.half_next);
    }
}

/// Test access to the residual and the Newton matrix at any iterate.
#[cfg(test)]
impl TreeState {
    /// Sets the iterate from `q` (the root's `ξ_0`, `Δc_0` first for a floating tree, then
    /// the joints) and returns `h r(q)` with the drives' term (undamped-time drives at `θ_k`).
    pub(super) fn scaled_residual_at(
        &mut self,
        mechanism: &Mechanism,
        bodies: &Bodies,
        h: f64,
        g: &Vector3<f64>,
        q: &[f64],
    ) -> Vec<f64> {
        self.begin(mechanism, bodies);
        let nb = self.tree.base_dofs();
        if self.tree.floating {
            self.root_xi = Vector3::new(q[0], q[1], q[2]);
            self.root_dc = Vector3::new(q[3], q[4], q[5]);
        }
        self.theta_next.copy_from_slice(&q[nb..]);
        self.diag.iter_mut().for_each(|d| *d = 0.0);
        self.forward_next(true);
        let o = self.poses[0].com;
        self.residuals(mechanism, bodies, h, 0.5, g, &o);
        self.drive_efforts(mechanism, h);
        self.subtract_drive_efforts(h);
        self.residual.iter().map(|r| r * h).collect()
    }

    /// The poses forward kinematics gives at `q_k` (rotation, centre of mass), per body.
    pub(super) fn poses_at_k(&self) -> Vec<(UnitQuaternion<f64>, Vector3<f64>)> {
        self.poses.iter().map(|p| (p.quat, p.com)).collect()
    }

    /// `K(q)⁻¹ b`, the Newton matrix at the iterate `q` (set by [`Self::scaled_residual_at`]).
    pub(super) fn solve_at_iterate(
        &mut self,
        mechanism: &Mechanism,
        bodies: &Bodies,
        b: &[f64],
    ) -> Vec<f64> {
        let o = self.poses[0].com;
        assert!(self.factor_at_iterate(bodies, mechanism.first_body, &o));
        let mut x = vec![0.0; b.len()];
        self.jacobian.solve(&self.tree, b, &mut x);
        x
    }

    /// The number of generalized coordinates.
    pub(super) fn dofs(&self) -> usize {
        self.tree.dofs()
    }
}
