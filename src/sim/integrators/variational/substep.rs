//! Substepping: a body whose Newton solve does not converge at the full step redoes it as
//! `n = 2, 4, 8, ...` variational steps of `h/n` (momentum stays exact).

use super::VariationalSettings;
use super::lanes::{Lanes, Pack, Quat, V3, has};
use super::newton::{NewtonOut, advance, predict};
use crate::sim::integrators::StepStats;
use crate::sim::so3::Real;
use nalgebra::{UnitQuaternion, Vector3};

/// The substepping guard, after [`finish`](super::integrator::finish) has applied the full-step
/// solve to every lane: lanes whose solve converged keep it; each other lane redoes its step from `start` (momentum and
/// orientation before the step) as `n = 2, 4, 8, ... <= max_substeps` variational steps of
/// `h/n` ([`substep_body`]), and keeps the first split at which every substep converges. When
/// none does, the full-step result stays and the body is counted in
/// [`StepStats::newton_failures`]. Out of line: only bodies at the edge take it.
#[cold]
#[inline(never)]
#[allow(clippy::too_many_arguments)]
pub(super) fn substep_unconverged<L, const N: usize>(
    out: &NewtonOut<L, N>,
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
        if has(out.converged, i) {
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
        let out = Lanes::<1>::newton(j_over_h, m, xi, threshold, settings);
        iterations_max = iterations_max.max(out.iterations[0]);
        if !has(out.converged, 0) {
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
