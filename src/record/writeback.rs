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
//!
//! **Syncing beside the writing.** On this machine (a Firecracker guest, virtio disk) the
//! written-back pages are not the cost: after the advice and 2 s of waiting, with no dirty
//! page left (`/proc/meminfo`), `fsync` of 240 MB still took 0.36-0.40 s, and it takes
//! 0.47 s whether done once or as 30 syncs of 8 MB each: the disk's cache flush costs about
//! 1.5-2 ns per byte written since the previous flush, whenever it happens. Paid at the end,
//! that flush was a third of a 1 s swarm run's wall time (`perf sched`: the block worker ran
//! 330 ms after the last step while both cores were otherwise idle). A thread of the file's
//! own therefore syncs it (`fdatasync`) each time another [`SYNC_BYTES`] have been written,
//! while the writing and the stepping go on; the final `sync_all` flushes only what came
//! after the last of them. A 1-thread bench beside a loop of 8 MB writes and syncs ran at the
//! same speed as alone (89-92 ns per body-step both), so the waiting costs the stepping
//! nothing while a core is free. The thread starts at the first [`SYNC_BYTES`] (small files
//! never start one), and [`WritebackFile::finish`] stops it and reports its first error
//! (the descriptor is shared, so Linux reports a write-back error to one `fsync` only).

use std::fs::File;
use std::io::{Seek, SeekFrom, Write};
use std::num::NonZeroU64;
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;

/// Bytes handed to the kernel's writeback at a time.
pub const WRITEBACK_BYTES: u64 = 8 << 20;

/// How far behind the end of the written bytes the writeback stays.
pub const WRITEBACK_LAG: u64 = 32 << 20;

/// Bytes written between two syncs by the file's sync thread (see the module doc): what is
/// left for the final sync is at most this, plus what was written during the last sync.
pub const SYNC_BYTES: u64 = 16 << 20;

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
    /// The multiple of [`SYNC_BYTES`] the end had passed when the sync thread was last asked.
    sync_requested: u64,
    /// Syncs asked of the sync thread (for tests).
    sync_requests: u64,
    /// The sync thread, from the first [`SYNC_BYTES`] on.
    syncer: Option<Syncer>,
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
            sync_requested: 0,
            sync_requests: 0,
            syncer: None,
        }
    }

    /// Stops the sync thread, waiting for a sync under way, and returns the file, or the
    /// first error of the thread's syncs (the caller then syncs what is left: `sync_all`).
    pub fn finish(mut self) -> std::io::Result<File> {
        if let Some(syncer) = self.syncer.take() {
            syncer.stop()?;
        }
        Ok(self.file)
    }

    /// Syncs the sync thread has completed so far (for tests).
    pub fn syncs(&self) -> u64 {
        self.syncer.as_ref().map_or(0, |s| s.state().completed)
    }

    /// Syncs asked of the sync thread so far (for tests): one each time the end passes
    /// another multiple of [`SYNC_BYTES`] (one for a write passing several).
    pub fn sync_requests(&self) -> u64 {
        self.sync_requests
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

    /// Asks the sync thread (started here the first time) to sync each time the end passes
    /// another multiple of [`SYNC_BYTES`]. A thread that cannot be started leaves the whole
    /// sync to the end.
    fn request_sync(&mut self) {
        if self.end - self.sync_requested < SYNC_BYTES {
            return;
        }
        self.sync_requested = self.end - self.end % SYNC_BYTES;
        self.sync_requests += 1;
        if self.syncer.is_none() {
            self.syncer = self.file.try_clone().ok().and_then(Syncer::start);
        }
        if let Some(syncer) = &self.syncer {
            let (lock, wake) = &*syncer.shared;
            lock_state(lock).requested += 1;
            wake.notify_one();
        }
    }
}

/// What the writer and its sync thread share.
#[derive(Default)]
struct SyncState {
    /// Syncs asked for; the thread syncs once for any number asked while it was busy.
    requested: u64,
    /// The value of `requested` the last completed sync answered.
    answered: u64,
    /// Syncs completed.
    completed: u64,
    stop: bool,
    /// The first failed sync's error; the thread stops there.
    error: Option<std::io::Error>,
}

fn lock_state(lock: &Mutex<SyncState>) -> MutexGuard<'_, SyncState> {
    lock.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// A thread syncing a file (`fdatasync`) whenever asked, while its writer goes on.
struct Syncer {
    shared: Arc<(Mutex<SyncState>, Condvar)>,
    thread: Option<JoinHandle<()>>,
}

impl Syncer {
    /// Starts the thread on `file` (a second descriptor of the written file), or `None` if
    /// the system cannot start one.
    fn start(file: File) -> Option<Self> {
        let shared = Arc::new((Mutex::new(SyncState::default()), Condvar::new()));
        let theirs = shared.clone();
        let thread = std::thread::Builder::new()
            .name("tumble-sync".into())
            .spawn(move || sync_when_asked(&file, &theirs))
            .ok()?;
        Some(Self {
            shared,
            thread: Some(thread),
        })
    }

    fn state(&self) -> MutexGuard<'_, SyncState> {
        lock_state(&self.shared.0)
    }

    /// Stops the thread after the sync under way, if any; the first error of its syncs.
    fn stop(mut self) -> std::io::Result<()> {
        self.join();
        match self.state().error.take() {
            Some(err) => Err(err),
            None => Ok(()),
        }
    }

    fn join(&mut self) {
        self.state().stop = true;
        self.shared.1.notify_one();
        if let Some(thread) = self.thread.take() {
            // The thread does not panic; if it did, the final sync still syncs everything.
            let _ = thread.join();
        }
    }
}

impl Drop for Syncer {
    /// A writer dropped on an error path stops its thread too.
    fn drop(&mut self) {
        self.join();
    }
}

/// The sync thread: waits for a request, syncs, until stopped or a sync fails.
fn sync_when_asked(file: &File, shared: &(Mutex<SyncState>, Condvar)) {
    let (lock, wake) = shared;
    let mut state = lock_state(lock);
    loop {
        while !state.stop && state.requested == state.answered {
            state = wake
                .wait(state)
                .unwrap_or_else(|poisoned| poisoned.into_inner());
        }
        if state.stop {
            return;
        }
        let requested = state.requested;
        drop(state);
        let result = file.sync_data();
        state = lock_state(lock);
        state.answered = requested;
        state.completed += 1;
        if let Err(err) = result {
            state.error = Some(err);
            return;
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
            self.request_sync();
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
        // 50_000_150 / 16 MiB = 2.98: the end passed two multiples of 16 MiB.
        assert_eq!(w.sync_requests(), 2);
        w.flush().unwrap();
        w.finish().unwrap().sync_all().unwrap();
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

    /// Waits until `w`'s sync thread has completed a sync (60 s at most).
    fn wait_for_a_sync(w: &WritebackFile) {
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
        while w.syncs() == 0 {
            assert!(std::time::Instant::now() < deadline, "no sync within 60 s");
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
    }

    /// No sync thread below [`SYNC_BYTES`]; from there one sync asked per [`SYNC_BYTES`], and
    /// the thread syncs while the writer goes on.
    #[test]
    fn the_sync_thread_syncs_each_sync_bytes_while_the_writing_goes_on() {
        let dir = tempfile::tempdir().unwrap();
        let mut w = WritebackFile::new(File::create(dir.path().join("f")).unwrap());
        let mb = vec![7u8; 1 << 20];
        for _ in 0..15 {
            w.write_all(&mb).unwrap();
        }
        w.write_all(&mb[..(1 << 20) - 1]).unwrap();
        assert_eq!(w.sync_requests(), 0, "one byte short of 16 MiB");
        assert!(w.syncer.is_none(), "a small file starts no thread");
        w.write_all(&[1]).unwrap();
        assert_eq!(w.sync_requests(), 1, "16 MiB");
        // The thread answers without the writer doing anything more.
        wait_for_a_sync(&w);
        for _ in 0..33 {
            w.write_all(&mb).unwrap();
        }
        assert_eq!(w.sync_requests(), 3, "49 MiB");
        let syncs = w.syncs();
        assert!((1..=3).contains(&syncs), "{syncs} syncs for 3 asked");
        // Writes of 12 MiB: the end passes 64 MiB on the way from 61 to 73, 80 from 73 to 85
        // and 96 from 85 to 97, one sync each (counting 16 MiB from the end at the last request
        // instead would miss 80).
        for (end_mib, asked) in [(61, 3), (73, 4), (85, 5), (97, 6)] {
            w.write_all(&vec![1u8; 12 << 20]).unwrap();
            assert_eq!(w.sync_requests(), asked, "{end_mib} MiB");
        }
        // Stopping waits for the thread: it is gone with its descriptor.
        let file = w.finish().unwrap();
        assert_eq!(file.metadata().unwrap().len(), 97 << 20);
    }

    /// A writer dropped without `finish` (an error path) stops its sync thread: the thread's
    /// share of the state is gone once the writer is.
    #[test]
    fn a_dropped_writer_stops_its_sync_thread() {
        let dir = tempfile::tempdir().unwrap();
        let mut w = WritebackFile::new(File::create(dir.path().join("f")).unwrap());
        w.write_all(&vec![0u8; 16 << 20]).unwrap();
        let shared = Arc::downgrade(&w.syncer.as_ref().expect("a sync thread").shared);
        drop(w);
        assert!(
            shared.upgrade().is_none(),
            "the sync thread outlived its writer"
        );
    }

    /// A failed background sync is reported by `finish`, not lost: a pipe cannot be synced
    /// (`EINVAL`), so the thread's first sync fails.
    #[test]
    fn a_failed_sync_is_reported_when_the_file_is_finished() {
        let (mut reader, writer) = std::io::pipe().unwrap();
        let drain =
            std::thread::spawn(move || std::io::copy(&mut reader, &mut std::io::sink()).unwrap());
        let mut w = WritebackFile::new(File::from(std::os::fd::OwnedFd::from(writer)));
        let mb = vec![0u8; 1 << 20];
        for _ in 0..17 {
            w.write_all(&mb).unwrap();
        }
        assert_eq!(w.sync_requests(), 1);
        wait_for_a_sync(&w);
        let err = w.finish().expect_err("the sync of a pipe fails");
        assert_eq!(
            err.raw_os_error(),
            Some(rustix::io::Errno::INVAL.raw_os_error())
        );
        assert_eq!(drain.join().unwrap(), 17 << 20);
    }
}
