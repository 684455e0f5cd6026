//! Joint constraint rows `g(q) = 0` and their Jacobians, written in the PARENT body's frame.
//!
//! A joint connects a parent body `a` and a child body `b` (maximal coordinates: every body
//! keeps its pose `R`, `c`: principal frame, centre of mass). Variations are `δc` (world) and
//! `η` (body frame, `δR = R η^`), so a Jacobian row has six columns per body: `[∂/∂c, ∂/∂η]`,
//! and `Gᵀ λ` is an impulse `[force (world); torque (body frame)]`, the units of `[p; M]`.
//!
//! With `W = R_aᵀ R_b`, the anchors `a_a`, `a_b` (the joint origin in each body's frame),
//! `ρ = R_aᵀ (c_b + R_b a_b − c_a)` and the anchor gap `d = ρ − a_a` (parent frame):
//!
//! | row | value | `∂/∂c_a` | `∂/∂η_a` | `∂/∂c_b` | `∂/∂η_b` |
//! |---|---|---|---|---|---|
//! | gap along `t` (parent axes) | `t·d` | `−(R_a t)ᵀ` | `(t × ρ)ᵀ` | `(R_a t)ᵀ` | `(a_b × Wᵀt)ᵀ` |
//! | dot `t` (parent), `s` (child) | `t·(W s) − c₀` | 0 | `(t × W s)ᵀ` | 0 | `(s × Wᵀt)ᵀ` |
//!
//! (from `δ(R_aᵀ) = −η_a^ R_aᵀ`, `δ(R_b a_b) = R_b (η_b × a_b)`, `δW = W η_b^ − η_a^ W`).
//!
//! | joint | rows |
//! |---|---|
//! | [`RowKind::Hinge`] (revolute, continuous) | gap along the parent's x, y, z (3); dots of the two normals `n₁`, `n₂ ⊥ u_a` with the child's axis `u_b` (2) |
//! | [`RowKind::Slider`] (prismatic) | gap along `n₁`, `n₂` (2); rotation lock `t₂·(W s₃)`, `t₃·(W s₁)`, `t₁·(W s₂)` with the triad `(t₁, t₂, t₃) = (u_a, n₁, n₂)` and `s_k = W₀ᵀ t_k` (3) |
//! | [`RowKind::Universal`] (two revolutes through one point, a massless link between) | gap (3); `u₁·(W u₂) − cos α` (1) |
//! | [`RowKind::Ball`] (three revolutes through one point) | gap (3) |
//!
//! Every value is unchanged by a rigid motion of the whole mechanism (`c → Q c + t`, `R → Q R`),
//! so the impulses `Gᵀλ` of any `λ` sum to zero force and zero torque: the total linear and
//! angular momentum of a free-floating mechanism is exact to round-off whatever the Newton
//! tolerance. (Rows written in the world frame lose that: `design/joints.md`.)
//!
//! The dot rows also vanish for an anti-parallel axis (`W u_b = −u_a`): [`JointRows::sign_ok`]
//! tells the true root from that one after a solve.

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

/// Largest number of rows of one joint block: a joint's constraint rows (at most 5) and its drive
/// rows ([`crate::sim::mechanism::drive`], one per driven coordinate).
pub const MAX_ROWS: usize = 7;
/// Rows of one joint (unused rows, past [`RowKind::count`], are zero).
pub type RowValues = SVector<f64, MAX_ROWS>;
/// One body's columns of a joint's rows: `[∂/∂c (world), ∂/∂η (body)]`.
pub type RowJacobian = SMatrix<f64, MAX_ROWS, 6>;
/// One row's columns for one body.
pub type Row6 = SMatrix<f64, 1, 6>;

/// The pose of one body: `world_from_body` rotation as a matrix, centre of mass in the world.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyPose {
    pub rot: Matrix3<f64>,
    pub com: Vector3<f64>,
}

impl BodyPose {
    pub fn identity() -> Self {
        Self {
            rot: Matrix3::identity(),
            com: Vector3::zeros(),
        }
    }
}

/// What a joint's rows constrain (constant vectors in the body frames, unit length).
#[derive(Debug, Clone, PartialEq)]
pub enum RowKind {
    /// One rotation about an axis: `axis_child` (`u_b`, child frame) stays along `u_a`, the
    /// parent's axis, to which `normals_parent` are orthogonal.
    Hinge {
        axis_parent: Vector3<f64>,
        axis_child: Vector3<f64>,
        normals_parent: [Vector3<f64>; 2],
    },
    /// One translation along `axis_parent`; no rotation. `lock[k] = (t, s)` are the dot rows
    /// `t·(W s)` (parent, child frame) of the rotation lock.
    Slider {
        axis_parent: Vector3<f64>,
        normals_parent: [Vector3<f64>; 2],
        lock: [(Vector3<f64>, Vector3<f64>); 3],
    },
    /// Two rotations about axes through the anchor: `axis_parent` (fixed in the parent) and
    /// `axis_child` (fixed in the child) keep the angle of cosine `cos0` between them.
    Universal {
        axis_parent: Vector3<f64>,
        axis_child: Vector3<f64>,
        cos0: f64,
    },
    /// Every rotation about the anchor.
    Ball,
}

impl RowKind {
    /// Number of rows.
    pub fn count(&self) -> usize {
        match self {
            RowKind::Hinge { .. } | RowKind::Slider { .. } => 5,
            RowKind::Universal { .. } => 4,
            RowKind::Ball => 3,
        }
    }

    /// Per row: whether it is a length (m: the gap rows) rather than a cosine (the dot rows,
    /// dimensionless: a small misalignment in rad).
    pub fn is_length_row(&self, row: usize) -> bool {
        match self {
            RowKind::Slider { .. } => row < 2,
            _ => row < 3,
        }
    }
}

/// The rows of one joint.
#[derive(Debug, Clone, PartialEq)]
pub struct JointRows {
    /// `a_a`: the joint origin in the parent body's frame (for a joint on the world: in the
    /// world frame, with the world as a body at rest at the identity pose).
    pub anchor_parent: Vector3<f64>,
    /// `a_b`: the joint origin in the child body's frame.
    pub anchor_child: Vector3<f64>,
    pub kind: RowKind,
}

/// Gap row along `t`: value and the four 3-column blocks `(∂c_a, ∂η_a, ∂c_b, ∂η_b)`.
struct Frame<'a> {
    a: &'a BodyPose,
    w: Matrix3<f64>,
    rho: Vector3<f64>,
    d: Vector3<f64>,
    anchor_child: Vector3<f64>,
}

impl JointRows {
    /// Number of rows.
    pub fn count(&self) -> usize {
        self.kind.count()
    }

    fn frame<'a>(&self, a: &'a BodyPose, b: &BodyPose) -> Frame<'a> {
        let w = a.rot.transpose() * b.rot;
        let rho = a.rot.transpose() * (b.com + b.rot * self.anchor_child - a.com);
        Frame {
            a,
            w,
            rho,
            d: rho - self.anchor_parent,
            anchor_child: self.anchor_child,
        }
    }

    /// The row values `g` (unused rows 0).
    pub fn values(&self, a: &BodyPose, b: &BodyPose) -> RowValues {
        let f = self.frame(a, b);
        let mut g = RowValues::zeros();
        match &self.kind {
            RowKind::Hinge {
                axis_child,
                normals_parent,
                ..
            } => {
                g.fixed_rows_mut::<3>(0).copy_from(&f.d);
                let ws = f.w * axis_child;
                g[3] = normals_parent[0].dot(&ws);
                g[4] = normals_parent[1].dot(&ws);
            }
            RowKind::Slider {
                normals_parent,
                lock,
                ..
            } => {
                g[0] = normals_parent[0].dot(&f.d);
                g[1] = normals_parent[1].dot(&f.d);
                for (k, (t, s)) in lock.iter().enumerate() {
                    g[2 + k] = t.dot(&(f.w * s));
                }
            }
            RowKind::Universal {
                axis_parent,
                axis_child,
                cos0,
            } => {
                g.fixed_rows_mut::<3>(0).copy_from(&f.d);
                g[3] = axis_parent.dot(&(f.w * axis_child)) - cos0;
            }
            RowKind::Ball => g.fixed_rows_mut::<3>(0).copy_from(&f.d),
        }
        g
    }

    /// The row values and their Jacobians for the parent's and the child's columns.
    pub fn evaluate(
        &self,
        a: &BodyPose,
        b: &BodyPose,
        jac_parent: &mut RowJacobian,
        jac_child: &mut RowJacobian,
    ) -> RowValues {
        let f = self.frame(a, b);
        jac_parent.fill(0.0);
        jac_child.fill(0.0);
        let mut g = RowValues::zeros();
        match &self.kind {
            RowKind::Hinge {
                axis_child,
                normals_parent,
                ..
            } => {
                anchor_rows(&f, &mut g, jac_parent, jac_child);
                let ws = f.w * axis_child;
                for (k, t) in normals_parent.iter().enumerate() {
                    g[3 + k] = t.dot(&ws);
                    dot_row(&f, t, axis_child, 3 + k, jac_parent, jac_child);
                }
            }
            RowKind::Slider {
                normals_parent,
                lock,
                ..
            } => {
                for (k, t) in normals_parent.iter().enumerate() {
                    g[k] = gap_row(&f, t, k, jac_parent, jac_child);
                }
                for (k, (t, s)) in lock.iter().enumerate() {
                    g[2 + k] = t.dot(&(f.w * s));
                    dot_row(&f, t, s, 2 + k, jac_parent, jac_child);
                }
            }
            RowKind::Universal {
                axis_parent,
                axis_child,
                cos0,
            } => {
                anchor_rows(&f, &mut g, jac_parent, jac_child);
                g[3] = axis_parent.dot(&(f.w * axis_child)) - cos0;
                dot_row(&f, axis_parent, axis_child, 3, jac_parent, jac_child);
            }
            RowKind::Ball => anchor_rows(&f, &mut g, jac_parent, jac_child),
        }
        g
    }

    /// Whether the solved configuration is the true root of the dot rows, not the spurious
    /// one with the axis reversed (`u_a·(W u_b) > 0`; for the rotation lock, `W W₀ᵀ` turned by
    /// less than 90° about every axis: every `t_k·(W s_k) > 0`).
    pub fn sign_ok(&self, a: &BodyPose, b: &BodyPose) -> bool {
        let w = a.rot.transpose() * b.rot;
        match &self.kind {
            RowKind::Hinge {
                axis_parent,
                axis_child,
                ..
            } => axis_parent.dot(&(w * axis_child)) > 0.0,
            RowKind::Slider {
                axis_parent,
                normals_parent,
                lock,
            } => {
                let t = [*axis_parent, normals_parent[0], normals_parent[1]];
                // s_k = W0ᵀ t_k: lock[0] = (t2, s3), lock[1] = (t3, s1), lock[2] = (t1, s2).
                let s = [lock[1].1, lock[2].1, lock[0].1];
                (0..3).all(|k| t[k].dot(&(w * s[k])) > 0.0)
            }
            RowKind::Universal { .. } | RowKind::Ball => true,
        }
    }

    /// The anchor gap `d` in the parent frame (m) and the relative rotation `W = R_aᵀ R_b`.
    pub fn gap(&self, a: &BodyPose, b: &BodyPose) -> (Vector3<f64>, Matrix3<f64>) {
        let f = self.frame(a, b);
        (f.d, f.w)
    }
}

/// The three gap rows `d` (parent axes): `∂d/∂c_a = −R_aᵀ`, `∂d/∂η_a = ρ^`,
/// `∂d/∂c_b = R_aᵀ`, `∂d/∂η_b = −W a_b^`.
fn anchor_rows(f: &Frame, g: &mut RowValues, jp: &mut RowJacobian, jc: &mut RowJacobian) {
    g.fixed_rows_mut::<3>(0).copy_from(&f.d);
    let rt = f.a.rot.transpose();
    jp.fixed_view_mut::<3, 3>(0, 0).copy_from(&(-rt));
    jp.fixed_view_mut::<3, 3>(0, 3)
        .copy_from(&crate::sim::so3::hat(&f.rho));
    jc.fixed_view_mut::<3, 3>(0, 0).copy_from(&rt);
    jc.fixed_view_mut::<3, 3>(0, 3)
        .copy_from(&(-(f.w * crate::sim::so3::hat(&f.anchor_child))));
}

/// One gap row along `t` (parent frame) into row `row`; returns its value `t·d`.
fn gap_row(
    f: &Frame,
    t: &Vector3<f64>,
    row: usize,
    jp: &mut RowJacobian,
    jc: &mut RowJacobian,
) -> f64 {
    let rt = f.a.rot * t;
    let wt = f.w.transpose() * t;
    set3(jp, row, 0, &(-rt));
    set3(jp, row, 3, &t.cross(&f.rho));
    set3(jc, row, 0, &rt);
    set3(jc, row, 3, &f.anchor_child.cross(&wt));
    t.dot(&f.d)
}

/// One dot row `t·(W s)` (its Jacobian only) into row `row`.
fn dot_row(
    f: &Frame,
    t: &Vector3<f64>,
    s: &Vector3<f64>,
    row: usize,
    jp: &mut RowJacobian,
    jc: &mut RowJacobian,
) {
    set3(jp, row, 3, &t.cross(&(f.w * s)));
    set3(jc, row, 3, &s.cross(&(f.w.transpose() * t)));
}

fn set3(j: &mut RowJacobian, row: usize, col: usize, v: &Vector3<f64>) {
    j[(row, col)] = v.x;
    j[(row, col + 1)] = v.y;
    j[(row, col + 2)] = v.z;
}

/// Two unit vectors completing the unit `u` to a right-handed orthonormal triad `(u, n₁, n₂)`.
pub fn normals(u: &Vector3<f64>) -> [Vector3<f64>; 2] {
    let seed = if u.x.abs() < 0.6 {
        Vector3::x()
    } else if u.y.abs() < 0.6 {
        Vector3::y()
    } else {
        Vector3::z()
    };
    let n1 = (seed - u * u.dot(&seed)).normalize();
    [n1, u.cross(&n1)]
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::sim::so3::exp_matrix;

    pub(crate) fn pose(rv: [f64; 3], c: [f64; 3]) -> BodyPose {
        BodyPose {
            rot: exp_matrix(&Vector3::from(rv)),
            com: Vector3::from(c),
        }
    }

    /// Moves `p` by the variation `δ = [δc (world); η (body)]`: `c + δc`, `R exp(η)`.
    pub(crate) fn perturbed(p: &BodyPose, delta: &SVector<f64, 6>) -> BodyPose {
        BodyPose {
            rot: p.rot * exp_matrix(&delta.fixed_rows::<3>(3).into_owned()),
            com: p.com + delta.fixed_rows::<3>(0),
        }
    }

    pub(crate) fn kinds() -> Vec<JointRows> {
        let u = Vector3::new(0.3, -0.5, 0.8).normalize();
        let ub = Vector3::new(-0.2, 0.9, 0.1).normalize();
        let w0 = exp_matrix(&Vector3::new(0.2, 0.1, -0.4));
        let [n1, n2] = normals(&u);
        let anchors = (Vector3::new(0.1, -0.2, 0.3), Vector3::new(-0.4, 0.05, 0.2));
        let s = |t: Vector3<f64>| w0.transpose() * t;
        [
            RowKind::Hinge {
                axis_parent: u,
                axis_child: ub,
                normals_parent: [n1, n2],
            },
            RowKind::Slider {
                axis_parent: u,
                normals_parent: [n1, n2],
                lock: [(n1, s(n2)), (n2, s(u)), (u, s(n1))],
            },
            RowKind::Universal {
                axis_parent: u,
                axis_child: ub,
                cos0: 0.2,
            },
            RowKind::Ball,
        ]
        .into_iter()
        .map(|kind| JointRows {
            anchor_parent: anchors.0,
            anchor_child: anchors.1,
            kind,
        })
        .collect()
    }

    /// Every Jacobian column against central differences of the values, at a generic pose.
    #[test]
    fn jacobians_match_finite_differences() {
        let a = pose([0.4, -0.3, 0.9], [0.2, 1.0, -0.5]);
        let b = pose([-1.1, 0.5, 0.2], [0.7, 0.4, 0.1]);
        let eps = 1e-6;
        for rows in kinds() {
            let (mut jp, mut jc) = (RowJacobian::zeros(), RowJacobian::zeros());
            let g = rows.evaluate(&a, &b, &mut jp, &mut jc);
            assert_eq!(g, rows.values(&a, &b));
            for col in 0..6 {
                let mut d = SVector::<f64, 6>::zeros();
                d[col] = eps;
                let fd_a = (rows.values(&perturbed(&a, &d), &b)
                    - rows.values(&perturbed(&a, &-d), &b))
                    / (2.0 * eps);
                let fd_b = (rows.values(&a, &perturbed(&b, &d))
                    - rows.values(&a, &perturbed(&b, &-d)))
                    / (2.0 * eps);
                // Central differences: O(ε²) truncation + ε_mach/ε round-off ≈ 1e-10.
                // Measured ≤ 6e-11.
                assert!(
                    (jp.column(col) - fd_a).amax() < 1e-8,
                    "{:?} parent col {col}: {} vs {fd_a}",
                    rows.kind,
                    jp.column(col)
                );
                assert!(
                    (jc.column(col) - fd_b).amax() < 1e-8,
                    "{:?} child col {col}",
                    rows.kind
                );
            }
        }
    }

    /// The rows do not change under a rigid motion of both bodies, so the impulses of any `λ`
    /// carry no net force and no net torque about the world origin.
    #[test]
    fn impulses_carry_no_net_force_or_torque() {
        let a = pose([0.4, -0.3, 0.9], [0.2, 1.0, -0.5]);
        let b = pose([-1.1, 0.5, 0.2], [0.7, 0.4, 0.1]);
        let lambda = RowValues::from_column_slice(&[0.3, -1.2, 0.7, 2.0, -0.4, 0.9, -0.6]);
        for rows in kinds() {
            let (mut jp, mut jc) = (RowJacobian::zeros(), RowJacobian::zeros());
            rows.evaluate(&a, &b, &mut jp, &mut jc);
            let (ia, ib) = (jp.transpose() * lambda, jc.transpose() * lambda);
            let force = |i: &SVector<f64, 6>| i.fixed_rows::<3>(0).into_owned();
            let torque = |p: &BodyPose, i: &SVector<f64, 6>| {
                p.com.cross(&force(i)) + p.rot * i.fixed_rows::<3>(3)
            };
            let net_force = force(&ia) + force(&ib);
            let net_torque = torque(&a, &ia) + torque(&b, &ib);
            // Round-off of sums of O(1) terms: measured ≤ 4.4e-16.
            assert!(net_force.amax() < 1e-14, "{:?}: {net_force}", rows.kind);
            assert!(net_torque.amax() < 1e-14, "{:?}: {net_torque}", rows.kind);
            let q = exp_matrix(&Vector3::new(0.7, -0.2, 0.3));
            let t = Vector3::new(5.0, -3.0, 2.0);
            let moved = |p: &BodyPose| BodyPose {
                rot: q * p.rot,
                com: q * p.com + t,
            };
            let g0 = rows.values(&a, &b);
            let g1 = rows.values(&moved(&a), &moved(&b));
            // Measured 1.1e-15.
            assert!((g0 - g1).amax() < 1e-13, "{:?}", rows.kind);
        }
    }

    #[test]
    fn normals_complete_a_right_handed_triad() {
        for u in [
            Vector3::x(),
            Vector3::y(),
            Vector3::z(),
            -Vector3::z(),
            Vector3::new(1.0, 1.0, 1.0).normalize(),
        ] {
            let [n1, n2] = normals(&u);
            assert!((n1.norm() - 1.0).abs() < 1e-15 && (n2.norm() - 1.0).abs() < 1e-15);
            assert!(n1.dot(&u).abs() < 1e-15 && n2.dot(&u).abs() < 1e-15);
            assert!((u.cross(&n1) - n2).amax() < 1e-15);
        }
    }
}
