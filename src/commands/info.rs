//! `tumble info LOG.mcap`: bodies, span, step size, integrator and settings, tool version,
//! message counts, and whether the file is complete or truncated ([`crate::replay::info`]).
//! Exit 0 for a complete file, 1 for a truncated or damaged one (its readable part is still
//! reported), 2 when the file cannot be read at all.

use crate::replay::info;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct InfoArgs {
    /// An MCAP file.
    pub mcap: PathBuf,
    /// Print the report as JSON (keys as in the text; see `tumble::replay::info::RecordingInfo`).
    #[arg(long)]
    pub json: bool,
    /// List every frame, body, articulated model and joint (the text report shows the first
    /// 20 of each and says how many more there are).
    #[arg(long)]
    pub all: bool,
}

/// Prints the report; `Ok(false)` when the file is truncated.
pub fn run(args: &InfoArgs) -> anyhow::Result<bool> {
    let report = info::info(&args.mcap)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        let limit = (!args.all).then_some(info::TEXT_LIST_LIMIT);
        print!("{}", info::text_with(&report, limit));
    }
    if let Some(t) = &report.truncation {
        eprintln!("warning: {t}");
    }
    Ok(report.complete)
}
