//! What real viewers need from tumble's recordings (issue 13): Foxglove's reader refuses any MCAP
//! chunk whose chunk index lists no message indexes, so every MCAP tumble writes (simulate, trade,
//! dataset) is checked chunk by chunk with the Python `mcap` reader and the mcap crate.

mod common;

use common::{run_py, text, tumble};
use std::path::{Path, PathBuf};

/// A scene with the bundled box and arm, long enough to fill several 64 KiB chunks.
fn write_scene(dir: &Path, duration: f64) -> PathBuf {
    let models = common::root().join("models");
    let path = dir.join("scene.toml");
    std::fs::write(
        &path,
        format!(
            "[sim]\ndt = 0.001\nduration = {duration}\nlog_every = 1\n\n\
             [[model]]\nurdf = \"{}\"\nposition = [0, 0, 1]\nangvel = [0.3, 4.0, 0.2]\n\n\
             [[model]]\nurdf = \"{}\"\nname = \"arm\"\nposition = [1, 0, 1]\n",
            models.join("box.urdf").display(),
            models.join("arm.urdf").display()
        ),
    )
    .unwrap();
    path
}

/// Every chunk index of `file` lists at least one message index (Python reader and mcap crate
/// agree on the number of chunks); returns the number of chunks.
fn assert_every_chunk_indexed(py: &serde_json::Value, file: &Path) -> usize {
    let key = file.display().to_string();
    let info = &py["files"][&key];
    let chunks = info["chunks"]
        .as_array()
        .unwrap_or_else(|| panic!("{key}: no summary: {py}"));
    assert!(!chunks.is_empty(), "{key}: no chunk");
    for (i, c) in chunks.iter().enumerate() {
        assert!(
            c["message_indexes"].as_u64().unwrap() > 0,
            "{key}: chunk {i} lists no message indexes (Foxglove refuses the file): {c}"
        );
    }
    let bytes = std::fs::read(file).unwrap();
    let summary = mcap::Summary::read(&bytes).unwrap().expect("summary");
    assert_eq!(summary.chunk_indexes.len(), chunks.len(), "{key}");
    for ci in &summary.chunk_indexes {
        assert!(!ci.message_index_offsets.is_empty(), "{key}: {ci:?}");
    }
    chunks.len()
}

#[test]
fn every_mcap_tumble_writes_has_message_indexes_in_every_chunk() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut files = Vec::new();

    // simulate: one short run (one chunk) and one of several chunks.
    let scene = write_scene(d, 0.01);
    let out = tumble(&["simulate", scene.to_str().unwrap(), "--out", "short"], d);
    assert!(out.status.success(), "{}", text(&out.stderr));
    files.push(d.join("short.mcap"));
    let out = tumble(
        &[
            "simulate",
            scene.to_str().unwrap(),
            "--out",
            "long",
            "--duration",
            "2",
        ],
        d,
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    files.push(d.join("long.mcap"));

    // trade: the side-by-side recording (one topic group per integrator).
    let out = tumble(
        &[
            "trade",
            "--out",
            "trade",
            "--dt",
            "0.01",
            "--duration",
            "0.5",
            "--integrators",
            "variational,rk4",
            "--repeats",
            "1",
        ],
        d,
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    files.push(d.join("trade/trade.mcap"));

    // dataset: per-run recordings.
    let spec = d.join("spec.toml");
    std::fs::write(
        &spec,
        format!(
            "[dataset]\nruns = 2\nseed = 1\nrecord = [\"mcap\"]\nrecord_runs = 2\n\n\
             [scene.sim]\nduration = 0.05\n\n[[scene.model]]\nurdf = \"{}\"\n",
            common::root().join("models/arm.urdf").display()
        ),
    )
    .unwrap();
    let out = tumble(&["dataset", spec.to_str().unwrap(), "--out", "ds", "-q"], d);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let mut dataset_files: Vec<PathBuf> = walk(&d.join("ds"))
        .into_iter()
        .filter(|p| p.extension().is_some_and(|e| e == "mcap"))
        .collect();
    dataset_files.sort();
    assert_eq!(dataset_files.len(), 2, "{dataset_files:?}");
    files.extend(dataset_files);

    let args: Vec<&Path> = files.iter().map(PathBuf::as_path).collect();
    let py = run_py("mcap_chunks.py", &args);
    let chunks: Vec<usize> = files
        .iter()
        .map(|f| assert_every_chunk_indexed(&py, f))
        .collect();
    // Measured: short 1 chunk, long 23 chunks (2001 steps of 5 frames and 5 bodies); before the
    // fix every file's first chunk held only schemas and channels (0 message indexes).
    assert_eq!(chunks[0], 1, "{chunks:?}");
    assert!(chunks[1] >= 10, "{chunks:?}");
}

fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            out.extend(walk(&path));
        } else {
            out.push(path);
        }
    }
    out
}
