//! [`Variational`], the [`Integrator`] over a batch: its state (the per-body `ξ`), the stepping
//! of a range block by block (rotation in packs of bodies on the machine's vector unit, then translation, then the
//! guard's test), and the step of one lane group ([`step_bodies`]: predict, Newton, rotate,
//! substep when needed).

use super::VariationalSettings;
use super::lanes::{LANES, Lanes, Pack, Quat, V3, has};
use super::newton::{NewtonOut, advance, newton_one_update, predict};
use super::one_body::solve_xi;
use super::substep::substep_unconverged;
#[cfg(target_arch = "x86_64")]
use super::vector::{F64x4, F64x8x2};
use crate::sim::Bodies;
use crate::sim::guard::Watch;
use crate::sim::integrators::EnergyFlow;
use crate::sim::integrators::translation::step_translation;
use crate::sim::integrators::{BLOCK_BODIES, Integrator, StepStats};
use crate::sim::loads::{KickLedger, Loads};
use crate::sim::simd::Level;

use nalgebra::{UnitQuaternion, Vector3};

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
    /// The work of the applied loads ([`Loads::forced_step`]).
    ledger: KickLedger,
    /// The vector unit the step runs on ([`crate::sim::simd`]: the same bits on all).
    simd: Level,
}

impl Variational {
    pub fn new(dt_secs: f64, settings: VariationalSettings) -> Self {
        Self {
            settings,
            dt_secs,
            xi: Vec::new(),
            fresh: false,
            ledger: KickLedger::default(),
            simd: crate::sim::simd::active(),
        }
    }

    /// The same integrator stepping on `level`'s vector unit (the machine's widest when it
    /// lacks `level`): for the test that every unit steps the same bits, and for benchmarks.
    pub fn with_simd(mut self, level: Level) -> Self {
        self.simd = level.min(crate::sim::simd::detected());
        self
    }

    /// The vector unit it steps on.
    pub fn simd(&self) -> Level {
        self.simd
    }

    /// The per-body `ξ` of the next step (after [`Integrator::init`]).
    pub fn xi(&self) -> &[Vector3<f64>] {
        &self.xi
    }
}

impl Integrator for Variational {
    /// The potential's quadrature ([`crate::sim::integrators::translation::Potential::alpha`]).
    fn gravity_drift(&self) -> f64 {
        self.settings.potential.alpha()
    }

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

    fn energy_flow(&self) -> EnergyFlow {
        EnergyFlow {
            input_work: self.ledger.work,
            dissipated: 0.0,
            ..Default::default()
        }
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
    /// suspect. Every body steps from its own state alone (the packs of every vector unit round
    /// as one body does), and the blocks start at `range.start` in multiples of every pack's width, so the lanes
    /// and the bits are those of one pass over the range.
    pub fn step_range_watched(
        &mut self,
        bodies: &mut Bodies,
        range: std::ops::Range<usize>,
        loads: &Loads,
        watch: Option<&Watch>,
    ) -> (StepStats, bool) {
        if loads.loads_any(&range) {
            // The kicks of the applied loads around the unforced step; the guard's test after
            // the end kick, over the whole range.
            let mut ledger = std::mem::take(&mut self.ledger);
            let (stats, _) = loads.forced_step(bodies, &range, self.dt_secs, &mut ledger, |b| {
                self.step_range_unforced(b, range.clone(), loads, None)
            });
            self.ledger = ledger;
            let suspect = watch.is_some_and(|w| w.any_suspect(bodies, range));
            return (stats, suspect);
        }
        self.step_range_unforced(bodies, range, loads, watch)
    }

    /// [`Variational::step_range_watched`] without the applied loads' kicks, on the vector unit
    /// of [`Variational::simd`] (every unit steps the same bits).
    #[allow(unsafe_code)]
    fn step_range_unforced(
        &mut self,
        bodies: &mut Bodies,
        range: std::ops::Range<usize>,
        loads: &Loads,
        watch: Option<&Watch>,
    ) -> (StepStats, bool) {
        let job = Blocks {
            offset: range.start,
            bodies,
            xi: &mut self.xi,
            range,
            loads,
            watch,
            dt: self.dt_secs,
            predict_xi: !std::mem::replace(&mut self.fresh, false),
            settings: &self.settings,
        };
        match self.simd {
            // SAFETY: `self.simd` is at most `simd::detected()` (`Variational::new`,
            // `with_simd`): the CPU has the instructions these functions are compiled with.
            #[cfg(target_arch = "x86_64")]
            Level::Avx512 => unsafe { step_blocks_avx512(job) },
            #[cfg(target_arch = "x86_64")]
            Level::Avx2 => unsafe { step_blocks_avx2(job) },
            _ => step_blocks_portable(job),
        }
    }
}

/// One call's bodies and settings for [`step_blocks`].
struct Blocks<'a> {
    bodies: &'a mut Bodies,
    /// The per-body `ξ`, indexed from `offset`.
    xi: &'a mut [Vector3<f64>],
    offset: usize,
    range: std::ops::Range<usize>,
    loads: &'a Loads,
    watch: Option<&'a Watch>,
    dt: f64,
    predict_xi: bool,
    settings: &'a VariationalSettings,
}

/// [`step_blocks`] in lanes of [`LANES`] plain doubles (SSE2 on x86-64), out of line as the
/// other units' functions are.
#[inline(never)]
fn step_blocks_portable(job: Blocks) -> (StepStats, bool) {
    step_blocks::<Lanes<LANES>, LANES>(job)
}

/// [`step_blocks`] in 4 lanes of AVX registers, compiled for AVX2 (translation and guard
/// included, vectorized by the compiler for AVX2 with the same rounding).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn step_blocks_avx2(job: Blocks) -> (StepStats, bool) {
    step_blocks::<F64x4, 4>(job)
}

/// [`step_blocks`] in 8 lanes of AVX-512 registers, compiled for AVX-512F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn step_blocks_avx512(job: Blocks) -> (StepStats, bool) {
    step_blocks::<F64x8x2, 16>(job)
}

/// The step of `job.range`, block by block of [`BLOCK_BODIES`] bodies: rotation in packs of `N`
/// bodies (the rest one by one), translation, then the guard's test of the block while it is in
/// cache. Inlined into each vector unit's function, so it is compiled with that unit's
/// instructions.
#[inline(always)]
fn step_blocks<L: Pack<N>, const N: usize>(job: Blocks) -> (StepStats, bool) {
    let Blocks {
        bodies,
        xi,
        offset,
        range,
        loads,
        watch,
        dt,
        predict_xi,
        settings,
    } = job;
    let mut stats = StepStats::default();
    let mut any_suspect = false;
    let mut start = range.start;
    while start < range.end {
        let block = start..(start + BLOCK_BODIES).min(range.end);
        rotate_block::<L, N>(
            bodies,
            &mut xi[block.start - offset..block.end - offset],
            block.clone(),
            dt,
            predict_xi,
            settings,
            &mut stats,
        );
        step_translation(
            &mut bodies.com_world[block.clone()],
            &mut bodies.linvel_world[block.clone()],
            dt,
            loads,
            settings.potential,
        );
        if let Some(watch) = watch {
            any_suspect |= watch.any_suspect(bodies, block.clone());
        }
        start = block.end;
    }
    (stats, any_suspect)
}

// The blocks start in multiples of the lanes of every unit, so the lanes are those of one pass.
const _: () = assert!(BLOCK_BODIES.is_multiple_of(LANES));
const _: () = assert!(BLOCK_BODIES.is_multiple_of(16));

/// The rotation step of the bodies `block` (batch indices; `xi` is theirs), in packs of `N`
/// bodies and the rest one by one.
#[inline(always)]
fn rotate_block<L: Pack<N>, const N: usize>(
    bodies: &mut Bodies,
    xi: &mut [Vector3<f64>],
    block: std::ops::Range<usize>,
    dt: f64,
    predict_xi: bool,
    settings: &VariationalSettings,
    stats: &mut StepStats,
) {
    let first = block.start;
    let (j_l, j_r) = bodies.inertia_body[block.clone()].as_chunks::<N>();
    let (ij_l, ij_r) = bodies.inv_inertia_body[block.clone()].as_chunks::<N>();
    let (m_l, m_r) = bodies.angmom_body[block.clone()].as_chunks_mut::<N>();
    let (q_l, q_r) = bodies.world_from_body[block].as_chunks_mut::<N>();
    let (xi_l, xi_r) = xi.as_chunks_mut::<N>();
    let chunks = j_l.iter().zip(ij_l).zip(m_l).zip(q_l).zip(xi_l);
    for (c, ((((j, ij), m), q), xi)) in chunks.enumerate() {
        step_bodies::<L, N>(
            j,
            ij,
            m,
            q,
            xi,
            dt,
            predict_xi,
            settings,
            first + c * N,
            stats,
        );
    }
    let rest = j_r.iter().zip(ij_r).zip(m_r).zip(q_r).zip(xi_r);
    for (r, ((((j, ij), m), q), xi)) in rest.enumerate() {
        step_bodies::<Lanes<1>, 1>(
            std::array::from_ref(j),
            std::array::from_ref(ij),
            std::array::from_mut(m),
            std::array::from_mut(q),
            std::array::from_mut(xi),
            dt,
            predict_xi,
            settings,
            first + j_l.len() * N + r,
            stats,
        );
    }
}

/// Steps `N` bodies: predict `ξ` (unless `predict_xi` is false), Newton, rotate `q` and `M`.
/// `first_body` is the batch index of lane 0 (for [`StepStats::failed_body`]).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn step_bodies<L: Pack<N>, const N: usize>(
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
    let m = V3::<L>::gather(angmom);
    let mut xi0 = V3::gather(xi);
    if predict_xi {
        xi0 = predict(V3::gather(inv_inertia), m, xi0, L::splat(dt_secs));
    }
    let j_over_h = V3::<L>::gather(inertia).scale(L::splat(1.0 / dt_secs));
    let threshold = L::splat(settings.newton_tol) * m.amax();
    // Two inlined copies of `finish`: the common path keeps everything in registers.
    match newton_one_update(j_over_h, m, xi0, threshold, settings) {
        Some(out) => finish(&out, m, angmom, q, xi, first_body, stats),
        None => {
            let out = L::newton(j_over_h, m, xi0, threshold, settings);
            if settings.substep && out.converged != L::ALL {
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
pub(super) fn finish<L: Pack<N>, const N: usize>(
    out: &NewtonOut<L, N>,
    m: V3<L>,
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
        stats.add_solve(first_body + i, out.iterations[i], has(out.converged, i));
    }
}
