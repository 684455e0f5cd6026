//! Shared helpers of the integration tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;

/// The repository root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The interoperability venv's python (created on first use by `scripts/pyenv.sh`).
/// Panics with a clear message when it cannot be created: these tests never pass silently.
pub fn python() -> PathBuf {
    let out = Command::new("bash")
        .arg(root().join("scripts/pyenv.sh"))
        .output()
        .expect("cannot run bash scripts/pyenv.sh");
    assert!(
        out.status.success(),
        "scripts/pyenv.sh failed (the interoperability tests need Python 3 and PyPI):\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    PathBuf::from(String::from_utf8(out.stdout).unwrap().trim())
}

/// Runs `tests/py/<script>` with the venv's python and parses its JSON output.
pub fn run_py(script: &str, args: &[&Path]) -> serde_json::Value {
    let out = Command::new(python())
        .arg(root().join("tests/py").join(script))
        .args(args)
        .output()
        .expect("cannot run python");
    assert!(
        out.status.success(),
        "{script} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("script output is not JSON")
}

/// A program from the venv's bin folder (e.g. `rerun`).
pub fn venv_bin(name: &str) -> PathBuf {
    python().parent().unwrap().join(name)
}
