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

use nalgebra::{Matrix3, Vector3};

/// One body's response to impulses, and the velocity change they made so far.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Response {
    /// `1 / m`, 1/kg (0: the body does not move, the ground).
    pub inv_mass: f64,
    /// `I⁻¹` in world axes, 1/(kg m²).
    pub inv_inertia_world: Matrix3<f64>,
    /// Velocity change so far, m/s.
    pub dv: Vector3<f64>,
    /// Angular velocity change so far, rad/s.
    pub dw: Vector3<f64>,
    /// Angular momentum change so far (world, about the centre of mass), kg m²/s.
    pub dl: Vector3<f64>,
}

impl Response {
    /// A body of `inv_mass` and `inv_inertia_world`, not yet pushed.
    pub fn new(inv_mass: f64, inv_inertia_world: Matrix3<f64>) -> Self {
        Self {
            inv_mass,
            inv_inertia_world,
            dv: Vector3::zeros(),
            dw: Vector3::zeros(),
            dl: Vector3::zeros(),
        }
    }

    /// The velocity change of the point at arm `r` per unit impulse there:
    /// `K(r) = I/m − [r]× I⁻¹ [r]×`.
    pub fn point_matrix(&self, r: &Vector3<f64>) -> Matrix3<f64> {
        let rx = r.cross_matrix();
        Matrix3::identity() * self.inv_mass - rx * self.inv_inertia_world * rx
    }

    /// The velocity change of the point at arm `r` so far.
    pub fn point_velocity(&self, r: &Vector3<f64>) -> Vector3<f64> {
        self.dv + self.dw.cross(r)
    }

    /// Applies the impulse `p` (world) at arm `r`.
    pub fn push(&mut self, p: &Vector3<f64>, r: &Vector3<f64>) {
        let l = r.cross(p);
        self.dv += p * self.inv_mass;
        self.dl += l;
        self.dw += self.inv_inertia_world * l;
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
    /// Fills `w` and `w_inv` from the bodies' responses; `false` when the block is singular
    /// (two bodies that cannot move).
    pub fn prepare(&mut self, bodies: &[Response]) -> bool {
        let mut k = bodies[self.a].point_matrix(&self.r_a);
        if let Some(b) = self.b {
            k += bodies[b].point_matrix(&self.r_b);
        }
        self.w = self.frame.transpose() * k * self.frame;
        match self.w.try_inverse() {
            Some(inv) => {
                self.w_inv = inv;
                true
            }
            None => false,
        }
    }

    /// The contact's velocity over the step with the impulses so far, contact frame.
    pub fn velocity(&self, bodies: &[Response]) -> Vector3<f64> {
        let mut du = bodies[self.a].point_velocity(&self.r_a);
        if let Some(b) = self.b {
            du -= bodies[b].point_velocity(&self.r_b);
        }
        self.u_free + self.frame.transpose() * du
    }

    /// Starts from `impulse_world` (the same contact's impulse of the last step) projected
    /// into this row's cone, applied to the bodies.
    pub fn warm_start(&mut self, impulse_world: &Vector3<f64>, bodies: &mut [Response]) {
        let mut l = self.frame.transpose() * impulse_world;
        l.x = l.x.max(0.0);
        let t = (l.y * l.y + l.z * l.z).sqrt();
        if t > self.mu * l.x && t > 0.0 {
            let f = self.mu * l.x / t;
            l.y *= f;
            l.z *= f;
        }
        if l != Vector3::zeros() {
            self.apply(&l, bodies);
            self.lambda = l;
        }
    }

    /// Applies the impulse change `d` (contact frame) to the bodies.
    pub fn apply(&self, d: &Vector3<f64>, bodies: &mut [Response]) {
        let p = self.frame * d;
        bodies[self.a].push(&p, &self.r_a);
        if let Some(b) = self.b {
            bodies[b].push(&(-p), &self.r_b);
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
        let t = friction_in_disk(&w_tt, &u0, limit);
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
    if limit <= 0.0 || *u0 == nalgebra::Vector2::zeros() {
        return nalgebra::Vector2::zeros();
    }
    let eig = nalgebra::SymmetricEigen::new(*w);
    let (a, q) = (eig.eigenvalues, eig.eigenvectors);
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
/// feasible everywhere or a sweep changes no impulse by more than `rel_tol × max |λ|`, at
/// most `max_sweeps` sweeps.
pub fn solve(
    rows: &mut [Row],
    bodies: &mut [Response],
    rel_tol: f64,
    max_sweeps: u32,
) -> SolveStats {
    let mut stats = SolveStats::default();
    if rows.is_empty() {
        stats.converged = true;
        return stats;
    }
    while stats.sweeps < max_sweeps {
        stats.sweeps += 1;
        let (change, largest) = sweep(rows, bodies);
        if change <= rel_tol * largest || change <= 1e-300 {
            stats.converged = true;
            break;
        }
        if stats.sweeps.is_multiple_of(SWEEPS_PER_POLISH) && polish(rows, bodies) {
            stats.converged = true;
            break;
        }
    }
    stats
}

/// One sweep of projected Gauss-Seidel: (the largest impulse change, the largest impulse).
fn sweep(rows: &mut [Row], bodies: &mut [Response]) -> (f64, f64) {
    let mut change = 0.0f64;
    let mut largest = 0.0f64;
    for row in rows.iter_mut() {
        let u = row.velocity(bodies);
        let new = row.local_solve(&u);
        let d = new - row.lambda;
        if d != Vector3::zeros() {
            row.apply(&d, bodies);
            row.lambda = new;
        }
        change = change.max(d.amax());
        largest = largest.max(new.amax());
    }
    (change, largest)
}

/// Islands larger than this many unknowns are left to the sweeps (a dense solve of their
/// active set would cost more than the sweeps it saves).
const POLISH_MAX_UNKNOWNS: usize = 400;

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
/// exact and solved as the linear system it makes (`W` restricted to the active rows, a
/// `1e-8 · max W_ii` diagonal shift for the redundant contacts of a face, dense LU), island
/// by island of bodies joined by active contacts. Accepted only when every condition holds:
/// `λ_n ≥ 0`, sticking impulses inside their cones, open contacts separating. Returns whether
/// every island was accepted; a rejected island keeps the sweeps' impulses.
pub fn polish(rows: &mut [Row], bodies: &mut [Response]) -> bool {
    // Islands over the bodies joined by pushing contacts (union-find, smallest root).
    let mut parent: Vec<usize> = (0..bodies.len()).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    for row in rows.iter() {
        if let Some(b) = row.b
            && row.lambda.x > 0.0
        {
            let (ra, rb) = (root(&mut parent, row.a), root(&mut parent, b));
            let (lo, hi) = (ra.min(rb), ra.max(rb));
            parent[hi] = lo;
        }
    }
    let mut island_rows: std::collections::BTreeMap<usize, Vec<usize>> = Default::default();
    for (i, row) in rows.iter().enumerate() {
        let r = root(&mut parent, row.a);
        island_rows.entry(r).or_default().push(i);
    }
    let mut all = true;
    for members in island_rows.values() {
        all &= polish_island(rows, bodies, members);
    }
    all
}

/// [`polish`] on the rows `members` (one island).
fn polish_island(rows: &mut [Row], bodies: &mut [Response], members: &[usize]) -> bool {
    let modes: Vec<Mode> = members
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
    // Unknowns: 3 per sticking row, 1 per sliding row.
    let mut offset = Vec::with_capacity(members.len());
    let mut n = 0;
    for m in &modes {
        offset.push(n);
        n += match m {
            Mode::Open => 0,
            Mode::Stick => 3,
            Mode::Slide(..) => 1,
        };
    }
    if n == 0 || n > POLISH_MAX_UNKNOWNS {
        return n == 0;
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
    let mut a = nalgebra::DMatrix::<f64>::zeros(n, n);
    let mut rhs = nalgebra::DVector::<f64>::zeros(n);
    for (ii, &i) in members.iter().enumerate() {
        let eq = match modes[ii] {
            Mode::Open => continue,
            Mode::Stick => 3,
            Mode::Slide(..) => 1,
        };
        let ri = &rows[i];
        let b = Vector3::new(ri.target_n, 0.0, 0.0) - ri.u_free;
        for e in 0..eq {
            rhs[offset[ii] + e] = b[e];
        }
        for (jj, &j) in members.iter().enumerate() {
            if matches!(modes[jj], Mode::Open) {
                continue;
            }
            let rj = &rows[j];
            let w = coupling(ri, rj, bodies);
            if w == Matrix3::zeros() {
                continue;
            }
            let block = nalgebra::DMatrix::from_column_slice(3, 3, w.as_slice())
                * select(&modes[jj], rj.mu);
            for e in 0..eq {
                for c in 0..block.ncols() {
                    a[(offset[ii] + e, offset[jj] + c)] += block[(e, c)];
                }
            }
        }
    }
    let shift = 1e-8 * (0..n).map(|k| a[(k, k)].abs()).fold(0.0, f64::max);
    for k in 0..n {
        a[(k, k)] += shift;
    }
    let Some(x) = a.lu().solve(&rhs) else {
        return false;
    };
    // The candidate, checked before it replaces the sweeps' impulses.
    let candidate: Vec<Vector3<f64>> = members
        .iter()
        .enumerate()
        .map(|(ii, &i)| match modes[ii] {
            Mode::Open => Vector3::zeros(),
            Mode::Stick => Vector3::new(x[offset[ii]], x[offset[ii] + 1], x[offset[ii] + 2]),
            Mode::Slide(d1, d2) => {
                let l = x[offset[ii]];
                Vector3::new(l, rows[i].mu * d1 * l, rows[i].mu * d2 * l)
            }
        })
        .collect();
    for (ii, l) in candidate.iter().enumerate() {
        let mu = rows[members[ii]].mu;
        if l.x < 0.0 || (l.y * l.y + l.z * l.z).sqrt() > mu * l.x * (1.0 + 1e-9) + 1e-300 {
            return false;
        }
    }
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
    let ok = members.iter().enumerate().all(|(ii, &i)| {
        !matches!(modes[ii], Mode::Open) || {
            let u = rows[i].velocity(bodies);
            u.x >= rows[i].target_n - 1e-9 * (1.0 + scale)
        }
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

/// `W_ij`: the velocity of contact `i` (its frame) per unit impulse of contact `j` (its
/// frame), through the bodies they share: `Σ_X s_i s_j C_iᵀ (I/m − [r_i]× I⁻¹ [r_j]×) C_j`,
/// `s = +1` on a contact's `a`, `−1` on its `b`.
fn coupling(ri: &Row, rj: &Row, bodies: &[Response]) -> Matrix3<f64> {
    let sides = |r: &Row| [(Some(r.a), 1.0, r.r_a), (r.b, -1.0, r.r_b)];
    let mut k = Matrix3::zeros();
    for (xi, si, arm_i) in sides(ri) {
        let Some(xi) = xi else { continue };
        for (xj, sj, arm_j) in sides(rj) {
            if xj != Some(xi) {
                continue;
            }
            let body = &bodies[xi];
            k += (Matrix3::identity() * body.inv_mass
                - arm_i.cross_matrix() * body.inv_inertia_world * arm_j.cross_matrix())
                * (si * sj);
        }
    }
    if k == Matrix3::zeros() {
        return k;
    }
    ri.frame.transpose() * k * rj.frame
}
