//! `tumble dataset merge SHARD_DIR... --out DIR`: checks shard folders and joins them into one
//! dataset, identical to the one an unsharded run writes.
//!
//! Checks, each failing with an error that names the folder: every input has a manifest of the
//! same dataset (tool version, spec text, seed, run count, chunking, URDF checksums) and the
//! same `bodies.parquet`; no chunk is in two inputs; together they cover every chunk (else the
//! missing chunks are listed with the shard `k/N` that should have made them); every listed file
//! has its size and SHA-256. Files are then hard-linked into `--out` (copied when the folders
//! are on different file systems) and the joined manifest is written (`shard: null`,
//! `complete: true`).

use super::generate::OUTPUTS;
use super::manifest::{MANIFEST, Manifest, verify_file};
use super::shard::shard_of;
use crate::record::parquet::files::{FileInfo, hidden_part_path};
use anyhow::{Context, bail};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// What a merge did.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MergeSummary {
    pub inputs: usize,
    pub chunks: u64,
    pub runs: u64,
    pub files: usize,
    pub bytes: u64,
}

/// A shard folder, or its `manifest.json`.
fn folder(input: &Path) -> PathBuf {
    if input.is_file() {
        input.parent().map(Path::to_path_buf).unwrap_or_default()
    } else {
        input.to_path_buf()
    }
}

/// Merges the datasets in `inputs` into `out`.
pub fn merge(inputs: &[PathBuf], out: &Path, force: bool) -> anyhow::Result<MergeSummary> {
    if inputs.is_empty() {
        bail!("merge: no input folders");
    }
    let dirs: Vec<PathBuf> = inputs.iter().map(|p| folder(p)).collect();
    let mut manifests = Vec::with_capacity(dirs.len());
    for dir in &dirs {
        let manifest = Manifest::load(dir)?
            .with_context(|| format!("{}: no {MANIFEST}: not a dataset folder", dir.display()))?;
        manifests.push(manifest);
    }
    let first = &manifests[0];
    for (dir, m) in dirs.iter().zip(&manifests).skip(1) {
        if let Err(what) = first.same_dataset(m) {
            bail!(
                "{} and {} are not shards of the same dataset: their {what} differ",
                dirs[0].display(),
                dir.display()
            );
        }
        if m.bodies.sha256 != first.bodies.sha256 {
            bail!(
                "{} and {}: bodies.parquet differs",
                dirs[0].display(),
                dir.display()
            );
        }
    }
    let out_abs = std::path::absolute(out).unwrap_or_else(|_| out.to_path_buf());
    for dir in &dirs {
        if std::path::absolute(dir).unwrap_or_else(|_| dir.clone()) == out_abs {
            bail!(
                "--out {} is one of the inputs: merge into a new folder",
                out.display()
            );
        }
    }
    // Which input holds each chunk.
    let mut owner: BTreeMap<u64, usize> = BTreeMap::new();
    for (i, m) in manifests.iter().enumerate() {
        for c in &m.chunks_done {
            if let Some(&j) = owner.get(&c.chunk) {
                bail!(
                    "chunk {} (runs {}..{}) is in both {} and {}: the inputs overlap",
                    c.chunk,
                    c.runs[0],
                    c.runs[1],
                    dirs[j].display(),
                    dirs[i].display()
                );
            }
            owner.insert(c.chunk, i);
        }
    }
    let missing: Vec<u64> = (0..first.chunks)
        .filter(|c| !owner.contains_key(c))
        .collect();
    if !missing.is_empty() {
        let shards: Vec<_> = manifests.iter().filter_map(|m| m.shard).collect();
        let hint = match shards.first() {
            Some(s) => {
                let mut which: Vec<String> = missing
                    .iter()
                    .map(|&c| shard_of(c, s.count).to_string())
                    .collect();
                which.dedup();
                which.sort();
                which.dedup();
                format!(" (they belong to shard {})", which.join(", "))
            }
            None => String::new(),
        };
        let listed: Vec<String> = missing.iter().take(10).map(u64::to_string).collect();
        bail!(
            "the inputs miss {} of {} chunks: {}{}{hint}",
            missing.len(),
            first.chunks,
            listed.join(", "),
            if missing.len() > 10 { ", ..." } else { "" }
        );
    }
    for (dir, m) in dirs.iter().zip(&manifests) {
        verify_file(dir, &m.bodies)?;
        for c in &m.chunks_done {
            for f in &c.files {
                verify_file(dir, f).with_context(|| format!("chunk {}", c.chunk))?;
            }
        }
    }

    // Write.
    if !force && let Some(name) = OUTPUTS.iter().find(|n| out.join(n).exists()) {
        bail!(
            "{} exists; pass --force to replace the dataset in {} (or choose another --out)",
            out.join(name).display(),
            out.display()
        );
    }
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    // Held while merging: a second run into `out` is refused before it removes anything.
    let _folder = crate::fsutil::lock_folder(out)?;
    if force {
        super::generate::remove_outputs(out)?;
    }
    let mut merged = first.clone();
    merged.shard = None;
    merged.chunks_done.clear();
    let mut files = 0;
    let mut bytes = 0;
    place(&dirs[0], out, &first.bodies)?;
    for (i, m) in manifests.iter().enumerate() {
        for c in &m.chunks_done {
            for f in &c.files {
                place(&dirs[i], out, f)?;
                files += 1;
                bytes += f.bytes;
            }
            merged.add_chunk(c.clone());
        }
    }
    merged.complete = true;
    merged.save(out)?;
    Ok(MergeSummary {
        inputs: dirs.len(),
        chunks: merged.chunks_done.len() as u64,
        runs: merged.runs_done(),
        files,
        bytes,
    })
}

/// `from/<file>` to `to/<file>`: a hard link, else a copy (under a hidden `.part` name, renamed).
fn place(from: &Path, to: &Path, file: &FileInfo) -> anyhow::Result<()> {
    let src = from.join(&file.name);
    let dst = to.join(&file.name);
    if let Some(parent) = dst.parent() {
        std::fs::create_dir_all(parent)
            .with_context(|| format!("cannot create {}", parent.display()))?;
    }
    if dst.exists() {
        std::fs::remove_file(&dst).with_context(|| format!("cannot replace {}", dst.display()))?;
    }
    if std::fs::hard_link(&src, &dst).is_ok() {
        return Ok(());
    }
    let part = hidden_part_path(&dst);
    crate::fsutil::create_part_named(&dst, &part)
        .and_then(|mut out| {
            let mut input = std::fs::File::open(&src)?;
            std::io::copy(&mut input, &mut out)?;
            Ok(())
        })
        .with_context(|| format!("cannot copy {} to {}", src.display(), dst.display()))
        .and_then(|()| crate::fsutil::publish(&[&dst]))
        .inspect_err(|_| crate::fsutil::discard(&[&dst]))
}
