//! Completing an MCAP file written by the mcap crate's writer (the ROS 2 recordings) or by
//! tumble's own ([`super::writer`]): the chunk size both use, the flush and sync.

use crate::record::writeback::WritebackFile;
use anyhow::Context;
use std::io::BufWriter;
use std::path::Path;

/// The mcap writer of a recording file: buffered, its bytes handed to the disk's writeback as
/// they are written ([`WritebackFile`]).
pub type McapFileWriter = mcap::Writer<BufWriter<WritebackFile>>;

/// Target chunk size, bytes (the mcap writer closes a chunk once it is this big). Small enough
/// that a file cut short (a killed process, a full disk) loses little: every complete chunk is
/// readable (`tumble convert`, `tumble info`); large enough that zstd still compresses well.
pub const CHUNK_BYTES: u64 = 64 * 1024;

/// Flushes `buffered`, the writer of the file `part`, and syncs the file.
pub fn sync_file(buffered: BufWriter<WritebackFile>, part: &Path) -> anyhow::Result<()> {
    let file = buffered
        .into_inner()
        .map_err(|e| e.into_error())
        .with_context(|| format!("cannot write {}", part.display()))?
        .finish()
        .with_context(|| format!("cannot sync {}", part.display()))?;
    file.sync_all()
        .with_context(|| format!("cannot sync {}", part.display()))
}

/// Ends an MCAP file written under `part` (summary, indexes, footer), flushes and syncs it; it
/// stays under `part` (the caller renames it). Shared by the MCAP sinks of the mcap crate's
/// writer (the ROS 2 files).
pub fn complete_file(mut writer: McapFileWriter, part: &Path) -> anyhow::Result<()> {
    writer
        .finish()
        .with_context(|| format!("cannot finish {}", part.display()))?;
    sync_file(writer.into_inner(), part)
}

/// [`complete_file`], then publishes `part` onto `path` ([`crate::fsutil::publish`]).
pub fn finish_file(writer: McapFileWriter, part: &Path, path: &Path) -> anyhow::Result<()> {
    complete_file(writer, part)?;
    crate::fsutil::publish(&[path])
}
