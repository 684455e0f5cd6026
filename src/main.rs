//! The `tumble` binary: parses arguments, dispatches, and maps results to exit codes.
//! Exit codes: 0 success, 1 the input has problems (`inspect` found invalid links, `info` a
//! truncated file, `diff` runs that differ beyond the tolerance),
//! 2 an error (bad input, unreadable or unwritable files); clap's usage errors also exit 2;
//! 3 a simulation stopped by the divergence guard (its recordings are finished and readable);
//! 130 / 143 / 129 work stopped by SIGINT / SIGTERM / SIGHUP (at a clean boundary with its files
//! finished while stepping; at once, with no file published, before or outside it:
//! `tumble::interrupt`).

use clap::Parser;
use std::process::ExitCode;
use tumble::cli::{Cli, Command};
use tumble::commands;

fn main() -> ExitCode {
    let cli = Cli::parse();
    if let Err(e) = tumble::interrupt::restore_sigpipe() {
        eprintln!("warning: {e:#}");
    }
    if let Err(e) = tumble::interrupt::watch() {
        eprintln!("warning: {e:#}");
    }
    let result = match &cli.command {
        Command::Inspect(args) => commands::inspect::run(args).map(|ok| if ok { 0 } else { 1 }),
        Command::Simulate(args) => commands::simulate::run(args).map(|()| 0),
        Command::Trade(args) => commands::trade::run(args).map(|()| 0),
        Command::Bench(args) => commands::bench::run(args).map(|()| 0),
        Command::Stability(args) => commands::stability::run(args).map(|()| 0),
        Command::Survey(args) => commands::survey::run(args).map(|()| 0),
        Command::Info(args) => commands::info::run(args).map(|ok| if ok { 0 } else { 1 }),
        Command::Diff(args) => commands::diff::run(args).map(|same| if same { 0 } else { 1 }),
        Command::Convert(args) => commands::convert::run(args).map(|ok| if ok { 0 } else { 1 }),
        Command::Dataset(args) => commands::dataset::run(args).map(|()| 0),
    };
    match result {
        Ok(code) => ExitCode::from(code),
        Err(e) => {
            eprintln!(
                "error: {}{}",
                tumble::message::error_text(&e),
                tumble::fsutil::file_size_limit_note(&e)
            );
            if let Some(stop) = e.downcast_ref::<tumble::interrupt::Interrupted>() {
                ExitCode::from(stop.exit_code())
            } else if e.downcast_ref::<tumble::simulation::Diverged>().is_some() {
                ExitCode::from(3)
            } else {
                ExitCode::from(2)
            }
        }
    }
}
