//! Trajectory datasets at scale: `tumble dataset SPEC.toml --out DIR` runs a scene template many
//! times with randomized parameters and writes Parquet tables, a manifest and optional per-run
//! recordings.
//!
//! Flow: [`spec`] parses the TOML (template, `[vary]` distributions, run count, master seed);
//! run `i` draws its parameters from `crate::scene::placement::rng` streams seeded by (seed, i) alone ([`sample`]);
//! runs are grouped into chunks of `runs_per_file`, each simulated by one thread in run order
//! ([`chunk`]) into Parquet part files ([`crate::record::parquet`], the runs table [`runs`]);
//! [`generate`] runs the chunks in parallel, resumes and stops cleanly, keeping [`manifest`] up
//! to date; [`shard`] splits the chunks among machines and [`merge`] joins their folders.
//!
//! Folder layout:
//!
//! ```text
//! DIR/manifest.json                      spec, tool version, seed, per-file size and SHA-256
//! DIR/bodies.parquet                     mass properties of each model choice's bodies
//! DIR/trajectories/part-NNNNN.parquet    one row per recorded step and body
//! DIR/joints/part-NNNNN.parquet         one row per recorded step and joint (articulated models)
//! DIR/runs/part-NNNNN.parquet            one row per run: drawn parameters and outcome
//! DIR/recordings/run-NNNNNN.{mcap,rrd}   optional, the first `record_runs` runs
//! DIR/meta/, DIR/data/                   `--format lerobot`: the runs as a LeRobot v3.0 dataset ([`lerobot`])
//! ```

pub mod chunk;
pub mod generate;
pub mod joint_vary;
pub mod lerobot;
pub mod manifest;
pub mod merge;
pub mod runs;
pub mod sample;
pub mod shard;
pub mod spec;

pub use generate::{Options, Summary, generate};
pub use manifest::Manifest;
pub use merge::merge;
pub use shard::Shard;
pub use spec::DatasetSpec;
