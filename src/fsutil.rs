//! Files appear whole or not at all, each run owns the files it writes, and nothing is written
//! through a link.
//!
//! Every output `path` is written under `<path>.part` and renamed onto `path` when complete
//! ([`publish`]). The rules, and why (docs/reliability.md, "Threat model"):
//!
//! - **A run owns its `.part` files.** [`create_part`] opens `<path>.part` with `O_NOFOLLOW`
//!   (a symbolic link planted there is refused, never followed: its target is not truncated),
//!   refuses anything but a regular file with one name (a hard link planted there would make
//!   the truncation reach the other name's file), and takes an exclusive `flock` on it before
//!   truncating it. The lock is held until the file is published or discarded, through a
//!   duplicate of the descriptor kept in this module (so the sink may close its own handle).
//!   A second run on the same output finds the lock taken and is refused at once, naming the
//!   process that holds it ([`holder`], from `/proc/locks`); the first run is untouched. A
//!   `.part` left by a run that was killed (`SIGKILL`, a power cut) holds no lock and is
//!   reused. After taking the lock the name is checked to still be the locked file (the
//!   classic lock-file protocol), so a run never truncates a file another run has just
//!   published or replaced.
//! - **All of a run's files are published together or none** ([`publish`]). Before the first
//!   rename every final name is checked (a directory there fails the whole set), each existing
//!   file is kept under a backup name (a hard link, so the final name never disappears), and
//!   a rename that fails rolls back the renames already made: the previous files are back
//!   under their names and no `.part` is left.
//! - **Checked before any work** ([`check_output`]): a directory or a special file at a final
//!   name, a link or a foreign file at its `.part` name, an existing file without `--force`,
//!   and a `.part` locked by a running tumble are all refused before the first step.

use anyhow::{Context, bail};
use std::fs::File;
use std::io::Write;
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// `<path>.part`.
pub fn part_path(path: &Path) -> PathBuf {
    let mut name = path.as_os_str().to_owned();
    name.push(".part");
    PathBuf::from(name)
}

/// The `.part` files this process has created and not yet published or discarded, each with a
/// duplicate of its locked descriptor (the `flock` lives as long as one descriptor of the open
/// file does, so the lock outlives the writer's own handle until the rename).
static HELD: Mutex<Vec<Held>> = Mutex::new(Vec::new());

struct Held {
    /// The final name.
    path: PathBuf,
    /// Where the file is written until it is published (`<path>.part` unless the writer chose
    /// another name, [`create_part_named`]).
    part: PathBuf,
    lock: File,
}

fn held() -> std::sync::MutexGuard<'static, Vec<Held>> {
    HELD.lock().unwrap_or_else(|e| e.into_inner())
}

/// Held by [`publish`] while it renames, so that [`abandon`] (a signal) never cuts a
/// publish in half.
static PUBLISHING: Mutex<()> = Mutex::new(());

/// Removes every `.part` file this process holds, after any publish in progress has ended;
/// returns how many. What a signal does before the process exits
/// ([`crate::interrupt`]).
pub fn abandon() -> usize {
    let _publishing = PUBLISHING.lock().unwrap_or_else(|e| e.into_inner());
    let finals: Vec<PathBuf> = held().iter().map(|h| h.path.clone()).collect();
    let finals: Vec<&Path> = finals.iter().map(PathBuf::as_path).collect();
    discard(&finals);
    finals.len()
}

/// `file.try_lock()`, retried for up to 100 ms while the lock is taken. A lock released by its
/// holder can live on for a moment in a process forked by another thread of the holder (the
/// descriptor is copied at `fork` and closed only at `exec`): seen in the test suite, which
/// starts the binary from many threads. A real second run is still refused within 0.1 s.
fn try_lock_briefly(file: &File) -> Result<(), std::fs::TryLockError> {
    let started = std::time::Instant::now();
    loop {
        match file.try_lock() {
            Err(std::fs::TryLockError::WouldBlock)
                if started.elapsed() < std::time::Duration::from_millis(100) =>
            {
                std::thread::sleep(std::time::Duration::from_millis(2));
            }
            other => return other,
        }
    }
}

/// The `(device, inode)` of a file's metadata.
fn identity(meta: &std::fs::Metadata) -> (u64, u64) {
    (meta.dev(), meta.ino())
}

/// The process holding a `flock` on the file with inode `ino`, read from `/proc/locks`
/// (`1: FLOCK  ADVISORY  WRITE 1234 00:1f:5678 0 EOF`); `None` when it cannot be told.
pub fn holder(ino: u64) -> Option<u32> {
    // `/proc/locks` is read in pieces; a lock taken or released elsewhere meanwhile can shift a
    // line past the reader (seen once in 7 runs of the unit tests, which lock many files at
    // once), so a miss is retried a few times.
    (0..4).find_map(|_| holder_once(ino))
}

fn holder_once(ino: u64) -> Option<u32> {
    let locks = std::fs::read_to_string("/proc/locks").ok()?;
    locks.lines().find_map(|line| {
        let fields: Vec<&str> = line.split_whitespace().collect();
        // Waiting requests are marked `->` and shift the fields by one; they hold nothing.
        if fields.get(1) != Some(&"FLOCK") {
            return None;
        }
        let inode = fields.get(5)?.rsplit(':').next()?.parse::<u64>().ok()?;
        (inode == ino).then(|| fields.get(4)?.parse().ok())?
    })
}

/// "another tumble run (process 1234) is writing `final`": the refusal of a second run.
fn busy(final_path: &Path, part: &Path, ino: u64) -> anyhow::Error {
    let who = match holder(ino) {
        Some(pid) => format!("process {pid}"),
        None => "another process".to_string(),
    };
    anyhow::anyhow!(
        "another tumble run ({who}) is writing {} (it holds the lock on {}); wait for it to \
         finish or choose another output",
        final_path.display(),
        part.display()
    )
}

/// What is wrong with a file found at a `.part` name, if anything: a symbolic link, a special
/// file, or a file with other hard links.
fn foreign_part(part: &Path, meta: &std::fs::Metadata) -> Option<String> {
    let kind = meta.file_type();
    if kind.is_symlink() {
        let target = std::fs::read_link(part)
            .map(|t| format!(" (to {})", t.display()))
            .unwrap_or_default();
        return Some(format!(
            "{} is a symbolic link{target}; tumble never writes through a link: remove it",
            part.display()
        ));
    }
    if !kind.is_file() {
        return Some(format!(
            "{} exists and is not a regular file; remove it or choose another output",
            part.display()
        ));
    }
    if meta.nlink() > 1 {
        return Some(format!(
            "{} has {} hard links; tumble will not truncate a file that has another name: \
             remove it",
            part.display(),
            meta.nlink()
        ));
    }
    None
}

/// Opens `<final_path>.part` for writing as this run's own file (see the module
/// documentation): never through a link, never a file with another name, never a file another
/// run holds. The returned file is empty. Publish it with [`publish`], or [`discard`] it.
pub fn create_part(final_path: &Path) -> anyhow::Result<File> {
    create_part_named(final_path, &part_path(final_path))
}

/// [`create_part`] under the name `part` instead of `<final_path>.part` (a plot keeps its
/// extension last, `x.part.png`, so that the drawing library picks the encoder).
pub fn create_part_named(final_path: &Path, part: &Path) -> anyhow::Result<File> {
    use rustix::fs::{Mode, OFlags};
    let part = part.to_path_buf();
    // A rival run may publish or replace the file between our open and our lock; each such
    // race costs one more round, and a handful of rounds always suffices in practice.
    for _ in 0..16 {
        let flags = OFlags::RDWR | OFlags::CREATE | OFlags::NOFOLLOW | OFlags::CLOEXEC;
        let fd = match rustix::fs::open(&part, flags, Mode::from_raw_mode(0o644)) {
            Ok(fd) => fd,
            Err(rustix::io::Errno::LOOP) => {
                let meta = std::fs::symlink_metadata(&part)
                    .with_context(|| format!("cannot create {}", part.display()))?;
                bail!(
                    "{}",
                    foreign_part(&part, &meta)
                        .unwrap_or_else(|| format!("cannot create {}", part.display()))
                );
            }
            Err(e) => {
                return Err(std::io::Error::from(e))
                    .with_context(|| format!("cannot create {}", part.display()));
            }
        };
        let file = File::from(fd);
        let meta = file
            .metadata()
            .with_context(|| format!("cannot create {}", part.display()))?;
        if let Some(problem) = foreign_part(&part, &meta) {
            bail!("{problem}");
        }
        match try_lock_briefly(&file) {
            Ok(()) => {}
            Err(std::fs::TryLockError::WouldBlock) => {
                return Err(busy(final_path, &part, meta.ino()));
            }
            Err(std::fs::TryLockError::Error(e)) => {
                return Err(e).with_context(|| format!("cannot lock {}", part.display()));
            }
        }
        // Still the file under the name? Else it was published or replaced meanwhile: again.
        // And still its only name (a hard link made between the check above and the lock)?
        // Both only happen in a race with another process, which no sequential test can
        // stage (cargo-mutants reports these two checks as missed: docs/mutants.md).
        let now = match std::fs::symlink_metadata(&part) {
            Ok(now) if identity(&now) == identity(&meta) => now,
            _ => continue,
        };
        if let Some(problem) = foreign_part(&part, &now) {
            bail!("{problem}");
        }
        file.set_len(0)
            .with_context(|| format!("cannot truncate {}", part.display()))?;
        let lock = file
            .try_clone()
            .with_context(|| format!("cannot create {}", part.display()))?;
        held().push(Held {
            path: final_path.to_path_buf(),
            part: part.clone(),
            lock,
        });
        return Ok(file);
    }
    bail!(
        "cannot create {}: other processes keep replacing it",
        part.display()
    )
}

/// Takes this process's lock on the `.part` file of `final_path` out of the registry (the lock
/// ends when the writer's handle is closed too): its name and the lock. `None` when this
/// process does not hold one.
fn release(final_path: &Path) -> Option<(PathBuf, File)> {
    let mut held = held();
    let i = held.iter().position(|h| h.path == final_path)?;
    let h = held.swap_remove(i);
    Some((h.part, h.lock))
}

/// The name this process writes `final_path` under: the registered one, else `<path>.part`.
fn current_part(final_path: &Path) -> PathBuf {
    held()
        .iter()
        .find(|h| h.path == final_path)
        .map_or_else(|| part_path(final_path), |h| h.part.clone())
}

/// Is the file at `part` the one `lock` is a descriptor of?
fn is_ours(part: &Path, lock: &File) -> bool {
    match (std::fs::symlink_metadata(part), lock.metadata()) {
        (Ok(a), Ok(b)) => identity(&a) == identity(&b),
        _ => false,
    }
}

/// Removes the `.part` files of `finals` that this process created and still holds; a `.part`
/// of another run (or none) is left alone. Never fails: it runs on error paths.
pub fn discard(finals: &[&Path]) {
    for final_path in finals {
        if let Some((part, lock)) = release(final_path)
            && is_ours(&part, &lock)
        {
            std::fs::remove_file(&part).ok();
        }
    }
}

/// The backup name of `final_path` while a publish replaces it: `.<name>.<pid>.old` in the
/// same folder (hidden, unique to this process).
fn backup_path(final_path: &Path) -> PathBuf {
    let name = final_path.file_name().unwrap_or_default().to_string_lossy();
    final_path.with_file_name(format!(".{name}.{}.old", std::process::id()))
}

/// One final name replaced by [`publish`], for the roll-back.
struct Replaced {
    final_path: PathBuf,
    /// The previous file under its backup name, if there was one.
    backup: Option<PathBuf>,
}

/// Moves the previous file at `final_path` (if any) to its backup name, keeping the final name
/// in place where the file system allows (a hard link first; a rename where links are not
/// supported).
fn back_up(final_path: &Path) -> anyhow::Result<Option<PathBuf>> {
    let meta = match std::fs::symlink_metadata(final_path) {
        Ok(meta) => meta,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(e).with_context(|| format!("cannot read {}", final_path.display())),
    };
    if meta.is_dir() {
        bail!("cannot replace {}: it is a directory", final_path.display());
    }
    let backup = backup_path(final_path);
    std::fs::remove_file(&backup).ok();
    if std::fs::hard_link(final_path, &backup).is_err() {
        std::fs::rename(final_path, &backup)
            .with_context(|| format!("cannot replace {}", final_path.display()))?;
    }
    Ok(Some(backup))
}

/// Publishes the complete `.part` files of `finals` under their final names, all of them or
/// none (see the module documentation). On error every final name holds what it held before,
/// and the `.part` files are removed.
pub fn publish(finals: &[&Path]) -> anyhow::Result<()> {
    let _publishing = PUBLISHING.lock().unwrap_or_else(|e| e.into_inner());
    let mut replaced: Vec<Replaced> = Vec::new();
    let mut failure = None;
    for &final_path in finals {
        let part = current_part(final_path);
        let backup = match back_up(final_path) {
            Ok(backup) => backup,
            Err(e) => {
                failure = Some(e);
                break;
            }
        };
        if let Err(e) = std::fs::rename(&part, final_path) {
            // Drop the backup link (the previous file is still in place), or put a
            // renamed-away previous file back.
            if let Some(backup) = &backup {
                if std::fs::symlink_metadata(final_path).is_ok() {
                    std::fs::remove_file(backup).ok();
                } else {
                    std::fs::rename(backup, final_path).ok();
                }
            }
            failure = Some(anyhow::anyhow!(
                "cannot rename {} to {}: {e}",
                part.display(),
                final_path.display()
            ));
            break;
        }
        replaced.push(Replaced {
            final_path: final_path.to_path_buf(),
            backup,
        });
    }
    if let Some(e) = failure {
        // Roll back, last first: each previous file back to its final name (replacing the new
        // one), each new file without a predecessor back to its `.part` name (removed below).
        for r in replaced.iter().rev() {
            match &r.backup {
                Some(backup) => {
                    std::fs::rename(backup, &r.final_path).ok();
                }
                None => {
                    std::fs::rename(&r.final_path, current_part(&r.final_path)).ok();
                }
            }
        }
        discard(finals);
        return Err(e.context("no output was published: the previous files, if any, are unchanged"));
    }
    for r in &replaced {
        if let Some(backup) = &r.backup {
            std::fs::remove_file(backup).ok();
        }
    }
    for final_path in finals {
        release(final_path);
    }
    Ok(())
}

/// Writes `bytes` to `<path>.part` (this run's own, [`create_part`]), then publishes it onto
/// `path`. On error the part file is removed and `path` is untouched.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    let result = create_part(path).and_then(|mut file| {
        file.write_all(bytes)
            .with_context(|| format!("cannot write {}", part_path(path).display()))
    });
    match result {
        Ok(()) => publish(&[path]),
        Err(e) => {
            discard(&[path]);
            Err(e)
        }
    }
}

/// Checks an output before any work (see the module documentation): refuses a directory or a
/// special file at `path`, an existing file unless `force` ("`path` exists; pass --force to
/// replace it"), a link, a special file or a multiply linked file at `<path>.part`, and a
/// `.part` that a running tumble holds. A refusal costs nothing and leaves everything as it was.
pub fn check_output(path: &Path, force: bool) -> anyhow::Result<()> {
    match std::fs::symlink_metadata(path) {
        Ok(meta) if meta.is_dir() => bail!(
            "{} is a directory; tumble writes a file under that name: choose another output",
            path.display()
        ),
        Ok(meta) if !meta.is_file() && !meta.file_type().is_symlink() => bail!(
            "{} exists and is not a regular file; choose another output",
            path.display()
        ),
        Ok(_) if !force => bail!(
            "{} exists; pass --force to replace it (or choose another output)",
            path.display()
        ),
        _ => {}
    }
    let part = part_path(path);
    if let Ok(meta) = std::fs::symlink_metadata(&part) {
        if let Some(problem) = foreign_part(&part, &meta) {
            bail!("{problem}");
        }
        // Locked by a running tumble? (Opened without creating, truncating or following.)
        use rustix::fs::{Mode, OFlags};
        let flags = OFlags::RDONLY | OFlags::NOFOLLOW | OFlags::CLOEXEC | OFlags::NONBLOCK;
        if let Ok(fd) = rustix::fs::open(&part, flags, Mode::empty()) {
            let file = File::from(fd);
            if let Err(std::fs::TryLockError::WouldBlock) = file.try_lock() {
                return Err(busy(path, &part, meta.ino()));
            }
        }
    }
    Ok(())
}

/// [`check_output`] under its former name: refuses to replace an existing file unless `force`.
pub fn check_not_overwriting(path: &Path, force: bool) -> anyhow::Result<()> {
    check_output(path, force)
}

/// `EFBIG`: a write past the file-size limit (`ulimit -f`, RLIMIT_FSIZE) or the file system's
/// largest file.
const EFBIG: i32 = 27;

/// For an error caused by a write past the file-size limit: " (the file-size limit, ulimit -f,
/// is N bytes)", read from `/proc/self/limits`; else empty. `main` appends it to the message,
/// which already names the file.
pub fn file_size_limit_note(e: &anyhow::Error) -> String {
    let too_large = e.chain().any(|cause| {
        cause
            .downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.raw_os_error() == Some(EFBIG))
    });
    if !too_large {
        return String::new();
    }
    match file_size_limit_bytes() {
        Some(limit) => format!(
            " (the file-size limit, ulimit -f, is {limit} bytes = {})",
            crate::budget::human_bytes(limit as f64)
        ),
        None => " (the file is larger than the file-size limit, ulimit -f, allows)".to_string(),
    }
}

/// The soft file-size limit in bytes (`Max file size` in `/proc/self/limits`); `None` when
/// unlimited or unknown.
pub fn file_size_limit_bytes() -> Option<u64> {
    let limits = std::fs::read_to_string("/proc/self/limits").ok()?;
    let line = limits.lines().find(|l| l.starts_with("Max file size"))?;
    line["Max file size".len()..]
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

/// A folder a run writes many files into (a dataset), held for the run: see [`lock_folder`].
#[derive(Debug)]
pub struct FolderLock {
    _file: File,
}

/// Takes an exclusive lock on the folder `dir` (an existing folder) for as long as the returned
/// value lives: a `flock` on the folder itself (Linux locks directories as files), so nothing is
/// added to the folder. A second run on the same folder is refused at once, naming the process
/// that holds it, instead of removing or overwriting the first run's files.
pub fn lock_folder(dir: &Path) -> anyhow::Result<FolderLock> {
    use rustix::fs::{Mode, OFlags};
    let flags = OFlags::RDONLY | OFlags::DIRECTORY | OFlags::CLOEXEC;
    let file = rustix::fs::open(dir, flags, Mode::empty())
        .map(File::from)
        .map_err(std::io::Error::from)
        .with_context(|| format!("cannot lock the folder {}", dir.display()))?;
    let meta = file
        .metadata()
        .with_context(|| format!("cannot lock the folder {}", dir.display()))?;
    match try_lock_briefly(&file) {
        Ok(()) => Ok(FolderLock { _file: file }),
        Err(std::fs::TryLockError::WouldBlock) => {
            let who = match holder(meta.ino()) {
                Some(pid) => format!("process {pid}"),
                None => "another process".to_string(),
            };
            bail!(
                "another tumble run ({who}) is writing into {} (it holds the folder's lock); wait \
                 for it to finish or choose another output",
                dir.display()
            )
        }
        Err(std::fs::TryLockError::Error(e)) => {
            Err(e).with_context(|| format!("cannot lock the folder {}", dir.display()))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(path: &Path) -> String {
        std::fs::read_to_string(path).unwrap()
    }

    /// The names in `dir`, sorted.
    fn listing(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    /// A planted symbolic link at the `.part` name is refused, never followed: its target keeps
    /// its bytes (issue 28, item 2).
    #[test]
    fn a_link_at_the_part_name_is_refused_and_its_target_untouched() {
        let dir = tempfile::tempdir().unwrap();
        let victim = dir.path().join("victim");
        std::fs::write(&victim, "precious").unwrap();
        let out = dir.path().join("run.mcap");
        std::os::unix::fs::symlink(&victim, part_path(&out)).unwrap();
        let e = create_part(&out).unwrap_err().to_string();
        assert!(e.contains("run.mcap.part is a symbolic link"), "{e}");
        assert!(e.contains("victim"), "{e}");
        let e = check_output(&out, true).unwrap_err().to_string();
        assert!(e.contains("symbolic link"), "{e}");
        assert_eq!(read(&victim), "precious");
        // A dangling link is refused the same way, and nothing is created at its target.
        let out2 = dir.path().join("b.rrd");
        std::os::unix::fs::symlink(dir.path().join("new"), part_path(&out2)).unwrap();
        assert!(
            create_part(&out2)
                .unwrap_err()
                .to_string()
                .contains("symbolic link")
        );
        assert!(!dir.path().join("new").exists());
    }

    /// A `.part` that is a second name of another file would truncate that file: refused.
    #[test]
    fn a_hard_link_at_the_part_name_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let victim = dir.path().join("victim");
        std::fs::write(&victim, "precious").unwrap();
        let out = dir.path().join("run.mcap");
        std::fs::hard_link(&victim, part_path(&out)).unwrap();
        let e = create_part(&out).unwrap_err().to_string();
        assert!(e.contains("has 2 hard links"), "{e}");
        assert!(check_output(&out, true).is_err());
        assert_eq!(read(&victim), "precious");
    }

    /// A `.part` locked by another open file (another run) is refused at once, naming the
    /// holder's process (this test's own: `/proc/locks` tells); its bytes are untouched. A stale
    /// one (no lock: a killed run's) is reused, emptied.
    #[test]
    fn a_locked_part_is_refused_and_a_stale_one_reused() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("run.mcap");
        std::fs::write(part_path(&out), "other run").unwrap();
        let other = File::open(part_path(&out)).unwrap();
        other.lock().unwrap();
        let me = format!("process {}", std::process::id());
        let e = create_part(&out).unwrap_err().to_string();
        assert!(e.contains("another tumble run") && e.contains(&me), "{e}");
        let e = check_output(&out, false).unwrap_err().to_string();
        assert!(e.contains("another tumble run") && e.contains(&me), "{e}");
        assert_eq!(read(&part_path(&out)), "other run");
        drop(other);
        let mut file = create_part(&out).unwrap();
        assert_eq!(
            file.metadata().unwrap().len(),
            0,
            "a stale .part is emptied"
        );
        file.write_all(b"new").unwrap();
        publish(&[&out]).unwrap();
        assert_eq!(read(&out), "new");
        assert_eq!(listing(dir.path()), ["run.mcap"]);
    }

    /// Two writers of one output in one process: the second is refused while the first holds
    /// it, and may start once the first has published.
    #[test]
    fn one_writer_per_output_until_published() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("x.rrd");
        let mut first = create_part(&out).unwrap();
        assert!(create_part(&out).is_err());
        first.write_all(b"1").unwrap();
        drop(first); // the writer's handle closed: the lock still holds until publish
        assert!(create_part(&out).is_err());
        publish(&[&out]).unwrap();
        let mut second = create_part(&out).unwrap();
        second.write_all(b"2").unwrap();
        publish(&[&out]).unwrap();
        assert_eq!(read(&out), "2");
    }

    /// All of a set published or none: a directory at the last name fails the set, and every
    /// name keeps what it held before (issue 28, item 4). Nothing else is left in the folder.
    #[test]
    fn a_failed_publish_rolls_back_every_name() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b, c) = (
            dir.path().join("r.mcap"),
            dir.path().join("r.parquet"),
            dir.path().join("r.rrd"),
        );
        std::fs::write(&a, "old a").unwrap();
        for path in [&a, &b, &c] {
            create_part(path).unwrap().write_all(b"new").unwrap();
        }
        std::fs::create_dir(&c).unwrap();
        let e = publish(&[&a, &b, &c]).unwrap_err();
        let e = format!("{e:#}");
        assert!(e.contains("no output was published"), "{e}");
        assert!(e.contains("r.rrd"), "{e}");
        assert_eq!(read(&a), "old a");
        assert!(!b.exists(), "a name that was free is free again");
        assert!(c.is_dir());
        assert_eq!(listing(dir.path()), ["r.mcap", "r.rrd"]);
        // The locks are released: the same outputs can be written again.
        std::fs::remove_dir(&c).unwrap();
        for path in [&a, &b, &c] {
            create_part(path).unwrap().write_all(b"again").unwrap();
        }
        publish(&[&a, &b, &c]).unwrap();
        for path in [&a, &b, &c] {
            assert_eq!(read(path), "again");
        }
        assert_eq!(listing(dir.path()), ["r.mcap", "r.parquet", "r.rrd"]);
    }

    /// A rename that fails after others succeeded (here the middle file's `.part` was removed
    /// behind the run's back) puts the earlier names back and leaves the later ones alone.
    #[test]
    fn a_failed_rename_in_the_middle_puts_the_earlier_files_back() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b, c) = (
            dir.path().join("s.mcap"),
            dir.path().join("s.rrd"),
            dir.path().join("s.ros2.mcap"),
        );
        std::fs::write(&a, "old a").unwrap();
        std::fs::write(&c, "old c").unwrap();
        for path in [&a, &b, &c] {
            create_part(path).unwrap().write_all(b"new").unwrap();
        }
        // The `.part` of b vanishes (removed by hand): its rename fails after a's succeeded.
        std::fs::remove_file(part_path(&b)).unwrap();
        assert!(publish(&[&a, &b, &c]).is_err());
        assert_eq!(read(&a), "old a");
        assert_eq!(read(&c), "old c");
        assert!(!b.exists());
        assert_eq!(listing(dir.path()), ["s.mcap", "s.ros2.mcap"]);
    }

    /// Discarding removes this run's `.part` files only: another run's `.part` under a name
    /// this process never created stays.
    #[test]
    fn discard_removes_only_what_this_run_holds() {
        let dir = tempfile::tempdir().unwrap();
        let (mine, theirs) = (dir.path().join("m.mcap"), dir.path().join("t.mcap"));
        create_part(&mine).unwrap();
        std::fs::write(part_path(&theirs), "theirs").unwrap();
        discard(&[&mine, &theirs]);
        assert_eq!(listing(dir.path()), ["t.mcap.part"]);
        // And a `.part` of ours replaced by someone else's file is not removed either.
        create_part(&mine).unwrap();
        std::fs::remove_file(part_path(&mine)).unwrap();
        std::fs::write(part_path(&mine), "someone else's").unwrap();
        discard(&[&mine]);
        assert_eq!(read(&part_path(&mine)), "someone else's");
    }

    #[test]
    fn outputs_are_checked_before_any_work() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("o.rrd");
        assert!(check_output(&out, false).is_ok());
        std::fs::create_dir(&out).unwrap();
        let e = check_output(&out, true).unwrap_err().to_string();
        assert!(e.contains("o.rrd is a directory"), "{e}");
        std::fs::remove_dir(&out).unwrap();
        std::fs::write(&out, "x").unwrap();
        let e = check_output(&out, false).unwrap_err().to_string();
        assert!(e.contains("exists; pass --force"), "{e}");
        assert!(check_output(&out, true).is_ok());
        // A link at the final name is replaced by the rename (never followed): allowed.
        let link = dir.path().join("l.mcap");
        std::os::unix::fs::symlink(&out, &link).unwrap();
        assert!(check_output(&link, true).is_ok());
        create_part(&link).unwrap().write_all(b"new").unwrap();
        publish(&[&link]).unwrap();
        assert_eq!(read(&out), "x", "the link's target is untouched");
        assert!(!std::fs::symlink_metadata(&link).unwrap().is_symlink());
        // A FIFO at the final name is refused even with --force (renaming onto it would
        // replace it; a reader blocked on it would never see the file).
        let fifo = dir.path().join("f.mcap");
        rustix::fs::mknodat(
            rustix::fs::CWD,
            &fifo,
            rustix::fs::FileType::Fifo,
            rustix::fs::Mode::from_raw_mode(0o644),
            0,
        )
        .unwrap();
        for force in [false, true] {
            let e = check_output(&fifo, force).unwrap_err().to_string();
            assert!(e.contains("f.mcap exists and is not a regular file"), "{e}");
        }
    }

    /// Backing up a previous file: none there is no backup; a name that cannot be examined
    /// (below a regular file) is an error naming it, not taken for "nothing there".
    #[test]
    fn back_up_tells_absent_from_unreadable() {
        let dir = tempfile::tempdir().unwrap();
        assert_eq!(back_up(&dir.path().join("none.mcap")).unwrap(), None);
        let file = dir.path().join("file");
        std::fs::write(&file, "x").unwrap();
        let e = back_up(&file.join("x.mcap")).unwrap_err().to_string();
        assert!(
            e.contains("cannot read") && e.contains("file/x.mcap"),
            "{e}"
        );
        let backup = back_up(&file).unwrap().unwrap();
        assert_eq!(read(&backup), "x");
        assert_eq!(
            read(&file),
            "x",
            "the final name stays in place (a hard link)"
        );
    }

    #[test]
    fn write_atomic_replaces_whole_files() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("t.csv");
        std::fs::write(&out, "old").unwrap();
        write_atomic(&out, b"a,b\n").unwrap();
        assert_eq!(read(&out), "a,b\n");
        std::os::unix::fs::symlink(dir.path().join("v"), part_path(&out)).unwrap();
        assert!(write_atomic(&out, b"x").is_err());
        assert_eq!(read(&out), "a,b\n");
        assert!(!dir.path().join("v").exists());
    }

    #[test]
    fn a_folder_has_one_writer() {
        let dir = tempfile::tempdir().unwrap();
        let first = lock_folder(dir.path()).unwrap();
        let e = lock_folder(dir.path()).unwrap_err().to_string();
        let me = format!("process {}", std::process::id());
        assert!(e.contains("another tumble run") && e.contains(&me), "{e}");
        drop(first);
        assert!(lock_folder(dir.path()).is_ok());
        // Nothing is added to the folder, and a file is not a folder.
        assert_eq!(listing(dir.path()), Vec::<String>::new());
        let file = dir.path().join("f");
        std::fs::write(&file, "x").unwrap();
        let e = lock_folder(&file).unwrap_err();
        assert!(format!("{e:#}").contains("cannot lock the folder"), "{e:#}");
    }

    #[test]
    fn the_file_size_limit_is_named_for_efbig_only() {
        let efbig = anyhow::Error::from(std::io::Error::from_raw_os_error(EFBIG))
            .context("cannot write run.rrd.part");
        let note = file_size_limit_note(&efbig);
        assert!(note.contains("ulimit -f"), "{note}");
        let enospc = anyhow::Error::from(std::io::Error::from_raw_os_error(28));
        assert_eq!(file_size_limit_note(&enospc), "");
    }
}
