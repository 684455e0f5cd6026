//! The direct solve of the mechanism's Schur system `K x = r`, `K = G_R S G_Lᵀ`, in time linear
//! in the number of joints (Baraff, "Linear-time dynamics using Lagrange multipliers",
//! SIGGRAPH 1996), plus a dense Schur complement for the few rows that break the tree (mimic
//! joints).
//!
//! `G_L` (impulse directions) and `G_R` (the rows being solved) are the joint Jacobians at two
//! configurations (the step's start and end; both the same configuration for the velocity
//! projection), `S = blockdiag(S_i)` a per-body 6x6 compliance `[s_c I, 0; 0, S_rot]` mapping an
//! impulse `[force; torque]` to a displacement `[δc; η]`. `K` is not symmetric in general (two
//! configurations, and `S_rot` is not symmetric), so the elimination is a block LU.
//!
//! Each body is one node, each joint another; joint `j` is linked to its parent body and to its
//! child body, and every body but a floating root has exactly one parent joint, so these nodes
//! form a tree (a forest when the base is welded to the world). The augmented system, with the
//! body impulses `z_i = Σ_j G_L,jiᵀ x_j`,
//!
//! ```text
//! [ I        −G_Lᵀ ] [z]   [0]
//! [ G_R S     0    ] [x] = [r]
//! ```
//!
//! has that tree as its sparsity graph: eliminating the nodes leaves first creates no fill-in.
//! Eliminating node `n` into its parent `p` is `D_p −= M_pn D_n⁻¹ M_np`, `b_p −= M_pn D_n⁻¹ b_n`;
//! back-substitution, root first, is `x_n = D_n⁻¹ (b_n − M_np x_p)`. With body `b`, its parent
//! joint `j` and that joint's parent body `P`:
//!
//! ```text
//! body b into joint j:   D_j += G_R,jb S_b D_b⁻¹ G_L,jbᵀ        b_j −= G_R,jb S_b D_b⁻¹ b_b
//! joint j into body P:   D_P += G_L,jPᵀ D_j⁻¹ G_R,jP S_P         b_P += G_L,jPᵀ D_j⁻¹ b_j
//! back:                  x_j = D_j⁻¹ (b_j − G_R,jP S_P z_P)      z_b = D_b⁻¹ (b_b + G_L,jbᵀ x_j)
//! ```
//!
//! (`D_b` starts at `I`, `D_j` at 0 plus `I` on the rows a joint does not use.) One 6x6 and one
//! 5x5 LU per joint, a few small products: O(joints) per factorisation and per solve.
//!
//! Extra rows `m` (mimic joints) couple joints anywhere in the tree. With `t` the tree rows:
//! `x_t = K_tt⁻¹ (r_t − K_tm x_m)`, `(K_mm − K_mt K_tt⁻¹ K_tm) x_m = r_m − K_mt K_tt⁻¹ r_t`: one
//! tree solve per extra row, then a dense system of their number.

use super::rows::{MAX_ROWS, Row6, RowJacobian, RowValues};
use nalgebra::{DMatrix, DVector, Matrix3, SMatrix, SVector};

type Matrix6 = SMatrix<f64, 6, 6>;
type Matrix5 = SMatrix<f64, MAX_ROWS, MAX_ROWS>;
type Vector6 = SVector<f64, 6>;

/// The inverse of a small square matrix by Gauss-Jordan elimination with partial pivoting
/// (fixed size, unrolled by the compiler: faster here than a general LU and its solves),
/// written to `out`; `false` when a pivot is zero or not finite.
///
/// The operations on `inv`, in their order, are those of the plain elimination
/// (`tests::invert_reference`, compared bit for bit); the working copy `a` is updated only in
/// the columns right of the pivot: the others are never read again (the pivot search and the
/// multipliers read column `k` at step `k`).
#[inline]
fn invert_into<const N: usize>(m: &SMatrix<f64, N, N>, inv: &mut SMatrix<f64, N, N>) -> bool {
    let mut a = *m;
    *inv = SMatrix::<f64, N, N>::identity();
    for k in 0..N {
        let mut p = k;
        for i in k + 1..N {
            if a[(i, k)].abs() > a[(p, k)].abs() {
                p = i;
            }
        }
        if p != k {
            for j in k..N {
                a.swap((k, j), (p, j));
            }
            inv.swap_rows(k, p);
        }
        let pivot = a[(k, k)];
        if !(pivot != 0.0 && pivot.is_finite()) {
            return false;
        }
        let r = 1.0 / pivot;
        for j in k + 1..N {
            a[(k, j)] *= r;
        }
        for j in 0..N {
            inv[(k, j)] *= r;
        }
        for i in 0..N {
            if i != k {
                let f = a[(i, k)];
                if f != 0.0 {
                    for j in k + 1..N {
                        a[(i, j)] -= f * a[(k, j)];
                    }
                    for j in 0..N {
                        inv[(i, j)] -= f * inv[(k, j)];
                    }
                }
            }
        }
    }
    true
}

/// [`invert_into`] returning the inverse (`None`: singular).
#[cfg(test)]
fn invert<const N: usize>(m: &SMatrix<f64, N, N>) -> Option<SMatrix<f64, N, N>> {
    let mut out = SMatrix::zeros();
    invert_into(m, &mut out).then_some(out)
}

/// A body's compliance `S_i = [s_c I, 0; 0, S_rot]` (impulse → displacement).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Compliance {
    pub trans: f64,
    pub rot: Matrix3<f64>,
}

impl Compliance {
    /// `S v` for an impulse `v = [force; torque]`.
    #[inline]
    pub fn apply(&self, v: &Vector6) -> Vector6 {
        let t = v.fixed_rows::<3>(0) * self.trans;
        let r = self.rot * v.fixed_rows::<3>(3);
        Vector6::new(t.x, t.y, t.z, r.x, r.y, r.z)
    }

    /// `G S` for a joint's rows `G` (5x6).
    #[inline]
    fn right_of(&self, g: &RowJacobian) -> RowJacobian {
        let mut out = RowJacobian::zeros();
        out.fixed_view_mut::<MAX_ROWS, 3>(0, 0)
            .copy_from(&(g.fixed_view::<MAX_ROWS, 3>(0, 0) * self.trans));
        out.fixed_view_mut::<MAX_ROWS, 3>(0, 3)
            .copy_from(&(g.fixed_view::<MAX_ROWS, 3>(0, 3) * self.rot));
        out
    }
}

/// The structure of a mechanism's tree.
#[derive(Debug, Clone, PartialEq)]
pub struct Topology {
    /// Per body: its parent joint (`None` for a floating root).
    pub parent_joint: Vec<Option<usize>>,
    /// Per joint: parent body (`None`: the world) and child body (`parent < child`).
    pub joint_bodies: Vec<(Option<usize>, usize)>,
    /// Per joint: rows used (≤ [`MAX_ROWS`]).
    pub rows: Vec<usize>,
}

/// One extra row: its columns for up to four bodies (`None`: unused slot).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ExtraRow {
    pub bodies: [Option<(usize, Row6)>; 4],
}

impl ExtraRow {
    /// `Σ_i row_i · v_i` over its bodies.
    fn dot(&self, v: &[Vector6]) -> f64 {
        self.bodies
            .iter()
            .flatten()
            .map(|(i, row)| (row * v[*i])[0])
            .sum()
    }
}

/// The joint Jacobians a solve needs, per joint: `(parent columns, child columns)`.
pub struct Jacobians<'a> {
    pub left: &'a [(RowJacobian, RowJacobian)],
    pub right: &'a [(RowJacobian, RowJacobian)],
    pub extra_left: &'a [ExtraRow],
    pub extra_right: &'a [ExtraRow],
}

/// Factorisation and buffers, sized once per mechanism (no allocation per solve).
#[derive(Debug, Clone)]
pub struct TreeSolver {
    topo: Topology,
    /// Per body: whether no joint has it as parent (its `D_b` stays the identity, whose
    /// inverse is the identity, bit for bit).
    leaf: Vec<bool>,
    d_body: Vec<Matrix6>,
    inv_body: Vec<Matrix6>,
    d_joint: Vec<Matrix5>,
    inv_joint: Vec<Matrix5>,
    /// `D_b⁻¹ G_L,jbᵀ` per child body `b` of joint `j` (indexed by joint).
    y_child: Vec<SMatrix<f64, 6, MAX_ROWS>>,
    /// `G_R,jb S_b` (indexed by joint).
    h_child: Vec<RowJacobian>,
    /// `D_j⁻¹ G_R,jP S_P` (indexed by joint; unused for a joint on the world).
    x_parent: Vec<RowJacobian>,
    b_body: Vec<Vector6>,
    b_joint: Vec<RowValues>,
    y_vec: Vec<Vector6>,
    z: Vec<Vector6>,
    // Extra rows.
    s: Vec<Compliance>,
    extra_cols: Vec<Vec<RowValues>>,
    schur: DMatrix<f64>,
    schur_rhs: DVector<f64>,
    schur_pivots: Vec<usize>,
    impulse: Vec<Vector6>,
    tree_rhs: Vec<RowValues>,
    /// Per joint, the diagonal `D₀` added on the rows past the joint's own (`1` by default:
    /// an unused row solves to 0; a drive row of [`crate::sim::mechanism::step`] sets its
    /// compliance there).
    pub free_row_diag: Vec<RowValues>,
}

impl TreeSolver {
    pub fn new(topo: Topology, extra_rows: usize) -> Self {
        let (nb, nj) = (topo.parent_joint.len(), topo.joint_bodies.len());
        let mut leaf = vec![true; nb];
        for &(p, _) in &topo.joint_bodies {
            if let Some(p) = p {
                leaf[p] = false;
            }
        }
        Self {
            leaf,
            d_body: vec![Matrix6::identity(); nb],
            inv_body: vec![Matrix6::identity(); nb],
            d_joint: vec![Matrix5::zeros(); nj],
            inv_joint: vec![Matrix5::identity(); nj],
            y_child: vec![SMatrix::zeros(); nj],
            h_child: vec![RowJacobian::zeros(); nj],
            x_parent: vec![RowJacobian::zeros(); nj],
            b_body: vec![Vector6::zeros(); nb],
            b_joint: vec![RowValues::zeros(); nj],
            y_vec: vec![Vector6::zeros(); nb],
            z: vec![Vector6::zeros(); nb],
            s: vec![
                Compliance {
                    trans: 0.0,
                    rot: Matrix3::zeros()
                };
                nb
            ],
            extra_cols: vec![vec![RowValues::zeros(); nj]; extra_rows],
            schur: DMatrix::zeros(extra_rows, extra_rows),
            schur_rhs: DVector::zeros(extra_rows),
            schur_pivots: vec![0; extra_rows],
            impulse: vec![Vector6::zeros(); nb],
            tree_rhs: vec![RowValues::zeros(); nj],
            free_row_diag: vec![RowValues::repeat(1.0); nj],
            topo,
        }
    }

    /// Factorises `K = G_R S G_Lᵀ` (tree rows) and, with extra rows, the dense Schur
    /// complement. `false` when a pivot block is singular or the result is not finite.
    pub fn factor(&mut self, jac: &Jacobians, s: &[Compliance]) -> bool {
        let topo = &self.topo;
        for d in &mut self.d_body {
            *d = Matrix6::identity();
        }
        for (j, d) in self.d_joint.iter_mut().enumerate() {
            *d = Matrix5::zeros();
            for k in topo.rows[j]..MAX_ROWS {
                d[(k, k)] = self.free_row_diag[j][k];
            }
        }
        for b in (0..topo.parent_joint.len()).rev() {
            if self.leaf[b] {
                // `D_b = I` (no joint adds to it): Gauss-Jordan returns `I` exactly (pivots 1,
                // no multiplier), and `inv_body[b]` is `I` from `new` on.
                debug_assert_eq!(self.d_body[b], Matrix6::identity());
            } else if !invert_into(&self.d_body[b], &mut self.inv_body[b]) {
                return false;
            }
            let Some(j) = topo.parent_joint[b] else {
                continue;
            };
            let (gl_p, gl_c) = &jac.left[j];
            let (gr_p, gr_c) = &jac.right[j];
            // The products straight into their buffers (`mul_to` is the `*` of nalgebra, the
            // same operations), no temporaries copied.
            self.inv_body[b].mul_to(&gl_c.transpose(), &mut self.y_child[j]);
            self.h_child[j] = s[b].right_of(gr_c);
            self.d_joint[j] += self.h_child[j] * self.y_child[j];
            if !invert_into(&self.d_joint[j], &mut self.inv_joint[j]) {
                return false;
            }
            if let Some(p) = topo.joint_bodies[j].0 {
                let hp = s[p].right_of(gr_p);
                self.inv_joint[j].mul_to(&hp, &mut self.x_parent[j]);
                self.d_body[p] += gl_p.transpose() * self.x_parent[j];
            }
        }
        if jac.extra_right.is_empty() {
            return true;
        }
        // The compliances, for the products with the extra rows (here and in the solve).
        self.s.copy_from_slice(s);
        // Columns K_tm[:, m] = G_R,t S G_L,mᵀ, then Y_m = K_tt⁻¹ K_tm[:, m].
        let n_extra = jac.extra_right.len();
        for m in 0..n_extra {
            let mut col = std::mem::take(&mut self.extra_cols[m]);
            for c in col.iter_mut() {
                *c = RowValues::zeros();
            }
            for (i, row) in jac.extra_left[m].bodies.iter().flatten() {
                let w = s[*i].apply(&row.transpose());
                self.add_joint_rows(*i, &w, jac.right, &mut col);
            }
            self.solve_tree(jac.left, &mut col);
            self.extra_cols[m] = col;
        }
        // Σ = K_mm − K_mt Y.
        for m in 0..n_extra {
            for k in 0..n_extra {
                let direct: f64 = jac.extra_right[m]
                    .bodies
                    .iter()
                    .flatten()
                    .map(|(i, rr)| {
                        jac.extra_left[k]
                            .bodies
                            .iter()
                            .flatten()
                            .filter(|(l, _)| l == i)
                            .map(|(_, rl)| (rr * s[*i].apply(&rl.transpose()))[0])
                            .sum::<f64>()
                    })
                    .sum();
                let y = std::mem::take(&mut self.extra_cols[k]);
                let coupled = self.extra_row_times(&jac.extra_right[m], &y, jac.left);
                self.extra_cols[k] = y;
                self.schur[(m, k)] = direct - coupled;
            }
        }
        self.schur.iter().all(|x| x.is_finite())
            && lu_in_place(&mut self.schur, &mut self.schur_pivots)
    }

    /// Adds `G_R,ji w` to `out[j]` for every joint `j` touching body `i`.
    fn add_joint_rows(
        &self,
        body: usize,
        w: &Vector6,
        right: &[(RowJacobian, RowJacobian)],
        out: &mut [RowValues],
    ) {
        for (j, &(p, c)) in self.topo.joint_bodies.iter().enumerate() {
            if c == body {
                out[j] += right[j].1 * w;
            }
            if p == Some(body) {
                out[j] += right[j].0 * w;
            }
        }
    }

    /// `K_mt x = G_R,m S G_L,tᵀ x` for one extra row.
    fn extra_row_times(
        &mut self,
        row: &ExtraRow,
        x: &[RowValues],
        left: &[(RowJacobian, RowJacobian)],
    ) -> f64 {
        for v in self.impulse.iter_mut() {
            *v = Vector6::zeros();
        }
        for (j, &(p, c)) in self.topo.joint_bodies.iter().enumerate() {
            self.impulse[c] += left[j].1.transpose() * x[j];
            if let Some(p) = p {
                self.impulse[p] += left[j].0.transpose() * x[j];
            }
        }
        for (i, v) in self.impulse.iter_mut().enumerate() {
            *v = self.s[i].apply(v);
        }
        row.dot(&self.impulse)
    }

    /// Solves `K_tt x = rhs` in place (tree rows only), after [`TreeSolver::factor`].
    /// `left` are the left Jacobians the factorisation was given.
    fn solve_tree(&mut self, left: &[(RowJacobian, RowJacobian)], rhs: &mut [RowValues]) {
        let topo = &self.topo;
        for b in self.b_body.iter_mut() {
            *b = Vector6::zeros();
        }
        self.b_joint.copy_from_slice(rhs);
        for b in (0..topo.parent_joint.len()).rev() {
            let y = self.inv_body[b] * self.b_body[b];
            self.y_vec[b] = y;
            let Some(j) = topo.parent_joint[b] else {
                continue;
            };
            let x = self.inv_joint[j] * (self.b_joint[j] - self.h_child[j] * y);
            self.b_joint[j] = x;
            if let Some(p) = topo.joint_bodies[j].0 {
                self.b_body[p] += left[j].0.transpose() * x;
            }
        }
        for b in 0..topo.parent_joint.len() {
            match topo.parent_joint[b] {
                None => self.z[b] = self.y_vec[b],
                Some(j) => {
                    let x = match topo.joint_bodies[j].0 {
                        Some(p) => self.b_joint[j] - self.x_parent[j] * self.z[p],
                        None => self.b_joint[j],
                    };
                    rhs[j] = x;
                    self.z[b] = self.y_vec[b] + self.y_child[j] * x;
                }
            }
        }
    }

    /// Solves `K x = r` for the tree rows `rhs` and the extra rows `extra` (both replaced by
    /// the solution), after a successful [`TreeSolver::factor`].
    pub fn solve(&mut self, jac: &Jacobians, rhs: &mut [RowValues], extra: &mut [f64]) {
        if extra.is_empty() {
            self.solve_tree(jac.left, rhs);
            return;
        }
        // x_t0 = K_tt⁻¹ r_t; Σ x_m = r_m − K_mt x_t0; x_t = x_t0 − Y x_m.
        self.solve_tree(jac.left, rhs);
        let x0 = std::mem::take(&mut self.tree_rhs);
        let mut x0 = x0;
        x0.copy_from_slice(rhs);
        for m in 0..extra.len() {
            self.schur_rhs[m] = extra[m] - self.extra_row_times(&jac.extra_right[m], &x0, jac.left);
        }
        self.tree_rhs = x0;
        lu_solve(&self.schur, &self.schur_pivots, &mut self.schur_rhs);
        for m in 0..extra.len() {
            let xm = self.schur_rhs[m];
            extra[m] = xm;
            for (r, y) in rhs.iter_mut().zip(&self.extra_cols[m]) {
                *r -= y * xm;
            }
        }
    }
}

/// LU with partial pivoting of the square `a`, in place (`L` below the diagonal, unit
/// diagonal implied; `U` on and above), row swaps in `pivots`. `false` when a pivot is zero or
/// not finite. (nalgebra's dynamic LU allocates; this one works in the buffers given.)
fn lu_in_place(a: &mut DMatrix<f64>, pivots: &mut [usize]) -> bool {
    let n = a.nrows();
    for k in 0..n {
        let p = (k..n)
            .max_by(|&i, &j| a[(i, k)].abs().total_cmp(&a[(j, k)].abs()))
            .unwrap_or(k);
        pivots[k] = p;
        if p != k {
            a.swap_rows(k, p);
        }
        let pivot = a[(k, k)];
        if !(pivot != 0.0 && pivot.is_finite()) {
            return false;
        }
        for i in k + 1..n {
            let f = a[(i, k)] / pivot;
            a[(i, k)] = f;
            for j in k + 1..n {
                a[(i, j)] -= f * a[(k, j)];
            }
        }
    }
    true
}

/// Solves `a x = b` in place with the factors of [`lu_in_place`].
fn lu_solve(a: &DMatrix<f64>, pivots: &[usize], b: &mut DVector<f64>) {
    let n = a.nrows();
    for k in 0..n {
        b.swap_rows(k, pivots[k]);
    }
    for i in 0..n {
        for j in 0..i {
            b[i] -= a[(i, j)] * b[j];
        }
    }
    for i in (0..n).rev() {
        for j in i + 1..n {
            b[i] -= a[(i, j)] * b[j];
        }
        b[i] /= a[(i, i)];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pseudo-random number in [-1, 1) (xorshift; fixed seed, so the test is reproducible).
    fn rng(state: &mut u64) -> f64 {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        (*state >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }

    fn random_jac(state: &mut u64, rows: usize) -> RowJacobian {
        RowJacobian::from_fn(|r, _| if r < rows { rng(state) } else { 0.0 })
    }

    /// The plain Gauss-Jordan elimination [`invert`] was written from (every column of the
    /// working copy updated): the bit-for-bit reference of the faster code.
    pub(super) fn invert_reference<const N: usize>(
        m: &SMatrix<f64, N, N>,
    ) -> Option<SMatrix<f64, N, N>> {
        let mut a = *m;
        let mut inv = SMatrix::<f64, N, N>::identity();
        for k in 0..N {
            let mut p = k;
            for i in k + 1..N {
                if a[(i, k)].abs() > a[(p, k)].abs() {
                    p = i;
                }
            }
            if p != k {
                a.swap_rows(k, p);
                inv.swap_rows(k, p);
            }
            let pivot = a[(k, k)];
            if !(pivot != 0.0 && pivot.is_finite()) {
                return None;
            }
            let r = 1.0 / pivot;
            for j in 0..N {
                a[(k, j)] *= r;
                inv[(k, j)] *= r;
            }
            for i in 0..N {
                if i != k {
                    let f = a[(i, k)];
                    if f != 0.0 {
                        for j in 0..N {
                            a[(i, j)] -= f * a[(k, j)];
                            inv[(i, j)] -= f * inv[(k, j)];
                        }
                    }
                }
            }
        }
        Some(inv)
    }

    /// Bits of every entry (so that `-0.0` and `0.0`, and NaNs, are told apart).
    pub(super) fn bits<const R: usize, const C: usize>(m: &SMatrix<f64, R, C>) -> Vec<u64> {
        m.iter().map(|x| x.to_bits()).collect()
    }

    /// A matrix of the kinds the tree solve meets: dense, sparse with signed zeros, with
    /// entries of mixed signs and sizes, padded with a diagonal block (a joint's unused rows).
    fn structured<const N: usize>(st: &mut u64, kind: u32) -> SMatrix<f64, N, N> {
        SMatrix::from_fn(|i, j| {
            let x = rng(st);
            match kind % 5 {
                0 => x,
                1 => {
                    if x.abs() < 0.4 {
                        if x < 0.0 { -0.0 } else { 0.0 }
                    } else {
                        x * 10f64.powi((x * 8.0) as i32)
                    }
                }
                2 => {
                    if i == j {
                        x + 2.0f64.copysign(x)
                    } else if (i + j) % 2 == 0 {
                        -0.0
                    } else {
                        x
                    }
                }
                3 => {
                    if i >= 5 || j >= 5 {
                        if i == j {
                            1.0
                        } else if x < 0.0 {
                            -0.0
                        } else {
                            0.0
                        }
                    } else {
                        x
                    }
                }
                _ => {
                    if i == j {
                        1.0
                    } else {
                        0.0
                    }
                }
            }
        })
    }

    /// [`invert`] gives the bits of the plain elimination on every kind of block.
    #[test]
    fn invert_matches_the_plain_elimination_bit_for_bit() {
        let mut st = 0x1234_5678_9abc_def1u64;
        for n in 0..20_000u32 {
            let m6 = structured::<6>(&mut st, n);
            let (a, b) = (invert(&m6), invert_reference(&m6));
            assert_eq!(a.map(|m| bits(&m)), b.map(|m| bits(&m)), "6x6 case {n}");
            let m7 = structured::<MAX_ROWS>(&mut st, n);
            let (a, b) = (invert(&m7), invert_reference(&m7));
            assert_eq!(a.map(|m| bits(&m)), b.map(|m| bits(&m)), "7x7 case {n}");
        }
    }

    /// A branched tree (body 1 has three children), a joint on the world, unused rows and two
    /// extra rows: the solution satisfies the dense system `K x = r` built independently.
    #[test]
    fn invert_inverts_and_refuses_singular_matrices() {
        let mut st = 7u64;
        let m = SMatrix::<f64, 6, 6>::from_fn(|_, _| rng(&mut st)) + Matrix6::identity() * 0.5;
        let inv = invert(&m).unwrap();
        // Well-conditioned random matrix: measured 4e-16.
        assert!((m * inv - Matrix6::identity()).amax() < 1e-13);
        let mut singular = m;
        let row = singular.row(2).into_owned();
        singular.set_row(4, &(row * 3.0));
        assert!(invert(&singular).is_none() || invert(&singular).unwrap().amax() > 1e12);
        assert!(invert(&Matrix5::zeros()).is_none());
    }

    #[test]
    fn solves_the_dense_system() {
        for floating in [true, false] {
            let mut st = 0x9e37_79b9_7f4a_7c15u64;
            // Bodies 0..6; joints: child b has parent joint b-1 (floating) or b (fixed base).
            let parents: [Option<usize>; 6] = [None, Some(0), Some(1), Some(1), Some(1), Some(3)];
            let rows = [5, 4, 5, 3, 5, 5];
            let mut topo = Topology {
                parent_joint: vec![None; 6],
                joint_bodies: Vec::new(),
                rows: Vec::new(),
            };
            for b in 0..6 {
                if floating && b == 0 {
                    continue;
                }
                topo.parent_joint[b] = Some(topo.joint_bodies.len());
                topo.joint_bodies.push((parents[b], b));
                topo.rows.push(rows[b]);
            }
            let nj = topo.joint_bodies.len();
            let left: Vec<_> = (0..nj)
                .map(|j| {
                    (
                        random_jac(&mut st, topo.rows[j]),
                        random_jac(&mut st, topo.rows[j]),
                    )
                })
                .collect();
            // The right Jacobians near the left ones (as in a step: two nearby configurations).
            let right: Vec<_> = left
                .iter()
                .enumerate()
                .map(|(j, (p, c))| {
                    (
                        p + random_jac(&mut st, topo.rows[j]) * 0.1,
                        c + random_jac(&mut st, topo.rows[j]) * 0.1,
                    )
                })
                .collect();
            let s: Vec<Compliance> = (0..6)
                .map(|_| {
                    let a = Matrix3::from_fn(|_, _| rng(&mut st) * 0.2);
                    Compliance {
                        trans: 0.5 + rng(&mut st).abs(),
                        rot: Matrix3::identity() * 2.0 + a,
                    }
                })
                .collect();
            let extra = |st: &mut u64| ExtraRow {
                bodies: [
                    Some((2, Row6::from_fn(|_, _| rng(st)))),
                    Some((5, Row6::from_fn(|_, _| rng(st)))),
                    None,
                    None,
                ],
            };
            let extra_left = vec![extra(&mut st), extra(&mut st)];
            let extra_right: Vec<ExtraRow> = extra_left
                .iter()
                .map(|e| {
                    let mut e = *e;
                    for (_, row) in e.bodies.iter_mut().flatten() {
                        *row += Row6::from_fn(|_, _| rng(&mut st) * 0.1);
                    }
                    e
                })
                .collect();
            // Dense K over (tree rows used, extra rows).
            let mut g_left = DMatrix::zeros(0, 36);
            let mut g_right = DMatrix::zeros(0, 36);
            let push = |gl: &mut DMatrix<f64>, rowv: Vec<f64>| {
                let r = gl.nrows();
                *gl = gl.clone().insert_row(r, 0.0);
                for (c, v) in rowv.into_iter().enumerate() {
                    gl[(r, c)] = v;
                }
            };
            for j in 0..nj {
                let (p, c) = topo.joint_bodies[j];
                for r in 0..topo.rows[j] {
                    for (g, side) in [(&mut g_left, &left[j]), (&mut g_right, &right[j])] {
                        let mut v = vec![0.0; 36];
                        for k in 0..6 {
                            v[c * 6 + k] = side.1[(r, k)];
                            if let Some(p) = p {
                                v[p * 6 + k] = side.0[(r, k)];
                            }
                        }
                        push(g, v);
                    }
                }
            }
            for (el, er) in extra_left.iter().zip(&extra_right) {
                for (g, e) in [(&mut g_left, el), (&mut g_right, er)] {
                    let mut v = vec![0.0; 36];
                    for (i, row) in e.bodies.iter().flatten() {
                        for k in 0..6 {
                            v[i * 6 + k] += row[k];
                        }
                    }
                    push(g, v);
                }
            }
            let mut s_dense = DMatrix::zeros(36, 36);
            for (i, si) in s.iter().enumerate() {
                for k in 0..3 {
                    s_dense[(i * 6 + k, i * 6 + k)] = si.trans;
                }
                for r in 0..3 {
                    for c in 0..3 {
                        s_dense[(i * 6 + 3 + r, i * 6 + 3 + c)] = si.rot[(r, c)];
                    }
                }
            }
            let k_dense = &g_right * &s_dense * g_left.transpose();
            let n = k_dense.nrows();
            let r_dense = DVector::from_fn(n, |_, _| rng(&mut st));
            let x_dense = k_dense.clone().lu().solve(&r_dense).unwrap();

            let mut solver = TreeSolver::new(topo.clone(), 2);
            let jac = Jacobians {
                left: &left,
                right: &right,
                extra_left: &extra_left,
                extra_right: &extra_right,
            };
            assert!(solver.factor(&jac, &s));
            let mut rhs = vec![RowValues::zeros(); nj];
            let mut k = 0;
            for j in 0..nj {
                for r in 0..topo.rows[j] {
                    rhs[j][r] = r_dense[k];
                    k += 1;
                }
            }
            let mut extra_rhs = [r_dense[k], r_dense[k + 1]];
            solver.solve(&jac, &mut rhs, &mut extra_rhs);
            let mut k = 0;
            let mut worst: f64 = 0.0;
            for j in 0..nj {
                for r in 0..MAX_ROWS {
                    if r < topo.rows[j] {
                        worst = worst.max((rhs[j][r] - x_dense[k]).abs());
                        k += 1;
                    } else {
                        assert_eq!(rhs[j][r], 0.0, "unused row {r} of joint {j}");
                    }
                }
            }
            worst = worst.max((extra_rhs[0] - x_dense[k]).abs());
            worst = worst.max((extra_rhs[1] - x_dense[k + 1]).abs());
            let scale = x_dense.amax();
            // Two LU solves of a well-conditioned 30-row system: measured ≤ 2e-14 relative.
            assert!(
                worst < 1e-11 * scale,
                "floating {floating}: {worst:e} (scale {scale:e})"
            );
        }
    }
}
