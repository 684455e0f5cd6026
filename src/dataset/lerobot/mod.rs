//! A dataset's runs as a LeRobot v3.0 dataset (`tumble dataset --format lerobot`,
//! `tumble convert DATASET_DIR --lerobot OUT_DIR`), written from the native tables only
//! (`runs/`, `joints/`; `trajectories/` and `bodies.parquet` for a floating base), so it does not
//! depend on how the runs were drawn.
//!
//! Layout written (v3.0, no video):
//!
//! ```text
//! OUT/meta/info.json                              codebase_version "v3.0", fps, features, totals ([`info`])
//! OUT/meta/stats.json                             per feature min/max/mean/std/count/q01..q99 ([`stats`])
//! OUT/meta/tasks.parquet                          one task, pandas index `task`, column `task_index` ([`info`])
//! OUT/meta/episodes/chunk-000/file-000.parquet    one row per episode ([`episodes`])
//! OUT/data/chunk-CCC/file-FFF.parquet             one row per frame ([`frames`])
//! ```
//!
//! Mapping (one episode per run, [`source`]): the frames are the recorded joints-table rows on
//! the regular grid (`step % log_every == 0`; an off-grid last row is dropped), so
//! `fps = 1 / (dt · log_every)`, which must be the same integer for every run. Runs the
//! divergence guard stopped (`status = "diverged"`) are left out; episodes are numbered
//! 0.. in run order and the episodes table's `tumble/run` column gives each one's run.
//! A floating base adds the root link frame's pose and velocity, from its body's rows in
//! `trajectories/` and `bodies.parquet` ([`info`] lists the features).
//!
//! Sources of the format facts (huggingface/lerobot, read at commit 7427f31 and in the PyPI
//! release 0.4.4, the version `LeRobotDataset` was checked with):
//! - <https://github.com/huggingface/lerobot/blob/main/src/lerobot/datasets/utils.py>: paths
//!   (`data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet`, `meta/episodes/...`,
//!   `meta/tasks.parquet`, `meta/stats.json`), `DEFAULT_CHUNK_SIZE = 1000`,
//!   `DEFAULT_DATA_FILE_SIZE_IN_MB = 100`, `DEFAULT_VIDEO_FILE_SIZE_IN_MB = 200`, `DatasetInfo`
//!   (`fps: int`), `get_hf_features_from_features` (shape `[1]` → a scalar column, `[n]` → a
//!   fixed-size list).
//! - `src/lerobot/utils/constants.py`: `DEFAULT_FEATURES` (`timestamp` float32, `frame_index`,
//!   `episode_index`, `index`, `task_index` int64, shape `[1]`, names null).
//! - `src/lerobot/datasets/dataset_metadata.py`: `save_episode` / `_save_episode_metadata`
//!   (episode columns, `dataset_from_index` / `dataset_to_index`, `splits = {"train": "0:N"}`).
//! - `src/lerobot/datasets/compute_stats.py`: per-episode stats (`get_feature_stats`, quantiles
//!   q01 q10 q50 q90 q99, population std) and their aggregation (`aggregate_stats`).
//! - `src/lerobot/datasets/io_utils.py`: `load_tasks` (pandas `read_parquet`, index `task`),
//!   `load_episodes` (every `meta/episodes/*/*.parquet`), `load_nested_dataset`
//!   (`data/*/*.parquet`, so other folders beside `data/` and `meta/` are ignored).

pub mod episodes;
pub mod frames;
pub mod info;
pub mod source;
pub mod stats;

use anyhow::{Context, bail};
use std::path::PathBuf;

/// The folders a LeRobot dataset adds to its folder (what `--force` removes).
pub const OUTPUTS: &[&str] = &["meta", "data"];

/// The hidden folder the LeRobot files are written in before they take their final names.
const STAGING: &str = ".lerobot.part";

/// What to convert.
#[derive(Debug, Clone)]
pub struct Options {
    /// The native dataset folder (manifest.json, runs/, joints/).
    pub native: PathBuf,
    /// Where `meta/` and `data/` go (may be `native`).
    pub out: PathBuf,
    /// Replace `meta/` and `data/` in `out`.
    pub force: bool,
    /// Where the spec's relative URDF paths are resolved from (the spec's folder), to read the
    /// robot name; `None`: the current folder.
    pub base_dir: Option<PathBuf>,
    /// How messages name the spec ("models/arm_dataset.toml", or the manifest's path).
    pub spec_name: String,
}

/// What was written.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Summary {
    pub episodes: u64,
    pub frames: u64,
    /// Runs left out because the divergence guard stopped them.
    pub diverged_left_out: u64,
    pub fps: u32,
    pub data_files: u64,
}

/// Converts the native dataset in `opts.native` into a LeRobot v3.0 dataset in `opts.out`.
///
/// Everything is written under `out/.lerobot.part/` first; only when every file is complete are
/// the previous `meta/` and `data/` removed and the new ones renamed into place. On error the
/// staging folder is removed and `out` is left as it was.
pub fn write(opts: &Options) -> anyhow::Result<Summary> {
    let out = opts.out.as_path();
    if !opts.force
        && let Some(name) = OUTPUTS.iter().find(|n| out.join(n).exists())
    {
        bail!(
            "{} exists; pass --force to replace the LeRobot dataset there",
            out.join(name).display()
        );
    }
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let staging = out.join(STAGING);
    if staging.exists() {
        std::fs::remove_dir_all(&staging)
            .with_context(|| format!("cannot remove {}", staging.display()))?;
    }
    let result = source::Source::open(opts).and_then(|src| frames::write_all(&src, &staging));
    let summary = match result {
        Ok(s) => s,
        Err(e) => {
            let _ = std::fs::remove_dir_all(&staging);
            return Err(e);
        }
    };
    for name in OUTPUTS {
        let path = out.join(name);
        if path.exists() {
            std::fs::remove_dir_all(&path)
                .with_context(|| format!("--force: cannot remove {}", path.display()))?;
        }
    }
    for name in OUTPUTS {
        std::fs::rename(staging.join(name), out.join(name))
            .with_context(|| format!("cannot move the new {name}/ into {}", out.display()))?;
    }
    let _ = std::fs::remove_dir_all(&staging);
    Ok(summary)
}
