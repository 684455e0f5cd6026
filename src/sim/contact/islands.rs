//! The islands of a contact solve, side by side on the stepping threads.
//!
//! [`super::solve::solve`] groups its rows into islands: rows joined by the bodies they move (a
//! robot's bodies are one). Islands share no body, and an island's solve reads and writes its
//! own rows and bodies only, so the islands can be solved in any order, or at once, with the
//! same bits. Here consecutive islands are cut into batches of about equal row counts
//! ([`BATCHES_PER_THREAD`] per thread, taken by whichever thread is free); each batch gets its
//! own copy of its bodies' responses, renumbered in the ascending order of their batch indices
//! (every ordering by body inside an island's solve, the polish's islands and their roots, is
//! then the same), and its robots' groups (moved, not copied); the batches are solved on the
//! pool, island by island as the serial loop does, and their results written back. The
//! recordings are byte-identical for every thread count
//! (`islands_solved_side_by_side_step_the_same_bits` in `tests/mechanism/contact_robots.rs`).

use super::solve::{Responses, Row, SolveStats, solve_island};
use rayon::prelude::*;
use std::ops::Range;

/// Fewest rows for which the islands are solved on the pool: below it the copies and the
/// threads' meeting cost more than the solve (a few microseconds).
pub const MIN_ROWS_ON_POOL: usize = 256;

/// Batches per stepping thread (as the partitions: a free thread takes the next batch, so a
/// slow core does not hold the other up).
pub const BATCHES_PER_THREAD: usize = 8;

/// A run of consecutive islands, with its own copy of the bodies they move.
struct Batch<'a> {
    rows: &'a mut [Row],
    /// Its islands, as ranges of `rows`.
    islands: Vec<Range<usize>>,
    /// The batch index of each local body, ascending.
    global: Vec<usize>,
    /// The batch index of each local group.
    group_global: Vec<usize>,
    local: Responses,
    /// Per local body, the local index of its island seed ([`super::solve::solve`]).
    seeds: Vec<usize>,
    stats: SolveStats,
}

/// Solves the islands `islands` (consecutive ranges covering `rows`) on `pool`: the same
/// results, bit for bit, as [`solve_island`] on each in turn.
pub fn solve_on_pool(
    rows: &mut [Row],
    islands: &[Range<usize>],
    bodies: &mut Responses,
    seeds: &[usize],
    rel_tol: f64,
    max_sweeps: u32,
    pool: &rayon::ThreadPool,
) -> SolveStats {
    let batch_count = (pool.current_num_threads() * BATCHES_PER_THREAD).max(1);
    let target_rows = rows.len().div_ceil(batch_count).max(1);
    let mut batches: Vec<Batch> = Vec::with_capacity(batch_count + 1);
    // The islands are consecutive from row 0: each batch's rows are the head of the rest.
    let mut rest: &mut [Row] = rows;
    let mut k = 0;
    while k < islands.len() {
        // Consecutive islands until the batch holds `target_rows` rows (at least one island).
        let first = k;
        let start = islands[first].start;
        let mut end = start;
        while k < islands.len() && end - start < target_rows {
            end = islands[k].end;
            k += 1;
        }
        let (head, tail) = std::mem::take(&mut rest).split_at_mut(end - start);
        rest = tail;
        batches.push(gather(
            head,
            islands[first..k]
                .iter()
                .map(|r| r.start - start..r.end - start)
                .collect(),
            bodies,
            seeds,
        ));
    }
    pool.install(|| {
        batches.par_iter_mut().with_max_len(1).for_each(|batch| {
            let mut stats = SolveStats {
                sweeps: 0,
                converged: true,
            };
            for island in &batch.islands {
                let s = solve_island(
                    &mut batch.rows[island.clone()],
                    &mut batch.local,
                    &batch.seeds,
                    rel_tol,
                    max_sweeps,
                );
                stats.sweeps = stats.sweeps.max(s.sweeps);
                stats.converged &= s.converged;
            }
            batch.stats = stats;
        })
    });
    let mut stats = SolveStats {
        sweeps: 0,
        converged: true,
    };
    for batch in batches {
        stats.sweeps = stats.sweeps.max(batch.stats.sweeps);
        stats.converged &= batch.stats.converged;
        scatter(batch, bodies);
    }
    stats
}

/// The batch of `rows` (its islands `islands`): its bodies (the rows' and their seeds),
/// copied and renumbered; its groups moved out of `bodies`; the rows' bodies renumbered.
fn gather<'a>(
    rows: &'a mut [Row],
    islands: Vec<Range<usize>>,
    bodies: &mut Responses,
    seeds: &[usize],
) -> Batch<'a> {
    let mut global: Vec<usize> = Vec::with_capacity(4 * rows.len());
    for row in rows.iter() {
        for body in std::iter::once(row.a).chain(row.b) {
            global.push(body);
            global.push(seeds[body]);
        }
    }
    global.sort_unstable();
    global.dedup();
    let local = |body: usize| global.binary_search(&body).expect("a batch body");
    let mut group_global: Vec<usize> = global
        .iter()
        .filter_map(|&i| bodies.bodies[i].member.map(|(g, _)| g))
        .collect();
    group_global.sort_unstable();
    group_global.dedup();
    let local_bodies = global
        .iter()
        .map(|&i| {
            let mut r = bodies.bodies[i];
            r.member = r.member.map(|(g, m)| {
                let lg = group_global.binary_search(&g).expect("a batch group");
                (lg, m)
            });
            r
        })
        .collect();
    let local_groups = group_global
        .iter()
        .map(|&g| std::mem::take(&mut bodies.groups[g]))
        .collect();
    let local_seeds = global.iter().map(|&i| local(seeds[i])).collect();
    for row in rows.iter_mut() {
        row.a = local(row.a);
        row.b = row.b.map(local);
    }
    Batch {
        rows,
        islands,
        local: Responses {
            bodies: local_bodies,
            groups: local_groups,
        },
        seeds: local_seeds,
        global,
        group_global,
        stats: SolveStats::default(),
    }
}

/// Writes a solved batch back: its bodies' responses, its groups, its rows' body indices.
fn scatter(mut batch: Batch, bodies: &mut Responses) {
    for (l, &i) in batch.global.iter().enumerate() {
        let member = bodies.bodies[i].member;
        bodies.bodies[i] = batch.local.bodies[l];
        bodies.bodies[i].member = member;
    }
    for (lg, &g) in batch.group_global.iter().enumerate() {
        bodies.groups[g] = std::mem::take(&mut batch.local.groups[lg]);
    }
    for row in batch.rows.iter_mut() {
        row.a = batch.global[row.a];
        row.b = row.b.map(|b| batch.global[b]);
    }
}
