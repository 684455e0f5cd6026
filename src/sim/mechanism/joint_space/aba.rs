//! The Newton matrix of the joint-space step, factorised and solved in time linear in the
//! bodies: Featherstone's articulated-body elimination (R. Featherstone, *Rigid Body Dynamics
//! Algorithms*, 2008, §7.3, the ABA's second and third passes with no bias forces), generalised
//! to the non-symmetric matrix of the discrete equations.
//!
//! The step's residual is `r_j(q') = s_jᵀ Σ_{i ∈ subtree(j)} w_i(q')` with the left twists
//! `s_j` taken at `q_k` (fixed in the step) and `w_i` body `i`'s momentum change, a function of
//! its pose at the iterate. Its derivative is therefore
//!
//! ```text
//! ∂r/∂q' = Σ_i S_i(q_k)ᵀ A_i S'_i(q'),   A_i = ∂w_i / ∂V'_i   (6x6, world-aligned, about o)
//! ```
//!
//! with `S'_i` the right twists `s'_j = s_j(q')` of `i`'s ancestors (the variation `V'_i` of
//! the body's pose), the same sparsity as the mass matrix `Σ S_iᵀ I_i S_i`, which it is at
//! `q' = q_k`. The elimination, leaves to root, with `a_j` the diagonal (drives):
//!
//! ```text
//! factor:  Iᴬ_b = A_b + Σ_children (Iᴬ_c − U_c L_cᵀ / D_c),
//!          U_j = Iᴬ_b s'_j,   L_j = Iᴬ_bᵀ s_j,   D_j = s_jᵀ Iᴬ_b s'_j + a_j
//! solve:   backward  u_j = b_j − s_jᵀ pᴬ_b,   pᴬ_parent += pᴬ_b + U_j u_j / D_j
//!          forward   x_j = (u_j − L_jᵀ α_parent) / D_j,   α_b = α_parent + s'_j x_j
//! ```
//!
//! (from `s_jᵀ (Iᴬ_b α_b + pᴬ_b) + a_j x_j = b_j` with `α_b = α_parent + s'_j x_j`: each
//! joint's unknown eliminated in terms of its parent's motion). A floating root closes it with
//! the 6x6 `(S_0ᵀ Iᴬ_0 S'_0) x_0 = b_0 − S_0ᵀ pᴬ_0` (LU), `S_0`, `S'_0` the root's own left and
//! right maps (see [`root_maps`]).
//!
//! [`body_block`] gives `h A_i` for the free-body discrete Lagrangian's momenta; the step
//! solves `(h ∂r/∂q') δq = −h r`.

use super::kinematics::Pose;
use super::model::TreeModel;
use crate::sim::so3::{d_coefficient, hat};
use nalgebra::{LU, Matrix3, Matrix6, U6, Vector3, Vector6};

/// `dD/d(θ²)` of [`d_coefficient`]: `D = (1 − (θ/2) cot(θ/2)) / θ²`; by series below
/// `θ = 0.1` (`1/720 + θ²/15120 + θ⁴/403200`, the next term `θ⁶/…` below 1e-12 there; the
/// derivative only shapes the Newton direction, never the solution).
fn d_coefficient_slope(theta_sq: f64) -> f64 {
    if theta_sq < 1e-2 {
        1.0 / 720.0 + theta_sq / 15120.0 + theta_sq * theta_sq / 403_200.0
    } else {
        let theta = theta_sq.sqrt();
        let half = 0.5 * theta;
        let (s, c) = half.sin_cos();
        let cot = c / s;
        let num = 1.0 - half * cot;
        // d/dθ [(θ/2) cot(θ/2)] = cot(θ/2)/2 − (θ/4) / sin²(θ/2)
        let dnum = -(0.5 * cot - 0.25 * theta / (s * s));
        let dd_dtheta = dnum / theta_sq - 2.0 * num / (theta_sq * theta);
        dd_dtheta / (2.0 * theta)
    }
}

/// `h A_i`: the derivative of body `i`'s momentum change (world wrench about `o`,
/// `(R_k (M⁺ − M) + (c_k − o) × (p⁺ − p), p⁺ − p)`) with respect to its pose's variation at
/// the iterate, `δR' = [δω]× R'`, `δc' = δv_o + δω × (c' − o)`, times `h`:
///
/// ```text
/// h A = [[R_k G Jr⁻¹(ξ) R'ᵀ − m [r_k]×[r']×,  m [r_k]×],
///        [−m [r']×,                            m I    ]]
/// ```
///
/// `r_k = c_k − o`, `r' = c' − o`, `ξ = log(R_kᵀ R')`, `Jr⁻¹(ξ) = I + ½ ξ^ + D ξ^²` (the
/// right Jacobian's inverse: `δξ = Jr⁻¹ R'ᵀ δω`), and `G = h ∂M⁺/∂ξ` of
/// `M⁺ = Jr⁻¹(ξ) J ξ / h` with `y = J ξ`:
///
/// ```text
/// G = J + ½ (ξ^ J − y^) + D (ξ^² J − ξ^ y^ − (ξ × y)^) + 2 D' (ξ × (ξ × y)) ξᵀ
/// ```
pub fn body_block(
    start: &Pose,
    next: &Pose,
    xi: &Vector3<f64>,
    inertia: &Vector3<f64>,
    mass: f64,
    o: &Vector3<f64>,
) -> Matrix6<f64> {
    let j = Matrix3::from_diagonal(inertia);
    let y = inertia.component_mul(xi);
    let s = xi.norm_squared();
    let d = d_coefficient(s);
    let dd = d_coefficient_slope(s);
    let xh = hat(xi);
    let yh = hat(&y);
    let xy = xi.cross(&y);
    let g = j
        + (xh * j - yh) * 0.5
        + (xh * xh * j - xh * yh - hat(&xy)) * d
        + xi.cross(&xy) * (xi.transpose() * (2.0 * dd));
    let jr_inv = Matrix3::identity() + xh * 0.5 + xh * xh * d;
    let rk = hat(&(start.com - o));
    let rn = hat(&(next.com - o));
    let top_left = start.rot * g * jr_inv * next.rot.transpose() - rk * rn * mass;
    let mut out = Matrix6::zeros();
    out.fixed_view_mut::<3, 3>(0, 0).copy_from(&top_left);
    out.fixed_view_mut::<3, 3>(0, 3).copy_from(&(rk * mass));
    out.fixed_view_mut::<3, 3>(3, 0).copy_from(&(rn * -mass));
    out.fixed_view_mut::<3, 3>(3, 3)
        .copy_from(&(Matrix3::identity() * mass));
    out
}

/// A floating root's left and right maps from its coordinates `(ξ_0, Δc_0)` (`R_0' = R_0
/// exp(ξ_0)`, `c_0' = c_0 + Δc_0`): the residual's rows are `S_0ᵀ w = (R_0ᵀ n, f)`, so
/// `S_0 = diag(R_0, I)` at `q_k`; the pose's variation is `S'_0 δ` with
/// `δω = R_0' Jr(ξ_0) δξ_0`, `δv_o = δc_0 + (c_0' − o) × δω`:
///
/// ```text
/// S'_0 = [[R_0' Jr(ξ_0), 0], [[c_0' − o]× R_0' Jr(ξ_0), I]]
/// ```
pub fn root_maps(
    start: &Pose,
    next: &Pose,
    xi: &Vector3<f64>,
    o: &Vector3<f64>,
) -> (Matrix6<f64>, Matrix6<f64>) {
    let mut left = Matrix6::identity();
    left.fixed_view_mut::<3, 3>(0, 0).copy_from(&start.rot);
    let rot = next.rot * crate::sim::so3::t_matrix(&-xi);
    let mut right = Matrix6::identity();
    right.fixed_view_mut::<3, 3>(0, 0).copy_from(&rot);
    right
        .fixed_view_mut::<3, 3>(3, 0)
        .copy_from(&(hat(&(next.com - o)) * rot));
    (left, right)
}

/// The factorised Newton matrix (see the module doc) and the solve's buffers.
#[derive(Debug, Clone)]
pub struct Jacobian {
    /// Per body, `Iᴬ` (filled with the bodies' [`body_block`]s by the caller, then reduced).
    pub articulated: Vec<Matrix6<f64>>,
    /// Per joint, its unit twist at `q_k` (`s_j`) and at the iterate (`s'_j`), filled by
    /// the caller.
    pub left: Vec<Vector6<f64>>,
    pub right: Vec<Vector6<f64>>,
    /// A floating root's maps ([`root_maps`]), filled by the caller.
    pub root_left: Matrix6<f64>,
    pub root_right: Matrix6<f64>,
    u: Vec<Vector6<f64>>,
    l: Vec<Vector6<f64>>,
    d_inv: Vec<f64>,
    root: Option<LU<f64, U6, U6>>,
    bias: Vec<Vector6<f64>>,
    accel: Vec<Vector6<f64>>,
    joint_u: Vec<f64>,
}

impl Jacobian {
    pub fn new(tree: &TreeModel, bodies: usize) -> Self {
        let nj = tree.joints.len();
        Self {
            articulated: vec![Matrix6::zeros(); bodies],
            left: vec![Vector6::zeros(); nj],
            right: vec![Vector6::zeros(); nj],
            root_left: Matrix6::identity(),
            root_right: Matrix6::identity(),
            u: vec![Vector6::zeros(); nj],
            l: vec![Vector6::zeros(); nj],
            d_inv: vec![0.0; nj],
            root: None,
            bias: vec![Vector6::zeros(); bodies],
            accel: vec![Vector6::zeros(); bodies],
            joint_u: vec![0.0; nj],
        }
    }

    /// Reduces `articulated` with the diagonal `diag` (per joint). `false` when a pivot
    /// vanishes or is not finite, or the root's block is singular.
    pub fn factor(&mut self, tree: &TreeModel, diag: &[f64], locked: &[bool]) -> bool {
        for (j, joint) in tree.joints.iter().enumerate().rev() {
            let ia = self.articulated[joint.child];
            if locked[j] {
                // A held coordinate (a stop): a weld, its child's articulated inertia passed
                // whole to the parent (`d⁻¹ = 0`), its update 0.
                self.d_inv[j] = 0.0;
                self.u[j] = Vector6::zeros();
                self.l[j] = Vector6::zeros();
                if let Some(p) = joint.parent {
                    self.articulated[p] += ia;
                }
                continue;
            }
            let u = ia * self.right[j];
            let l = ia.tr_mul(&self.left[j]);
            let d = self.left[j].dot(&u) + diag[j];
            // Positive at `q' = q_k` (the mass matrix's pivot); near the solution of a
            // step it stays near that. Only a vanishing or non-finite pivot is refused.
            if !(d.abs() > f64::MIN_POSITIVE && d.is_finite()) {
                return false;
            }
            let d_inv = 1.0 / d;
            self.u[j] = u;
            self.l[j] = l;
            self.d_inv[j] = d_inv;
            if let Some(p) = joint.parent {
                let reduced = ia - u * (l.transpose() * d_inv);
                self.articulated[p] += reduced;
            }
        }
        if tree.floating {
            let k = self.root_left.transpose() * self.articulated[0] * self.root_right;
            let lu = k.lu();
            if !lu.is_invertible() || !k.iter().all(|v| v.is_finite()) {
                return false;
            }
            self.root = Some(lu);
        }
        true
    }

    /// `x = K⁻¹ b` (generalized coordinates: the base's first, then the joints').
    pub fn solve(&mut self, tree: &TreeModel, b: &[f64], x: &mut [f64]) {
        let nb = tree.base_dofs();
        for v in self.bias.iter_mut() {
            *v = Vector6::zeros();
        }
        for (j, joint) in tree.joints.iter().enumerate().rev() {
            let pa = self.bias[joint.child];
            let u = b[nb + j] - self.left[j].dot(&pa);
            self.joint_u[j] = u;
            if let Some(p) = joint.parent {
                self.bias[p] += pa + self.u[j] * (u * self.d_inv[j]);
            }
        }
        if let Some(lu) = &self.root {
            let rhs = Vector6::from_column_slice(&b[..6]) - self.root_left.tr_mul(&self.bias[0]);
            let x0 = lu.solve(&rhs).unwrap_or_else(Vector6::zeros);
            x[..6].copy_from_slice(x0.as_slice());
            self.accel[0] = self.root_right * x0;
        }
        for (j, joint) in tree.joints.iter().enumerate() {
            let ap = match joint.parent {
                Some(p) => self.accel[p],
                None => Vector6::zeros(),
            };
            let xj = (self.joint_u[j] - self.l[j].dot(&ap)) * self.d_inv[j];
            x[nb + j] = xj;
            self.accel[joint.child] = ap + self.right[j] * xj;
        }
    }
}
