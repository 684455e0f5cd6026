//! The exponential-map Lie-group variational integrator (the seed's scheme).
//!
//! Discrete Lagrangian per body (Kobilarov, Crane & Desbrun 2009, "Lie group integrators for
//! animation and control of vehicles", with the retraction τ = exp): with `R1 = R0 exp(ξ)`,
//! `L_d = ξ^T J ξ / (2h) - h V_d(c0, c1) + (translation, see [`super::translation`])`.
//! Varying `R_k → R_k exp(η_k)` changes `ξ_{k-1}` by `T(-ξ_{k-1})^-1 η_k` and `ξ_k` by
//! `-T(ξ_k)^-1 η_k` (right and left Jacobians of exp, [`crate::sim::so3`]); the discrete
//! Euler-Lagrange equations
//! `D2 L_d(q_{k-1}, q_k) + D1 L_d(q_k, q_{k+1}) = 0` become, with the body angular momentum
//! `M_k = T(ξ_k)^{-T} J ξ_k / h` (the discrete Legendre transform `-D1 L_d`):
//!
//! 1. solve `f(ξ) = J ξ - h T(ξ)^T M_k = 0` for `ξ` (Newton, warm-started from the previous `ξ`
//!    extrapolated with Euler's equations, see `predict`);
//! 2. `R_{k+1} = R_k exp(ξ)` (quaternion product, renormalised);
//! 3. `M_{k+1} = exp(ξ)^T M_k`.
//!
//! Step 3 and step 2 rotate by the same `exp(ξ)`, so the spatial angular momentum
//! `π = R_k M_k` is conserved to round-off whatever the Newton tolerance. Energy is not conserved
//! but bounded (no drift), error O(h^2); orientation converges with order 2.
//! Initial conditions: `M_0 = J Ω_0` (continuous Legendre transform), then `ξ_0` solves step 1;
//! taking `ξ_0 = h Ω_0` instead would make the momentum wrong by O(h).
//!
//! The Newton Jacobian is `∂f/∂ξ = J - h ∂(T(ξ)^T M)/∂ξ` in closed form
//! ([`so3::t_transpose_times_jacobian`]); the seed's approximation `J T(ξ)^-1` (the seed's
//! spatial `R^T M_I R T(hw)^-1` written in the body frame) is kept as [`Jacobian::Approximate`]:
//! cheaper per iteration, but only linearly convergent.
//!
//! # Cost of a step, and what bounds it
//!
//! Measured with `cargo bench --bench step` (criterion medians, ns per body-step) and
//! `valgrind --tool=callgrind` on the bench binary (instructions, exact and reproducible), on a
//! shared 2-core x86-64 VM (Golden Cove class, 2 MB L2 per core, ≈ 3.9 GHz estimated from a
//! dependent `mulsd` chain), SSE2 baseline target (no `target-cpu`). Workload of the bench: 10 000
//! asymmetric bodies, h = 1 ms, `h|Ω|` ≤ 0.006 rad, so every coefficient comes from its series and
//! no `sin`/`cos`/`sqrt` is called at all.
//!
//! Before (one body at a time, warm start = previous `ξ`): 101 / 85 / 91 ns for 1 / 100 / 10 000
//! bodies (same session as the figures below); 1009 instructions per body-step (803 in the
//! Newton solve), IPC ≈ 3.
//! - Newton updates: 1.62 per body-step on average (62 % of the bodies need two: the previous `ξ`
//!   is off by O(h^2 |Ω|^2)), so 2.62 residual evaluations, 1.62 Jacobians and 3x3 solves.
//! - Recomputation: the final `exp(ξ)` for the quaternion and `exp(ξ)^T M` redid the cross
//!   products and coefficients of the last residual; above the series switch each evaluation
//!   called `sin_cos(θ)` and `sin(θ/2)`, and the quaternion another `sin_cos(θ/2)`.
//! - Renormalisation: a `sqrt` and a division per body-step.
//!
//! Now: 52 / 26 / 26 ns for 1 / 100 / 10 000 bodies (1.9x / 3.3x / 3.5x faster); 515
//! instructions per body-step at 10 000 bodies, IPC ≈ 5. One body stays at ≈ 52 ns: its Newton
//! chain (residual → Jacobian → division → residual) is latency-bound, plus the fixed cost of a
//! step call. With `h|Ω|` ≈ 0.03 (h = 10 ms, same bodies; `sin_cos` and often two updates):
//! 70 ns instead of 132.
//! - One Newton update per body-step: the predicted warm start (`predict`) is off by
//!   O(h^3 |Ω|^3), and one quadratically convergent update takes that below the 1e-12 relative
//!   tolerance, which is still checked on the computed residual at every step (the Newton loop and
//!   its stopping rule are unchanged). Measured: 100 % of 1e6 body-steps of the bench workload need
//!   one update (62 % needed two before). For larger `h|Ω|` it saves less: at `h|Ω|` ≈ 0.03 half
//!   the steps need one update instead of all needing two; at 0.3 it still saves about one update
//!   in five.
//! - Per body-step: 2 residual evaluations (≈ 55 flops each with the series coefficients), one
//!   analytic Jacobian (≈ 70 flops, reusing `ξ×M` and `ξ×(ξ×M)` of the residual), one Cramer
//!   solve (≈ 50 flops and a division), the predictor (15), the momentum update (12, reusing the
//!   last residual's cross products), the quaternion product and renormalisation (≈ 45: one
//!   Newton step for `1/|q|`, no `sqrt`, no division), the tolerance tests (≈ 15), translation (12):
//!   ≈ 350 flops, counted as 176 two-lane SSE2 arithmetic instructions plus 14 scalar ones per
//!   body-step. Above the series switch: one `sin_cos(θ/2)` and one division per residual
//!   evaluation, nothing more (the quaternion reuses it).
//! - Four bodies per instruction stream (`Lanes`): the same code, written over `N` lanes, runs
//!   2 bodies per SSE2 instruction and two independent chains; N = 2 / 4 / 8 measured 31 / 27 /
//!   29 ns (before the last 4 % of gains). A group of four takes one straight-line path (`newton_one_update`) when all four are
//!   in the series regime and converge after one update; otherwise the lane-wise Newton loop
//!   (`newton`) runs from the same start. Both round identically (same operations, no FMA
//!   contraction in Rust), so a body's trajectory does not depend on its neighbours.
//!
//! What bounds it now: instruction issue, not flops or memory. Of the 515 instructions per
//! body-step, 190 are FP arithmetic, 92 register moves and 118 spills to and reloads from the
//! stack (SSE2's destructive two-operand forms and 16 `xmm` registers, each 4-lane value taking
//! two), 59 shuffles that transpose the `Vec<Vector3>` storage into lanes, 24 loads and stores
//! of the state, the rest constants and loop control. At ≈ 5 instructions per cycle that is
//! ≈ 100 cycles ≈ 26 ns. The FP-port floor (176 packed instructions on 2-3 ports) is ≈ 60-90
//! cycles, i.e. ≈ 15-23 ns: the step is within 1.2-1.7x of it; closing the gap needs AVX
//! (three-operand, four lanes per instruction), which needs `target-cpu` flags or `unsafe`
//! runtime dispatch, both excluded here. Memory: 304 bytes per body-step (176 read: `J`, `J^-1`,
//! `M`, `q`, `ξ`, `c`, `v`; 128 written), 12 GB/s at 26 ns, and the 10 000-body working set
//! (1.8 MB) stays in L2: far below the bandwidth available.

use super::translation::{Potential, step_translation};
use super::{BLOCK_BODIES, Integrator, StepStats};
use crate::sim::Bodies;
use crate::sim::guard::Watch;
use crate::sim::loads::Loads;
use crate::sim::so3::{self, Coefficients, Real, SERIES_THETA_SQ};
use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};
use std::ops::{Add, Div, Mul, Neg, Sub};

/// The Newton Jacobian used by [`Variational`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Jacobian {
    /// `J - h ∂(T(ξ)^T M)/∂ξ`: quadratic convergence. The default.
    #[default]
    Analytic,
    /// The seed's `J T(ξ)^-1`: linear convergence, cheaper per iteration.
    Approximate,
}

impl Jacobian {
    pub fn name(self) -> &'static str {
        match self {
            Jacobian::Analytic => "analytic",
            Jacobian::Approximate => "approximate",
        }
    }
}

/// Settings of the variational integrator.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct VariationalSettings {
    /// Newton stops when `|f(ξ)|_∞ <= newton_tol · h |M|_∞` (relative residual; tested as
    /// `|f(ξ)/h|_∞ <= newton_tol · |M|_∞`, component by component, so a NaN never passes).
    pub newton_tol: f64,
    /// Iteration cap. A solve that reaches it has not converged: the body's step is split
    /// into substeps (when `substep` is on), else counted in [`StepStats::newton_failures`].
    pub newton_max_iters: u32,
    pub jacobian: Jacobian,
    pub potential: Potential,
    /// Automatic substepping: a body whose Newton solve does not converge within
    /// `newton_max_iters` redoes its step as 2, 4, 8, ... substeps of `h/n` (each a full
    /// variational step, so momentum stays exact) until every substep converges or `n` would
    /// exceed `max_substeps`. Counted in [`StepStats::substepped`]. Default on.
    pub substep: bool,
    /// Largest substep split factor tried (default 1024).
    pub max_substeps: u32,
}

impl Default for VariationalSettings {
    fn default() -> Self {
        Self {
            newton_tol: 1e-12,
            newton_max_iters: 10,
            jacobian: Jacobian::Analytic,
            potential: Potential::Symmetric,
            substep: true,
            max_substeps: 1024,
        }
    }
}

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
    let out = newton(
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
        converged: out.converged[0],
    }
}

/// One body's rotational free step evaluated at a trial `ξ`, for solvers that own the Newton
/// loop (the articulated step, [`crate::sim::mechanism`]): the residual `g(ξ) = (J/h) ξ - T(ξ)^T M`
/// (`f/h` of the module doc), its analytic Jacobian `∂g/∂ξ`, and what [`RotationEval::advance`]
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

// ---------------------------------------------------------------------------------------------
// The step's arithmetic, written once over `N` lanes (`N` bodies processed by the same
// instructions; one body is `N = 1`), so every path rounds identically.

/// `N` bodies' values of one quantity. The lane loops become SSE2 packed instructions (`addpd`,
/// `mulpd`, `divpd`: two lanes per instruction); `N = 4` gives two independent dependency chains
/// per value, which measured faster than `N = 2` and `N = 8` (see the module doc).
#[derive(Debug, Clone, Copy)]
struct Lanes<const N: usize>([f64; N]);

/// Bodies stepped together.
const LANES: usize = 4;

macro_rules! lanes_binop {
    ($trait:ident, $method:ident, $op:tt) => {
        impl<const N: usize> $trait for Lanes<N> {
            type Output = Self;
            #[inline(always)]
            fn $method(self, o: Self) -> Self {
                Lanes(std::array::from_fn(|i| self.0[i] $op o.0[i]))
            }
        }
    };
}
lanes_binop!(Add, add, +);
lanes_binop!(Sub, sub, -);
lanes_binop!(Mul, mul, *);
lanes_binop!(Div, div, /);

impl<const N: usize> Neg for Lanes<N> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Lanes(self.0.map(|x| -x))
    }
}

impl<const N: usize> Real for Lanes<N> {
    #[inline(always)]
    fn splat(v: f64) -> Self {
        Lanes([v; N])
    }
    #[inline(always)]
    fn abs(self) -> Self {
        Lanes(self.0.map(f64::abs))
    }
}

impl<const N: usize> Lanes<N> {
    /// Whether `pred` holds in every lane (evaluated in all lanes, no early exit).
    #[inline(always)]
    fn all(self, pred: impl Fn(f64) -> bool) -> bool {
        self.0.iter().fold(true, |acc, &x| acc & pred(x))
    }
    /// Lane-wise maximum (equal to `f64::max` for non-NaN lanes).
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        Lanes(std::array::from_fn(|i| {
            if self.0[i] > o.0[i] {
                self.0[i]
            } else {
                o.0[i]
            }
        }))
    }
}

/// A 3-vector of lanes.
#[derive(Debug, Clone, Copy)]
struct V3<R> {
    x: R,
    y: R,
    z: R,
}

impl<R: Real> V3<R> {
    #[inline(always)]
    fn splat(v: R) -> Self {
        Self { x: v, y: v, z: v }
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Self {
            x: self.x + o.x,
            y: self.y + o.y,
            z: self.z + o.z,
        }
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Self {
            x: self.x - o.x,
            y: self.y - o.y,
            z: self.z - o.z,
        }
    }
    /// Component-wise product.
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        Self {
            x: self.x * o.x,
            y: self.y * o.y,
            z: self.z * o.z,
        }
    }
    #[inline(always)]
    fn scale(self, s: R) -> Self {
        Self {
            x: self.x * s,
            y: self.y * s,
            z: self.z * s,
        }
    }
    #[inline(always)]
    fn dot(self, o: Self) -> R {
        self.x * o.x + self.y * o.y + self.z * o.z
    }
    #[inline(always)]
    fn cross(self, o: Self) -> Self {
        Self {
            x: self.y * o.z - self.z * o.y,
            y: self.z * o.x - self.x * o.z,
            z: self.x * o.y - self.y * o.x,
        }
    }
}

impl<const N: usize> V3<Lanes<N>> {
    #[inline(always)]
    fn gather(v: &[Vector3<f64>; N]) -> Self {
        Self {
            x: Lanes(v.each_ref().map(|v| v.x)),
            y: Lanes(v.each_ref().map(|v| v.y)),
            z: Lanes(v.each_ref().map(|v| v.z)),
        }
    }
    #[inline(always)]
    fn lane(self, i: usize) -> Vector3<f64> {
        Vector3::new(self.x.0[i], self.y.0[i], self.z.0[i])
    }
    #[inline(always)]
    fn scatter(self, v: &mut [Vector3<f64>; N]) {
        for (i, v) in v.iter_mut().enumerate() {
            *v = self.lane(i);
        }
    }
    /// `|v|_∞` per lane.
    #[inline(always)]
    fn amax(self) -> Lanes<N> {
        self.x.abs().max(self.y.abs()).max(self.z.abs())
    }
    /// Lanes where every `|v_i| <= threshold` (false for NaN).
    #[inline(always)]
    fn within(self, threshold: Lanes<N>) -> [bool; N] {
        let (x, y, z) = (self.x.abs(), self.y.abs(), self.z.abs());
        std::array::from_fn(|i| {
            (x.0[i] <= threshold.0[i]) & (y.0[i] <= threshold.0[i]) & (z.0[i] <= threshold.0[i])
        })
    }
    /// Lanes where every component is finite.
    #[inline(always)]
    fn finite(self) -> [bool; N] {
        let s = self.x.abs() + self.y.abs() + self.z.abs();
        s.0.map(f64::is_finite)
    }
    /// Lane-wise `if keep { self } else { other }`.
    #[inline(always)]
    fn select(self, keep: &[bool; N], other: Self) -> Self {
        let pick = |a: Lanes<N>, b: Lanes<N>| {
            Lanes(std::array::from_fn(
                |i| if keep[i] { a.0[i] } else { b.0[i] },
            ))
        };
        Self {
            x: pick(self.x, other.x),
            y: pick(self.y, other.y),
            z: pick(self.z, other.z),
        }
    }
}

/// The coefficient functions per lane: all lanes by series at once when every `θ` is below
/// [`so3::SERIES_THETA`] (at `h|Ω|` below 0.02 rad: the common case), otherwise lane by lane
/// with [`Coefficients::new`] (one `sin_cos` per lane above it). Both round identically.
#[inline(always)]
fn coefficients<const N: usize>(theta_sq: Lanes<N>) -> Coefficients<Lanes<N>> {
    if theta_sq.all(|t| t < SERIES_THETA_SQ) {
        Coefficients::series(theta_sq)
    } else {
        coefficients_by_lane(theta_sq)
    }
}

/// [`coefficients`] lane by lane, out of line: only bodies turning more than
/// [`so3::SERIES_THETA`] per step take it.
#[inline(never)]
fn coefficients_by_lane<const N: usize>(theta_sq: Lanes<N>) -> Coefficients<Lanes<N>> {
    {
        let k = theta_sq.0.map(Coefficients::new);
        let field = |f: fn(&Coefficients) -> f64| Lanes(k.each_ref().map(f));
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
}

/// The residual, scaled by `1/h`: `g(ξ) = f(ξ)/h = (J/h) ξ - T(ξ)^T M`, with the cross products
/// that the Jacobian and the momentum update reuse (`T(ξ)^T M = M - B ξ×M + C ξ×(ξ×M)`).
/// Newton's updates do not depend on a constant scaling of the residual, and
/// `|f|_∞ <= tol · h|M|_∞` is `|g|_∞ <= tol · |M|_∞`. Working with `M` rather than `hM` lets the
/// momentum update reuse `ξ×M` exactly as `exp(ξ)^T M = M - A ξ×M + B ξ×(ξ×M)` needs it (no
/// rescaling by `1/h`, whose rounding would bias the update and double the momentum round-off).
#[derive(Debug, Clone, Copy)]
struct Eval<R> {
    k: Coefficients<R>,
    /// `ξ × M`
    xm: V3<R>,
    /// `ξ × (ξ × M)`
    xxm: V3<R>,
    f: V3<R>,
}

#[inline(always)]
fn evaluate<R: Real>(j_over_h: V3<R>, m: V3<R>, xi: V3<R>, k: Coefficients<R>) -> Eval<R> {
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
fn analytic_jacobian<R: Real>(j_over_h: V3<R>, m: V3<R>, xi: V3<R>, e: &Eval<R>) -> [V3<R>; 3] {
    let k = &e.k;
    let d = j_over_h.sub(V3::splat(k.c * xi.dot(m)));
    let p = e
        .xxm
        .scale(k.dc_over_theta)
        .sub(e.xm.scale(k.db_over_theta))
        .sub(m.scale(k.c + k.c));
    let q = xi.scale(k.c);
    let bm = m.scale(k.b);
    let col = |diag: V3<R>, xj: R, mj: R| diag.sub(p.scale(xj)).sub(q.scale(mj));
    [
        col(
            V3 {
                x: d.x,
                y: -bm.z,
                z: bm.y,
            },
            xi.x,
            m.x,
        ),
        col(
            V3 {
                x: bm.z,
                y: d.y,
                z: -bm.x,
            },
            xi.y,
            m.y,
        ),
        col(
            V3 {
                x: -bm.y,
                y: bm.x,
                z: d.z,
            },
            xi.z,
            m.z,
        ),
    ]
}

/// The seed's approximate Jacobian `J T(ξ)^-1` (of `g`: `J/h T(ξ)^-1`), as columns (lane by
/// lane: not a hot path).
fn approximate_jacobian<const N: usize>(j: V3<Lanes<N>>, xi: V3<Lanes<N>>) -> [V3<Lanes<N>>; 3] {
    let per_lane: [Matrix3<f64>; N] = std::array::from_fn(|i| {
        Matrix3::from_diagonal(&j.lane(i)) * so3::t_inverse_matrix(&xi.lane(i))
    });
    [0, 1, 2].map(|c| V3::gather(&per_lane.each_ref().map(|a| a.column(c).into_owned())))
}

/// Solves `[c0 c1 c2] x = b` by the adjugate: rows of the inverse are `c1×c2`, `c2×c0`,
/// `c0×c1` over `det = c0·(c1×c2)`. Returns `(x, det)`; `x` is meaningless when `det` is zero
/// or not finite. 30 multiplications, 17 additions, one division.
#[inline(always)]
fn cramer<R: Real>(c: &[V3<R>; 3], b: V3<R>) -> (V3<R>, R) {
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
/// by O(h^2 |Ω|^2): one Newton update then meets `newton_tol` (see the module doc).
#[inline(always)]
fn predict<R: Real>(inv_j: V3<R>, m: V3<R>, xi_prev: V3<R>, h: R) -> V3<R> {
    xi_prev.add(m.cross(xi_prev).mul(inv_j).scale(h))
}

/// A quaternion `w + v` of lanes.
#[derive(Debug, Clone, Copy)]
struct Quat<R> {
    w: R,
    v: V3<R>,
}

impl<const N: usize> Quat<Lanes<N>> {
    #[inline(always)]
    fn gather(q: &[UnitQuaternion<f64>; N]) -> Self {
        Self {
            w: Lanes(q.each_ref().map(|q| q.w)),
            v: V3 {
                x: Lanes(q.each_ref().map(|q| q.i)),
                y: Lanes(q.each_ref().map(|q| q.j)),
                z: Lanes(q.each_ref().map(|q| q.k)),
            },
        }
    }
    #[inline(always)]
    fn scatter(self, q: &mut [UnitQuaternion<f64>; N]) {
        for (i, q) in q.iter_mut().enumerate() {
            *q = UnitQuaternion::new_unchecked(Quaternion::new(
                self.w.0[i],
                self.v.x.0[i],
                self.v.y.0[i],
                self.v.z.0[i],
            ));
        }
    }
}

/// After the solve: `R_{k+1} = R_k exp(ξ)` and `M_{k+1} = exp(ξ)^T M_k`, both from the same
/// half-angle pair in `e.k`, reusing `ξ × M` and `ξ × (ξ × M)` from the last residual:
/// `exp(ξ)^T M = M - A ξ×M + B ξ×(ξ×M)`.
///
/// The product of unit quaternions drifts off the unit sphere by round-off (~1e-16 a step, a
/// random walk); it is pulled back by one Newton step for `1/|q|`, `q ← q (3 - |q|^2)/2`, which
/// leaves `||q|^2 - 1| = O(ε^2)`: no sqrt and no division, and the norm never drifts.
#[inline(always)]
fn advance<R: Real>(q: Quat<R>, m: V3<R>, xi: V3<R>, e: &Eval<R>) -> (Quat<R>, V3<R>) {
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
struct NewtonOut<const N: usize> {
    xi: V3<Lanes<N>>,
    /// The residual evaluation at `xi`.
    eval: Eval<Lanes<N>>,
    iterations: [u32; N],
    converged: [bool; N],
}

/// Newton on `g(ξ) = f(ξ)/h = 0` from `xi`, lane by lane: a lane stops (its `ξ` is frozen) once
/// every `|g_i| <= threshold` (`newton_tol · |M|_∞`), or after `newton_max_iters` updates, or on a
/// non-finite residual or a singular Jacobian. Lanes that stopped are re-evaluated with the
/// others at the same `ξ`, which reproduces their residual exactly.
#[inline(never)]
fn newton<const N: usize>(
    j_over_h: V3<Lanes<N>>,
    m: V3<Lanes<N>>,
    mut xi: V3<Lanes<N>>,
    threshold: Lanes<N>,
    settings: &VariationalSettings,
) -> NewtonOut<N> {
    let mut iterations = [0u32; N];
    let mut done = [false; N];
    let mut converged = [false; N];
    loop {
        let eval = evaluate(j_over_h, m, xi, coefficients(xi.dot(xi)));
        let within = eval.f.within(threshold);
        let finite = eval.f.finite();
        for i in 0..N {
            if !done[i] {
                converged[i] = within[i];
                done[i] = within[i] | (iterations[i] >= settings.newton_max_iters) | !finite[i];
            }
        }
        if done.iter().all(|&d| d) {
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
        for i in 0..N {
            done[i] |= !(det.0[i] != 0.0 && det.0[i].is_finite());
            iterations[i] += u32::from(!done[i]);
        }
        xi = xi.select(&done, xi.sub(delta));
    }
}

/// The common case of [`newton`] as straight-line code: every `|ξ|` in the series regime, no
/// lane meets the tolerance at the warm start, every lane does after exactly one update. Returns
/// what [`newton`] would (the same arithmetic in the same order), or `None` when any lane leaves
/// that path; the caller then runs [`newton`] from the same start.
#[inline(always)]
fn newton_one_update<const N: usize>(
    j_over_h: V3<Lanes<N>>,
    m: V3<Lanes<N>>,
    xi0: V3<Lanes<N>>,
    threshold: Lanes<N>,
    settings: &VariationalSettings,
) -> Option<NewtonOut<N>> {
    if settings.jacobian != Jacobian::Analytic || settings.newton_max_iters == 0 {
        return None;
    }
    // Series regime only: merging the lane-by-lane `sin_cos` branch into this path would keep
    // the coefficients in memory (measured +12 % instructions per body-step).
    let series = |t2: Lanes<N>| {
        t2.all(|t| t < SERIES_THETA_SQ)
            .then(|| Coefficients::series(t2))
    };
    let e0 = evaluate(j_over_h, m, xi0, series(xi0.dot(xi0))?);
    // A non-finite residual needs no test here: it makes `ξ` non-finite and fails the series
    // test below.
    if e0.f.within(threshold).iter().any(|&c| c) {
        return None;
    }
    let (delta, det) = cramer(&analytic_jacobian(j_over_h, m, xi0, &e0), e0.f);
    if !det.all(|d| d != 0.0 && d.is_finite()) {
        return None;
    }
    let xi = xi0.sub(delta);
    let eval = evaluate(j_over_h, m, xi, series(xi.dot(xi))?);
    let converged = eval.f.within(threshold);
    converged.iter().all(|&c| c).then_some(NewtonOut {
        xi,
        eval,
        iterations: [1; N],
        converged,
    })
}

/// Steps `N` bodies: predict `ξ` (unless `predict_xi` is false), Newton, rotate `q` and `M`.
/// `first_body` is the batch index of lane 0 (for [`StepStats::failed_body`]).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn step_bodies<const N: usize>(
    inertia: &[Vector3<f64>; N],
    inv_inertia: &[Vector3<f64>; N],
    angmom: &mut [Vector3<f64>; N],
    q: &mut [UnitQuaternion<f64>; N],
    xi: &mut [Vector3<f64>; N],
    dt_secs: f64,
    predict_xi: bool,
    settings: &VariationalSettings,
    first_body: usize,
    stats: &mut StepStats,
) {
    let m = V3::gather(angmom);
    let mut xi0 = V3::gather(xi);
    if predict_xi {
        xi0 = predict(V3::gather(inv_inertia), m, xi0, Lanes::splat(dt_secs));
    }
    let j_over_h = V3::gather(inertia).scale(Lanes::splat(1.0 / dt_secs));
    let threshold = Lanes::splat(settings.newton_tol) * m.amax();
    // Two inlined copies of `finish`: the common path keeps everything in registers.
    match newton_one_update(j_over_h, m, xi0, threshold, settings) {
        Some(out) => finish(&out, m, angmom, q, xi, first_body, stats),
        None => {
            let out = newton(j_over_h, m, xi0, threshold, settings);
            if settings.substep && !out.converged.iter().all(|&c| c) {
                let start = (*angmom, *q);
                finish(
                    &out,
                    m,
                    angmom,
                    q,
                    xi,
                    first_body,
                    &mut StepStats::default(),
                );
                substep_unconverged(
                    &out,
                    start,
                    inertia,
                    inv_inertia,
                    angmom,
                    q,
                    xi,
                    dt_secs,
                    settings,
                    first_body,
                    stats,
                );
            } else {
                finish(&out, m, angmom, q, xi, first_body, stats);
            }
        }
    }
}

/// Rotates `q` and `M` by the solved `ξ`, stores `ξ`, and adds the Newton statistics.
#[inline(always)]
fn finish<const N: usize>(
    out: &NewtonOut<N>,
    m: V3<Lanes<N>>,
    angmom: &mut [Vector3<f64>; N],
    q: &mut [UnitQuaternion<f64>; N],
    xi: &mut [Vector3<f64>; N],
    first_body: usize,
    stats: &mut StepStats,
) {
    let (q_next, m_next) = advance(Quat::gather(q), m, out.xi, &out.eval);
    q_next.scatter(q);
    m_next.scatter(angmom);
    out.xi.scatter(xi);
    for i in 0..N {
        stats.add_solve(first_body + i, out.iterations[i], out.converged[i]);
    }
}

/// The substepping guard, after [`finish`] has applied the full-step solve to every lane: lanes
/// whose solve converged keep it; each other lane redoes its step from `start` (momentum and
/// orientation before the step) as `n = 2, 4, 8, ... <= max_substeps` variational steps of
/// `h/n` ([`substep_body`]), and keeps the first split at which every substep converges. When
/// none does, the full-step result stays and the body is counted in
/// [`StepStats::newton_failures`]. Out of line: only bodies at the edge take it.
#[cold]
#[inline(never)]
#[allow(clippy::too_many_arguments)]
fn substep_unconverged<const N: usize>(
    out: &NewtonOut<N>,
    start: ([Vector3<f64>; N], [UnitQuaternion<f64>; N]),
    inertia: &[Vector3<f64>; N],
    inv_inertia: &[Vector3<f64>; N],
    angmom: &mut [Vector3<f64>; N],
    q: &mut [UnitQuaternion<f64>; N],
    xi: &mut [Vector3<f64>; N],
    dt_secs: f64,
    settings: &VariationalSettings,
    first_body: usize,
    stats: &mut StepStats,
) {
    for i in 0..N {
        if out.converged[i] {
            stats.add_solve(first_body + i, out.iterations[i], true);
            continue;
        }
        stats.newton_iters_max = stats.newton_iters_max.max(out.iterations[i]);
        let (m0, q0) = (start.0[i], start.1[i]);
        let mut n = 2;
        let mut converged = false;
        while n <= settings.max_substeps {
            if let Some(split) =
                substep_body(&inertia[i], &inv_inertia[i], m0, q0, dt_secs, n, settings)
            {
                angmom[i] = split.angmom;
                q[i] = split.q;
                // The next full step's warm start: the last substep's ξ scaled to the full step.
                xi[i] = split.xi * f64::from(n);
                stats.newton_iters_max = stats.newton_iters_max.max(split.iterations_max);
                converged = true;
                break;
            }
            n *= 2;
        }
        stats.substepped += 1;
        stats.substep_factor_max = stats.substep_factor_max.max(n.min(settings.max_substeps));
        if !converged {
            stats.add_solve(first_body + i, settings.newton_max_iters, false);
        }
    }
}

/// One body's step of `h` done as `n` variational steps of `h/n` (the first from the cold start
/// `ξ = (h/n) J^-1 M`, the others from the predictor). `None` when a substep's Newton solve does
/// not converge.
struct Split {
    angmom: Vector3<f64>,
    q: UnitQuaternion<f64>,
    xi: Vector3<f64>,
    iterations_max: u32,
}

fn substep_body(
    inertia: &Vector3<f64>,
    inv_inertia: &Vector3<f64>,
    angmom: Vector3<f64>,
    q: UnitQuaternion<f64>,
    dt_secs: f64,
    n: u32,
    settings: &VariationalSettings,
) -> Option<Split> {
    let h = dt_secs / f64::from(n);
    let j_over_h = V3::<Lanes<1>>::gather(&[*inertia]).scale(Lanes::splat(1.0 / h));
    let inv_j = V3::gather(&[*inv_inertia]);
    let mut m = V3::gather(&[angmom]);
    let mut quat = Quat::gather(&[q]);
    let mut xi = m.mul(inv_j).scale(Lanes::splat(h));
    let mut iterations_max = 0;
    for s in 0..n {
        if s > 0 {
            xi = predict(inv_j, m, xi, Lanes::splat(h));
        }
        let threshold = Lanes::splat(settings.newton_tol) * m.amax();
        let out = newton(j_over_h, m, xi, threshold, settings);
        iterations_max = iterations_max.max(out.iterations[0]);
        if !out.converged[0] {
            return None;
        }
        (quat, m) = advance(quat, m, out.xi, &out.eval);
        xi = out.xi;
    }
    let mut q_out = [q];
    quat.scatter(&mut q_out);
    Some(Split {
        angmom: m.lane(0),
        q: q_out[0],
        xi: xi.lane(0),
        iterations_max,
    })
}

/// The exponential-map variational integrator over a batch.
#[derive(Debug, Clone)]
pub struct Variational {
    pub settings: VariationalSettings,
    dt_secs: f64,
    /// Per body: the last solved `ξ` (state, and the base of the next warm start).
    xi: Vec<Vector3<f64>>,
    /// `xi` was just solved by [`Integrator::init`] for the current momenta: the next step's
    /// solution is `xi` itself, so it is used as the warm start without extrapolation.
    fresh: bool,
}

impl Variational {
    pub fn new(dt_secs: f64, settings: VariationalSettings) -> Self {
        Self {
            settings,
            dt_secs,
            xi: Vec::new(),
            fresh: false,
        }
    }

    /// The per-body `ξ` of the next step (after [`Integrator::init`]).
    pub fn xi(&self) -> &[Vector3<f64>] {
        &self.xi
    }
}

impl Integrator for Variational {
    fn name(&self) -> &'static str {
        "variational"
    }

    fn dt(&self) -> f64 {
        self.dt_secs
    }

    fn init(&mut self, bodies: &Bodies) {
        self.init_range(bodies, 0..bodies.len());
    }

    fn step(&mut self, bodies: &mut Bodies, loads: &Loads) -> StepStats {
        if self.xi.len() != bodies.len() {
            self.init(bodies);
        }
        self.step_range(bodies, 0..bodies.len(), loads)
    }

    fn step_watched(
        &mut self,
        bodies: &mut Bodies,
        loads: &Loads,
        watch: &Watch,
    ) -> (StepStats, bool) {
        if self.xi.len() != bodies.len() {
            self.init(bodies);
        }
        self.step_range_watched(bodies, 0..bodies.len(), loads, Some(watch))
    }
}

impl Variational {
    /// [`Integrator::init`] for the bodies `range` of the batch only (the articulated stepper
    /// steps free bodies between mechanisms this way).
    pub fn init_range(&mut self, bodies: &Bodies, range: std::ops::Range<usize>) {
        self.xi = range
            .map(|i| {
                let guess = bodies.angvel_body(i) * self.dt_secs;
                solve_xi(
                    &bodies.inertia_body[i],
                    &bodies.angmom_body[i],
                    self.dt_secs,
                    &guess,
                    &self.settings,
                )
                .xi
            })
            .collect();
        self.fresh = true;
    }

    /// [`Integrator::step`] for the bodies `range` of the batch only, after
    /// [`Variational::init_range`] with the same range (failed bodies are reported by their
    /// batch index).
    pub fn step_range(
        &mut self,
        bodies: &mut Bodies,
        range: std::ops::Range<usize>,
        loads: &Loads,
    ) -> StepStats {
        self.step_range_watched(bodies, range, loads, None).0
    }

    /// [`Variational::step_range`], block by block of [`BLOCK_BODIES`] bodies (rotation, then
    /// translation), and with `watch` the guard's per-body test of each block right after its
    /// step, while its state is in cache; returns the statistics and whether any body is
    /// suspect. Every body steps from its own state alone (the 4-body lanes round as one body
    /// does), and the blocks start at `range.start` in multiples of [`LANES`], so the lanes
    /// and the bits are those of one pass over the range.
    pub fn step_range_watched(
        &mut self,
        bodies: &mut Bodies,
        range: std::ops::Range<usize>,
        loads: &Loads,
        watch: Option<&Watch>,
    ) -> (StepStats, bool) {
        let offset = range.start;
        let predict_xi = !std::mem::replace(&mut self.fresh, false);
        let dt = self.dt_secs;
        let mut stats = StepStats::default();
        let mut any_suspect = false;
        let mut start = range.start;
        while start < range.end {
            let block = start..(start + BLOCK_BODIES).min(range.end);
            rotate_block(
                bodies,
                &mut self.xi[block.start - offset..block.end - offset],
                block.clone(),
                dt,
                predict_xi,
                &self.settings,
                &mut stats,
            );
            step_translation(
                &mut bodies.com_world[block.clone()],
                &mut bodies.linvel_world[block.clone()],
                dt,
                loads,
                self.settings.potential,
            );
            if let Some(watch) = watch {
                any_suspect |= watch.any_suspect(bodies, block.clone());
            }
            start = block.end;
        }
        (stats, any_suspect)
    }
}

// The blocks start in multiples of the lanes, so the lanes are those of one pass.
const _: () = assert!(BLOCK_BODIES.is_multiple_of(LANES));

/// The rotation step of the bodies `block` (batch indices; `xi` is theirs), in lanes of
/// [`LANES`] bodies and the rest one by one.
fn rotate_block(
    bodies: &mut Bodies,
    xi: &mut [Vector3<f64>],
    block: std::ops::Range<usize>,
    dt: f64,
    predict_xi: bool,
    settings: &VariationalSettings,
    stats: &mut StepStats,
) {
    let first = block.start;
    let (j_l, j_r) = bodies.inertia_body[block.clone()].as_chunks::<LANES>();
    let (ij_l, ij_r) = bodies.inv_inertia_body[block.clone()].as_chunks::<LANES>();
    let (m_l, m_r) = bodies.angmom_body[block.clone()].as_chunks_mut::<LANES>();
    let (q_l, q_r) = bodies.world_from_body[block].as_chunks_mut::<LANES>();
    let (xi_l, xi_r) = xi.as_chunks_mut::<LANES>();
    let chunks = j_l.iter().zip(ij_l).zip(m_l).zip(q_l).zip(xi_l);
    for (c, ((((j, ij), m), q), xi)) in chunks.enumerate() {
        step_bodies(
            j,
            ij,
            m,
            q,
            xi,
            dt,
            predict_xi,
            settings,
            first + c * LANES,
            stats,
        );
    }
    let rest = j_r.iter().zip(ij_r).zip(m_r).zip(q_r).zip(xi_r);
    for (r, ((((j, ij), m), q), xi)) in rest.enumerate() {
        step_bodies::<1>(
            std::array::from_ref(j),
            std::array::from_ref(ij),
            std::array::from_mut(m),
            std::array::from_mut(q),
            std::array::from_mut(xi),
            dt,
            predict_xi,
            settings,
            first + j_l.len() * LANES + r,
            stats,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solve3_inverts() {
        let a = Matrix3::new(4.0, 1.0, -2.0, 0.5, 3.0, 1.0, -1.0, 2.0, 5.0);
        let x = Vector3::new(0.3, -1.7, 2.2);
        let b = a * x;
        // Measured 4e-16.
        assert!((solve3(&a, &b).unwrap() - x).amax() < 1e-14);
        assert!(solve3(&Matrix3::zeros(), &b).is_none());
    }

    /// Analytic Newton converges quadratically: residual roughly squares each iteration, so a
    /// cold start from `h Ω` at `h|Ω| = 0.5` needs only a few iterations.
    #[test]
    fn newton_converges_quadratically_from_cold_start() {
        let j = Vector3::new(1.0, 2.0, 3.0);
        let omega = Vector3::new(0.2, 0.25, 0.1); // |Ω| ≈ 0.34 rad/s
        let m = j.component_mul(&omega);
        let h = 1.0; // h|Ω| ≈ 0.34
        let settings = VariationalSettings {
            newton_tol: 1e-14,
            ..Default::default()
        };
        let solve = solve_xi(&j, &m, h, &(omega * h), &settings);
        assert!(solve.converged);
        // Measured 3 iterations; linear convergence at this ratio would need > 10.
        assert!(solve.iterations <= 4, "iterations = {}", solve.iterations);
        let k = Coefficients::new(solve.xi.norm_squared());
        let res = j.component_mul(&solve.xi) - so3::t_transpose_times(&solve.xi, &k, &(m * h));
        assert!(res.amax() < 1e-14 * (m * h).amax());

        let approx = VariationalSettings {
            jacobian: Jacobian::Approximate,
            newton_max_iters: 200,
            ..settings
        };
        let slow = solve_xi(&j, &m, h, &(omega * h), &approx);
        assert!(slow.converged);
        // The approximate Jacobian converges only linearly: measured 12 iterations.
        assert!(slow.iterations > solve.iterations);
        assert!((slow.xi - solve.xi).amax() < 1e-12);
    }

    use crate::sim::BodyInit;
    use nalgebra::{Isometry3, Translation3};

    fn body(moments: Vector3<f64>, euler: (f64, f64, f64), angvel: Vector3<f64>) -> BodyInit {
        BodyInit {
            mass: 1.5,
            principal_moments: moments,
            world_from_body: Isometry3::from_parts(
                Translation3::new(0.1, -0.2, 0.3),
                UnitQuaternion::from_euler_angles(euler.0, euler.1, euler.2),
            ),
            linvel_world: Vector3::new(0.5, 0.0, 1.0),
            angvel_world: angvel,
        }
    }

    /// Bodies covering every path: series regime with one update (the common path), a slow
    /// spinner (`h|Ω|` ≈ 3e-4), a fast one above `SERIES_THETA` at h = 1 ms (`sin_cos`, two
    /// updates, lane-by-lane coefficients), one at rest (zero residual at the start).
    fn mixed_bodies() -> Vec<BodyInit> {
        vec![
            body(
                Vector3::new(1.0, 2.0, 3.0),
                (0.2, 0.4, -0.3),
                Vector3::new(0.05, 3.0, 0.05),
            ),
            body(
                Vector3::new(0.5, 0.7, 0.9),
                (1.0, -0.4, 2.0),
                Vector3::new(0.1, -0.2, 0.2),
            ),
            body(
                Vector3::new(2.0, 1.0, 1.5),
                (-2.0, 0.1, 0.4),
                Vector3::new(30.0, -12.0, 8.0),
            ),
            body(
                Vector3::new(1.0, 1.2, 1.4),
                (0.0, 0.0, 0.0),
                Vector3::zeros(),
            ),
            body(
                Vector3::new(1.0, 3.0, 3.5),
                (0.3, 0.3, 0.3),
                Vector3::new(-2.0, 1.0, 4.0),
            ),
        ]
    }

    /// The batched path (four lanes, with a fallback to the lane-wise Newton loop when one body
    /// leaves the common path) and the one-body path give bit-identical trajectories: the
    /// arithmetic is the same code in the same order, and Rust never contracts to FMA.
    #[test]
    fn batched_lanes_match_one_body_steps_bit_for_bit() {
        let inits = mixed_bodies();
        let g = Loads::uniform_gravity(Vector3::new(0.0, 0.0, -9.81));
        let mut batch = Bodies::new(&inits);
        let mut batch_integ = Variational::new(0.001, VariationalSettings::default());
        batch_integ.init(&batch);
        let mut singles: Vec<(Bodies, Variational)> = inits
            .iter()
            .map(|init| {
                let bodies = Bodies::new(std::slice::from_ref(init));
                let mut integ = Variational::new(0.001, VariationalSettings::default());
                integ.init(&bodies);
                (bodies, integ)
            })
            .collect();
        let mut iters_max = 0;
        for _ in 0..500 {
            let stats = batch_integ.step(&mut batch, &g);
            assert_eq!(stats.newton_failures, 0);
            iters_max = iters_max.max(stats.newton_iters_max);
            for (bodies, integ) in &mut singles {
                integ.step(bodies, &g);
            }
        }
        // The fast spinner needs two updates (h|Ω| ≈ 0.034): the fallback path ran.
        assert_eq!(iters_max, 2);
        for (i, (single, integ)) in singles.iter().enumerate() {
            assert_eq!(
                batch.world_from_body[i], single.world_from_body[0],
                "body {i}"
            );
            assert_eq!(batch.angmom_body[i], single.angmom_body[0], "body {i}");
            assert_eq!(batch.com_world[i], single.com_world[0], "body {i}");
            assert_eq!(batch_integ.xi()[i], integ.xi()[0], "body {i}");
        }
    }

    /// With the Euler-equation predictor one Newton update meets the 1e-12 tolerance at every
    /// step for `h|Ω|` ≈ 3e-3 (without it, 35 % of the steps need two: measured 7072 of 20000).
    /// The step right after `init` needs none: `init` solved it already.
    #[test]
    fn predicted_warm_start_needs_one_newton_update() {
        let init = body(
            Vector3::new(1.0, 2.0, 3.0),
            (0.2, 0.4, -0.3),
            Vector3::new(0.5, 3.0, 0.5),
        );
        let mut bodies = Bodies::new(&vec![init; 5]);
        let mut integ = Variational::new(0.001, VariationalSettings::default());
        integ.init(&bodies);
        let g = Loads::none();
        assert_eq!(integ.step(&mut bodies, &g).newton_iters_max, 0);
        for _ in 0..20_000 {
            let stats = integ.step(&mut bodies, &g);
            assert_eq!((stats.newton_iters_max, stats.newton_failures), (1, 0));
        }
    }

    /// The cheap renormalisation `q (3 - |q|^2)/2` keeps the quaternion unit to round-off,
    /// with no drift, over 1e5 steps of a fast, tumbling body.
    #[test]
    fn quaternion_norm_stays_at_round_off() {
        let init = body(
            Vector3::new(1.0, 2.0, 3.0),
            (0.2, 0.4, -0.3),
            Vector3::new(3.0, 20.0, 3.0),
        );
        let mut bodies = Bodies::new(&vec![init; 4]);
        let mut integ = Variational::new(0.001, VariationalSettings::default());
        integ.init(&bodies);
        let mut worst: f64 = 0.0;
        for _ in 0..100_000 {
            integ.step(&mut bodies, &Loads::none());
            worst = worst.max((bodies.world_from_body[0].coords.norm_squared() - 1.0).abs());
        }
        // Measured 4.4e-16 (2 ulp of 1).
        assert!(worst < 2e-15, "||q|^2 - 1| = {worst:e}");
    }

    /// A non-finite momentum is a Newton failure for that body only, not a panic, and does not
    /// disturb the other bodies of its lane group.
    #[test]
    fn non_finite_body_fails_alone() {
        let inits = mixed_bodies();
        let mut bodies = Bodies::new(&inits);
        let mut integ = Variational::new(0.001, VariationalSettings::default());
        integ.init(&bodies);
        let mut reference = bodies.clone();
        let mut reference_integ = integ.clone();
        bodies.angmom_body[1] = Vector3::new(f64::NAN, 0.0, 0.0);
        let stats = integ.step(&mut bodies, &Loads::none());
        assert_eq!(stats.newton_failures, 1);
        reference_integ.step(&mut reference, &Loads::none());
        for i in [0, 2, 3, 4] {
            assert_eq!(bodies.world_from_body[i], reference.world_from_body[i]);
            assert_eq!(bodies.angmom_body[i], reference.angmom_body[i]);
        }
    }
}
