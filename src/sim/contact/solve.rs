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
        let stick = match w_tt.try_inverse() {
            Some(inv) => lt - inv * ut,
            None => nalgebra::Vector2::zeros(),
        };
        let t = if stick.norm() <= limit {
            stick
        } else {
            // Sliding: maximum dissipation puts the friction against the slip velocity (the
            // current one: at the fixed point, the final one); a contact that is not yet
            // slipping takes the direction of the sticking impulse.
            let slip = ut;
            let d = if slip.norm() > 1e-300 {
                -slip / slip.norm()
            } else {
                stick / stick.norm()
            };
            d * limit
        };
        Vector3::new(lambda_n, t.x, t.y)
    }
}

/// What a solve did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SolveStats {
    pub sweeps: u32,
    pub converged: bool,
}

/// Projected Gauss-Seidel over `rows` (warm-started from their `lambda`, already applied to
/// `bodies`): sweeps in row order until the largest impulse change is at most
/// `rel_tol × max |λ|` (or an absolute `1e-300`), at most `max_sweeps`.
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
        if change <= rel_tol * largest || change <= 1e-300 {
            stats.converged = true;
            break;
        }
    }
    stats
}
