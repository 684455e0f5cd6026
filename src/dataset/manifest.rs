//! `manifest.json`: what a dataset folder holds and how it was made.
//!
//! ```json
//! {
//!   "format": "tumble-dataset-1",
//!   "tool_version": "0.1.0",
//!   "spec_sha256": "…", "seed": 42, "runs": 10000, "runs_per_file": 100, "chunks": 100,
//!   "shard": null | {"index": 1, "count": 4},
//!   "complete": true,
//!   "inputs": {"box.urdf": "<sha256>", …},
//!   "bodies": {"name": "bodies.parquet", "rows": 5, "bytes": 2345, "sha256": "…"},
//!   "chunks_done": [
//!     {"chunk": 0, "runs": [0, 100], "files": [
//!        {"name": "trajectories/part-00000.parquet", "rows": 30300, "bytes": …, "sha256": "…"},
//!        {"name": "runs/part-00000.parquet", "rows": 100, …},
//!        {"name": "recordings/run-000000.mcap", "rows": 0, …}]},
//!     …],
//!   "spec": "<the spec file's text>"
//! }
//! ```
//!
//! `chunks_done` is sorted by chunk; nothing in the manifest depends on the thread count, the
//! time or the machine, so a dataset's manifest is as reproducible as its files. It is rewritten
//! atomically (`manifest.json.part`, renamed) as chunks complete and at the end.

use super::shard::Shard;
use crate::record::parquet::files::{FileInfo, file_digest};
use anyhow::Context;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The value of `format`.
pub const FORMAT: &str = "tumble-dataset-1";
/// The manifest's file name in a dataset folder.
pub const MANIFEST: &str = "manifest.json";

#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Manifest {
    pub format: String,
    pub tool_version: String,
    /// SHA-256 of the spec text.
    pub spec_sha256: String,
    pub seed: u64,
    pub runs: u64,
    pub runs_per_file: u64,
    pub chunks: u64,
    pub shard: Option<Shard>,
    /// Every chunk this folder is meant to hold is in `chunks_done`.
    pub complete: bool,
    /// SHA-256 of each URDF the spec names (paths as written in the spec).
    pub inputs: BTreeMap<String, String>,
    pub bodies: FileInfo,
    pub chunks_done: Vec<ChunkRecord>,
    pub spec: String,
}

/// One completed chunk: its runs `[start, end)` and files.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct ChunkRecord {
    pub chunk: u64,
    pub runs: [u64; 2],
    pub files: Vec<FileInfo>,
}

impl Manifest {
    /// Reads `dir/manifest.json`, or `None` when there is none.
    pub fn load(dir: &Path) -> anyhow::Result<Option<Self>> {
        let path = dir.join(MANIFEST);
        if !path.exists() {
            return Ok(None);
        }
        Self::read(&path).map(Some)
    }

    /// Reads a manifest file.
    pub fn read(path: &Path) -> anyhow::Result<Self> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read {}", path.display()))?;
        let manifest: Self = serde_json::from_str(&text)
            .with_context(|| format!("{}: not a tumble dataset manifest", path.display()))?;
        if manifest.format != FORMAT {
            anyhow::bail!(
                "{}: format {:?}, this tumble reads {FORMAT:?}",
                path.display(),
                manifest.format
            );
        }
        Ok(manifest)
    }

    /// Writes `dir/manifest.json` atomically.
    pub fn save(&self, dir: &Path) -> anyhow::Result<()> {
        let mut text = serde_json::to_string_pretty(self)?;
        text.push('\n');
        crate::fsutil::write_atomic(&dir.join(MANIFEST), text.as_bytes())
    }

    /// Adds a completed chunk, keeping `chunks_done` sorted (a chunk already listed is replaced).
    pub fn add_chunk(&mut self, record: ChunkRecord) {
        self.chunks_done.retain(|c| c.chunk != record.chunk);
        let at = self.chunks_done.partition_point(|c| c.chunk < record.chunk);
        self.chunks_done.insert(at, record);
    }

    /// Total runs in `chunks_done`.
    pub fn runs_done(&self) -> u64 {
        self.chunks_done.iter().map(|c| c.runs[1] - c.runs[0]).sum()
    }

    /// The fields that must agree for two manifests to describe the same dataset, with the first
    /// that differs: `Err("spec_sha256")` etc.
    pub fn same_dataset(&self, other: &Self) -> Result<(), &'static str> {
        if self.tool_version != other.tool_version {
            return Err("tool_version");
        }
        if self.spec_sha256 != other.spec_sha256 {
            return Err("spec (spec_sha256)");
        }
        if self.seed != other.seed {
            return Err("seed");
        }
        if (self.runs, self.runs_per_file, self.chunks)
            != (other.runs, other.runs_per_file, other.chunks)
        {
            return Err("runs / runs_per_file");
        }
        if self.inputs != other.inputs {
            return Err("inputs (URDF checksums)");
        }
        Ok(())
    }
}

/// Checks that `dir/<file.name>` exists with the listed size and SHA-256; the error says what
/// differs.
pub fn verify_file(dir: &Path, file: &FileInfo) -> anyhow::Result<()> {
    let path: PathBuf = dir.join(&file.name);
    if !path.is_file() {
        anyhow::bail!("{} is missing", path.display());
    }
    let (bytes, sha) = file_digest(&path)?;
    if bytes != file.bytes {
        anyhow::bail!(
            "{} has {bytes} bytes, the manifest lists {} (truncated or replaced)",
            path.display(),
            file.bytes
        );
    }
    if sha != file.sha256 {
        anyhow::bail!(
            "{}: SHA-256 {sha} differs from the manifest's {} (corrupted or replaced)",
            path.display(),
            file.sha256
        );
    }
    Ok(())
}

/// SHA-256 hex of a string.
pub fn sha256_hex(text: &str) -> String {
    use sha2::Digest;
    crate::record::parquet::files::hex(&sha2::Sha256::digest(text.as_bytes()))
}
