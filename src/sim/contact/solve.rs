//! The impulses of one step: non-penetration and Coulomb's friction cone at every contact,
//! solved contact by contact (projected Gauss-Seidel with each contact's 3 × 3 block solved in
//! its cone).
//!
//! Each contact `c` has the frame `C = [n t₁ t₂]` (normal from `b` toward `a`, two tangents)
//! and its impulse `λ` on `a` in that frame (`−λ` on `b`). The velocity of the contact over
//! the step, `u = u_free + Cᵀ (Δv_a + Δω_a × r_a − Δv_b − Δω_b × r_b)`, is linear in the
//! impulses: a body's response to an impulse `P` at the arm `r` is `Δv = P / m`,
//! `Δω = I⁻¹ (r × P)` (world inertia at the start of the step). The conditions are
//! Signorini's with Coulomb's cone and maximum dissipation (Stewart & Trinkle 1996;
//! Moreau 1988):
//! - `λ_n ≥ 0`, `u_n ≥ b_n`, `λ_n (u_n − b_n) = 0` (`b_n` the target: `−gap / h` closes the gap
//!   exactly at the end of the step; restitution raises it);
//! - `|λ_t| ≤ μ λ_n`; sticking (`u_t = 0`) inside the cone, sliding on its edge with `λ_t`
//!   opposite the slip.
//!
//! One contact's block given the others: the sticking solution `λ* = λ − W⁻¹ (u − b)` (`W` its
//! 3 × 3 Delassus block) is the answer when it lies in the cone; with `λ*_n ≤ 0` the contact
//! opens (`λ = 0`); otherwise it slides: `λ_t = μ λ_n d` along `d = λ*_t / |λ*_t|`, `λ_n`
//! from the normal row. The sweeps repeat until no impulse changes by more than the
//! tolerance times the largest impulse.

use super::islands;
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use std::ops::Range;

/// One body's response to impulses, and the velocity change they made so far.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Response {
    /// `1 / m`, 1/kg (0: the body does not move, the ground).
    pub inv_mass: f64,
    /// `I⁻¹` in world axes, 1/(kg m²).
    pub inv_inertia_world: Matrix3<f64>,
    /// Velocity change so far, m/s (a free body's).
    pub dv: Vector3<f64>,
    /// Angular velocity change so far, rad/s (a free body's).
    pub dw: Vector3<f64>,
    /// Impulse so far (world), N s.
    pub df: Vector3<f64>,
    /// Angular momentum change so far (world, about the centre of mass), kg m²/s.
    pub dl: Vector3<f64>,
    /// For a body of a mechanism: its [`Group`] and its member index there; its velocity
    /// change is the group's.
    pub member: Option<(usize, usize)>,
}

/// The bodies of one mechanism that can touch: an impulse on any of them moves all of the
/// mechanism's bodies through its joints (`M_c⁻¹`, [`crate::sim::mechanism::constrained`]).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Group {
    /// Per member: its body's index in the mechanism.
    pub local: Vec<usize>,
    /// Per member: the world twists `[v; ω]` of every body of the mechanism (6 rows each)
    /// per unit world wrench `[F; τ]` (about its centre of mass) on the member, `6n × 6`.
    pub columns: Vec<DMatrix<f64>>,
    /// The twists' change so far, `6n`.
    pub twist: DVector<f64>,
    /// Whether warm-start impulses are already in the prediction the rows' free velocities
    /// came from (they are recorded, not applied again).
    pub predicted: bool,
}

impl Group {
    /// Body `local`'s velocity change `(v, ω)` so far.
    fn twist_of(&self, local: usize) -> (Vector3<f64>, Vector3<f64>) {
        let t = self.twist.fixed_rows::<6>(6 * local);
        (
            Vector3::new(t[0], t[1], t[2]),
            Vector3::new(t[3], t[4], t[5]),
        )
    }
}

impl Response {
    /// A free body of `inv_mass` and `inv_inertia_world`, not yet pushed.
    pub fn new(inv_mass: f64, inv_inertia_world: Matrix3<f64>) -> Self {
        Self {
            inv_mass,
            inv_inertia_world,
            dv: Vector3::zeros(),
            dw: Vector3::zeros(),
            df: Vector3::zeros(),
            dl: Vector3::zeros(),
            member: None,
        }
    }

    /// Member `member` of group `group`, not yet pushed.
    pub fn member(group: usize, member: usize) -> Self {
        Self {
            member: Some((group, member)),
            ..Self::new(0.0, Matrix3::zeros())
        }
    }
}

/// The bodies the rows act on: free bodies and the members of mechanisms.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Responses {
    pub bodies: Vec<Response>,
    pub groups: Vec<Group>,
}

impl Responses {
    /// Free bodies only.
    pub fn free(bodies: Vec<Response>) -> Self {
        Self {
            bodies,
            groups: Vec::new(),
        }
    }

    pub fn clear(&mut self) {
        self.bodies.clear();
        self.groups.clear();
    }

    /// The velocity of the point at arm `r` of body `i` per unit impulse at arm `r_j` of body
    /// `j` (world): `[I, −[r]×] C_ij [I; [r_j]×]` with `C_ij` the twist of `i` per wrench on
    /// `j` — for one free body `I/m − [r]× I⁻¹ [r_j]×` — and zero when an impulse on `j`
    /// does not move `i`.
    pub fn block(&self, i: usize, r: &Vector3<f64>, j: usize, r_j: &Vector3<f64>) -> Matrix3<f64> {
        let (bi, bj) = (&self.bodies[i], &self.bodies[j]);
        match (bi.member, bj.member) {
            (None, None) if i == j => {
                Matrix3::identity() * bi.inv_mass
                    - r.cross_matrix() * bi.inv_inertia_world * r_j.cross_matrix()
            }
            (Some((gi, _)), Some((gj, mj))) if gi == gj => {
                let g = &self.groups[gi];
                let li = g.local[bi.member.expect("member").1];
                let c = g.columns[mj].fixed_view::<6, 6>(6 * li, 0);
                let (cvv, cvw) = (c.fixed_view::<3, 3>(0, 0), c.fixed_view::<3, 3>(0, 3));
                let (cwv, cww) = (c.fixed_view::<3, 3>(3, 0), c.fixed_view::<3, 3>(3, 3));
                let (rx, rjx) = (r.cross_matrix(), r_j.cross_matrix());
                cvv + cvw * rjx - rx * cwv - rx * cww * rjx
            }
            _ => Matrix3::zeros(),
        }
    }

    /// The velocity change of the point at arm `r` of body `i` so far.
    pub fn point_velocity(&self, i: usize, r: &Vector3<f64>) -> Vector3<f64> {
        let b = &self.bodies[i];
        match b.member {
            None => b.dv + b.dw.cross(r),
            Some((g, m)) => {
                let g = &self.groups[g];
                let (v, w) = g.twist_of(g.local[m]);
                v + w.cross(r)
            }
        }
    }

    /// Applies the impulse `p` (world) at arm `r` of body `i`.
    pub fn push(&mut self, i: usize, p: &Vector3<f64>, r: &Vector3<f64>) {
        self.push_as(i, p, r, false);
    }

    /// [`Responses::push`] for a warm start: on a member of a group whose prediction already
    /// holds it, only recorded.
    pub fn push_warm(&mut self, i: usize, p: &Vector3<f64>, r: &Vector3<f64>) {
        self.push_as(i, p, r, true);
    }

    fn push_as(&mut self, i: usize, p: &Vector3<f64>, r: &Vector3<f64>, warm: bool) {
        let l = r.cross(p);
        let b = &mut self.bodies[i];
        b.df += p;
        b.dl += l;
        match b.member {
            None => {
                b.dv += p * b.inv_mass;
                b.dw += b.inv_inertia_world * l;
            }
            Some((g, m)) => {
                let g = &mut self.groups[g];
                if !(warm && g.predicted) {
                    let wrench = nalgebra::Vector6::new(p.x, p.y, p.z, l.x, l.y, l.z);
                    g.twist.gemv(1.0, &g.columns[m], &wrench, 1.0);
                }
            }
        }
    }

    /// Per body, the body whose island it belongs to at least (a mechanism's members are one:
    /// its first member), in one pass.
    fn island_seeds(&self) -> Vec<usize> {
        let mut first = vec![usize::MAX; self.groups.len()];
        self.bodies
            .iter()
            .enumerate()
            .map(|(i, b)| match b.member {
                None => i,
                Some((g, _)) => {
                    if first[g] == usize::MAX {
                        first[g] = i;
                    }
                    first[g]
                }
            })
            .collect()
    }
}

/// One contact's row block.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Row {
    /// Which contact of the narrow phase the row is (the caller's index).
    pub source: usize,
    /// Index of `a`'s [`Response`].
    pub a: usize,
    /// Index of `b`'s, `None` for the ground.
    pub b: Option<usize>,
    /// Arms from the centres of mass to the contact, world.
    pub r_a: Vector3<f64>,
    pub r_b: Vector3<f64>,
    /// Columns `n, t₁, t₂`, world.
    pub frame: Matrix3<f64>,
    /// The contact's velocity over the step without impulses, contact frame, m/s.
    pub u_free: Vector3<f64>,
    /// The least normal velocity `b_n`, m/s.
    pub target_n: f64,
    /// Coulomb's coefficient.
    pub mu: f64,
    /// Newton's restitution.
    pub restitution: f64,
    /// For a bounce inside the step: the normal velocity it leaves with at the end of the
    /// step (`e` times its approach), m/s; 0 otherwise.
    pub leave_n: f64,
    /// The Delassus block `W = Cᵀ (K_a + K_b) C` and its inverse.
    pub w: Matrix3<f64>,
    pub w_inv: Matrix3<f64>,
    /// The eigenvalues and eigenvectors of `W`'s tangential 2 × 2 block (for
    /// [`friction_in_disk_eigen`]; set by [`Row::prepare`]).
    pub tangent_eigen: (nalgebra::Vector2<f64>, nalgebra::Matrix2<f64>),
    /// The impulse on `a`, contact frame, N s.
    pub lambda: Vector3<f64>,
}

/// An orthonormal frame `[n t₁ t₂]` for the unit normal `n` (`t₁` across the axis `n` is least
/// along, so the frame is the same for the same normal).
pub fn contact_frame(n: &Vector3<f64>) -> Matrix3<f64> {
    let a = n.iamin();
    let mut e = Vector3::zeros();
    e[a] = 1.0;
    let t1 = n.cross(&e).normalize();
    let t2 = n.cross(&t1);
    Matrix3::from_columns(&[*n, t1, t2])
}

impl Row {
    /// Fills `w` (and `w_inv` where it exists) from the bodies' responses; `false` when the
    /// bodies cannot move along the normal (two bodies that cannot move, a robot's joints).
    pub fn prepare(&mut self, bodies: &Responses) -> bool {
        let mut k = bodies.block(self.a, &self.r_a, self.a, &self.r_a);
        if let Some(b) = self.b {
            k += bodies.block(b, &self.r_b, b, &self.r_b)
                - bodies.block(self.a, &self.r_a, b, &self.r_b)
                - bodies.block(b, &self.r_b, self.a, &self.r_a);
        }
        self.w = self.frame.transpose() * k * self.frame;
        // A normal the bodies cannot move along (a robot's joints hold it): nothing to solve.
        if self.w[(0, 0)] <= 1e-12 * self.w.amax() {
            return false;
        }
        // Singular for a robot that can move its contact point in fewer than three directions.
        self.w_inv = self.w.try_inverse().unwrap_or_else(Matrix3::zeros);
        let w_tt = nalgebra::Matrix2::new(
            self.w[(1, 1)],
            self.w[(1, 2)],
            self.w[(2, 1)],
            self.w[(2, 2)],
        );
        let eig = nalgebra::SymmetricEigen::new(w_tt);
        self.tangent_eigen = (eig.eigenvalues, eig.eigenvectors);
        true
    }

    /// The contact's velocity over the step with the impulses so far, contact frame.
    pub fn velocity(&self, bodies: &Responses) -> Vector3<f64> {
        let mut du = bodies.point_velocity(self.a, &self.r_a);
        if let Some(b) = self.b {
            du -= bodies.point_velocity(b, &self.r_b);
        }
        self.u_free + self.frame.transpose() * du
    }

    /// Starts from `impulse_world` (the same contact's impulse of the last step) projected
    /// into this row's cone, applied to the bodies.
    pub fn warm_start(&mut self, impulse_world: &Vector3<f64>, bodies: &mut Responses) {
        let mut l = self.frame.transpose() * impulse_world;
        l.x = l.x.max(0.0);
        let t = (l.y * l.y + l.z * l.z).sqrt();
        if t > self.mu * l.x && t > 0.0 {
            let f = self.mu * l.x / t;
            l.y *= f;
            l.z *= f;
        }
        if l != Vector3::zeros() {
            let p = self.frame * l;
            bodies.push_warm(self.a, &p, &self.r_a);
            if let Some(b) = self.b {
                bodies.push_warm(b, &(-p), &self.r_b);
            }
            self.lambda = l;
        }
    }

    /// Applies the impulse change `d` (contact frame) to the bodies.
    pub fn apply(&self, d: &Vector3<f64>, bodies: &mut Responses) {
        let p = self.frame * d;
        bodies.push(self.a, &p, &self.r_a);
        if let Some(b) = self.b {
            bodies.push(b, &(-p), &self.r_b);
        }
    }

    /// The block's solution given the others' impulses and the contact's velocity `u` (the
    /// module's rule): the normal row first (`λ_n ≥ 0`, `u_n ≥ b_n`), then the tangential
    /// pair: sticking (`u_t = 0`) when that needs at most `μ λ_n`, otherwise `μ λ_n` against
    /// the slip.
    pub fn local_solve(&self, u: &Vector3<f64>) -> Vector3<f64> {
        let lambda_n = (self.lambda.x - (u.x - self.target_n) / self.w[(0, 0)]).max(0.0);
        let dn = lambda_n - self.lambda.x;
        // The velocity with the new normal impulse.
        let ut = nalgebra::Vector2::new(u.y + self.w[(1, 0)] * dn, u.z + self.w[(2, 0)] * dn);
        let lt = nalgebra::Vector2::new(self.lambda.y, self.lambda.z);
        let w_tt = nalgebra::Matrix2::new(
            self.w[(1, 1)],
            self.w[(1, 2)],
            self.w[(2, 1)],
            self.w[(2, 2)],
        );
        let limit = self.mu * lambda_n;
        // The tangential velocity with this contact's friction removed.
        let u0 = ut - w_tt * lt;
        let t = friction_in_disk_eigen(&self.tangent_eigen, &u0, limit);
        Vector3::new(lambda_n, t.x, t.y)
    }
}

/// The friction impulse of one contact given its free tangential velocity `u0` (this contact's
/// friction removed) and the disk `|λ_t| ≤ limit`: the minimiser of the kinetic energy
/// `½ λᵀ W λ + λᵀ u0` over the disk (maximum dissipation). Inside the disk it is the sticking
/// impulse `−W⁻¹ u0`; on its edge `λ = −(W + γ I)⁻¹ u0` with `γ > 0` such that `|λ| = limit`, so
/// that the final slip `u0 + W λ = −γ λ` is exactly opposite the friction. `γ` solves the
/// secular equation `1/|λ(γ)| = 1/limit` by Newton's method (Moré & Sorensen 1983), in the
/// eigenbasis of the 2 × 2 block `W`.
pub fn friction_in_disk(
    w: &nalgebra::Matrix2<f64>,
    u0: &nalgebra::Vector2<f64>,
    limit: f64,
) -> nalgebra::Vector2<f64> {
    let eig = nalgebra::SymmetricEigen::new(*w);
    friction_in_disk_eigen(&(eig.eigenvalues, eig.eigenvectors), u0, limit)
}

/// [`friction_in_disk`] with `W`'s eigenvalues and eigenvectors given (a row computes them once).
pub fn friction_in_disk_eigen(
    eigen: &(nalgebra::Vector2<f64>, nalgebra::Matrix2<f64>),
    u0: &nalgebra::Vector2<f64>,
    limit: f64,
) -> nalgebra::Vector2<f64> {
    if limit <= 0.0 || *u0 == nalgebra::Vector2::zeros() {
        return nalgebra::Vector2::zeros();
    }
    let (mut a, q) = *eigen;
    // A direction the contact cannot move in (a robot's joints forbid it: `W` singular) keeps
    // its slip whatever the friction; its eigenvalue, zero up to round-off, is raised to
    // `1e-12` of the other so that the secular equation stays finite (the friction along it
    // then opposes the slip at the limit, as maximum dissipation asks).
    let top = a.x.max(a.y);
    if top <= 0.0 {
        return nalgebra::Vector2::zeros();
    }
    a.x = a.x.max(1e-12 * top);
    a.y = a.y.max(1e-12 * top);
    let c = q.transpose() * u0;
    let norm_at = |g: f64| ((c.x / (a.x + g)).powi(2) + (c.y / (a.y + g)).powi(2)).sqrt();
    if a.x > 0.0 && a.y > 0.0 && norm_at(0.0) <= limit {
        return -(q * nalgebra::Vector2::new(c.x / a.x, c.y / a.y));
    }
    // Newton on ψ(γ) = 1/|λ(γ)| − 1/limit, increasing and concave in γ: from the left of the
    // root the iterates increase to it monotonically.
    let mut g = (-a.x.min(a.y)).max(0.0) + 1e-300;
    for _ in 0..50 {
        let n = norm_at(g);
        let dn = -((c.x * c.x) / (a.x + g).powi(3) + (c.y * c.y) / (a.y + g).powi(3)) / n;
        let psi = 1.0 / n - 1.0 / limit;
        let dpsi = -dn / (n * n);
        let step = psi / dpsi;
        g -= step;
        if step.abs() <= 1e-15 * g.abs() {
            break;
        }
    }
    let lambda = -(q * nalgebra::Vector2::new(c.x / (a.x + g), c.y / (a.y + g)));
    // The secular equation holds to round-off; the radial scaling makes |λ| ≤ limit exact.
    let n = lambda.norm();
    if n > limit {
        lambda * (limit / n)
    } else {
        lambda
    }
}

/// What a solve did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SolveStats {
    pub sweeps: u32,
    pub converged: bool,
}

/// Sweeps of projected Gauss-Seidel between two active-set solves.
const SWEEPS_PER_POLISH: u32 = 10;

/// The impulses of `rows` (warm-started from their `lambda`, already applied to `bodies`):
/// projected Gauss-Seidel sweeps in row order, and every [`SWEEPS_PER_POLISH`] sweeps the
/// active-set solve of each island of touching bodies ([`polish`]), which ends the solve
/// exactly when the sweeps found the right active set. Stops when an active-set solve is
/// feasible everywhere, when a sweep changes no impulse by more than `rel_tol × max |λ|`, or
/// when it changes no contact's velocity by more than `rel_tol` times the largest velocity
/// the rows ask for (`|u_free|`, `|b_n|`): redundant contacts — the four corners of a face,
/// a robot's feet — share their impulses in many ways, and the sweeps drift among them long
/// after every velocity is right. At most `max_sweeps` sweeps.
///
/// With `pool` and at least [`islands::MIN_ROWS_ON_POOL`] rows, the islands are solved on the
/// pool's threads ([`islands::solve_on_pool`]): the same bits.
pub fn solve(
    rows: &mut [Row],
    bodies: &mut Responses,
    rel_tol: f64,
    max_sweeps: u32,
    pool: Option<&rayon::ThreadPool>,
) -> SolveStats {
    let mut stats = SolveStats {
        sweeps: 0,
        converged: true,
    };
    if rows.is_empty() {
        return stats;
    }
    // Island by island (rows joined by the bodies they move; a robot's bodies are one): each
    // stops when it is solved, and a pile does not make a lone resting box sweep on. The rows
    // are grouped by island for the solve, in one order, then put back in theirs.
    let seeds = bodies.island_seeds();
    let mut parent: Vec<usize> = (0..bodies.bodies.len()).collect();
    for (i, &seed) in seeds.iter().enumerate() {
        union(&mut parent, i, seed);
    }
    for row in rows.iter() {
        if let Some(b) = row.b {
            union(&mut parent, row.a, b);
        }
    }
    let roots: Vec<usize> = (0..parent.len()).map(|i| find(&mut parent, i)).collect();
    // The keys are unique (one row per contact `source`): an unstable sort gives the same order.
    rows.sort_unstable_by_key(|r| (roots[r.a], r.source));
    let mut islands: Vec<Range<usize>> = Vec::new();
    let mut start = 0;
    while start < rows.len() {
        let key = roots[rows[start].a];
        let len = rows[start..]
            .iter()
            .position(|r| roots[r.a] != key)
            .unwrap_or(rows.len() - start);
        islands.push(start..start + len);
        start += len;
    }
    match pool {
        Some(pool) if rows.len() >= islands::MIN_ROWS_ON_POOL && islands.len() > 1 => {
            stats =
                islands::solve_on_pool(rows, &islands, bodies, &seeds, rel_tol, max_sweeps, pool);
        }
        _ => {
            for island in islands {
                let island = solve_island(&mut rows[island], bodies, &seeds, rel_tol, max_sweeps);
                stats.sweeps = stats.sweeps.max(island.sweeps);
                stats.converged &= island.converged;
            }
        }
    }
    rows.sort_unstable_by_key(|r| r.source);
    stats
}

/// The root of `i` in the union-find forest `parent` (halving the path).
fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

/// Joins the trees of `a` and `b` under the smaller root.
fn union(parent: &mut [usize], a: usize, b: usize) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    let (lo, hi) = (ra.min(rb), ra.max(rb));
    parent[hi] = lo;
}

/// [`solve`] on one island's rows (`seeds`: per body of `bodies`, its island seed).
pub(super) fn solve_island(
    rows: &mut [Row],
    bodies: &mut Responses,
    seeds: &[usize],
    rel_tol: f64,
    max_sweeps: u32,
) -> SolveStats {
    let mut stats = SolveStats::default();
    // The velocities the rows ask for: the scale of the velocity criterion.
    let velocity_scale = rows
        .iter()
        .map(|r| r.u_free.amax().max(r.target_n.abs()))
        .fold(0.0, f64::max);
    while stats.sweeps < max_sweeps {
        stats.sweeps += 1;
        let (change, largest, velocity_change) = sweep(rows, bodies);
        if change <= rel_tol * largest
            || change <= 1e-300
            || velocity_change <= rel_tol * velocity_scale
        {
            stats.converged = true;
            break;
        }
        if stats.sweeps.is_multiple_of(SWEEPS_PER_POLISH) && polish(rows, bodies, seeds) {
            stats.converged = true;
            break;
        }
    }
    stats
}

/// One sweep of projected Gauss-Seidel: (the largest impulse change, the largest impulse,
/// the largest change of a contact's own velocity, `|W_ii Δλ_i|`).
fn sweep(rows: &mut [Row], bodies: &mut Responses) -> (f64, f64, f64) {
    let mut change = 0.0f64;
    let mut largest = 0.0f64;
    let mut velocity_change = 0.0f64;
    for row in rows.iter_mut() {
        let u = row.velocity(bodies);
        let new = row.local_solve(&u);
        let d = new - row.lambda;
        if d != Vector3::zeros() {
            row.apply(&d, bodies);
            row.lambda = new;
            velocity_change = velocity_change.max((row.w * d).amax());
        }
        change = change.max(d.amax());
        largest = largest.max(new.amax());
    }
    (change, largest, velocity_change)
}

/// Islands larger than this many unknowns are left to the sweeps (a dense solve of their
/// active set would cost more than the sweeps it saves).
const POLISH_MAX_UNKNOWNS: usize = 400;

/// Guesses of the active set an active-set solve tries at most.
const POLISH_ATTEMPTS: usize = 8;

/// How a row enters the active-set system.
#[derive(Debug, Clone, Copy)]
enum Mode {
    /// Not pushing: `λ = 0`.
    Open,
    /// Sticking: `u = b`, three unknowns.
    Stick,
    /// Sliding along the unit tangential direction `d` (contact frame `t₁, t₂`):
    /// `λ = λ_n (1, μ d)`, one unknown, the normal row `u_n = b_n`.
    Slide(f64, f64),
}

/// The active-set solve: the sweeps' guess of which contacts push, stick and slide, taken as
/// exact and solved as the linear system it makes for the correction of the sweeps'
/// impulses (`W` restricted to the active rows, a `1e-8 · max W_ii` diagonal shift for the
/// redundant contacts of a face, dense LU: of the many ways redundant contacts can share an
/// impulse, the one nearest the sweeps'), island by island of bodies joined by active
/// contacts (a robot's bodies are one island). Accepted only when every condition holds:
/// `λ_n ≥ 0`, sticking impulses inside their cones, open contacts separating. Returns whether
/// every island was accepted; a rejected island keeps the sweeps' impulses.
pub fn polish(rows: &mut [Row], bodies: &mut Responses, seeds: &[usize]) -> bool {
    // Islands over the bodies joined by pushing contacts (union-find, smallest root), over
    // the bodies the rows touch and their mechanisms' seeds only (`seeds`: `island_seeds`,
    // made once per solve): an island's root is the smallest body of its component, which is
    // the smallest of those (a seed is its mechanism's smallest member), so the islands and
    // their order are those of a union-find over every body, at the cost of the rows alone.
    // (Over every body, each island's polish was a pass over the whole batch: 10 000 resting
    // boxes made that 99 % of the contact phase.)
    let mut nodes: Vec<usize> = Vec::with_capacity(4 * rows.len());
    for row in rows.iter() {
        for body in std::iter::once(row.a).chain(row.b) {
            nodes.push(body);
            nodes.push(seeds[body]);
        }
    }
    nodes.sort_unstable();
    nodes.dedup();
    let local = |body: usize| nodes.binary_search(&body).expect("a row's body is a node");
    // Local indices are in the order of the bodies': the smaller local root is the smaller body.
    let mut parent: Vec<usize> = (0..nodes.len()).collect();
    for (i, &body) in nodes.iter().enumerate() {
        if seeds[body] != body {
            union(&mut parent, i, local(seeds[body]));
        }
    }
    for row in rows.iter() {
        if let Some(b) = row.b
            && row.lambda.x > 0.0
        {
            union(&mut parent, local(row.a), local(b));
        }
    }
    // Rows by island (the root's body, ascending), each island's rows in their order.
    let mut island_rows: Vec<(usize, usize)> = rows
        .iter()
        .enumerate()
        .map(|(i, row)| (find(&mut parent, local(row.a)), i))
        .collect();
    island_rows.sort_unstable();
    let mut all = true;
    for island in island_rows.chunk_by(|x, y| x.0 == y.0) {
        let members: Vec<usize> = island.iter().map(|&(_, i)| i).collect();
        all &= polish_island(rows, bodies, &members);
    }
    all
}

/// [`polish`] on the rows `members` (one island).
fn polish_island(rows: &mut [Row], bodies: &mut Responses, members: &[usize]) -> bool {
    let mut modes: Vec<Mode> = members
        .iter()
        .map(|&i| {
            let r = &rows[i];
            if r.lambda.x <= 0.0 {
                return Mode::Open;
            }
            let t = (r.lambda.y * r.lambda.y + r.lambda.z * r.lambda.z).sqrt();
            if t < r.mu * r.lambda.x * (1.0 - 1e-9) || t == 0.0 {
                Mode::Stick
            } else {
                Mode::Slide(r.lambda.y / t, r.lambda.z / t)
            }
        })
        .collect();
    let all_open = |modes: &[Mode]| modes.iter().all(|m| matches!(m, Mode::Open));
    if all_open(&modes) {
        return true;
    }
    // The guess adjusted while the solve contradicts it: a pushing contact that would pull
    // opens, a sticking one outside its cone slides along its friction (an active-set
    // method; a face's redundant corners need it: of their many solutions, the nearest may
    // pull at one corner).
    let mut candidate = None;
    // Rows the loop made slide: their slip must come out opposite their friction.
    let mut made_to_slide = vec![false; members.len()];
    for _ in 0..POLISH_ATTEMPTS {
        if all_open(&modes) {
            return false;
        }
        let Some(c) = solve_modes(rows, bodies, members, &modes) else {
            return false;
        };
        let mut changed = false;
        for (ii, l) in c.iter().enumerate() {
            let mu = rows[members[ii]].mu;
            let t = (l.y * l.y + l.z * l.z).sqrt();
            match modes[ii] {
                Mode::Open => {}
                _ if l.x < 0.0 => {
                    modes[ii] = Mode::Open;
                    changed = true;
                }
                Mode::Stick if t > mu * l.x * (1.0 + 1e-9) + 1e-300 => {
                    modes[ii] = Mode::Slide(l.y / t, l.z / t);
                    made_to_slide[ii] = true;
                    changed = true;
                }
                _ => {}
            }
        }
        if !changed {
            candidate = Some(c);
            break;
        }
    }
    let Some(candidate) = candidate else {
        return false;
    };
    // Swap in the candidate, then check the open contacts separate.
    let old: Vec<Vector3<f64>> = members.iter().map(|&i| rows[i].lambda).collect();
    for (ii, &i) in members.iter().enumerate() {
        let d = candidate[ii] - rows[i].lambda;
        if d != Vector3::zeros() {
            rows[i].apply(&d, bodies);
            rows[i].lambda = candidate[ii];
        }
    }
    let scale = candidate.iter().map(|l| l.x).fold(0.0, f64::max);
    let ok = members.iter().enumerate().all(|(ii, &i)| match modes[ii] {
        Mode::Open => {
            let u = rows[i].velocity(bodies);
            u.x >= rows[i].target_n - 1e-9 * (1.0 + scale)
        }
        Mode::Slide(d1, d2) if made_to_slide[ii] => {
            // Maximum dissipation: the slip `u_t` along `−d`.
            let u = rows[i].velocity(bodies);
            let slip = (u.y * u.y + u.z * u.z).sqrt();
            slip <= 1e-12 || (u.y * d1 + u.z * d2) <= -(1.0 - 1e-9) * slip
        }
        _ => true,
    });
    if !ok {
        for (ii, &i) in members.iter().enumerate() {
            let d = old[ii] - rows[i].lambda;
            if d != Vector3::zeros() {
                rows[i].apply(&d, bodies);
                rows[i].lambda = old[ii];
            }
        }
    }
    ok
}

/// The impulses of the rows `members` (one island) if every one were in its mode `modes`
/// (the linear system [`polish`] describes); `None` without unknowns, with too many, or when
/// the system is singular.
fn solve_modes(
    rows: &[Row],
    bodies: &Responses,
    members: &[usize],
    modes: &[Mode],
) -> Option<Vec<Vector3<f64>>> {
    // Unknowns: 3 per sticking row, 1 per sliding row.
    let mut offset = Vec::with_capacity(members.len());
    let mut n = 0;
    for m in modes {
        offset.push(n);
        n += match m {
            Mode::Open => 0,
            Mode::Stick => 3,
            Mode::Slide(..) => 1,
        };
    }
    if n == 0 || n > POLISH_MAX_UNKNOWNS {
        return None;
    }
    // λ_j = S_j x_j, and row i's equations P_i (u_free_i + Σ_j W_ij S_j x_j − b_i) = 0.
    let select = |m: &Mode, mu: f64| -> nalgebra::DMatrix<f64> {
        match *m {
            Mode::Stick => nalgebra::DMatrix::identity(3, 3),
            Mode::Slide(d1, d2) => {
                nalgebra::DMatrix::from_column_slice(3, 1, &[1.0, mu * d1, mu * d2])
            }
            Mode::Open => nalgebra::DMatrix::zeros(3, 0),
        }
    };
    // The reference the correction starts from: the sweeps' normal impulses with the sticking
    // contacts' friction taken out (a sliding one's is fixed by its normal). Of the ways
    // redundant contacts can share their impulses — the four corners of a face, a robot's
    // feet — the solve then picks the one nearest the sweeps' normals with the least friction:
    // no internal friction stress accumulating from step to step (the sweeps' warm starts
    // would carry it towards the cones' edges).
    let reference: Vec<Vector3<f64>> = members
        .iter()
        .enumerate()
        .map(|(ii, &i)| match modes[ii] {
            Mode::Open => Vector3::zeros(),
            Mode::Stick => Vector3::new(rows[i].lambda.x, 0.0, 0.0),
            Mode::Slide(d1, d2) => {
                let l = rows[i].lambda.x;
                Vector3::new(l, rows[i].mu * d1 * l, rows[i].mu * d2 * l)
            }
        })
        .collect();
    let mut a = nalgebra::DMatrix::<f64>::zeros(n, n);
    let mut rhs = nalgebra::DVector::<f64>::zeros(n);
    for (ii, &i) in members.iter().enumerate() {
        let eq = match modes[ii] {
            Mode::Open => continue,
            Mode::Stick => 3,
            Mode::Slide(..) => 1,
        };
        let ri = &rows[i];
        // The velocity still missing from the reference: `b − u(λ) + Σ_j W_ij (λ_j − ref_j)`.
        let mut b = Vector3::new(ri.target_n, 0.0, 0.0) - ri.velocity(bodies);
        for (jj, &j) in members.iter().enumerate() {
            if matches!(modes[jj], Mode::Open) {
                continue;
            }
            let rj = &rows[j];
            let w = coupling(ri, rj, bodies);
            if w == Matrix3::zeros() {
                continue;
            }
            b += w * (rj.lambda - reference[jj]);
            let block = nalgebra::DMatrix::from_column_slice(3, 3, w.as_slice())
                * select(&modes[jj], rj.mu);
            for e in 0..eq {
                for c in 0..block.ncols() {
                    a[(offset[ii] + e, offset[jj] + c)] += block[(e, c)];
                }
            }
        }
        for e in 0..eq {
            rhs[offset[ii] + e] = b[e];
        }
    }
    let shift = 1e-8 * (0..n).map(|k| a[(k, k)].abs()).fold(0.0, f64::max);
    for k in 0..n {
        a[(k, k)] += shift;
    }
    let x = a.lu().solve(&rhs)?;
    // The candidate, checked before it replaces the sweeps' impulses.
    let candidate: Vec<Vector3<f64>> = members
        .iter()
        .enumerate()
        .map(|(ii, &i)| match modes[ii] {
            Mode::Open => Vector3::zeros(),
            Mode::Stick => {
                reference[ii] + Vector3::new(x[offset[ii]], x[offset[ii] + 1], x[offset[ii] + 2])
            }
            Mode::Slide(d1, d2) => {
                let l = reference[ii].x + x[offset[ii]];
                Vector3::new(l, rows[i].mu * d1 * l, rows[i].mu * d2 * l)
            }
        })
        .collect();
    Some(candidate)
}

/// `W_ij`: the velocity of contact `i` (its frame) per unit impulse of contact `j` (its
/// frame), through the bodies they move: `Σ s_i s_j C_iᵀ K(x_i, r_i; x_j, r_j) C_j` over their
/// sides ([`Responses::block`]), `s = +1` on a contact's `a`, `−1` on its `b`.
fn coupling(ri: &Row, rj: &Row, bodies: &Responses) -> Matrix3<f64> {
    let sides = |r: &Row| [(Some(r.a), 1.0, r.r_a), (r.b, -1.0, r.r_b)];
    let mut k = Matrix3::zeros();
    for (xi, si, arm_i) in sides(ri) {
        let Some(xi) = xi else { continue };
        for (xj, sj, arm_j) in sides(rj) {
            let Some(xj) = xj else { continue };
            k += bodies.block(xi, &arm_i, xj, &arm_j) * (si * sj);
        }
    }
    if k == Matrix3::zeros() {
        return k;
    }
    ri.frame.transpose() * k * rj.frame
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix2, Vector2};

    /// An anisotropic, coupled 2 × 2 block (a corner contact's `W_tt`).
    fn w() -> Matrix2<f64> {
        Matrix2::new(2.0, 0.7, 0.7, 1.1)
    }

    #[test]
    fn friction_inside_the_disk_is_the_sticking_impulse() {
        let u0 = Vector2::new(0.03, -0.02);
        let l = friction_in_disk(&w(), &u0, 1.0);
        // Sticking: the final slip u0 + W λ vanishes.
        assert!((u0 + w() * l).norm() <= 1e-15, "{}", (u0 + w() * l).norm());
    }

    #[test]
    fn friction_on_the_edge_opposes_the_final_slip_with_the_full_limit() {
        let u0 = Vector2::new(3.0, -1.0);
        let limit = 0.25;
        let l = friction_in_disk(&w(), &u0, limit);
        let slip = u0 + w() * l;
        // |λ| = μ λ_n, and λ antiparallel to the final slip (maximum dissipation): measured
        // 0 and 1 − cos = 0 to round-off.
        assert!((l.norm() - limit).abs() <= 1e-15, "{}", l.norm());
        let cos = l.dot(&slip) / (l.norm() * slip.norm());
        assert!((cos + 1.0).abs() <= 1e-12, "{cos}");
        // And not the radial projection of the sticking impulse (which W's coupling turns).
        let stick = -w().try_inverse().unwrap() * u0;
        let radial = stick * (limit / stick.norm());
        assert!((radial - l).norm() > 1e-3, "{}", (radial - l).norm());
    }

    #[test]
    fn no_friction_without_a_normal_impulse_or_a_slip() {
        assert_eq!(
            friction_in_disk(&w(), &Vector2::new(1.0, 2.0), 0.0),
            Vector2::zeros()
        );
        assert_eq!(
            friction_in_disk(&w(), &Vector2::zeros(), 1.0),
            Vector2::zeros()
        );
    }

    #[test]
    fn a_warm_start_is_projected_into_the_cone_and_applied() {
        let frame = contact_frame(&Vector3::z());
        let mut bodies = Responses::free(vec![Response::new(0.5, Matrix3::identity() * 4.0)]);
        let mut row = Row {
            source: 0,
            a: 0,
            b: None,
            r_a: Vector3::new(0.1, 0.0, -0.2),
            r_b: Vector3::zeros(),
            frame,
            u_free: Vector3::zeros(),
            target_n: 0.0,
            mu: 0.5,
            restitution: 0.0,
            leave_n: 0.0,
            w: Matrix3::zeros(),
            w_inv: Matrix3::zeros(),
            tangent_eigen: Default::default(),
            lambda: Vector3::zeros(),
        };
        assert!(row.prepare(&bodies));
        // Normal 2, tangential 3 along t₁ and 4 along t₂: |λ_t| = 5 > μ λ_n = 1.
        let world = frame * Vector3::new(2.0, 3.0, 4.0);
        row.warm_start(&world, &mut bodies);
        let expected = Vector3::new(2.0, 0.6, 0.8);
        assert!((row.lambda - expected).norm() <= 1e-15, "{}", row.lambda);
        // The bodies carry it: Δv = P / m.
        assert!((bodies.bodies[0].dv - frame * expected * 0.5).norm() <= 1e-15);
        // A pulling normal is dropped.
        let mut pulled = Row {
            lambda: Vector3::zeros(),
            ..row
        };
        let mut fresh = Responses::free(vec![Response::new(0.5, Matrix3::identity() * 4.0)]);
        pulled.warm_start(&(frame * Vector3::new(-1.0, 0.3, 0.0)), &mut fresh);
        assert_eq!(pulled.lambda, Vector3::zeros());
        assert_eq!(fresh.bodies[0].dv, Vector3::zeros());
    }
}
