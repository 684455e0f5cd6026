//! `tumble dataset SPEC.toml --out DIR [--threads N] [--shard k/N] [--resume | --force]` and
//! `tumble dataset merge SHARD_DIR... --out DIR`.

use crate::dataset::{self, DatasetSpec, Options, Shard};
use clap::Subcommand;
use std::path::PathBuf;

const AFTER_HELP: &str = "\
Examples:
  tumble dataset models/dataset.toml --out logs/dataset              all cores
  tumble dataset models/dataset.toml --out logs/dataset --resume     finish an interrupted run
  tumble dataset models/dataset.toml --out shard1 --shard 1/2        on machine 1 (and 2/2 on machine 2)
  tumble dataset merge shard1 shard2 --out logs/dataset              join the shards

The last line of a generation is a summary:
  runs=<n> chunks=<n> rows=<n> threads=<n> wall_secs=<s> runs_per_sec=<r> body_steps_per_sec=<r>";

/// `tumble dataset`: a spec and an output folder, or the `merge` subcommand.
#[derive(clap::Args, Debug, Clone, Default)]
#[command(
    args_conflicts_with_subcommands = true,
    subcommand_negates_reqs = true,
    after_help = AFTER_HELP
)]
pub struct DatasetArgs {
    #[command(subcommand)]
    pub command: Option<DatasetCommand>,
    /// The dataset spec (TOML): a [scene] template, [vary] distributions, [dataset] runs and
    /// seed (see models/dataset.toml).
    #[arg(required = true, value_name = "SPEC.toml")]
    pub spec: Option<PathBuf>,
    /// Output folder (manifest.json, bodies.parquet, trajectories/, runs/, recordings/).
    #[arg(long, required = true, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Worker threads (default: all cores). The output does not depend on it.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..=4096))]
    pub threads: Option<u64>,
    /// Compute only shard k of N: the chunks c with c mod N = k - 1. Join the N folders with
    /// `tumble dataset merge`.
    #[arg(long, value_name = "k/N")]
    pub shard: Option<Shard>,
    /// Complete the dataset in --out: check the files listed in its manifest (recomputing
    /// corrupted ones) and compute the rest. Without a manifest there, start afresh.
    #[arg(long, conflicts_with = "force")]
    pub resume: bool,
    /// Replace the dataset files in --out.
    #[arg(long)]
    pub force: bool,
    /// Output format: `parquet` (the native tables only) or `lerobot` (the native tables, and
    /// the runs as a LeRobot v3.0 dataset in the same folder: meta/ and data/; docs/datasets.md).
    #[arg(long, value_enum, default_value_t = Format::Parquet)]
    pub format: Format,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
    /// Run even when the estimated output exceeds 64 GiB or the computing time 7 days (the
    /// estimate is checked before anything runs).
    #[arg(long)]
    pub allow_huge: bool,
    /// Refuse the URDF oddities urdfdom loads instead of loading them with a warning; sets
    /// strict = true on the template's [[scene.model]] (docs/urdf.md).
    #[arg(long)]
    pub strict: bool,
    /// Also read mesh files from DIR (repeatable). By default a mesh is read only when its real
    /// path (links resolved) is inside the URDF's folder (its parent for a folder named urdf, or
    /// the ROS package holding it), a package path, ROS_PACKAGE_PATH or the scene's folder; any
    /// other is refused (exit 2). Adds to the template's [[scene.model]] allow_mesh_paths.
    #[arg(long = "allow-mesh-path", value_name = "DIR")]
    pub allow_mesh_paths: Vec<PathBuf>,
}

/// `--format`.
#[derive(clap::ValueEnum, Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Format {
    /// The native Parquet tables.
    #[default]
    Parquet,
    /// The native tables and a LeRobot v3.0 dataset (meta/, data/).
    Lerobot,
}

#[derive(Subcommand, Debug, Clone)]
pub enum DatasetCommand {
    /// Check shard folders (same spec, seed, version; no overlap; every chunk present; every
    /// checksum) and join them into one dataset.
    Merge(MergeArgs),
}

#[derive(clap::Args, Debug, Clone)]
pub struct MergeArgs {
    /// Shard folders (or their manifest.json).
    #[arg(required = true, value_name = "SHARD_DIR")]
    pub inputs: Vec<PathBuf>,
    /// The joined dataset's folder.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Replace a dataset in --out.
    #[arg(long)]
    pub force: bool,
}

pub fn run(args: &DatasetArgs) -> anyhow::Result<()> {
    if let Some(DatasetCommand::Merge(m)) = &args.command {
        let s = dataset::merge(&m.inputs, &m.out, m.force)?;
        println!(
            "merged {} folders: {} chunks, {} runs, {} files ({:.1} MB) into {}",
            s.inputs,
            s.chunks,
            s.runs,
            s.files,
            s.bytes as f64 / 1e6,
            m.out.display()
        );
        return Ok(());
    }
    let (Some(spec_path), Some(out)) = (&args.spec, &args.out) else {
        anyhow::bail!("usage: tumble dataset SPEC.toml --out DIR (see --help)");
    };
    if args.format == Format::Lerobot && args.shard.is_some() {
        anyhow::bail!(
            "--format lerobot with --shard: a shard holds only part of the runs; join the shards \
             with `tumble dataset merge`, then `tumble convert MERGED_DIR --lerobot OUT_DIR`"
        );
    }
    let mut spec = DatasetSpec::load(spec_path)?;
    if args.strict {
        spec.template.set_strict();
    }
    spec.template.allow_mesh_paths(&args.allow_mesh_paths)?;
    // Ctrl-C / SIGTERM: finish the chunks in flight, write the manifest, exit 130 / 143.
    crate::interrupt::install()?;
    let opts = Options {
        out: out.clone(),
        threads: args.threads.map(|n| n as usize),
        shard: args.shard,
        resume: args.resume,
        force: args.force,
        progress: !args.quiet,
        stop_after_chunks: None,
        allow_huge: args.allow_huge,
        raise_sigint_after_chunks: std::env::var("TUMBLE_TEST_SIGINT_AFTER_CHUNKS")
            .ok()
            .and_then(|v| v.parse().ok()),
    };
    let s = dataset::generate(&spec, &opts)?;
    let lerobot = if args.format == Format::Lerobot {
        let started = std::time::Instant::now();
        let l = dataset::lerobot::write(&dataset::lerobot::Options {
            native: out.clone(),
            out: out.clone(),
            // Derived from this folder's runs: a previous conversion is always replaced.
            force: true,
            base_dir: Some(spec.template.base_dir.clone()),
            spec_name: spec_path.display().to_string(),
        })?;
        Some((l, started.elapsed().as_secs_f64()))
    } else {
        None
    };
    if s.runs_skipped > 0 || s.chunks_redone > 0 {
        println!(
            "resumed: {} runs ({} chunks) were complete and checked; {} chunks recomputed",
            s.runs_skipped, s.chunks_skipped, s.chunks_redone
        );
    }
    if s.diverged > 0 {
        eprintln!(
            "warning: {} of {} runs were stopped by the divergence guard (runs table: status = \"diverged\")",
            s.diverged, s.runs_done
        );
    }
    println!(
        "wrote {} runs ({} rows) to {}{}",
        s.runs_done,
        s.rows,
        out.display(),
        args.shard
            .map(|k| format!(" (shard {k})"))
            .unwrap_or_default()
    );
    if let Some((l, secs)) = &lerobot {
        println!("{}", lerobot_line(l, out, *secs));
    }
    // With --format lerobot the figures include the LeRobot writing.
    let secs = (s.wall_secs + lerobot.as_ref().map_or(0.0, |(_, t)| *t)).max(1e-9);
    println!(
        "runs={} chunks={} rows={} threads={} wall_secs={:.3} runs_per_sec={:.1} body_steps_per_sec={:.4e}",
        s.runs_done,
        s.chunks_done,
        s.rows,
        s.threads,
        secs,
        s.runs_done as f64 / secs,
        s.body_steps as f64 / secs
    );
    Ok(())
}

/// The line saying what `--format lerobot` (or `convert --lerobot`) wrote.
pub fn lerobot_line(l: &dataset::lerobot::Summary, out: &std::path::Path, secs: f64) -> String {
    format!(
        "wrote LeRobot v3.0 dataset {}: {} episodes, {} frames at {} fps, {} data file(s){} in {secs:.3} s",
        out.display(),
        l.episodes,
        l.frames,
        l.fps,
        l.data_files,
        match l.diverged_left_out {
            0 => String::new(),
            n => format!(" ({n} diverged runs left out)"),
        }
    )
}
