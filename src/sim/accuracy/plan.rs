//! The substep factor of every body of a run for a tolerance (`simulate --accuracy TOL`), and
//! the a posteriori check of the achieved error.

use super::model::{Calibration, ErrorModel, Factor, factor_from};
use super::substeps::Substepped;
use crate::sim::integrators::VariationalSettings;
use crate::sim::loads::Loads;
use crate::sim::{Bodies, BodyInit, Integrator, IntegratorKind};
use nalgebra::Vector3;
use rayon::prelude::*;

/// Bodies rerun by the a posteriori check (all of them when the batch is no larger).
pub const CHECK_SAMPLE: usize = 64;

/// Per body: its calibration, factor and predicted error.
#[derive(Debug, Clone)]
pub struct Plan {
    pub kind: IntegratorKind,
    pub dt_secs: f64,
    pub duration_secs: f64,
    pub tol_rad: f64,
    pub calibrations: Vec<Calibration>,
    pub factors: Vec<Factor>,
}

impl Plan {
    /// Calibrates every body (in parallel on the current rayon pool) and picks its factor.
    pub fn new(
        kind: IntegratorKind,
        settings: &VariationalSettings,
        model: &ErrorModel,
        bodies: &[BodyInit],
        dt_secs: f64,
        duration_secs: f64,
        tol_rad: f64,
    ) -> Self {
        let calibrations: Vec<Calibration> = bodies
            .par_iter()
            .map(|b| {
                let q = b.world_from_body.rotation;
                let j = b.principal_moments;
                let m = j.component_mul(&q.inverse_transform_vector(&b.angvel_world));
                model.calibrate(kind, settings, &j, &m, duration_secs)
            })
            .collect();
        let factors = calibrations
            .iter()
            .map(|c| factor_from(c, dt_secs, tol_rad))
            .collect();
        Self {
            kind,
            dt_secs,
            duration_secs,
            tol_rad,
            calibrations,
            factors,
        }
    }

    /// The factors `k`.
    pub fn ks(&self) -> Vec<u32> {
        self.factors.iter().map(|f| f.k).collect()
    }

    /// Σ k: the substeps per recorded step (the cost, in body-steps per step).
    pub fn cost(&self) -> u64 {
        self.factors.iter().map(|f| u64::from(f.k)).sum()
    }

    /// The largest predicted error, rad.
    pub fn predicted_max(&self) -> f64 {
        self.factors
            .iter()
            .map(|f| f.predicted_rad)
            .fold(0.0, f64::max)
    }

    /// Counts of bodies per power-of-two bin of `k`: `(lo, hi, count)` for `lo <= k <= hi`
    /// (1, 2, 3-4, 5-8, …), empty bins left out.
    pub fn histogram(&self) -> Vec<(u32, u32, usize)> {
        let mut bins: Vec<(u32, u32, usize)> = Vec::new();
        for f in &self.factors {
            let hi = f.k.next_power_of_two();
            let lo = if hi <= 2 { hi } else { hi / 2 + 1 };
            match bins.iter_mut().find(|b| b.1 == hi) {
                Some(b) => b.2 += 1,
                None => bins.push((lo, hi, 1)),
            }
        }
        bins.sort_unstable();
        bins
    }

    /// The integrator stepping bodies `range` of the batch with their factors.
    pub fn integrator(
        &self,
        settings: &VariationalSettings,
        range: std::ops::Range<usize>,
    ) -> Box<dyn Integrator> {
        let ks = self.factors[range].iter().map(|f| f.k).collect();
        Box::new(Substepped::with_factors(
            self.kind,
            self.dt_secs,
            settings,
            ks,
        ))
    }

    /// The bodies the a posteriori check reruns: all when there are at most [`CHECK_SAMPLE`],
    /// else evenly spaced ones plus the body with the largest predicted error.
    pub fn check_sample(&self) -> Vec<usize> {
        let n = self.factors.len();
        if n <= CHECK_SAMPLE {
            return (0..n).collect();
        }
        let mut out: Vec<usize> = (0..CHECK_SAMPLE - 1)
            .map(|i| i * n / (CHECK_SAMPLE - 1))
            .collect();
        let worst = (0..n)
            .max_by(|&a, &b| {
                self.factors[a]
                    .predicted_rad
                    .total_cmp(&self.factors[b].predicted_rad)
            })
            .unwrap_or(0);
        out.push(worst);
        out.sort_unstable();
        out.dedup();
        out
    }
}

/// One body's a posteriori estimate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Checked {
    pub body: usize,
    pub k: u32,
    /// `max_t |θ_k(t) - θ_2k(t)| 2^p / (2^p - 1)`, rad (Richardson).
    pub estimated_rad: f64,
}

/// Reruns each body of `sample` alone (rotation only: translation is exact for the scheme)
/// for `steps` steps at its factor `k` and at `2k`, and estimates its achieved largest error by
/// Richardson extrapolation, `|θ_k - θ_2k| 2^p / (2^p - 1)`, sampled at up to 256 steps and the
/// last. In parallel on the current rayon pool.
pub fn check(
    plan: &Plan,
    settings: &VariationalSettings,
    bodies: &[BodyInit],
    sample: &[usize],
    steps: u64,
) -> Vec<Checked> {
    let p = plan.kind.order();
    let richardson = f64::from(1u32 << p) / (f64::from(1u32 << p) - 1.0);
    sample
        .par_iter()
        .map(|&i| {
            let k = plan.factors[i].k;
            let init = BodyInit {
                world_from_body: nalgebra::Isometry3::from_parts(
                    Default::default(),
                    bodies[i].world_from_body.rotation,
                ),
                linvel_world: Vector3::zeros(),
                ..bodies[i].clone()
            };
            let mut a = Bodies::new(std::slice::from_ref(&init));
            let mut b = a.clone();
            let mut ia = Substepped::uniform(plan.kind, plan.dt_secs, k, settings);
            let mut ib = Substepped::uniform(plan.kind, plan.dt_secs, 2 * k, settings);
            ia.init(&a);
            ib.init(&b);
            let every = (steps / 256).max(1);
            let g = Loads::none();
            let mut worst: f64 = 0.0;
            for s in 1..=steps {
                ia.step(&mut a, &g);
                ib.step(&mut b, &g);
                if s % every == 0 || s == steps {
                    worst = worst.max(a.world_from_body[0].angle_to(&b.world_from_body[0]));
                }
            }
            Checked {
                body: i,
                k,
                estimated_rad: worst * richardson,
            }
        })
        .collect()
}
