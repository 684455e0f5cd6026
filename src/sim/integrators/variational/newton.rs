//! The Newton core of the variational step, over lanes: the coefficient functions, the residual
//! `g(ξ) = (J/h) ξ - T(ξ)^T M` ([`evaluate`]), its analytic and approximate Jacobians, the 3x3
//! Cramer solve, the Euler-equation predictor of the warm start, the rotation of `q` and `M` by
//! the solved `ξ` ([`advance`]), and the Newton loops ([`newton`], and its straight-line common
//! case [`newton_one_update`]).

use super::lanes::{Pack, Quat, V3, has};
use super::{Jacobian, VariationalSettings};
use crate::sim::so3::{self, Coefficients, Real, SERIES_THETA_SQ};
use nalgebra::{Matrix3, Vector3};

/// The coefficient functions per lane: all lanes by series at once when every `θ` is below
/// [`so3::SERIES_THETA`] (at `h|Ω|` below 0.02 rad: the common case), otherwise lane by lane
/// with [`Coefficients::new`] (one `sin_cos` per lane above it). Both round identically.
#[inline(always)]
pub(super) fn coefficients<L: Pack<N>, const N: usize>(theta_sq: L) -> Coefficients<L> {
    if theta_sq.lt(L::splat(SERIES_THETA_SQ)) == L::ALL {
        Coefficients::series(theta_sq)
    } else {
        let k = coefficients_by_lane(theta_sq.to_array());
        Coefficients {
            a: L::from_array(k.a),
            b: L::from_array(k.b),
            c: L::from_array(k.c),
            db_over_theta: L::from_array(k.db_over_theta),
            dc_over_theta: L::from_array(k.dc_over_theta),
            half_cos: L::from_array(k.half_cos),
            half_sin_over_theta: L::from_array(k.half_sin_over_theta),
        }
    }
}

/// [`coefficients`] lane by lane, out of line and on plain arrays (so it is the same code for
/// every vector unit): only bodies turning more than [`so3::SERIES_THETA`] per step take it.
#[inline(never)]
fn coefficients_by_lane<const N: usize>(theta_sq: [f64; N]) -> Coefficients<[f64; N]> {
    let k = theta_sq.map(Coefficients::new);
    let field = |f: fn(&Coefficients) -> f64| k.each_ref().map(f);
    Coefficients {
        a: field(|k| k.a),
        b: field(|k| k.b),
        c: field(|k| k.c),
        db_over_theta: field(|k| k.db_over_theta),
        dc_over_theta: field(|k| k.dc_over_theta),
        half_cos: field(|k| k.half_cos),
        half_sin_over_theta: field(|k| k.half_sin_over_theta),
    }
}

/// The residual, scaled by `1/h`: `g(ξ) = f(ξ)/h = (J/h) ξ - T(ξ)^T M`, with the cross products
/// that the Jacobian and the momentum update reuse (`T(ξ)^T M = M - B ξ×M + C ξ×(ξ×M)`).
/// Newton's updates do not depend on a constant scaling of the residual, and
/// `|f|_∞ <= tol · h|M|_∞` is `|g|_∞ <= tol · |M|_∞`. Working with `M` rather than `hM` lets the
/// momentum update reuse `ξ×M` exactly as `exp(ξ)^T M = M - A ξ×M + B ξ×(ξ×M)` needs it (no
/// rescaling by `1/h`, whose rounding would bias the update and double the momentum round-off).
#[derive(Debug, Clone, Copy)]
pub(super) struct Eval<R> {
    pub(super) k: Coefficients<R>,
    /// `ξ × M`
    pub(super) xm: V3<R>,
    /// `ξ × (ξ × M)`
    pub(super) xxm: V3<R>,
    pub(super) f: V3<R>,
}

#[inline(always)]
pub(super) fn evaluate<R: Real>(
    j_over_h: V3<R>,
    m: V3<R>,
    xi: V3<R>,
    k: Coefficients<R>,
) -> Eval<R> {
    let xm = xi.cross(m);
    let xxm = xi.cross(xm);
    let f = j_over_h
        .mul(xi)
        .sub(m)
        .add(xm.scale(k.b))
        .sub(xxm.scale(k.c));
    Eval { k, xm, xxm, f }
}

/// Columns of the analytic Newton Jacobian `J/h - ∂(T(ξ)^T m)/∂ξ` of `g` (`m = M`), expanded from
/// [`so3::t_transpose_times_jacobian`]:
/// `diag(J/h - C ξ·m) - p ξ^T - C ξ m^T - B m^` with `p = C'/θ ξ×(ξ×m) - B'/θ ξ×m - 2 C m`.
/// About 70 flops, reusing `ξ×m` and `ξ×(ξ×m)` from the residual.
#[inline(always)]
pub(super) fn analytic_jacobian<R: Real>(
    j_over_h: V3<R>,
    m: V3<R>,
    xi: V3<R>,
    e: &Eval<R>,
) -> [V3<R>; 3] {
    let k = &e.k;
    let d = j_over_h.sub(V3::splat(k.c * xi.dot(m)));
    let p = e
        .xxm
        .scale(k.dc_over_theta)
        .sub(e.xm.scale(k.db_over_theta))
        .sub(m.scale(k.c + k.c));
    let q = xi.scale(k.c);
    let bm = m.scale(k.b);
    [
        jacobian_column(
            V3 {
                x: d.x,
                y: -bm.z,
                z: bm.y,
            },
            p,
            q,
            xi.x,
            m.x,
        ),
        jacobian_column(
            V3 {
                x: bm.z,
                y: d.y,
                z: -bm.x,
            },
            p,
            q,
            xi.y,
            m.y,
        ),
        jacobian_column(
            V3 {
                x: -bm.y,
                y: bm.x,
                z: d.z,
            },
            p,
            q,
            xi.z,
            m.z,
        ),
    ]
}

/// One column of [`analytic_jacobian`]: `diag - p ξ_j - q m_j`. A function, not a closure's
/// body: closures are not `#[inline(always)]`, and a vector operation left in one out of line
/// would be compiled without the dispatched unit's instructions.
#[inline(always)]
fn jacobian_column<R: Real>(diag: V3<R>, p: V3<R>, q: V3<R>, xj: R, mj: R) -> V3<R> {
    diag.sub(p.scale(xj)).sub(q.scale(mj))
}

/// The seed's approximate Jacobian `J T(ξ)^-1` (of `g`: `J/h T(ξ)^-1`), as columns (lane by
/// lane: not a hot path).
#[inline(always)]
pub(super) fn approximate_jacobian<L: Pack<N>, const N: usize>(j: V3<L>, xi: V3<L>) -> [V3<L>; 3] {
    let [c0, c1, c2] = approximate_by_lane(j.arrays(), xi.arrays());
    [V3::gather(&c0), V3::gather(&c1), V3::gather(&c2)]
}

/// [`approximate_jacobian`]'s columns, lane by lane, out of line on plain arrays.
#[inline(never)]
fn approximate_by_lane<const N: usize>(
    j: [[f64; N]; 3],
    xi: [[f64; N]; 3],
) -> [[Vector3<f64>; N]; 3] {
    let per_lane: [Matrix3<f64>; N] = std::array::from_fn(|i| {
        let j = Vector3::new(j[0][i], j[1][i], j[2][i]);
        let xi = Vector3::new(xi[0][i], xi[1][i], xi[2][i]);
        Matrix3::from_diagonal(&j) * so3::t_inverse_matrix(&xi)
    });
    [0, 1, 2].map(|c| per_lane.each_ref().map(|a| a.column(c).into_owned()))
}

/// Solves `[c0 c1 c2] x = b` by the adjugate: rows of the inverse are `c1×c2`, `c2×c0`,
/// `c0×c1` over `det = c0·(c1×c2)`. Returns `(x, det)`; `x` is meaningless when `det` is zero
/// or not finite. 30 multiplications, 17 additions, one division.
#[inline(always)]
pub(super) fn cramer<R: Real>(c: &[V3<R>; 3], b: V3<R>) -> (V3<R>, R) {
    let r0 = c[1].cross(c[2]);
    let r1 = c[2].cross(c[0]);
    let r2 = c[0].cross(c[1]);
    let det = c[0].dot(r0);
    let inv_det = R::splat(1.0) / det;
    let x = V3 {
        x: r0.dot(b),
        y: r1.dot(b),
        z: r2.dot(b),
    };
    (x.scale(inv_det), det)
}

/// Predicted `ξ_k` from the previous step's `ξ_{k-1}` and the current momentum `M_k`:
/// `ξ_k - ξ_{k-1} ≈ h^2 dΩ/dt = h^2 J^-1 (M × Ω) ≈ h J^-1 (M × ξ_{k-1})` (Euler's equations
/// `dM/dt = M × Ω` in the body frame). Its error is O(h^3 |Ω|^3) where `ξ_{k-1}` itself is off
/// by O(h^2 |Ω|^2): one Newton update then meets `newton_tol` (see `docs/variational_performance.md`).
#[inline(always)]
pub(super) fn predict<R: Real>(inv_j: V3<R>, m: V3<R>, xi_prev: V3<R>, h: R) -> V3<R> {
    xi_prev.add(m.cross(xi_prev).mul(inv_j).scale(h))
}

/// After the solve: `R_{k+1} = R_k exp(ξ)` and `M_{k+1} = exp(ξ)^T M_k`, both from the same
/// half-angle pair in `e.k`, reusing `ξ × M` and `ξ × (ξ × M)` from the last residual:
/// `exp(ξ)^T M = M - A ξ×M + B ξ×(ξ×M)`.
///
/// The product of unit quaternions drifts off the unit sphere by round-off (~1e-16 a step, a
/// random walk); it is pulled back by one Newton step for `1/|q|`, `q ← q (3 - |q|^2)/2`, which
/// leaves `||q|^2 - 1| = O(ε^2)`: no sqrt and no division, and the norm never drifts.
#[inline(always)]
pub(super) fn advance<R: Real>(q: Quat<R>, m: V3<R>, xi: V3<R>, e: &Eval<R>) -> (Quat<R>, V3<R>) {
    let k = &e.k;
    let m_next = m.add(e.xxm.scale(k.b).sub(e.xm.scale(k.a)));
    let u = xi.scale(k.half_sin_over_theta);
    let w = q.w * k.half_cos - q.v.dot(u);
    let v = u.scale(q.w).add(q.v.scale(k.half_cos)).add(q.v.cross(u));
    let n2 = w * w + v.dot(v);
    let s = R::splat(1.5) - R::splat(0.5) * n2;
    (
        Quat {
            w: w * s,
            v: v.scale(s),
        },
        m_next,
    )
}

/// The outcome of [`newton`], per lane.
pub(super) struct NewtonOut<L, const N: usize> {
    pub(super) xi: V3<L>,
    /// The residual evaluation at `xi`.
    pub(super) eval: Eval<L>,
    pub(super) iterations: [u32; N],
    /// The lanes that converged (a mask, bit `i` for lane `i`).
    pub(super) converged: u32,
}

/// Newton on `g(ξ) = f(ξ)/h = 0` from `xi`, lane by lane: a lane stops (its `ξ` is frozen) once
/// every `|g_i| <= threshold` (`newton_tol · |M|_∞`), or after `newton_max_iters` updates, or on a
/// non-finite residual or a singular Jacobian. Lanes that stopped are re-evaluated with the
/// others at the same `ξ`, which reproduces their residual exactly.
///
/// Inlined into its caller, so that each vector unit's copy is compiled with that unit's
/// instructions; [`Pack::newton`] is the out-of-line entry for the batched step.
#[inline(always)]
pub(super) fn newton<L: Pack<N>, const N: usize>(
    j_over_h: V3<L>,
    m: V3<L>,
    mut xi: V3<L>,
    threshold: L,
    settings: &VariationalSettings,
) -> NewtonOut<L, N> {
    let mut iterations = [0u32; N];
    let mut done = 0u32;
    let mut converged = 0u32;
    loop {
        let eval = evaluate(j_over_h, m, xi, coefficients(xi.dot(xi)));
        let within = eval.f.within(threshold);
        let finite = eval.f.finite();
        let capped = iteration_mask(&iterations, settings.newton_max_iters);
        // Lanes still running take their new state; stopped lanes keep theirs.
        converged = (converged & done) | (within & !done);
        done |= within | capped | !finite;
        done &= L::ALL;
        if done == L::ALL {
            return NewtonOut {
                xi,
                eval,
                iterations,
                converged,
            };
        }
        let cols = match settings.jacobian {
            Jacobian::Analytic => analytic_jacobian(j_over_h, m, xi, &eval),
            Jacobian::Approximate => approximate_jacobian(j_over_h, xi),
        };
        let (delta, det) = cramer(&cols, eval.f);
        done |= !(det.ne(L::splat(0.0)) & det.finite()) & L::ALL;
        for (i, n) in iterations.iter_mut().enumerate() {
            *n += u32::from(!has(done, i));
        }
        xi = xi.select(done, xi.sub(delta));
    }
}

/// The lanes whose iteration count has reached `max`.
#[inline(always)]
fn iteration_mask<const N: usize>(iterations: &[u32; N], max: u32) -> u32 {
    let mut m = 0;
    for (i, &n) in iterations.iter().enumerate() {
        m |= u32::from(n >= max) << i;
    }
    m
}

/// The common case of [`newton`] as straight-line code: every `|ξ|` in the series regime, no
/// lane meets the tolerance at the warm start, every lane does after exactly one update. Returns
/// what [`newton`] would (the same arithmetic in the same order), or `None` when any lane leaves
/// that path; the caller then runs [`newton`] from the same start.
#[inline(always)]
pub(super) fn newton_one_update<L: Pack<N>, const N: usize>(
    j_over_h: V3<L>,
    m: V3<L>,
    xi0: V3<L>,
    threshold: L,
    settings: &VariationalSettings,
) -> Option<NewtonOut<L, N>> {
    if settings.jacobian != Jacobian::Analytic || settings.newton_max_iters == 0 {
        return None;
    }
    // Series regime only: merging the lane-by-lane `sin_cos` branch into this path would keep
    // the coefficients in memory (measured +12 % instructions per body-step).
    let e0 = evaluate(j_over_h, m, xi0, series_only(xi0.dot(xi0))?);
    // A non-finite residual needs no test here: it makes `ξ` non-finite and fails the series
    // test below.
    if e0.f.within(threshold) != 0 {
        return None;
    }
    let (delta, det) = cramer(&analytic_jacobian(j_over_h, m, xi0, &e0), e0.f);
    if (det.ne(L::splat(0.0)) & det.finite()) != L::ALL {
        return None;
    }
    let xi = xi0.sub(delta);
    let eval = evaluate(j_over_h, m, xi, series_only(xi.dot(xi))?);
    let converged = eval.f.within(threshold);
    (converged == L::ALL).then_some(NewtonOut {
        xi,
        eval,
        iterations: [1; N],
        converged,
    })
}

/// The coefficients by their series when every lane is in the series regime.
#[inline(always)]
fn series_only<L: Pack<N>, const N: usize>(theta_sq: L) -> Option<Coefficients<L>> {
    if theta_sq.lt(L::splat(SERIES_THETA_SQ)) == L::ALL {
        Some(Coefficients::series(theta_sq))
    } else {
        None
    }
}
