//! The joint-space mass matrix `M(q)` plus a diagonal, factorised and solved in time linear in
//! the bodies: Featherstone's articulated-body recursion with no velocity terms
//! (R. Featherstone, *Rigid Body Dynamics Algorithms*, 2008, §7.3, the ABA's second and third
//! passes with the bias forces set to zero), in the world-aligned spatial algebra about the
//! step's reference point ([`super::kinematics`]).
//!
//! ```text
//! factor (leaves to root):  Iᴬ_b = I_b + Σ_children (Iᴬ_c − U_c U_cᵀ / D_c),
//!                           U_j = Iᴬ_b s_j,   D_j = s_jᵀ U_j + a_j        (a_j ≥ 0: the diagonal)
//! solve (M + diag a) x = τ: backward  u_j = τ_j − s_jᵀ pᴬ_b,   pᴬ_parent += pᴬ_b + U_j u_j / D_j
//!                           forward   x_j = (u_j − U_jᵀ α_parent) / D_j,   α_b = α_parent + s_j x_j
//! ```
//!
//! A floating root (generalized coordinates `η` in its body frame and `δc` in the world, its
//! centre of mass the reference point) closes the recursion with the 6x6 `Iᴬ_0 α_0 = w − pᴬ_0`
//! (Cholesky), `w = (R_0 τ_η, τ_c)`, `x_0 = (R_0ᵀ α_ω, α_v)`. The spatial inertia of a body
//! about `o` with `r = c − o` and `Ī = R J Rᵀ` maps a twist `(ω, v_o)` to its momentum
//! `(Ī ω + r × m v_c, m v_c)`, `v_c = v_o + ω × r`.

use super::kinematics::Pose;
use super::model::TreeModel;
use nalgebra::{Cholesky, Matrix3, Matrix6, U6, Vector3, Vector6};

/// The spatial inertia about `o` of a body at `pose` (principal moments `inertia`, mass `m`).
pub fn spatial_inertia(
    pose: &Pose,
    inertia: &Vector3<f64>,
    mass: f64,
    o: &Vector3<f64>,
) -> Matrix6<f64> {
    let r = pose.com - o;
    let rot = &pose.rot;
    let ibar = rot * Matrix3::from_diagonal(inertia) * rot.transpose();
    let rx = crate::sim::so3::hat(&r);
    let mut out = Matrix6::zeros();
    let top_left = ibar + (Matrix3::identity() * r.norm_squared() - r * r.transpose()) * mass;
    out.fixed_view_mut::<3, 3>(0, 0).copy_from(&top_left);
    out.fixed_view_mut::<3, 3>(0, 3).copy_from(&(rx * mass));
    out.fixed_view_mut::<3, 3>(3, 0)
        .copy_from(&(rx.transpose() * mass));
    out.fixed_view_mut::<3, 3>(3, 3)
        .copy_from(&(Matrix3::identity() * mass));
    out
}

/// The factorised `M(q) + diag(a)` (see the module doc) and the solve's buffers.
#[derive(Debug, Clone)]
pub struct Factor {
    /// Per body, `Iᴬ` (filled from the bodies' spatial inertias by the caller, then reduced).
    pub articulated: Vec<Matrix6<f64>>,
    /// Per joint, its unit twist `s_j` (filled by the caller).
    pub twist: Vec<Vector6<f64>>,
    u: Vec<Vector6<f64>>,
    d_inv: Vec<f64>,
    root: Option<Cholesky<f64, U6>>,
    root_rot: Matrix3<f64>,
    bias: Vec<Vector6<f64>>,
    accel: Vec<Vector6<f64>>,
    joint_u: Vec<f64>,
}

impl Factor {
    pub fn new(tree: &TreeModel, bodies: usize) -> Self {
        let nj = tree.joints.len();
        Self {
            articulated: vec![Matrix6::zeros(); bodies],
            twist: vec![Vector6::zeros(); nj],
            u: vec![Vector6::zeros(); nj],
            d_inv: vec![0.0; nj],
            root: None,
            root_rot: Matrix3::identity(),
            bias: vec![Vector6::zeros(); bodies],
            accel: vec![Vector6::zeros(); bodies],
            joint_u: vec![0.0; nj],
        }
    }

    /// Reduces `articulated` (the bodies' spatial inertias) with the diagonal `diag` (per
    /// joint); `root_rot` is the floating root's rotation. `false` when a pivot is not a
    /// positive finite number (the tree is singular there).
    pub fn factor(&mut self, tree: &TreeModel, diag: &[f64], root_rot: &Matrix3<f64>) -> bool {
        for (j, joint) in tree.joints.iter().enumerate().rev() {
            let ia = self.articulated[joint.child];
            let s = &self.twist[j];
            let u = ia * s;
            let d = s.dot(&u) + diag[j];
            if !(d > 0.0 && d.is_finite()) {
                return false;
            }
            let d_inv = 1.0 / d;
            self.u[j] = u;
            self.d_inv[j] = d_inv;
            if let Some(p) = joint.parent {
                let reduced = ia - u * (u.transpose() * d_inv);
                self.articulated[p] += reduced;
            }
        }
        if tree.floating {
            self.root_rot = *root_rot;
            self.root = Cholesky::new(self.articulated[0]);
            if self.root.is_none() {
                return false;
            }
        }
        true
    }

    /// `x = (M + diag a)⁻¹ τ` (generalized coordinates: the base's first, then the joints').
    pub fn solve(&mut self, tree: &TreeModel, tau: &[f64], x: &mut [f64]) {
        let nb = tree.base_dofs();
        for b in self.bias.iter_mut() {
            *b = Vector6::zeros();
        }
        for (j, joint) in tree.joints.iter().enumerate().rev() {
            let pa = self.bias[joint.child];
            let u = tau[nb + j] - self.twist[j].dot(&pa);
            self.joint_u[j] = u;
            if let Some(p) = joint.parent {
                self.bias[p] += pa + self.u[j] * (u * self.d_inv[j]);
            }
        }
        if let Some(chol) = &self.root {
            let t = Vector3::new(tau[0], tau[1], tau[2]);
            let n = self.root_rot * t;
            let w = Vector6::new(n.x, n.y, n.z, tau[3], tau[4], tau[5]) - self.bias[0];
            let a0 = chol.solve(&w);
            let ang = self.root_rot.transpose() * Vector3::new(a0[0], a0[1], a0[2]);
            x[..3].copy_from_slice(ang.as_slice());
            x[3..6].copy_from_slice(&[a0[3], a0[4], a0[5]]);
            self.accel[0] = a0;
        }
        for (j, joint) in tree.joints.iter().enumerate() {
            let ap = match joint.parent {
                Some(p) => self.accel[p],
                None => Vector6::zeros(),
            };
            let xj = (self.joint_u[j] - self.u[j].dot(&ap)) * self.d_inv[j];
            x[nb + j] = xj;
            self.accel[joint.child] = ap + self.twist[j] * xj;
        }
    }
}
