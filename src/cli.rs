//! Command-line definitions (clap). Each command's arguments live beside its code in
//! [`crate::commands`].

use crate::commands::{
    bench::BenchArgs, convert::ConvertArgs, diff::DiffArgs, info::InfoArgs, inspect::InspectArgs,
    simulate::SimulateArgs, stability::StabilityArgs, survey::SurveyArgs, trade::TradeArgs,
};
use clap::{Parser, Subcommand};

#[derive(Parser, Debug)]
#[command(
    name = "tumble",
    version,
    about = "URDF links as free rigid bodies: variational integration, MCAP and Rerun recordings"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Print every link's mass, centre of mass and inertia, validated, and the model's totals.
    Inspect(InspectArgs),
    /// Simulate a scene (or a URDF) and write STEM.mcap and STEM.rrd.
    Simulate(Box<SimulateArgs>),
    /// Measure the speed/accuracy trade of every integrator on a scene: table, CSV, JSON,
    /// work-precision and energy plots, and a side-by-side recording.
    Trade(TradeArgs),
    /// Time N bodies stepped K steps (no recording); prints `ns_per_body_step=<median>` last.
    Bench(BenchArgs),
    /// Map where each integrator is accurate, substeps, fails or diverges against the rotation
    /// per step h|Ω|, the inertia ratio and the spin axis; writes stability.csv and .png.
    Stability(StabilityArgs),
    /// Load every URDF under folders and tabulate which load and how healthy their inertial data are.
    Survey(SurveyArgs),
    /// What an MCAP recording holds: bodies, span, step size, integrator, settings, tool
    /// version, message counts, complete or truncated.
    Info(InfoArgs),
    /// Compare two recordings frame by frame over time (position and orientation error).
    Diff(DiffArgs),
    /// Replay a tumble MCAP recording into a Rerun .rrd (same entities as a fresh run); or, with
    /// --lerobot, a dataset folder into a LeRobot v3.0 dataset.
    Convert(ConvertArgs),
    /// Generate a randomized trajectory dataset (Parquet) from a spec, in parallel, resumable, shardable; or merge shards.
    Dataset(crate::commands::dataset::DatasetArgs),
}
