//! Files appear whole or not at all: everything is written under `<path>.part` and renamed.

use anyhow::Context;
use std::path::{Path, PathBuf};

/// `<path>.part`.
pub fn part_path(path: &Path) -> PathBuf {
    let mut name = path.as_os_str().to_owned();
    name.push(".part");
    PathBuf::from(name)
}

/// Writes `bytes` to `<path>.part`, then renames it onto `path`. On error the part file is
/// removed and `path` is untouched.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    let part = part_path(path);
    let result = std::fs::write(&part, bytes)
        .with_context(|| format!("cannot write {}", part.display()))
        .and_then(|()| {
            std::fs::rename(&part, path)
                .with_context(|| format!("cannot rename {} to {}", part.display(), path.display()))
        });
    if result.is_err() {
        std::fs::remove_file(&part).ok();
    }
    result
}

/// Refuses to replace an existing file unless `force`: "`path` exists; pass --force to replace
/// it". Every command that writes a named output calls this before doing any work, so a refusal
/// costs nothing and leaves everything as it was.
pub fn check_not_overwriting(path: &Path, force: bool) -> anyhow::Result<()> {
    if !force && path.exists() {
        anyhow::bail!(
            "{} exists; pass --force to replace it (or choose another output)",
            path.display()
        );
    }
    Ok(())
}
