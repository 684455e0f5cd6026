//! Parquet part files, written so that the same rows always give the same bytes.
//!
//! Writer settings are fixed here (not parquet-rs defaults that could move between versions
//! unnoticed): zstd level 1 for the trajectories (the small per-run tables are left
//! uncompressed: a compression context per column would cost more than it saves), dictionary encoding for the string columns only, column-chunk
//! statistics, row groups of [`ROW_GROUP_ROWS`] rows, parquet-rs's `created_by` (its version,
//! no time). Nothing in a file depends on the clock, the thread or the machine.
//!
//! A file is written under a hidden name `.<name>.part` in its final folder (readers such as
//! pyarrow skip names starting with `.`, so an interrupted write is never read as data),
//! hashed (SHA-256) as it is written, and renamed onto `<name>` when complete. It is not
//! fsynced: the manifest's checksums, checked by `--resume` and `merge`, catch a file a crash
//! or power cut left incomplete, and that chunk is recomputed.

use anyhow::Context;
use arrow_array::RecordBatch;
use arrow_schema::SchemaRef;
use parquet::arrow::ArrowWriter;
use parquet::basic::{Compression, ZstdLevel};
use parquet::file::properties::{EnabledStatistics, WriterProperties};
use parquet::schema::types::ColumnPath;
use sha2::{Digest, Sha256};
use std::fs::File;
use std::io::{BufWriter, Read, Write};
use std::path::{Path, PathBuf};

/// Rows per row group.
pub const ROW_GROUP_ROWS: usize = 128 * 1024;

/// String columns that are dictionary-encoded (few distinct values).
const DICTIONARY_COLUMNS: &[&str] = &[
    "body",
    "model",
    "integrator",
    "status",
    "link",
    "joint",
    "drive",
    "body_a",
    "body_b",
];

/// The writer properties of every dataset file: zstd level 1 when `compressed`, else none.
pub fn writer_properties(compressed: bool) -> anyhow::Result<WriterProperties> {
    let compression = if compressed {
        Compression::ZSTD(ZstdLevel::try_new(1)?)
    } else {
        Compression::UNCOMPRESSED
    };
    let mut builder = WriterProperties::builder()
        .set_compression(compression)
        .set_dictionary_enabled(false)
        .set_statistics_enabled(EnabledStatistics::Chunk)
        .set_max_row_group_row_count(Some(ROW_GROUP_ROWS));
    for name in DICTIONARY_COLUMNS {
        builder = builder.set_column_dictionary_enabled(ColumnPath::from(*name), true);
    }
    Ok(builder.build())
}

/// A file of the dataset as the manifest lists it.
#[derive(Debug, Clone, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct FileInfo {
    /// Path relative to the dataset folder, `/`-separated.
    pub name: String,
    /// Data rows (0 for recordings).
    pub rows: u64,
    pub bytes: u64,
    /// Lower-case hex SHA-256 of the file's bytes.
    pub sha256: String,
}

/// `dir/name` written under `dir/<parent of name>/.<file name>.part`.
pub fn hidden_part_path(path: &Path) -> PathBuf {
    let name = path.file_name().unwrap_or_default().to_string_lossy();
    path.with_file_name(format!(".{name}.part"))
}

/// Counts and hashes every byte on its way to the file.
struct HashingWriter {
    inner: BufWriter<File>,
    hasher: Sha256,
    bytes: u64,
}

impl Write for HashingWriter {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.hasher.update(&buf[..n]);
        self.bytes += n as u64;
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

/// One Parquet file being written.
pub struct PartWriter {
    writer: Option<ArrowWriter<HashingWriter>>,
    part: PathBuf,
    path: PathBuf,
    name: String,
    rows: u64,
}

impl PartWriter {
    /// Starts `dir/name` (`name` relative, `/`-separated; its folder is created), zstd-compressed
    /// when `compressed`.
    pub fn create(
        dir: &Path,
        name: &str,
        schema: SchemaRef,
        compressed: bool,
    ) -> anyhow::Result<Self> {
        let path = dir.join(name);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent)
                .with_context(|| format!("cannot create {}", parent.display()))?;
        }
        let part = hidden_part_path(&path);
        let file = crate::fsutil::create_part_named(&path, &part)?;
        let sink = HashingWriter {
            inner: BufWriter::with_capacity(1 << 20, file),
            hasher: Sha256::new(),
            bytes: 0,
        };
        let writer = ArrowWriter::try_new(sink, schema, Some(writer_properties(compressed)?))
            .with_context(|| format!("cannot start {}", part.display()))?;
        Ok(Self {
            writer: Some(writer),
            part,
            path,
            name: name.to_string(),
            rows: 0,
        })
    }

    pub fn write(&mut self, batch: &RecordBatch) -> anyhow::Result<()> {
        if let Some(w) = self.writer.as_mut() {
            w.write(batch)
                .with_context(|| format!("cannot write {}", self.part.display()))?;
            self.rows += batch.num_rows() as u64;
        }
        Ok(())
    }

    /// Writes the footer, renames onto the final name; returns what the manifest lists.
    pub fn finish(mut self) -> anyhow::Result<FileInfo> {
        let writer = self.writer.take().context("file already finished")?;
        let context = || format!("cannot finish {}", self.part.display());
        let mut sink = writer.into_inner().with_context(context)?;
        sink.flush().with_context(context)?;
        let HashingWriter {
            inner,
            hasher,
            bytes,
        } = sink;
        let file = inner
            .into_inner()
            .map_err(|e| e.into_error())
            .with_context(context)?;
        // No fsync per file: durability comes from the manifest's checksums instead, which
        // `--resume` checks (a file lost to a crash or power cut is recomputed). An fsync per part
        // file would serialize the workers on the file system.
        drop(file);
        crate::fsutil::publish(&[&self.path])?;
        Ok(FileInfo {
            name: self.name.clone(),
            rows: self.rows,
            bytes,
            sha256: hex(&hasher.finalize()),
        })
    }
}

impl Drop for PartWriter {
    /// An unfinished file (error, interruption) leaves nothing behind.
    fn drop(&mut self) {
        if self.writer.take().is_some() {
            crate::fsutil::discard(&[&self.path]);
        }
    }
}

/// Writes one batch as the whole file `dir/name`, uncompressed (the small tables).
pub fn write_file(dir: &Path, name: &str, batch: &RecordBatch) -> anyhow::Result<FileInfo> {
    let mut w = PartWriter::create(dir, name, batch.schema(), false)?;
    w.write(batch)?;
    w.finish()
}

/// Size and SHA-256 of an existing file.
pub fn file_digest(path: &Path) -> anyhow::Result<(u64, String)> {
    let mut file = File::open(path).with_context(|| format!("cannot open {}", path.display()))?;
    let mut hasher = Sha256::new();
    let mut buf = vec![0u8; 1 << 20];
    let mut bytes = 0u64;
    loop {
        let n = file
            .read(&mut buf)
            .with_context(|| format!("cannot read {}", path.display()))?;
        if n == 0 {
            break;
        }
        hasher.update(&buf[..n]);
        bytes += n as u64;
    }
    Ok((bytes, hex(&hasher.finalize())))
}

/// Lower-case hex.
pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Size and SHA-256 of a finished recording, as a manifest entry (`rows` = 0).
pub fn recording_info(dir: &Path, name: &str) -> anyhow::Result<FileInfo> {
    let (bytes, sha256) = file_digest(&dir.join(name))?;
    Ok(FileInfo {
        name: name.to_string(),
        rows: 0,
        bytes,
        sha256,
    })
}

/// Closes a Parquet table streamed into its `.part` file `part` (a sink's writer): the footer,
/// the buffer, the write-back, then `fsync`; every error names the file.
pub fn close_streamed(
    writer: ArrowWriter<BufWriter<crate::record::writeback::WritebackFile>>,
    part: &Path,
) -> anyhow::Result<()> {
    let file = writer
        .into_inner()
        .with_context(|| format!("cannot finish {}", part.display()))?
        .into_inner()
        .map_err(|e| e.into_error())
        .with_context(|| format!("cannot write {}", part.display()))?
        .finish()
        .with_context(|| format!("cannot sync {}", part.display()))?;
    file.sync_all()
        .with_context(|| format!("cannot sync {}", part.display()))
}
