//! Ctrl-C (SIGINT) and SIGTERM end long work at a clean boundary instead of killing the process
//! mid-write; a closed output pipe (SIGPIPE) ends the process quietly, as for any Unix filter.
//!
//! Commands that write long recordings or datasets call [`install`] first (`simulate`, `dataset`):
//! the handlers only set an atomic flag; loops poll [`requested`] at their boundaries (the
//! simulation loop after each step, `tumble dataset` between runs), finish their files and return
//! [`Interrupted`], which `main` maps to the shell convention 128 + signal number (130 for SIGINT,
//! 143 for SIGTERM). A second signal while the first is being handled terminates at once with that
//! status, so a stuck shutdown can always be forced. Other commands keep the default action (the
//! process ends at once; their outputs are written under `.part` names and renamed when complete,
//! so nothing half-written appears under a final name).
//!
//! SIGPIPE: Rust ignores it, so `println!` to a closed pipe (`tumble inspect ... | head -1`)
//! panics. [`restore_sigpipe`] (called by `main` for every command) restores the default action
//! instead: the process ends silently when its reader goes away.

use std::sync::OnceLock;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

static FLAG: AtomicBool = AtomicBool::new(false);
static SIGNAL: AtomicUsize = AtomicUsize::new(0);
static INSTALLED: OnceLock<Result<(), String>> = OnceLock::new();
static PIPE: OnceLock<Result<(), String>> = OnceLock::new();
static ALWAYS: AtomicBool = AtomicBool::new(true);

/// SIGINT's number (2 on every Unix).
pub const SIGINT: i32 = 2;
/// SIGTERM's number (15 on every Unix).
pub const SIGTERM: i32 = 15;

/// Registers the SIGINT/SIGTERM handlers once per process; later calls return the first call's
/// result.
pub fn install() -> anyhow::Result<()> {
    INSTALLED
        .get_or_init(|| register().map_err(|e| e.to_string()))
        .clone()
        .map_err(|e| anyhow::anyhow!("cannot install signal handlers: {e}"))
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
fn register() -> std::io::Result<()> {
    use signal_hook::consts::{SIGINT as INT, SIGTERM as TERM};
    use signal_hook::flag;
    debug_assert_eq!((INT, TERM), (SIGINT, SIGTERM));
    for (signal, status) in [(INT, 128 + INT), (TERM, 128 + TERM)] {
        // Order matters: the shutdown action sees the flag as it was before this delivery.
        flag::register_conditional_shutdown(signal, status, &FLAG)?;
        flag::register(signal, &FLAG)?;
        // The signal number, for the message and the exit status. The handler only stores.
        flag::register_usize(signal, &SIGNAL, signal as usize)?;
    }
    Ok(())
}

#[cfg(not(unix))]
fn register() -> std::io::Result<()> {
    Ok(())
}

/// Has SIGINT or SIGTERM arrived?
pub fn requested() -> bool {
    FLAG.load(Ordering::SeqCst)
}

/// The signal that arrived (2 or 15), or 0 for none.
pub fn signal() -> i32 {
    SIGNAL.load(Ordering::SeqCst) as i32
}

/// Work stopped early by SIGINT/SIGTERM after its files were finished. `main` exits with
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
    /// 128 + signal number (130 for SIGINT, 143 for SIGTERM); 130 when no signal is known.
    pub fn exit_code(&self) -> u8 {
        match self.signal {
            s @ 1..=127 => (128 + s) as u8,
            _ => 130,
        }
    }
}

/// `SIGINT`, `SIGTERM`, or `a stop request`.
pub fn signal_name(signal: i32) -> &'static str {
    match signal {
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
        assert_eq!(i(0).exit_code(), 130);
    }
}
