//! A batch split into contiguous partitions, stepped side by side (`--threads`).
//!
//! Free bodies do not interact, and every integrator steps each body from that body's state
//! alone (the variational step's packs of 4 or 16 bodies round exactly as one body does,
//! `batched_lanes_match_one_body_steps_bit_for_bit`), so a body's trajectory is the same bits
//! however the batch is cut: partition `k` of `n` holds bodies `[k·c, (k+1)·c)`, `c = ⌈N/n⌉`,
//! with its own integrator instance and [`Guard`], and the partitions are stepped on a rayon
//! pool of `--threads` threads, up to [`PARTITIONS_PER_THREAD`] partitions per thread taken by
//! whichever thread is free (work stealing evens out cores running at different speeds),
//! several steps at a time ([`Partitions::advance`]: up to the next recorded step), so
//! the threads meet once per recorded frame, not once per step. What the partitions report is
//! merged as one batch would report it: [`StepStats`] merged over the partitions (counts add,
//! maxima, the lowest failing body), and the run's [`Divergence`] is the earliest step's lowest
//! body, as the one-batch [`Guard::check`] picks. So the recordings are byte-identical for every
//! thread count (tested by `tests/reliability/scale.rs`).
//!
//! A batch holding mechanisms is cut only between mechanisms ([`ranges`]): a mechanism's bodies
//! are coupled by its joint rows, so each mechanism lies whole in one partition, whose
//! integrator and guard see it re-based to the partition's indices ([`rebase`]). The
//! constrained step of a mechanism reads and writes that mechanism's bodies alone, so its
//! trajectory too is the same bits however the batch is cut (`tests/mechanism/threads.rs`).

use super::guard::{Divergence, Guard};
use super::mechanism::Mechanism;
use super::{Bodies, BodyInit, Integrator, StepStats};
use crate::sim::contact::{ContactModel, ContactPhase, ContactPoint};
use crate::sim::loads::Loads;
use nalgebra::Isometry3;
use rayon::prelude::*;
use std::ops::Range;
use std::sync::Arc;

/// Fewest bodies a partition gets (smaller batches use fewer partitions: the threads' meeting
/// costs a few microseconds per window).
pub const MIN_BODIES_PER_PARTITION: usize = 256;

/// Partitions per stepping thread. The threads meet at the end of every window, so with one
/// partition per thread the window lasts as long as the slowest core takes: on the shared
/// 2-core machine one core often runs at 2/3 of the other's speed for seconds (a 1-thread
/// `tumble bench` at 10 000 bodies alternates between 31 and 45 ns per body-step), and the
/// fast core idles. With several partitions per thread, rayon's work stealing hands the
/// partitions to whichever thread is free, so both cores stay busy until the window's end.
pub const PARTITIONS_PER_THREAD: usize = 8;

/// Number of partitions for `bodies` bodies on `threads` threads: one on one thread,
/// else up to [`PARTITIONS_PER_THREAD`] per thread, none smaller than
/// [`MIN_BODIES_PER_PARTITION`].
pub fn partition_count(bodies: usize, threads: usize) -> usize {
    if threads <= 1 {
        return 1;
    }
    (threads * PARTITIONS_PER_THREAD)
        .min(bodies.div_ceil(MIN_BODIES_PER_PARTITION))
        .max(1)
}

/// Threads that step `partitions` partitions when `threads` are asked for (no more threads
/// than partitions).
pub fn stepping_threads(partitions: usize, threads: usize) -> usize {
    threads.clamp(1, partitions.max(1))
}

/// Bodies per partition when `bodies` bodies are split into `partitions` (the last may have
/// fewer): partition `k` holds `[k·c, (k+1)·c)`.
pub fn chunk_size(bodies: usize, partitions: usize) -> usize {
    bodies.div_ceil(partitions.max(1)).max(1)
}

/// The cost of stepping one body of a mechanism, in free-body steps: `tumble bench --scene`
/// measures 0.8-2.1 µs per body-step on the bundled mechanisms (double pendulum 816 ns, free
/// 3-link chain 1094 ns, 7-link chain 2058 ns) against 40-55 ns for a free body.
pub const MECHANISM_BODY_COST: usize = 30;

/// The partitions of `bodies` bodies on `threads` threads when `mechanisms` (disjoint body
/// ranges, sorted by start) must each stay whole: [`cut`] into [`partition_count`] partitions
/// of the total cost (a free body 1, a mechanism's body [`MECHANISM_BODY_COST`]).
pub fn ranges(bodies: usize, threads: usize, mechanisms: &[Range<usize>]) -> Vec<Range<usize>> {
    let total =
        bodies + mechanisms.iter().map(|m| m.len()).sum::<usize>() * (MECHANISM_BODY_COST - 1);
    cut(bodies, partition_count(total, threads), mechanisms)
}

/// `bodies` bodies cut into (at most) `n` contiguous ranges, no mechanism cut. Without
/// mechanisms: the uniform cuts at `k·c` ([`chunk_size`]). With them, the cuts balance the
/// estimated cost (a free body 1, a mechanism's body [`MECHANISM_BODY_COST`]): cut `k` is the
/// first body where the cost so far reaches `k/n` of the total, moved to the end of a
/// mechanism it falls inside; empty ranges are dropped.
pub fn cut(bodies: usize, n: usize, mechanisms: &[Range<usize>]) -> Vec<Range<usize>> {
    let n = n.max(1);
    if mechanisms.is_empty() {
        let c = chunk_size(bodies, n);
        return (0..n)
            .map(|k| (k * c).min(bodies)..((k + 1) * c).min(bodies))
            .filter(|r| !r.is_empty() || bodies == 0)
            .take(if bodies == 0 { 1 } else { n })
            .collect();
    }
    let mut cost = vec![1usize; bodies];
    for m in mechanisms {
        cost[m.clone()].fill(MECHANISM_BODY_COST);
    }
    let total: usize = cost.iter().sum();
    let mut out = Vec::with_capacity(n);
    let (mut start, mut so_far, mut i) = (0, 0, 0);
    for k in 1..=n {
        let target = total * k / n;
        while i < bodies && so_far < target {
            so_far += cost[i];
            i += 1;
        }
        if let Some(m) = mechanisms.iter().find(|m| m.start < i && i < m.end) {
            so_far += cost[i..m.end].iter().sum::<usize>();
            i = m.end;
        }
        if k == n {
            i = bodies;
        }
        if i > start {
            out.push(start..i);
            start = i;
        }
    }
    if out.is_empty() {
        out.push(0..0);
    }
    out
}

/// The mechanisms lying in `range`, re-based so that their body indices count from
/// `range.start` (the model is shared, not copied).
pub fn rebase(mechanisms: &[Arc<Mechanism>], range: &Range<usize>) -> Vec<Arc<Mechanism>> {
    mechanisms
        .iter()
        .filter(|m| range.start <= m.first_body && m.first_body < range.end)
        .map(|m| {
            debug_assert!(m.first_body + m.body_count <= range.end, "mechanism cut");
            Arc::new(Mechanism {
                first_body: m.first_body - range.start,
                ..Mechanism::clone(m)
            })
        })
        .collect()
}

/// Where body `i` lies: partition index, given the partitions' first bodies (`starts`,
/// increasing, `starts[0] = 0`) or, for uniform partitions, their size.
#[inline]
fn locate(i: usize, uniform: Option<usize>, starts: &[usize]) -> usize {
    match uniform {
        Some(chunk) => i / chunk,
        None => starts.partition_point(|&s| s <= i) - 1,
    }
}

/// One partition.
pub struct Part<'a> {
    /// Global index of its first body.
    pub first: usize,
    pub bodies: Bodies,
    integrator: Box<dyn Integrator + 'a>,
    guard: Guard,
    /// Statistics of each step of the current window (failed bodies in global indices).
    stats: Vec<StepStats>,
    /// The first divergence in the current window (global body index).
    stop: Option<Divergence>,
}

/// The partitions of a batch, and the pool that steps them.
pub struct Partitions<'a> {
    pub parts: Vec<Part<'a>>,
    /// Bodies per partition (the last may have fewer) when the cuts are uniform.
    uniform: Option<usize>,
    /// First body of each partition.
    starts: Vec<usize>,
    len: usize,
    pool: Option<rayon::ThreadPool>,
    /// The contact phase run before every step ([`Partitions::set_contact`]); `None`: nothing
    /// can touch, and the partitions step whole windows on their own.
    contact: Option<ContactPhase>,
}

/// Read access to the partitions' bodies from the pool's threads.
pub struct View<'a> {
    parts: Vec<(&'a Bodies, usize)>,
    uniform: Option<usize>,
    starts: &'a [usize],
    len: usize,
    pool: Option<&'a rayon::ThreadPool>,
}

impl View<'_> {
    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Body `i`: its partition's bodies and its index there.
    #[inline]
    pub fn body(&self, i: usize) -> (&Bodies, usize) {
        let (bodies, first) = self.parts[locate(i, self.uniform, self.starts)];
        (bodies, i - first)
    }

    /// Partition `k`'s bodies.
    pub fn part(&self, k: usize) -> &Bodies {
        self.parts[k].0
    }

    /// Pose of body `i`'s principal frame in the world.
    #[inline]
    pub fn world_from_body(&self, i: usize) -> Isometry3<f64> {
        let (bodies, j) = self.body(i);
        bodies.world_from_body(j)
    }

    /// Whether the partitions are stepped on a pool of several threads. Without one, work
    /// on the batch belongs on the calling thread: a rayon parallel iterator there would run
    /// on rayon's global pool, whose idle workers spin (`sched_yield`) after every task and
    /// took 0.19 s of the two cores' CPU in a 1 s, 10 000-body `--threads 1` run.
    pub fn is_threaded(&self) -> bool {
        self.pool.is_some()
    }

    /// Runs `f` on the pool (or here, with one partition).
    pub fn install<R: Send>(&self, f: impl FnOnce() -> R + Send) -> R {
        match self.pool {
            Some(pool) => pool.install(f),
            None => f(),
        }
    }
}

/// What a window of steps did.
#[derive(Debug, Clone, Copy, Default)]
pub struct Window {
    /// Merged statistics of the steps up to the last good one (the stopping step included).
    pub stats: StepStats,
    /// The earliest divergence (lowest body among those at that step).
    pub stop: Option<Divergence>,
}

impl<'a> Partitions<'a> {
    /// Splits `inits` into `integrators.len()` uniform partitions (each integrator is
    /// initialised on its partition) with one guard each; steps them on a pool of
    /// [`stepping_threads`] threads when that is more than one. No mechanisms.
    pub fn new(
        inits: &[BodyInit],
        integrators: Vec<Box<dyn Integrator + 'a>>,
        threads: usize,
        divergence_energy_ratio: f64,
        stop_on_newton_failure: Option<u32>,
    ) -> anyhow::Result<Self> {
        let chunk = chunk_size(inits.len(), integrators.len());
        let ranges: Vec<Range<usize>> = (0..integrators.len())
            .map(|k| (k * chunk).min(inits.len())..((k + 1) * chunk).min(inits.len()))
            .collect();
        let none = vec![Vec::new(); ranges.len()];
        let mut parts = Self::with_ranges(
            inits,
            &ranges,
            integrators,
            threads,
            &none,
            &Loads::none(),
            divergence_energy_ratio,
            stop_on_newton_failure,
        )?;
        parts.uniform = Some(chunk);
        Ok(parts)
    }

    /// Partitions `ranges` of `inits` (contiguous, covering the batch in order), stepped by
    /// `integrators` (one each, initialised here) on [`stepping_threads`] threads;
    /// `mechanisms[k]` are partition `k`'s
    /// mechanisms re-based to it ([`rebase`]), which its guard watches ([`Guard::watch_mechanisms`],
    /// under `loads`).
    pub fn with_ranges(
        inits: &[BodyInit],
        ranges: &[Range<usize>],
        integrators: Vec<Box<dyn Integrator + 'a>>,
        threads: usize,
        mechanisms: &[Vec<Arc<Mechanism>>],
        loads: &Loads,
        divergence_energy_ratio: f64,
        stop_on_newton_failure: Option<u32>,
    ) -> anyhow::Result<Self> {
        assert_eq!(ranges.len(), integrators.len());
        assert_eq!(ranges.len(), mechanisms.len());
        let parts: Vec<Part<'a>> = integrators
            .into_iter()
            .zip(ranges)
            .zip(mechanisms)
            .map(|((mut integrator, range), mechanisms)| {
                let bodies = Bodies::new(&inits[range.clone()]);
                integrator.init(&bodies);
                let mut guard =
                    Guard::new(&bodies, divergence_energy_ratio, stop_on_newton_failure);
                let part_loads = loads.part(range.clone());
                guard.exempt_loaded_bodies(&part_loads);
                guard.watch_mechanisms(mechanisms, &bodies, &part_loads);
                Part {
                    first: range.start,
                    bodies,
                    integrator,
                    guard,
                    stats: Vec::new(),
                    stop: None,
                }
            })
            .collect();
        let threads = stepping_threads(parts.len(), threads);
        let pool = if threads > 1 {
            Some(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .thread_name(|i| format!("tumble-step-{i}"))
                    .build()?,
            )
        } else {
            None
        };
        Ok(Self {
            starts: parts.iter().map(|p| p.first).collect(),
            parts,
            uniform: None,
            len: inits.len(),
            pool,
            contact: None,
        })
    }

    /// Runs `model`'s contact phase before every step from now on (nothing when the model is
    /// inactive: [`ContactModel::is_active`]); `mechanisms` are the batch's (batch indices),
    /// those with colliders answer contact through their joints ([`crate::sim::contact::robots`]).
    pub fn set_contact(
        &mut self,
        model: ContactModel,
        mechanisms: &[Arc<Mechanism>],
    ) -> anyhow::Result<()> {
        if !model.is_active() {
            self.contact = None;
            return Ok(());
        }
        // Bodies in contact exchange rotational energy with the ground and each other.
        for c in &model.colliders {
            let part = &mut self.parts[locate(c.body, self.uniform, &self.starts)];
            part.guard.exempt_bodies([c.body - part.first]);
            part.guard.exempt_mechanism_of(c.body - part.first);
        }
        let mut robots = Vec::new();
        let mut settings = None;
        for m in mechanisms {
            if !model.colliders.iter().any(|c| m.bodies().contains(&c.body)) {
                continue;
            }
            let k = locate(m.first_body, self.uniform, &self.starts);
            let part = &self.parts[k];
            let local = rebase(
                std::slice::from_ref(m),
                &(part.first..part.first + part.bodies.len()),
            );
            let local = local
                .into_iter()
                .next()
                .ok_or_else(|| anyhow::anyhow!("mechanism {:?} is cut by a partition", m.name))?;
            settings = settings.or(part.integrator.mechanism_settings());
            robots.push(crate::sim::contact::robots::Robot::new(
                local,
                k,
                m.first_body,
            ));
        }
        let settings = match (robots.is_empty(), settings) {
            (_, Some(s)) => s,
            (true, None) => crate::sim::integrators::VariationalSettings::default(),
            (false, None) => {
                anyhow::bail!("mechanisms with colliders need a variational integrator")
            }
        };
        self.contact = Some(ContactPhase::new(model, robots, settings)?);
        Ok(())
    }

    /// Whether a contact phase runs.
    pub fn has_contact(&self) -> bool {
        self.contact.is_some()
    }

    /// Whether body `i` has colliders (contact changes its momenta).
    pub fn collides(&self, i: usize) -> bool {
        self.contact.as_ref().is_some_and(|c| c.collides(i))
    }

    /// The contacts of the last step (empty without contact).
    pub fn contacts(&self) -> &[ContactPoint] {
        self.contact.as_ref().map_or(&[], |c| &c.contacts)
    }

    /// Sweeps of the last step's contact solve (0 without contact).
    pub fn contact_sweeps(&self) -> u32 {
        self.contact.as_ref().map_or(0, |c| c.stats.sweeps)
    }

    /// The energy the contact impulses changed so far, J (≤ 0 up to round-off: contact never
    /// creates energy; `docs/contact.md`).
    pub fn contact_work(&self) -> f64 {
        self.contact.as_ref().map_or(0.0, |c| c.work)
    }

    /// The energy flows of every partition's integrator, summed.
    pub fn energy_flow(&self) -> crate::sim::integrators::EnergyFlow {
        let flow = self
            .parts
            .iter()
            .fold(Default::default(), |a, p| a + p.integrator.energy_flow());
        crate::sim::integrators::EnergyFlow {
            contact_work: self.contact_work(),
            ..flow
        }
    }

    /// The partition holding body `i`.
    #[inline]
    pub fn part_of(&self, i: usize) -> usize {
        locate(i, self.uniform, &self.starts)
    }

    /// Number of bodies.
    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Threads stepping the partitions (1 without a pool: on the calling thread).
    pub fn threads(&self) -> usize {
        self.pool.as_ref().map_or(1, |p| p.current_num_threads())
    }

    /// The step size of the integrators, s.
    pub fn dt(&self) -> f64 {
        self.parts.first().map_or(0.0, |p| p.integrator.dt())
    }

    /// Body `i`: its partition's bodies and its index there.
    #[inline]
    pub fn body(&self, i: usize) -> (&Bodies, usize) {
        let part = &self.parts[self.part_of(i)];
        (&part.bodies, i - part.first)
    }

    /// Pose of body `i`'s principal frame in the world.
    #[inline]
    pub fn world_from_body(&self, i: usize) -> Isometry3<f64> {
        let (bodies, j) = self.body(i);
        bodies.world_from_body(j)
    }

    /// The joint coordinates carried for the mechanism whose first body is `first_body`
    /// (global index), written to `out` ([`Integrator::joint_coordinates`]); `false` when its
    /// partition's integrator carries none.
    pub fn joint_coordinates(&self, first_body: usize, out: &mut [f64]) -> bool {
        let part = &self.parts[self.part_of(first_body)];
        part.integrator
            .joint_coordinates(first_body - part.first, out)
    }

    /// The bodies, shareable between threads.
    pub fn view(&self) -> View<'_> {
        View {
            parts: self.parts.iter().map(|p| (&p.bodies, p.first)).collect(),
            uniform: self.uniform,
            starts: &self.starts,
            len: self.len,
            pool: self.pool.as_ref(),
        }
    }

    /// Steps every partition from step `from + 1` to step `to` (each stops at its first
    /// divergence) and merges what they report.
    pub fn advance(&mut self, from: u64, to: u64, loads: &Loads) -> Window {
        if self.contact.is_some() {
            return self.advance_in_contact(from, to, loads);
        }
        for part in &mut self.parts {
            part.stats.clear();
            part.stop = None;
        }
        self.step_parts(from, to, loads);
        self.window(from, to)
    }

    /// [`Partitions::advance`] with contact: step by step, the contact phase over the whole
    /// batch (on this thread, in one order, its independent parts on the pool: the same bits for
    /// every thread count), then every partition's step.
    fn advance_in_contact(&mut self, from: u64, to: u64, loads: &Loads) -> Window {
        for part in &mut self.parts {
            part.stats.clear();
            part.stop = None;
        }
        let dt = self.dt();
        let alpha = self
            .parts
            .first()
            .map_or(0.5, |p| p.integrator.gravity_drift());
        for step in from + 1..=to {
            let mut contact = self.contact.take().expect("contact phase");
            {
                let mut bodies: Vec<&mut Bodies> =
                    self.parts.iter_mut().map(|p| &mut p.bodies).collect();
                let mut step_loads = loads.clone();
                step_loads.set_time((step - 1) as f64 * dt);
                contact.start(
                    &mut bodies,
                    &self.starts,
                    dt,
                    &step_loads,
                    alpha,
                    self.pool.as_ref(),
                );
            }
            self.step_parts(step - 1, step, loads);
            {
                let mut bodies: Vec<&mut Bodies> =
                    self.parts.iter_mut().map(|p| &mut p.bodies).collect();
                contact.end(&mut bodies, &self.starts, self.pool.as_ref());
            }
            self.contact = Some(contact);
            if self.parts.iter().any(|p| p.stop.is_some()) {
                break;
            }
        }
        self.window(from, to)
    }

    /// Steps every partition from step `from + 1` to step `to`, each stopping at its first
    /// divergence, appending to its statistics.
    fn step_parts(&mut self, from: u64, to: u64, loads: &Loads) {
        let step_part = |part: &mut Part<'_>| {
            if part.stop.is_some() {
                return;
            }
            // The partition's own view of the loads (its bodies re-based), its time set per
            // step: `t_k = (k − 1) dt` at the start of step `k`, a product, not a running sum.
            let mut part_loads = loads.part(part.first..part.first + part.bodies.len());
            let dt = part.integrator.dt();
            for step in from + 1..=to {
                part_loads.set_time((step - 1) as f64 * dt);
                let (local, any_suspect) =
                    part.integrator
                        .step_watched(&mut part.bodies, &part_loads, part.guard.watch());
                let mut global = local;
                global.failed_body = local.failed_body.map(|b| b + part.first);
                part.stats.push(global);
                if let Some(d) = part
                    .guard
                    .check_flagged(&part.bodies, &local, step, any_suspect)
                {
                    part.stop = Some(Divergence {
                        body: d.body + part.first,
                        ..d
                    });
                    break;
                }
            }
        };
        match &self.pool {
            Some(pool) => pool.install(|| {
                // One task per partition, so that a free thread can take any of them.
                self.parts
                    .par_iter_mut()
                    .with_max_len(1)
                    .for_each(step_part)
            }),
            None => self.parts.iter_mut().for_each(step_part),
        }
    }

    /// What the window `from + 1 ..= to` did: the earliest divergence, the statistics up to it.
    fn window(&self, from: u64, to: u64) -> Window {
        let stop = self
            .parts
            .iter()
            .filter_map(|p| p.stop)
            .min_by_key(|d| (d.step, d.body));
        let last = stop.map_or(to, |d| d.step);
        let stats = self
            .parts
            .iter()
            .flat_map(|p| p.stats.iter().take((last - from) as usize))
            .fold(StepStats::default(), |a, s| a.merge(*s));
        Window { stats, stop }
    }

    /// Σ over the bodies in index order of `f(bodies, j)` (the order one batch would sum in).
    pub fn sum(&self, f: impl Fn(&Bodies, usize) -> f64) -> f64 {
        let mut total = 0.0;
        for part in &self.parts {
            for j in 0..part.bodies.len() {
                total += f(&part.bodies, j);
            }
        }
        total
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::IntegratorKind;
    use crate::sim::workload::free_body_batch;

    #[test]
    fn partition_counts_respect_the_minimum_size() {
        assert_eq!(partition_count(10, 8), 1);
        assert_eq!(partition_count(256, 2), 1);
        assert_eq!(partition_count(257, 2), 2);
        assert_eq!(partition_count(600, 2), 3);
        assert_eq!(partition_count(10_000, 2), 2 * PARTITIONS_PER_THREAD);
        assert_eq!(partition_count(100_000, 3), 3 * PARTITIONS_PER_THREAD);
        assert_eq!(partition_count(10_000, 1), 1);
        assert_eq!(partition_count(10_000, 0), 1);
        assert_eq!(partition_count(0, 4), 1);
        // No more threads than partitions, at least one.
        assert_eq!(stepping_threads(16, 2), 2);
        assert_eq!(stepping_threads(3, 8), 3);
        assert_eq!(stepping_threads(1, 2), 1);
        assert_eq!(stepping_threads(0, 2), 1);
        assert_eq!(stepping_threads(5, 0), 1);
    }

    /// Without mechanisms the ranges are the uniform `k·c` cuts; with them no cut falls inside a
    /// mechanism, the ranges cover the batch in order, and the costs are balanced to within one
    /// mechanism's cost.
    #[test]
    fn ranges_cut_between_mechanisms_and_balance_the_cost() {
        assert_eq!(cut(1000, 2, &[]), vec![0..500, 500..1000]);
        assert_eq!(cut(1003, 3, &[]), vec![0..335, 335..670, 670..1003]);
        assert_eq!(
            ranges(1000, 2, &[]),
            vec![0..250, 250..500, 500..750, 750..1000]
        );
        assert_eq!(ranges(1000, 1, &[]), vec![0..1000]);
        assert_eq!(ranges(100, 4, &[]), vec![0..100]);
        assert_eq!(ranges(0, 4, &[]), vec![0..0]);
        // 40 double pendulums, 200 free bodies, 20 three-link chains.
        let mut mechanisms: Vec<Range<usize>> = (0..40).map(|k| 2 * k..2 * k + 2).collect();
        mechanisms.extend((0..20).map(|k| 280 + 3 * k..283 + 3 * k));
        let cost = |r: &Range<usize>| -> usize {
            r.clone()
                .map(|i| {
                    if mechanisms.iter().any(|m| m.contains(&i)) {
                        MECHANISM_BODY_COST
                    } else {
                        1
                    }
                })
                .sum()
        };
        for threads in 1..=5 {
            let r = cut(340, threads, &mechanisms);
            assert_eq!(r.len(), threads, "{threads}: {r:?}");
            assert_eq!(r[0].start, 0);
            assert_eq!(r.last().unwrap().end, 340);
            for w in r.windows(2) {
                assert_eq!(w[0].end, w[1].start);
            }
            for cut in r.iter().map(|r| r.start) {
                assert!(
                    !mechanisms.iter().any(|m| m.start < cut && cut < m.end),
                    "{threads}: cut {cut} inside a mechanism"
                );
            }
            let total = cost(&(0..340));
            for part in &r {
                let c = cost(part) as f64;
                let ideal = total as f64 / threads as f64;
                // Off by less than one three-link chain's cost (90) plus a body: the cut
                // moves to the end of the mechanism it falls in. Measured 0 to 70 here.
                assert!(
                    (c - ideal).abs() <= 3.0 * MECHANISM_BODY_COST as f64 + 1.0,
                    "{threads}: {part:?} costs {c}, ideal {ideal}"
                );
            }
        }
        // One mechanism bigger than a share: it stays whole, the rest after it.
        let whole = |r: Range<usize>| vec![r];
        assert_eq!(cut(600, 2, &whole(0..500)), vec![0..500, 500..600]);
        assert_eq!(cut(600, 2, &whole(100..600)), vec![0..600]);
        // The partition count of a batch with mechanisms follows its total cost: 340 bodies
        // costing 40·2·30 + 200 + 20·3·30 = 4400, on 2 threads 16 partitions.
        assert_eq!(ranges(340, 2, &mechanisms).len(), 2 * PARTITIONS_PER_THREAD);
        assert_eq!(ranges(340, 1, &mechanisms), vec![0..340]);
        // 17 pendulums alone cost 34·30 = 1020: 4 partitions of at least 256 (not 5).
        let pendulums: Vec<Range<usize>> = (0..17).map(|k| 2 * k..2 * k + 2).collect();
        assert_eq!(ranges(34, 8, &pendulums).len(), 4);
    }

    /// The cut is the first body at which the cost so far reaches the share: a pendulum (2
    /// bodies, 60) then 598 free bodies, 658 in all, halves at body 271 (60 + 269 = 329).
    #[test]
    fn a_cut_falls_on_the_first_body_reaching_the_share() {
        let pendulum: Vec<Range<usize>> = std::iter::once(0..2).collect();
        assert_eq!(cut(600, 2, &pendulum), vec![0..271, 271..600]);
    }

    /// Records the thread each step ran on.
    struct ThreadLog(std::sync::Arc<std::sync::Mutex<Vec<String>>>);

    impl Integrator for ThreadLog {
        fn name(&self) -> &'static str {
            "thread-log"
        }
        fn init(&mut self, _bodies: &Bodies) {}
        fn step(&mut self, _bodies: &mut Bodies, _loads: &Loads) -> StepStats {
            let name = std::thread::current().name().unwrap_or("").to_owned();
            self.0.lock().unwrap().push(name);
            StepStats::default()
        }
        fn dt(&self) -> f64 {
            0.001
        }
    }

    /// Several partitions step on the pool's threads; one steps on the caller's thread (no
    /// pool is made for it).
    #[test]
    fn partitions_step_on_the_pool_and_one_on_the_caller() {
        let inits = free_body_batch(600);
        let g = Loads::none();
        for parts in [1, 2] {
            let log = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
            let integrators: Vec<Box<dyn Integrator>> = (0..parts)
                .map(|_| Box::new(ThreadLog(log.clone())) as Box<dyn Integrator>)
                .collect();
            let mut batch = Partitions::new(&inits, integrators, parts, f64::MAX, None).unwrap();
            batch.advance(0, 3, &g);
            let names = log.lock().unwrap().clone();
            assert_eq!(names.len(), 3 * parts);
            let on_pool = names
                .iter()
                .filter(|n| n.starts_with("tumble-step-"))
                .count();
            assert_eq!(on_pool, if parts == 1 { 0 } else { 3 * parts }, "{names:?}");
        }
    }

    /// A partition whose step is slow: the other thread steps all the others (work stealing),
    /// and the pool has as many threads as asked, not one per partition.
    #[test]
    fn a_free_thread_takes_the_partitions_a_slow_one_leaves() {
        struct Slow(
            std::sync::Arc<std::sync::Mutex<Vec<(usize, String)>>>,
            usize,
        );
        impl Integrator for Slow {
            fn name(&self) -> &'static str {
                "slow"
            }
            fn init(&mut self, _bodies: &Bodies) {}
            fn step(&mut self, _bodies: &mut Bodies, _loads: &Loads) -> StepStats {
                if self.1 == 0 {
                    std::thread::sleep(std::time::Duration::from_millis(200));
                }
                let name = std::thread::current().name().unwrap_or("").to_owned();
                self.0.lock().unwrap().push((self.1, name));
                StepStats::default()
            }
            fn dt(&self) -> f64 {
                0.001
            }
        }
        let inits = free_body_batch(2048);
        let log = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
        let integrators: Vec<Box<dyn Integrator>> = (0..8)
            .map(|k| Box::new(Slow(log.clone(), k)) as Box<dyn Integrator>)
            .collect();
        let mut batch = Partitions::new(&inits, integrators, 2, f64::MAX, None).unwrap();
        assert_eq!(batch.parts.len(), 8);
        batch.advance(0, 1, &Loads::none());
        let log = log.lock().unwrap().clone();
        assert_eq!(log.len(), 8);
        let slow = &log.iter().find(|(k, _)| *k == 0).unwrap().1;
        let threads: std::collections::BTreeSet<&String> = log.iter().map(|(_, n)| n).collect();
        assert_eq!(threads.len(), 2, "{log:?}");
        assert!(threads.iter().all(|n| n.starts_with("tumble-step-")));
        // The slow thread stepped partition 0 alone; the other seven went to the free one.
        assert_eq!(log.iter().filter(|(_, n)| n == slow).count(), 1, "{log:?}");
    }

    /// Re-based mechanisms count their bodies from the partition's start and share the model.
    #[test]
    fn rebase_keeps_the_mechanisms_of_a_range() {
        use crate::sim::mechanism::{Base, BodyPose, MechanismModel};
        let model = Arc::new(MechanismModel {
            body_count: 2,
            joints: Vec::new(),
            coordinates: Vec::new(),
            mimics: Vec::new(),
            drives: Vec::new(),
            stops: Vec::new(),
            base: Base::Floating,
            length_scale: 1.0,
        });
        let at = |first_body: usize| {
            Arc::new(Mechanism {
                name: format!("m{first_body}"),
                first_body,
                world_pose: BodyPose::identity(),
                shared: Arc::clone(&model),
            })
        };
        let all = vec![at(0), at(2), at(7), at(9)];
        let local = rebase(&all, &(2..9));
        assert_eq!(local.len(), 2);
        assert_eq!((local[0].name.as_str(), local[0].first_body), ("m2", 0));
        assert_eq!((local[1].name.as_str(), local[1].first_body), ("m7", 5));
        assert!(Arc::ptr_eq(&local[1].shared, &model));
        assert!(rebase(&all, &(4..7)).is_empty());
        assert_eq!(rebase(&all, &(9..11))[0].first_body, 0);
    }

    /// Every integrator: 3 partitions step the same bits as one batch (free bodies, per-body
    /// steps), including a remainder partition that is not a multiple of the packs' widths.
    #[test]
    fn partitions_step_the_same_bits_as_one_batch() {
        let inits = free_body_batch(1003);
        let g = Loads::uniform_gravity(nalgebra::Vector3::new(0.0, 0.0, -9.81));
        for &kind in IntegratorKind::ALL {
            let settings = Default::default();
            let one = kind.build(0.002, &settings);
            let mut whole = Partitions::new(&inits, vec![one], 1, 100.0, Some(1024)).unwrap();
            let three: Vec<_> = (0..3).map(|_| kind.build(0.002, &settings)).collect();
            let mut split = Partitions::new(&inits, three, 2, 100.0, Some(1024)).unwrap();
            assert_eq!(split.parts.len(), 3);
            let (a, b) = (whole.advance(0, 25, &g), split.advance(0, 25, &g));
            assert_eq!(a.stats, b.stats, "{}", kind.name());
            assert_eq!(a.stop, b.stop, "{}", kind.name());
            for i in 0..inits.len() {
                let (wb, wj) = whole.body(i);
                let (sb, sj) = split.body(i);
                assert_eq!(
                    wb.world_from_body(wj),
                    sb.world_from_body(sj),
                    "{} {i}",
                    kind.name()
                );
                assert_eq!(
                    wb.angmom_body[wj],
                    sb.angmom_body[sj],
                    "{} {i}",
                    kind.name()
                );
                assert_eq!(
                    wb.linvel_world[wj],
                    sb.linvel_world[sj],
                    "{} {i}",
                    kind.name()
                );
            }
        }
    }
}
