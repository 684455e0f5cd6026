//! A recording file whose bytes start going to the disk while it is being written.
//!
//! A run publishes its files only once they are synced (`File::sync_all`, then the rename:
//! `finish_all`), so that a crash or a power cut never leaves half a file under a final name.
//! Left to itself, Linux starts writing a file's dirty pages back only when they are 30 s old or
//! make up 10 % of memory (`vm.dirty_expire_centisecs`, `vm.dirty_background_ratio`): a big
//! recording (the 10 000-body swarm writes 240 MB per simulated second) then sits in the page
//! cache until the final sync, which writes all of it while nothing else runs (measured 0.5 s
//! for 224 MB on this machine's disk).
//!
//! [`WritebackFile`] asks the kernel to start writing back each [`WRITEBACK_BYTES`] the moment
//! it lies [`WRITEBACK_LAG`] behind the end of what was written, with
//! `posix_fadvise(POSIX_FADV_DONTNEED)`: Linux starts an asynchronous writeback of the range
//! (`WB_SYNC_NONE`, `mm/fadvise.c`) and drops the range's pages that are already clean; it
//! does not wait. The disk then works beside the stepping, and the final sync writes only the
//! last few megabytes. The lag keeps the range the writers still seek back into (the mcap
//! crate patches a chunk's header after writing the chunk; chunks hold one message, about 1 MB
//! per 10 000 bodies) in the cache. Seeking back further is still correct (the kernel reads a
//! dropped page back), only slower. The advice changes no byte of the file, and its failure
//! (a file system without it) is ignored: it is a hint.

use std::fs::File;
use std::io::{Seek, SeekFrom, Write};
use std::num::NonZeroU64;

/// Bytes handed to the kernel's writeback at a time.
pub const WRITEBACK_BYTES: u64 = 8 << 20;

/// How far behind the end of the written bytes the writeback stays.
pub const WRITEBACK_LAG: u64 = 32 << 20;

/// A [`File`] written from the start, starting the writeback of what lies well behind its end;
/// see the module doc.
pub struct WritebackFile {
    file: File,
    /// Where the next write goes.
    position: u64,
    /// The end of the bytes written so far.
    end: u64,
    /// Everything before this was handed to the writeback.
    started: u64,
    /// Writeback requests made (for tests).
    requests: u64,
}

impl WritebackFile {
    /// Wraps `file`, positioned at its start (a new, empty file).
    pub fn new(file: File) -> Self {
        Self {
            file,
            position: 0,
            end: 0,
            started: 0,
            requests: 0,
        }
    }

    /// The file.
    pub fn into_inner(self) -> File {
        self.file
    }

    /// The file, for syncing.
    pub fn get_ref(&self) -> &File {
        &self.file
    }

    /// Writeback requests made so far.
    pub fn requests(&self) -> u64 {
        self.requests
    }

    /// Bytes handed to the writeback so far (from the start of the file).
    pub fn started(&self) -> u64 {
        self.started
    }

    /// Hands every whole [`WRITEBACK_BYTES`] lying [`WRITEBACK_LAG`] behind the end to the
    /// writeback.
    fn start_writeback(&mut self) {
        let ready = self.end.saturating_sub(WRITEBACK_LAG);
        while ready - self.started >= WRITEBACK_BYTES {
            // A hint: an error (a file system without fadvise) changes nothing written.
            let _ = rustix::fs::fadvise(
                &self.file,
                self.started,
                NonZeroU64::new(WRITEBACK_BYTES),
                rustix::fs::Advice::DontNeed,
            );
            self.started += WRITEBACK_BYTES;
            self.requests += 1;
        }
    }
}

impl Write for WritebackFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.file.write(buf)?;
        self.position += n as u64;
        if self.position > self.end {
            self.end = self.position;
            self.start_writeback();
        }
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.file.flush()
    }
}

impl Seek for WritebackFile {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        self.position = self.file.seek(pos)?;
        Ok(self.position)
    }

    fn stream_position(&mut self) -> std::io::Result<u64> {
        Ok(self.position)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Read;

    /// The bytes are those written, seeks back included, and the writeback is requested for
    /// exactly the whole blocks lying the lag behind the end.
    #[test]
    fn writes_the_same_bytes_and_requests_whole_blocks_behind_the_lag() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f");
        let mut w = WritebackFile::new(File::create(&path).unwrap());
        let block: Vec<u8> = (0..1_000_003u32).map(|i| (i * 7 + i / 251) as u8).collect();
        let mut expected = Vec::new();
        // 50 writes of about 1 MB: 50_000_150 bytes.
        for k in 0..50 {
            w.write_all(&block).unwrap();
            expected.extend_from_slice(&block);
            if k == 30 {
                // Patch 4 bytes 900 kB back, as the mcap writer patches a chunk header.
                let at = w.stream_position().unwrap() - 900_000;
                w.seek(SeekFrom::Start(at)).unwrap();
                w.write_all(&[1, 2, 3, 4]).unwrap();
                expected[at as usize..at as usize + 4].copy_from_slice(&[1, 2, 3, 4]);
                w.seek(SeekFrom::End(0)).unwrap();
            }
        }
        assert_eq!(w.stream_position().unwrap(), 50_000_150);
        // (50_000_150 - 32 MiB) / 8 MiB = 1.96: one whole block handed over.
        assert_eq!(w.requests(), 1);
        assert_eq!(w.started(), WRITEBACK_BYTES);
        w.flush().unwrap();
        w.get_ref().sync_all().unwrap();
        drop(w);
        let mut read = Vec::new();
        File::open(&path).unwrap().read_to_end(&mut read).unwrap();
        assert!(
            read == expected,
            "the file's bytes differ from those written"
        );
    }

    /// Nothing is handed over before the end passes lag + one block; then one block per block.
    #[test]
    fn the_writeback_follows_the_end() {
        let dir = tempfile::tempdir().unwrap();
        let mut w = WritebackFile::new(File::create(dir.path().join("f")).unwrap());
        let mb = vec![0u8; 1 << 20];
        for _ in 0..39 {
            w.write_all(&mb).unwrap();
        }
        assert_eq!(w.requests(), 0, "39 MiB: 7 MiB past the lag");
        w.write_all(&mb).unwrap();
        assert_eq!(w.requests(), 1, "40 MiB: one block past the lag");
        for _ in 0..16 {
            w.write_all(&mb).unwrap();
        }
        assert_eq!((w.requests(), w.started()), (3, 24 << 20), "56 MiB");
    }
}
