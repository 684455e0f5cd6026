//! `tumble dataset SPEC --out DIR`: every chunk of the spec (of this shard) computed in
//! parallel, streamed to disk, listed in the manifest as it completes.
//!
//! - **Parallel, bounded**: a rayon pool of `threads` workers takes chunks in increasing order
//!   from a shared counter; each worker simulates its chunk's runs one after the other and
//!   streams their rows into the chunk's Parquet file (row groups of
//!   [`crate::record::parquet::files::ROW_GROUP_ROWS`]). Memory is `threads` × one chunk's row
//!   group and runs table, whatever the run count.
//! - **Deterministic**: a chunk's files depend on (spec, chunk index) only; the manifest lists
//!   chunks sorted; so any thread count, order or shard split gives the same bytes.
//! - **Interruption** (SIGINT/SIGTERM, [`crate::interrupt`]): no new chunk is started; chunks in
//!   flight are finished and listed (a chunk is the atomic unit: a second signal ends the process
//!   at once, and its unfinished hidden `.part` files are deleted by the next `--resume`). The
//!   manifest is written and [`crate::interrupt::Interrupted`] returned.
//! - **Resume** (`--resume`): the manifest must come from the same spec text, tool version, seed,
//!   shard and URDF files; every listed file is checked (size, SHA-256); a chunk whose file is
//!   missing, truncated or corrupted is recomputed (with a warning naming the file), complete
//!   ones are skipped. `--resume` on a folder without a manifest starts afresh, so a scheduler
//!   can always pass it.

use super::chunk::{ChunkStats, Context, run_chunk};
use super::manifest::{FORMAT, MANIFEST, Manifest, sha256_hex, verify_file};
use super::sample::ModelCache;
use super::shard::Shard;
use super::spec::DatasetSpec;
use crate::interrupt;
use crate::record::parquet::files::{file_digest, write_file};
use crate::record::parquet::tables::bodies_batch;
use anyhow::{Context as _, bail};
use indicatif::{ProgressBar, ProgressStyle};
use std::collections::BTreeMap;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::{Duration, Instant};

/// The outputs a dataset folder may hold (what `--force` removes).
pub const OUTPUTS: &[&str] = &[
    MANIFEST,
    "bodies.parquet",
    "trajectories",
    "joints",
    "runs",
    "recordings",
    // `--format lerobot` ([`super::lerobot`]).
    "meta",
    "data",
];

/// `--force`: removes every dataset output ([`OUTPUTS`]) from `dir`, files and folders.
pub fn remove_outputs(dir: &Path) -> anyhow::Result<()> {
    for name in OUTPUTS {
        let path = dir.join(name);
        if path.is_dir() {
            std::fs::remove_dir_all(&path)
        } else if path.exists() {
            std::fs::remove_file(&path)
        } else {
            Ok(())
        }
        .with_context(|| format!("--force: cannot remove {}", path.display()))?;
    }
    Ok(())
}

/// The manifest is rewritten at most this often while chunks complete (and always at the end).
const MANIFEST_INTERVAL: Duration = Duration::from_millis(500);

/// How to generate.
#[derive(Debug, Clone, Default)]
pub struct Options {
    pub out: PathBuf,
    /// Worker threads; `None`: all cores.
    pub threads: Option<usize>,
    pub shard: Option<Shard>,
    pub resume: bool,
    pub force: bool,
    /// Draw a progress bar on stderr (only when it is a terminal).
    pub progress: bool,
    /// Stop as if interrupted once this many chunks completed in this call (tests of resume;
    /// it affects this call only, unlike a signal).
    pub stop_after_chunks: Option<u64>,
    /// Lift the size and time limits of [`crate::budget`] (`--allow-huge`).
    pub allow_huge: bool,
    /// Tests only: send SIGINT to this process once this many chunks completed in this call
    /// (`tumble dataset` reads it from the environment variable
    /// `TUMBLE_TEST_SIGINT_AFTER_CHUNKS`). The signal takes the real path (handler, flag, clean
    /// stop, exit 130) at a known chunk, where a signal sent by a test from outside would race
    /// the run's end.
    pub raise_sigint_after_chunks: Option<u64>,
}

/// Parquet bytes per trajectory row, for the up-front estimate (measured about 60 with zstd;
/// rounded up).
const BYTES_PER_ROW: f64 = 100.0;

/// Refuses an absurd dataset before any work ([`crate::budget`]): the cost of up to 256 runs
/// drawn evenly across the run range, scaled to all runs.
fn check_budget(spec: &DatasetSpec, cache: &ModelCache, allow_huge: bool) -> anyhow::Result<()> {
    let sampled = spec.runs.clamp(1, 256);
    let (mut body_steps, mut rows, mut bodies_max, mut steps_max) = (0.0, 0.0, 0.0f64, 0.0f64);
    for k in 0..sampled {
        let run = (k as u128 * spec.runs as u128 / sampled as u128) as u64;
        let params = super::sample::draw(spec, run);
        let bodies = cache.worlds[params.model].bodies.len() as f64;
        let steps = params.steps() as f64;
        body_steps += bodies * steps;
        rows += bodies
            * crate::budget::recorded_steps(steps, spec.template.sim.log_every.max(1) as f64);
        bodies_max = bodies_max.max(bodies);
        steps_max = steps_max.max(steps);
    }
    let scale = spec.runs as f64 / sampled as f64;
    crate::budget::Estimate {
        bodies: bodies_max,
        steps: steps_max,
        recorded_steps: rows * scale,
        output_bytes: rows * scale * BYTES_PER_ROW,
        memory_bytes: bodies_max * crate::budget::BYTES_PER_BODY,
        compute_secs: body_steps * scale * crate::budget::NS_PER_BODY_STEP * 1e-9,
    }
    .check(allow_huge)
    .with_context(|| {
        format!(
            "{}: {} runs (estimated from {sampled} of them; the figures below are per run for \
             steps and bodies, for the whole dataset otherwise)",
            spec.path.display(),
            spec.runs
        )
    })
}

/// What a call did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Summary {
    /// Runs this folder is meant to hold (this shard's).
    pub runs_total: u64,
    /// Runs computed by this call.
    pub runs_done: u64,
    /// Runs found complete (`--resume`) and skipped.
    pub runs_skipped: u64,
    pub chunks_done: u64,
    pub chunks_skipped: u64,
    /// Listed chunks whose files failed the check and were recomputed.
    pub chunks_redone: u64,
    pub rows: u64,
    pub body_steps: u64,
    pub diverged: u64,
    pub threads: usize,
    pub wall_secs: f64,
}

/// Generates (or completes) the dataset of `spec` in `opts.out`.
pub fn generate(spec: &DatasetSpec, opts: &Options) -> anyhow::Result<Summary> {
    let started = Instant::now();
    let threads = opts
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    if threads == 0 {
        bail!("--threads must be at least 1");
    }
    let cache = ModelCache::load(spec)?;
    for warning in cache.worlds.iter().flat_map(|w| &w.warnings) {
        eprintln!("warning: {warning}");
    }
    check_budget(spec, &cache, opts.allow_huge)?;
    let dir = opts.out.as_path();
    let fresh = new_manifest(spec, opts.shard)?;
    let mut summary = Summary {
        threads,
        ..Default::default()
    };
    let (mut manifest, _folder) = prepare(dir, fresh, opts, &mut summary)?;
    let layouts: Vec<_> = cache.worlds.iter().map(|w| &w.layout).collect();
    manifest.bodies = write_file(
        dir,
        "bodies.parquet",
        &bodies_batch(spec.model_choices(), &layouts)?,
    )?;
    let owned: Vec<u64> = (0..spec.chunks())
        .filter(|&c| opts.shard.is_none_or(|s| s.owns(c)))
        .collect();
    let done: std::collections::HashSet<u64> =
        manifest.chunks_done.iter().map(|c| c.chunk).collect();
    let todo: Vec<u64> = owned
        .iter()
        .copied()
        .filter(|c| !done.contains(c))
        .collect();
    summary.runs_total = owned.iter().map(|&c| runs_in(spec, c)).sum();
    summary.chunks_skipped = (owned.len() - todo.len()) as u64;
    summary.runs_skipped = summary.runs_total - todo.iter().map(|&c| runs_in(spec, c)).sum::<u64>();
    manifest.complete = todo.is_empty();
    manifest.save(dir)?;

    let bar = progress_bar(opts.progress, summary.runs_total, summary.runs_skipped);
    let ctx = Context::new(spec, &cache, dir);
    let next = AtomicUsize::new(0);
    let stop = AtomicBool::new(false);
    let interrupted = AtomicBool::new(false);
    // Chunks abandoned because a run inside them was interrupted.
    let discarded = AtomicUsize::new(0);
    let failure: Mutex<Option<anyhow::Error>> = Mutex::new(None);
    struct Shared {
        manifest: Manifest,
        stats: ChunkStats,
        chunks: u64,
        saved: Instant,
    }
    let shared = Mutex::new(Shared {
        manifest,
        stats: ChunkStats::default(),
        chunks: 0,
        saved: Instant::now(),
    });
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(|i| format!("tumble-dataset-{i}"))
        .build()
        .context("cannot start the worker threads")?;
    let fail = |e: anyhow::Error| {
        stop.store(true, Ordering::SeqCst);
        if e.downcast_ref::<interrupt::Interrupted>().is_some() {
            interrupted.store(true, Ordering::SeqCst);
            discarded.fetch_add(1, Ordering::SeqCst);
        } else {
            failure
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .get_or_insert(e);
        }
    };
    pool.broadcast(|_| {
        loop {
            if interrupt::requested() {
                interrupted.store(true, Ordering::SeqCst);
                return;
            }
            if stop.load(Ordering::SeqCst) {
                return;
            }
            let i = next.fetch_add(1, Ordering::SeqCst);
            let Some(&chunk) = todo.get(i) else { return };
            let (record, stats) = match run_chunk(&ctx, chunk, &|| bar.inc(1)) {
                Ok(done) => done,
                Err(e) => return fail(e),
            };
            let mut s = shared.lock().unwrap_or_else(|p| p.into_inner());
            s.manifest.add_chunk(record);
            s.stats = add_stats(s.stats, stats);
            s.chunks += 1;
            #[cfg(unix)]
            if opts.raise_sigint_after_chunks == Some(s.chunks) {
                // The signal thread (`crate::interrupt`) sets the flag shortly after `raise`
                // returns: wait for it (at most a second), so the next loop turn sees it.
                let _ = signal_hook::low_level::raise(signal_hook::consts::SIGINT);
                let raised = std::time::Instant::now();
                while !crate::interrupt::requested()
                    && raised.elapsed() < std::time::Duration::from_secs(1)
                {
                    std::thread::sleep(std::time::Duration::from_millis(1));
                }
            }
            if opts.stop_after_chunks.is_some_and(|k| s.chunks >= k) {
                stop.store(true, Ordering::SeqCst);
                interrupted.store(true, Ordering::SeqCst);
            }
            if s.saved.elapsed() >= MANIFEST_INTERVAL {
                s.saved = Instant::now();
                if let Err(e) = s.manifest.save(dir) {
                    drop(s);
                    return fail(e);
                }
            }
        }
    });
    bar.finish_and_clear();
    let Shared {
        mut manifest,
        stats,
        chunks,
        ..
    } = shared.into_inner().unwrap_or_else(|p| p.into_inner());
    manifest.complete = owned.len() == manifest.chunks_done.len();
    let saved = manifest.save(dir);
    summary.runs_done = stats.runs;
    summary.rows = stats.rows;
    summary.body_steps = stats.body_steps;
    summary.diverged = stats.diverged;
    summary.chunks_done = chunks;
    summary.wall_secs = started.elapsed().as_secs_f64();
    if let Some(e) = failure.into_inner().unwrap_or_else(|p| p.into_inner()) {
        return Err(e.context(format!(
            "dataset {} stopped; the {} chunks completed are listed in {}",
            dir.display(),
            manifest.chunks_done.len(),
            dir.join(MANIFEST).display()
        )));
    }
    saved?;
    if !manifest.complete && (interrupted.load(Ordering::SeqCst) || interrupt::requested()) {
        let runs_listed = manifest.runs_done();
        return Err(interrupt::Interrupted {
            signal: interrupt::signal(),
            what: format!(
                "dataset stopped with {runs_listed} of {} runs complete",
                summary.runs_total
            ),
            finished: format!(
                "{}; {} chunks (part files) complete and listed in {}; run the same command with \
                 --resume to finish",
                match discarded.load(Ordering::SeqCst) {
                    0 => "the chunks in flight were finished".to_string(),
                    n => format!("{n} chunks in flight were discarded"),
                },
                manifest.chunks_done.len(),
                dir.join(MANIFEST).display()
            ),
        }
        .into());
    }
    Ok(summary)
}

fn runs_in(spec: &DatasetSpec, chunk: u64) -> u64 {
    let r = spec.chunk_runs(chunk);
    r.end - r.start
}

fn add_stats(a: ChunkStats, b: ChunkStats) -> ChunkStats {
    ChunkStats {
        runs: a.runs + b.runs,
        rows: a.rows + b.rows,
        body_steps: a.body_steps + b.body_steps,
        diverged: a.diverged + b.diverged,
    }
}

/// The manifest of a dataset not yet started.
fn new_manifest(spec: &DatasetSpec, shard: Option<Shard>) -> anyhow::Result<Manifest> {
    let mut inputs = BTreeMap::new();
    for urdf in spec.model_choices() {
        let path = spec.template.base_dir.join(urdf);
        let (_, sha) =
            file_digest(&path).with_context(|| format!("{}: model {urdf}", spec.path.display()))?;
        inputs.insert(urdf.clone(), sha);
    }
    Ok(Manifest {
        format: FORMAT.to_string(),
        tool_version: crate::VERSION.to_string(),
        spec_sha256: sha256_hex(&spec.text),
        seed: spec.seed,
        runs: spec.runs,
        runs_per_file: spec.runs_per_file,
        chunks: spec.chunks(),
        shard,
        complete: false,
        inputs,
        bodies: Default::default(),
        chunks_done: Vec::new(),
        spec: spec.text.clone(),
    })
}

/// Checks the output folder against `--resume` / `--force` and returns the manifest to continue
/// from: `fresh`, or the existing one with its checked chunks; and the folder's lock, held for
/// the run ([`crate::fsutil::lock_folder`]: a second run on the folder is refused before it
/// removes or writes anything).
fn prepare(
    dir: &Path,
    fresh: Manifest,
    opts: &Options,
    summary: &mut Summary,
) -> anyhow::Result<(Manifest, crate::fsutil::FolderLock)> {
    let lock = if dir.is_dir() {
        Some(crate::fsutil::lock_folder(dir)?)
    } else {
        None
    };
    let existing = Manifest::load(dir)?;
    if opts.force {
        remove_outputs(dir)?;
    } else if let Some(old) = &existing {
        let same = old.same_dataset(&fresh).and_then(|()| {
            if old.shard == fresh.shard {
                Ok(())
            } else {
                Err("shard")
            }
        });
        match (same, opts.resume) {
            (Ok(()), false) => bail!(
                "{} holds this dataset already ({} of {} runs listed); pass --resume to complete \
                 and check it, or --force to start over",
                dir.display(),
                old.runs_done(),
                old.runs
            ),
            (Err(what), _) => bail!(
                "{} holds a dataset of a different {what} (manifest.json); choose another --out, \
                 or pass --force to replace it",
                dir.display()
            ),
            (Ok(()), true) => {}
        }
    } else if let Some(name) = OUTPUTS[1..].iter().find(|n| dir.join(n).exists()) {
        bail!(
            "{} exists without a manifest.json; pass --force to replace the dataset files there \
             (or choose another --out)",
            dir.join(name).display()
        );
    }
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let lock = match lock {
        Some(lock) => lock,
        None => crate::fsutil::lock_folder(dir)?,
    };
    remove_unfinished(dir)?;
    let Some(mut manifest) = existing.filter(|_| !opts.force) else {
        return Ok((fresh, lock));
    };
    let listed = std::mem::take(&mut manifest.chunks_done);
    for record in listed {
        match record.files.iter().try_for_each(|f| verify_file(dir, f)) {
            Ok(()) => manifest.chunks_done.push(record),
            Err(e) => {
                eprintln!("warning: chunk {}: {e:#}: recomputing it", record.chunk);
                summary.chunks_redone += 1;
            }
        }
    }
    Ok((manifest, lock))
}

/// Deletes the hidden `.part` files an abrupt end (second signal, kill -9, power loss) left.
fn remove_unfinished(dir: &Path) -> anyhow::Result<()> {
    for sub in ["", "trajectories", "joints", "runs", "recordings"] {
        let folder = dir.join(sub);
        let Ok(entries) = std::fs::read_dir(&folder) else {
            continue;
        };
        for entry in entries.flatten() {
            let name = entry.file_name().to_string_lossy().into_owned();
            if name.ends_with(".part") && entry.path().is_file() {
                std::fs::remove_file(entry.path())
                    .with_context(|| format!("cannot remove {}", entry.path().display()))?;
            }
        }
    }
    Ok(())
}

fn progress_bar(enabled: bool, total: u64, position: u64) -> ProgressBar {
    if !enabled || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(total);
    if let Ok(style) = ProgressStyle::with_template(
        "{elapsed_precise} {wide_bar} {human_pos}/{human_len} runs  {rate}  ETA {eta}",
    ) {
        bar.set_style(style.with_key(
            "rate",
            |state: &indicatif::ProgressState, w: &mut dyn std::fmt::Write| {
                write!(w, "{:.0} runs/s", state.per_sec()).ok();
            },
        ));
    }
    bar.set_position(position);
    bar.reset_eta();
    bar
}
