//! The `tumble` binary run with a time limit: a run still going after the limit is a hang,
//! killed, and the test fails.

use std::io::Read;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Outcome of one run of the binary.
pub struct Limited {
    pub status: Option<i32>,
    pub stdout: String,
    pub stderr: String,
    pub elapsed: Duration,
}

/// Runs `tumble args` in `cwd`, killing it (and failing the test) after `limit`. Both pipes
/// are drained on threads, so that a chatty child cannot block on a full pipe.
pub fn run_limited<S: AsRef<std::ffi::OsStr>>(args: &[S], cwd: &Path, limit: Duration) -> Limited {
    let mut child = Command::new(env!("CARGO_BIN_EXE_tumble"))
        .args(args)
        .current_dir(cwd)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("cannot run tumble");
    let mut out = child.stdout.take().unwrap();
    let mut err = child.stderr.take().unwrap();
    let out = std::thread::spawn(move || {
        let mut s = Vec::new();
        out.read_to_end(&mut s).ok();
        s
    });
    let err = std::thread::spawn(move || {
        let mut s = Vec::new();
        err.read_to_end(&mut s).ok();
        s
    });
    let started = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().expect("wait") {
            break status;
        }
        if started.elapsed() > limit {
            child.kill().ok();
            child.wait().ok();
            let words: Vec<String> = args
                .iter()
                .map(|a| a.as_ref().to_string_lossy().into_owned())
                .collect();
            panic!(
                "tumble {} still running after {limit:?}: a hang",
                words.join(" ")
            );
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    Limited {
        status: status.code(),
        stdout: super::text(&out.join().unwrap()),
        stderr: super::text(&err.join().unwrap()),
        elapsed: started.elapsed(),
    }
}
