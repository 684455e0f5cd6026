//! SIGINT (Ctrl-C), SIGTERM and SIGHUP (the terminal closed) stop tumble cleanly; a file-size
//! limit (SIGXFSZ) is a write error; a closed output pipe (SIGPIPE) ends the process quietly, as
//! for any Unix filter.
//!
//! `main` calls [`watch`] for every command: a thread of its own (`tumble-signals`) receives
//! SIGINT, SIGTERM, SIGHUP and SIGXFSZ (signal-hook's self-pipe: the handlers only write a byte).
//! What it does with them depends on the phase:
//!
//! - **Before [`install`]** (loading a scene, and every command that does not poll): the
//!   process ends at once with 128 + the signal number (130 SIGINT, 143 SIGTERM, 129 SIGHUP),
//!   after one message and after removing this run's `.part` files
//!   ([`crate::fsutil::abandon`]; a publish in progress is let finish first, so the outputs
//!   are all published or none). A model that takes minutes to load is stopped within
//!   milliseconds.
//! - **After [`install`]** (`simulate`'s stepping, `dataset`'s runs): the first signal only
//!   sets a flag; loops poll [`requested`] at their boundaries (the simulation loop after each
//!   step, `tumble dataset` between runs), finish their files and return [`Interrupted`], which
//!   `main` maps to 128 + the signal number. A second signal while the first is being handled
//!   ends the process at once as above, so a stuck shutdown can always be forced.
//! - **SIGXFSZ** (a write past `ulimit -f`) is caught and otherwise ignored, so the write fails
//!   with `EFBIG` instead of the process being killed (exit 153 with no message and `.part`
//!   files left, before): the run fails like on a full disk, exit 2, its message naming the
//!   file and the limit (`main`), nothing published.
//!
//! SIGPIPE: Rust ignores it, so `println!` to a closed pipe (`tumble inspect ... | head -1`)
//! panics. [`restore_sigpipe`] (called by `main` for every command) restores the default action
//! instead: the process ends silently when its reader goes away.

use std::sync::OnceLock;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

static FLAG: AtomicBool = AtomicBool::new(false);
static SIGNAL: AtomicUsize = AtomicUsize::new(0);
/// Whether signals are polled ([`install`]) rather than acted on at once.
static POLLED: AtomicBool = AtomicBool::new(false);
static WATCHER: OnceLock<Result<(), String>> = OnceLock::new();
static PIPE: OnceLock<Result<(), String>> = OnceLock::new();
static ALWAYS: AtomicBool = AtomicBool::new(true);

/// SIGHUP's number (1 on every Unix).
pub const SIGHUP: i32 = 1;
/// SIGINT's number (2 on every Unix).
pub const SIGINT: i32 = 2;
/// SIGTERM's number (15 on every Unix).
pub const SIGTERM: i32 = 15;
/// SIGXFSZ's number on Linux.
pub const SIGXFSZ: i32 = 25;

/// Starts the signal thread once per process (see the module documentation); later calls
/// return the first call's result.
pub fn watch() -> anyhow::Result<()> {
    WATCHER
        .get_or_init(|| start_watcher().map_err(|e| e.to_string()))
        .clone()
        .map_err(|e| anyhow::anyhow!("cannot install signal handlers: {e}"))
}

/// From now on the first SIGINT/SIGTERM/SIGHUP only sets the flag [`requested`] reads (the
/// caller polls it at clean boundaries); starts the signal thread if [`watch`] has not.
pub fn install() -> anyhow::Result<()> {
    watch()?;
    POLLED.store(true, Ordering::SeqCst);
    Ok(())
}

/// Gives SIGPIPE its default action back (once per process).
pub fn restore_sigpipe() -> anyhow::Result<()> {
    PIPE.get_or_init(|| register_pipe().map_err(|e| e.to_string()))
        .clone()
        .map_err(|e| anyhow::anyhow!("cannot restore SIGPIPE: {e}"))
}

#[cfg(unix)]
fn register_pipe() -> std::io::Result<()> {
    signal_hook::flag::register_conditional_default(signal_hook::consts::SIGPIPE, &ALWAYS)?;
    Ok(())
}

#[cfg(not(unix))]
fn register_pipe() -> std::io::Result<()> {
    Ok(())
}

#[cfg(unix)]
fn start_watcher() -> std::io::Result<()> {
    use signal_hook::consts::{SIGHUP as HUP, SIGINT as INT, SIGTERM as TERM, SIGXFSZ as XFSZ};
    debug_assert_eq!((HUP, INT, TERM, XFSZ), (SIGHUP, SIGINT, SIGTERM, SIGXFSZ));
    let mut signals = signal_hook::iterator::Signals::new([INT, TERM, HUP, XFSZ])?;
    std::thread::Builder::new()
        .name("tumble-signals".into())
        .spawn(move || {
            for signal in signals.forever() {
                if signal != XFSZ {
                    on_signal(signal);
                }
            }
        })?;
    Ok(())
}

#[cfg(not(unix))]
fn start_watcher() -> std::io::Result<()> {
    Ok(())
}

/// What the signal thread does with SIGINT, SIGTERM or SIGHUP (see the module documentation).
fn on_signal(signal: i32) {
    if POLLED.load(Ordering::SeqCst) && !FLAG.load(Ordering::SeqCst) {
        SIGNAL.store(signal as usize, Ordering::SeqCst);
        FLAG.store(true, Ordering::SeqCst);
        return;
    }
    let removed = crate::fsutil::abandon();
    let kept = if removed == 0 {
        String::new()
    } else {
        format!(
            "; {removed} unfinished file{} removed, nothing published",
            if removed == 1 { "" } else { "s" }
        )
    };
    let again = if FLAG.load(Ordering::SeqCst) {
        " again"
    } else {
        ""
    };
    eprintln!("error: stopped by {}{again}{kept}", signal_name(signal));
    std::process::exit(128 + signal);
}

/// Has SIGINT, SIGTERM or SIGHUP arrived (after [`install`])?
pub fn requested() -> bool {
    FLAG.load(Ordering::SeqCst)
}

/// The signal that arrived (1, 2 or 15), or 0 for none.
pub fn signal() -> i32 {
    SIGNAL.load(Ordering::SeqCst) as i32
}

/// Work stopped early by SIGINT/SIGTERM/SIGHUP after its files were finished. `main` exits with
/// [`Interrupted::exit_code`].
#[derive(Debug, Clone, thiserror::Error)]
#[error("{what} (stopped by {}; {finished})", signal_name(*signal))]
pub struct Interrupted {
    /// The signal number (0: stopped by code, e.g. a test's chunk limit).
    pub signal: i32,
    /// What was stopped, e.g. "simulation stopped at step 1200 of 5000 (t = 1.2 s)".
    pub what: String,
    /// What was kept, e.g. "recordings finished: logs/a.mcap, logs/a.rrd".
    pub finished: String,
}

impl Interrupted {
    /// 128 + signal number (130 for SIGINT, 143 for SIGTERM, 129 for SIGHUP); 130 when no
    /// signal is known.
    pub fn exit_code(&self) -> u8 {
        match self.signal {
            s @ 1..=127 => (128 + s) as u8,
            _ => 130,
        }
    }
}

/// `SIGHUP`, `SIGINT`, `SIGTERM`, or `a stop request`.
pub fn signal_name(signal: i32) -> &'static str {
    match signal {
        SIGHUP => "SIGHUP",
        SIGINT => "SIGINT",
        SIGTERM => "SIGTERM",
        _ => "a stop request",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exit_codes_follow_the_shell_convention() {
        let i = |signal| Interrupted {
            signal,
            what: String::new(),
            finished: String::new(),
        };
        assert_eq!(i(SIGINT).exit_code(), 130);
        assert_eq!(i(SIGTERM).exit_code(), 143);
        assert_eq!(i(SIGHUP).exit_code(), 129);
        assert_eq!(i(0).exit_code(), 130);
    }
}
