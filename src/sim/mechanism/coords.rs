//! Joint coordinates read back from the body poses: the URDF joint positions (rad or m), their
//! rates, and their gradients (for the mimic rows `θ_f − k θ_l − b = 0`).
//!
//! - Hinge (revolute, continuous) with axis `u_a` (parent frame) and a reference direction `w`
//!   orthogonal to it, carried by both bodies (`w_a` in the parent frame, `w_b` in the child's;
//!   `W w_b = w_a` at the zero position): with `m = W w_b`,
//!   `θ = atan2((u_a × w_a)·m, w_a·m)`, unwrapped to the branch nearest a reference angle.
//!   `δm = ε × m` with `ε = W η_b − η_a` (parent frame), so
//!   `∂θ/∂ε = γ = (x (m × v_a) − y (m × w_a)) / (x² + y²)` (`x = w_a·m`, `y = v_a·m`,
//!   `v_a = u_a × w_a`): `∂θ/∂η_a = −γᵀ`, `∂θ/∂η_b = (Wᵀγ)ᵀ`. On the constraint `γ = u_a`.
//!   Rate: `θ̇ = γ·(W Ω_b − Ω_a)` (body-frame angular velocities).
//! - Slider (prismatic): `s = u_a·d`, the anchor gap along the axis (a gap row of
//!   [`super::rows`]). Rate: `ṡ = u_a·ḋ`, `ḋ = R_aᵀ (v_b + R_b (Ω_b × a_b) − v_a) − Ω_a × ρ`.
//! - Compound (two or three revolutes through one point, massless links between): the angles
//!   solve `Π_k O_k Rot(u_k, θ_k) = Q` for the relative rotation `Q`, by damped Gauss-Newton
//!   from the previous angles ([`decompose`]).

use super::rows::{BodyPose, Row6, RowJacobian};
use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use std::f64::consts::PI;

/// How a coordinate is read from its joint's two bodies.
#[derive(Debug, Clone, PartialEq)]
pub enum CoordinateKind {
    Hinge {
        axis_parent: Vector3<f64>,
        ref_parent: Vector3<f64>,
        ref_child: Vector3<f64>,
    },
    Slider {
        axis_parent: Vector3<f64>,
        anchor_parent: Vector3<f64>,
        anchor_child: Vector3<f64>,
    },
    /// Stage `stage` of its joint's compound chain.
    Compound { stage: usize },
}

/// `θ` mapped to the branch `θ + 2πn` nearest `reference`.
pub fn unwrap_near(theta: f64, reference: f64) -> f64 {
    theta + 2.0 * PI * ((reference - theta) / (2.0 * PI)).round()
}

/// Hinge angle (unwrapped near `reference`) and `γ` (parent frame), `W` returned too.
fn hinge(
    axis: &Vector3<f64>,
    wa: &Vector3<f64>,
    wb: &Vector3<f64>,
    a: &BodyPose,
    b: &BodyPose,
    reference: f64,
) -> (f64, Vector3<f64>, Matrix3<f64>) {
    let w = a.rot.transpose() * b.rot;
    let m = w * wb;
    let va = axis.cross(wa);
    let (x, y) = (wa.dot(&m), va.dot(&m));
    let theta = unwrap_near(y.atan2(x), reference);
    let r2 = x * x + y * y;
    let gamma = (m.cross(&va) * x - m.cross(wa) * y) / r2;
    (theta, gamma, w)
}

impl CoordinateKind {
    /// The coordinate's value at the poses (a hinge angle on the branch nearest `reference`).
    /// `None` for a compound stage (read with [`decompose`]).
    pub fn value(&self, a: &BodyPose, b: &BodyPose, reference: f64) -> Option<f64> {
        match self {
            CoordinateKind::Hinge {
                axis_parent,
                ref_parent,
                ref_child,
            } => Some(hinge(axis_parent, ref_parent, ref_child, a, b, reference).0),
            CoordinateKind::Slider {
                axis_parent,
                anchor_parent,
                anchor_child,
            } => {
                let rho = a.rot.transpose() * (b.com + b.rot * anchor_child - a.com);
                Some(axis_parent.dot(&(rho - anchor_parent)))
            }
            CoordinateKind::Compound { .. } => None,
        }
    }

    /// Value and gradient rows `(∂/∂parent, ∂/∂child)` (columns `[δc, η]`).
    pub fn gradient(
        &self,
        a: &BodyPose,
        b: &BodyPose,
        reference: f64,
    ) -> Option<(f64, Row6, Row6)> {
        match self {
            CoordinateKind::Hinge {
                axis_parent,
                ref_parent,
                ref_child,
            } => {
                let (theta, gamma, w) = hinge(axis_parent, ref_parent, ref_child, a, b, reference);
                let wg = w.transpose() * gamma;
                let ga = Row6::new(0.0, 0.0, 0.0, -gamma.x, -gamma.y, -gamma.z);
                let gb = Row6::new(0.0, 0.0, 0.0, wg.x, wg.y, wg.z);
                Some((theta, ga, gb))
            }
            CoordinateKind::Slider {
                axis_parent,
                anchor_parent,
                anchor_child,
            } => {
                let rows = super::rows::JointRows {
                    anchor_parent: *anchor_parent,
                    anchor_child: *anchor_child,
                    kind: super::rows::RowKind::Slider {
                        axis_parent: *axis_parent,
                        normals_parent: [*axis_parent; 2],
                        lock: [(Vector3::zeros(), Vector3::zeros()); 3],
                    },
                };
                let (mut jp, mut jc) = (RowJacobian::zeros(), RowJacobian::zeros());
                let g = rows.evaluate(a, b, &mut jp, &mut jc);
                Some((
                    g[0],
                    jp.fixed_rows::<1>(0).into_owned(),
                    jc.fixed_rows::<1>(0).into_owned(),
                ))
            }
            CoordinateKind::Compound { .. } => None,
        }
    }

    /// The coordinate's rate from the bodies' velocities (`v` world, `Ω` body frame).
    pub fn rate(
        &self,
        a: &BodyPose,
        b: &BodyPose,
        twist_a: (&Vector3<f64>, &Vector3<f64>),
        twist_b: (&Vector3<f64>, &Vector3<f64>),
        reference: f64,
    ) -> Option<f64> {
        let (_, ga, gb) = self.gradient(a, b, reference)?;
        let va = nalgebra::SVector::<f64, 6>::new(
            twist_a.0.x,
            twist_a.0.y,
            twist_a.0.z,
            twist_a.1.x,
            twist_a.1.y,
            twist_a.1.z,
        );
        let vb = nalgebra::SVector::<f64, 6>::new(
            twist_b.0.x,
            twist_b.0.y,
            twist_b.0.z,
            twist_b.1.x,
            twist_b.1.y,
            twist_b.1.z,
        );
        Some((ga * va)[0] + (gb * vb)[0])
    }
}

/// A chain of revolutes through one point with massless links between (a compound joint):
/// `Q = Π_k O_k Rot(u_k, θ_k)`, where `Q` is the rotation of the last link's frame in the first
/// joint's frame, `O_0 = I` and `O_k` the rotation of joint `k`'s frame in link `k−1`'s frame.
#[derive(Debug, Clone, PartialEq)]
pub struct CompoundChain {
    /// Unit axes, each in its joint's frame.
    pub axes: Vec<Vector3<f64>>,
    /// `O_k` (rotation), `O_0 = I`.
    pub origins: Vec<UnitQuaternion<f64>>,
    /// Rotation of the first joint's frame in the parent body's frame.
    pub parent_from_first: UnitQuaternion<f64>,
    /// Rotation of the last link's frame in the child body's frame.
    pub child_from_last: UnitQuaternion<f64>,
}

impl CompoundChain {
    /// `Π_k O_k Rot(u_k, θ_k)` and the axes in the first joint's frame at `θ` (the columns of
    /// the Jacobian of the product's left-trivialised variation).
    pub fn product(&self, theta: &[f64]) -> (UnitQuaternion<f64>, [Vector3<f64>; 3]) {
        let mut q = UnitQuaternion::identity();
        let mut axes = [Vector3::zeros(); 3];
        for (k, (u, o)) in self.axes.iter().zip(&self.origins).enumerate() {
            q *= o;
            axes[k] = q * u;
            q *= UnitQuaternion::from_scaled_axis(u * theta[k]);
        }
        (q, axes)
    }

    /// The rotation `Q` this chain must produce for the bodies' relative rotation `W = R_aᵀ R_b`.
    pub fn target(&self, w: &Matrix3<f64>) -> UnitQuaternion<f64> {
        let w = UnitQuaternion::from_matrix(w);
        self.parent_from_first.inverse() * w * self.child_from_last
    }

    /// Rotation of stage `k`'s link frame in the first joint's frame at `θ`.
    pub fn link_rotation(&self, theta: &[f64], k: usize) -> UnitQuaternion<f64> {
        let mut q = UnitQuaternion::identity();
        for (i, (u, o)) in self.axes.iter().zip(&self.origins).enumerate().take(k + 1) {
            q = q * o * UnitQuaternion::from_scaled_axis(u * theta[i]);
        }
        q
    }
}

/// The chain's angles for the relative rotation `target`, by damped Gauss-Newton on
/// `log(Q(θ) targetᵀ)` (left-trivialised: `δQ Qᵀ = Σ_k (axis_k at θ) δθ_k`), starting from
/// `theta` (the previous angles: the branch stays continuous) and written back there. Returns
/// the final rotation error, rad.
pub fn decompose(chain: &CompoundChain, target: &UnitQuaternion<f64>, theta: &mut [f64]) -> f64 {
    let n = chain.axes.len();
    let mut err = f64::INFINITY;
    for _ in 0..50 {
        let (q, axes) = chain.product(theta);
        let r = (target * q.inverse()).scaled_axis();
        err = r.norm();
        if err < 1e-14 {
            break;
        }
        // Normal equations (AᵀA + μI) δ = Aᵀ r with A = [axes], n ≤ 3.
        let mut ata = Matrix3::<f64>::identity() * 1e-12;
        let mut atr = Vector3::zeros();
        for i in 0..n {
            for j in 0..n {
                ata[(i, j)] += axes[i].dot(&axes[j]);
            }
            atr[i] = axes[i].dot(&r);
        }
        for i in n..3 {
            ata[(i, i)] = 1.0;
        }
        let Some(delta) = ata.lu().solve(&atr) else {
            break;
        };
        for i in 0..n {
            theta[i] += delta[i];
        }
    }
    err
}

/// The chain's angle rates for the relative angular velocity `omega_rel` (in the first joint's
/// frame): least squares `Σ_k axis_k θ̇_k = ω_rel`.
pub fn compound_rates(
    chain: &CompoundChain,
    theta: &[f64],
    omega_rel: &Vector3<f64>,
    out: &mut [f64],
) {
    let n = chain.axes.len();
    let (_, axes) = chain.product(theta);
    let mut ata = Matrix3::<f64>::identity() * 0.0;
    let mut atr = Vector3::zeros();
    for i in 0..n {
        for j in 0..n {
            ata[(i, j)] = axes[i].dot(&axes[j]);
        }
        atr[i] = axes[i].dot(omega_rel);
    }
    for i in n..3 {
        ata[(i, i)] = 1.0;
    }
    let x = ata.lu().solve(&atr).unwrap_or_else(Vector3::zeros);
    out[..n].copy_from_slice(&x.as_slice()[..n]);
}

#[cfg(test)]
mod tests {
    use super::super::rows::tests::{perturbed, pose};
    use super::*;
    use nalgebra::SVector;

    fn hinge_kind() -> (CoordinateKind, BodyPose, BodyPose, f64) {
        // Parent a at a generic pose; child b turned by θ about the axis from the zero pose.
        let a = pose([0.4, -0.3, 0.9], [0.2, 1.0, -0.5]);
        let u = Vector3::new(0.3, -0.5, 0.8).normalize();
        let wa = super::super::rows::normals(&u)[0];
        let b0_from_a = crate::sim::so3::exp_matrix(&Vector3::new(0.2, 0.7, -0.1));
        // W0 = R_aᵀ R_b at θ = 0; then w_b = W0ᵀ w_a.
        let theta = 2.5;
        let w = crate::sim::so3::exp_matrix(&(u * theta)) * b0_from_a;
        let b = BodyPose {
            rot: a.rot * w,
            com: Vector3::new(0.3, 0.1, 0.4),
        };
        let kind = CoordinateKind::Hinge {
            axis_parent: u,
            ref_parent: wa,
            ref_child: b0_from_a.transpose() * wa,
        };
        (kind, a, b, theta)
    }

    #[test]
    fn hinge_angle_and_gradient() {
        let (kind, a, b, theta) = hinge_kind();
        // Reads the angle back (2.5 rad), and on the branch near a reference 2π away.
        let got = kind.value(&a, &b, 0.0).unwrap();
        assert!((got - theta).abs() < 1e-14, "{got}");
        let far = kind.value(&a, &b, 2.0 * PI + 2.4).unwrap();
        assert!((far - theta - 2.0 * PI).abs() < 1e-13);
        let (_, ga, gb) = kind.gradient(&a, &b, 0.0).unwrap();
        let eps = 1e-6;
        // Off the constraint too: b moved by a generic rotation first.
        let b_off = perturbed(
            &b,
            &SVector::<f64, 6>::new(0.0, 0.0, 0.0, 0.05, -0.03, 0.02),
        );
        let (_, ga_off, gb_off) = kind.gradient(&a, &b_off, 0.0).unwrap();
        for (bb, ga, gb) in [(b, ga, gb), (b_off, ga_off, gb_off)] {
            for col in 0..6 {
                let mut d = SVector::<f64, 6>::zeros();
                d[col] = eps;
                let v = |a: &BodyPose, b: &BodyPose| kind.value(a, b, 0.0).unwrap();
                let fd_a = (v(&perturbed(&a, &d), &bb) - v(&perturbed(&a, &-d), &bb)) / (2.0 * eps);
                let fd_b = (v(&a, &perturbed(&bb, &d)) - v(&a, &perturbed(&bb, &-d))) / (2.0 * eps);
                // Measured ≤ 3e-11.
                assert!(
                    (ga[col] - fd_a).abs() < 1e-8,
                    "col {col}: {} vs {fd_a}",
                    ga[col]
                );
                assert!(
                    (gb[col] - fd_b).abs() < 1e-8,
                    "col {col}: {} vs {fd_b}",
                    gb[col]
                );
            }
        }
    }

    #[test]
    fn compound_decomposition_recovers_the_angles() {
        let chain = CompoundChain {
            axes: vec![Vector3::z(), Vector3::x(), Vector3::y()],
            origins: vec![
                UnitQuaternion::identity(),
                UnitQuaternion::from_euler_angles(0.1, 0.0, 0.2),
                UnitQuaternion::identity(),
            ],
            parent_from_first: UnitQuaternion::from_euler_angles(0.3, -0.2, 0.5),
            child_from_last: UnitQuaternion::from_euler_angles(-0.4, 0.1, 0.0),
        };
        let truth = [0.7, -0.4, 1.1];
        let (q, _) = chain.product(&truth);
        let mut theta = [0.6, -0.3, 1.0];
        let err = decompose(&chain, &q, &mut theta);
        // Measured 2e-16 rad after 4 iterations.
        assert!(err < 1e-13, "{err}");
        for k in 0..3 {
            assert!((theta[k] - truth[k]).abs() < 1e-12, "{theta:?}");
        }
        // Rates: ω_rel = Σ axis_k θ̇_k recovered.
        let rates = [0.3, -1.2, 0.5];
        let (_, axes) = chain.product(&truth);
        let omega: Vector3<f64> = (0..3).map(|k| axes[k] * rates[k]).sum();
        let mut out = [0.0; 3];
        compound_rates(&chain, &truth, &omega, &mut out);
        for k in 0..3 {
            assert!((out[k] - rates[k]).abs() < 1e-13);
        }
    }
}
