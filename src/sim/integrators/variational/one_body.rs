//! The one-body API: the same arithmetic as the batched step for one body (one lane), for
//! callers that own their solve: [`solve_xi`] (the initial `ξ`), [`RotationEval`] (the residual,
//! Jacobian and rotation at a trial `ξ`, used by the articulated step,
//! [`crate::sim::mechanism`]) and [`solve3`].

use super::VariationalSettings;
use super::lanes::{Lanes, Pack, Quat, V3, has};
use super::newton::{Eval, advance, analytic_jacobian, coefficients, cramer, evaluate};
use crate::sim::so3::{self, Coefficients, Real};
use nalgebra::{Matrix3, UnitQuaternion, Vector3};

/// Result of one Newton solve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewtonSolve {
    pub xi: Vector3<f64>,
    /// Coefficient functions at the returned `xi`.
    pub coefficients: Coefficients,
    /// Newton updates applied.
    pub iterations: u32,
    pub converged: bool,
}

/// Solves `J ξ = h T(ξ)^T M` for `ξ`, starting from `xi_guess`.
/// `inertia_body` is the diagonal of `J`.
pub fn solve_xi(
    inertia_body: &Vector3<f64>,
    angmom_body: &Vector3<f64>,
    dt_secs: f64,
    xi_guess: &Vector3<f64>,
    settings: &VariationalSettings,
) -> NewtonSolve {
    let m = V3::<Lanes<1>>::gather(&[*angmom_body]);
    let out = Lanes::<1>::newton(
        V3::gather(&[*inertia_body]).scale(Lanes::splat(1.0 / dt_secs)),
        m,
        V3::gather(&[*xi_guess]),
        Lanes::splat(settings.newton_tol) * m.amax(),
        settings,
    );
    let k = out.eval.k;
    NewtonSolve {
        xi: out.xi.lane(0),
        coefficients: Coefficients {
            a: k.a.0[0],
            b: k.b.0[0],
            c: k.c.0[0],
            db_over_theta: k.db_over_theta.0[0],
            dc_over_theta: k.dc_over_theta.0[0],
            half_cos: k.half_cos.0[0],
            half_sin_over_theta: k.half_sin_over_theta.0[0],
        },
        iterations: out.iterations[0],
        converged: has(out.converged, 0),
    }
}

/// One body's rotational free step evaluated at a trial `ξ`, for solvers that own the Newton
/// loop (the articulated step, [`crate::sim::mechanism`]): the residual `g(ξ) = (J/h) ξ - T(ξ)^T M`
/// (`f/h` of the [module doc](super)), its analytic Jacobian `∂g/∂ξ`, and what [`RotationEval::advance`]
/// needs. The same arithmetic, in the same order, as the batched step (`evaluate`,
/// `analytic_jacobian`, `advance`), so no formula is written twice.
#[derive(Debug, Clone, Copy)]
pub struct RotationEval {
    eval: Eval<Lanes<1>>,
    xi: V3<Lanes<1>>,
    m: V3<Lanes<1>>,
    j_over_h: V3<Lanes<1>>,
}

impl RotationEval {
    /// Evaluates at `xi` for the body-frame momentum `angmom_body` (`M`, the momentum after
    /// the constraint impulse in the articulated step) and the step `dt_secs` (may be negative).
    #[inline]
    pub fn new(
        inertia_body: &Vector3<f64>,
        angmom_body: &Vector3<f64>,
        dt_secs: f64,
        xi: &Vector3<f64>,
    ) -> Self {
        let j_over_h = V3::<Lanes<1>>::gather(&[*inertia_body]).scale(Lanes::splat(1.0 / dt_secs));
        let m = V3::gather(&[*angmom_body]);
        let x = V3::gather(&[*xi]);
        let eval = evaluate(j_over_h, m, x, coefficients(x.dot(x)));
        Self {
            eval,
            xi: x,
            m,
            j_over_h,
        }
    }

    /// `g(ξ) = (J/h) ξ - T(ξ)^T M`, kg m^2/s.
    #[inline]
    pub fn residual(&self) -> Vector3<f64> {
        self.eval.f.lane(0)
    }

    /// The analytic `∂g/∂ξ = J/h - ∂(T(ξ)^T M)/∂ξ`.
    #[inline]
    pub fn jacobian(&self) -> Matrix3<f64> {
        let cols = analytic_jacobian(self.j_over_h, self.m, self.xi, &self.eval);
        Matrix3::from_columns(&cols.map(|c| c.lane(0)))
    }

    /// The coefficient functions at `ξ`.
    #[inline]
    pub fn coefficients(&self) -> Coefficients {
        let k = self.eval.k;
        Coefficients {
            a: k.a.0[0],
            b: k.b.0[0],
            c: k.c.0[0],
            db_over_theta: k.db_over_theta.0[0],
            dc_over_theta: k.dc_over_theta.0[0],
            half_cos: k.half_cos.0[0],
            half_sin_over_theta: k.half_sin_over_theta.0[0],
        }
    }

    /// `T(ξ)^T = I - B ξ^ + C ξ^2`, the map from `δξ` to the body-frame variation of
    /// `R exp(ξ)` (`δ(R exp ξ) = R exp(ξ) (T(ξ)^T δξ)^`).
    #[inline]
    pub fn t_transpose(&self) -> Matrix3<f64> {
        let k = self.coefficients();
        let xh = so3::hat(&self.xi.lane(0));
        Matrix3::identity() - xh * k.b + xh * xh * k.c
    }

    /// `R exp(ξ)` (renormalised as in the batched step) and `exp(ξ)^T M`.
    #[inline]
    pub fn advance(&self, q: &UnitQuaternion<f64>) -> (UnitQuaternion<f64>, Vector3<f64>) {
        let (quat, m) = advance(Quat::gather(&[*q]), self.m, self.xi, &self.eval);
        let mut out = [*q];
        quat.scatter(&mut out);
        (out[0], m.lane(0))
    }
}

/// Solves the 3x3 system `a x = b` by the adjugate (Cramer); `None` when `a` is singular.
#[inline]
pub fn solve3(a: &Matrix3<f64>, b: &Vector3<f64>) -> Option<Vector3<f64>> {
    let cols = [0, 1, 2].map(|c| V3::<Lanes<1>>::gather(&[a.column(c).into_owned()]));
    let (x, det) = cramer(&cols, V3::gather(&[*b]));
    let det = det.0[0];
    (det != 0.0 && det.is_finite()).then(|| x.lane(0))
}
