//! Reading input files (scenes, URDFs, meshes) without trusting them.
//!
//! Rules, the same for every file tumble reads:
//!
//! - **Regular files only.** A directory, a FIFO, a socket or a device (`/dev/zero`,
//!   `/dev/urandom`, `/dev/stdin` on a pipe) is refused before it is opened: opening a FIFO
//!   blocks until a writer appears, and a device can deliver bytes forever. Symbolic links are
//!   followed; what they point at must be a regular file.
//! - **Size caps.** A file larger than its kind's cap ([`SCENE_MAX_BYTES`], [`URDF_MAX_BYTES`],
//!   [`MESH_MAX_BYTES`]) is refused before any of it is read.
//! - **Never more than the size the file had when checked.** At most the length from the
//!   file's metadata is read (a file growing while it is read is cut there), so a pseudo-file
//!   whose metadata says 0 bytes (`/proc/...`) reads as empty instead of blocking.
//!
//! Errors are `std::io::Error`s whose message states the rule (the callers add the file name).

use std::io::{Error, ErrorKind, Read};
use std::path::Path;

/// Largest scene file read: 16 MiB (real scenes are a few hundred bytes).
pub const SCENE_MAX_BYTES: u64 = 16 << 20;
/// Largest URDF read: 256 MiB (the largest URDF of example-robot-data 6.0.0 is 0.5 MB; a
/// generated model of 100 000 links is about 30 MB).
pub const URDF_MAX_BYTES: u64 = 256 << 20;
/// Largest mesh file read: 512 MiB (a binary STL of 10 million triangles; the largest mesh of
/// example-robot-data 6.0.0 is 13 MB).
pub const MESH_MAX_BYTES: u64 = 512 << 20;

/// What `file_type` is, in words ("a FIFO (named pipe)", "a directory", ...).
fn describe(file_type: &std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if file_type.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if file_type.is_socket() {
            return "a socket";
        }
        if file_type.is_char_device() {
            return "a character device";
        }
        if file_type.is_block_device() {
            return "a block device";
        }
    }
    if file_type.is_dir() {
        "a directory"
    } else {
        "a special file"
    }
}

/// `cap` in words: whole MiB when it is some, else bytes.
fn describe_cap(cap: u64) -> String {
    if cap >= 1 << 20 && cap % (1 << 20) == 0 {
        format!("{} MiB", cap >> 20)
    } else {
        format!("{cap} bytes")
    }
}

/// Checks that `path` is a regular file of at most `cap` bytes; returns its size. Does not
/// open it (so a FIFO cannot block).
pub fn check(path: &Path, cap: u64) -> std::io::Result<u64> {
    let meta = std::fs::metadata(path)?;
    let file_type = meta.file_type();
    if !file_type.is_file() {
        return Err(Error::new(
            ErrorKind::InvalidInput,
            format!(
                "not a regular file but {} (only regular files are read)",
                describe(&file_type)
            ),
        ));
    }
    if meta.len() > cap {
        return Err(Error::new(
            ErrorKind::InvalidInput,
            format!(
                "the file has {} bytes, over the {} limit for this kind of file",
                meta.len(),
                describe_cap(cap)
            ),
        ));
    }
    Ok(meta.len())
}

/// Reads a whole regular file of at most `cap` bytes (see the module documentation).
pub fn read_bytes(path: &Path, cap: u64) -> std::io::Result<Vec<u8>> {
    let len = check(path, cap)?;
    let file = std::fs::File::open(path)?;
    // The object opened may differ from the one checked (a rename in between): check again.
    let meta = file.metadata()?;
    if !meta.file_type().is_file() {
        return Err(Error::new(
            ErrorKind::InvalidInput,
            "not a regular file (only regular files are read)",
        ));
    }
    let len = len.min(meta.len());
    let mut bytes = Vec::with_capacity(usize::try_from(len).unwrap_or(0));
    file.take(len).read_to_end(&mut bytes)?;
    Ok(bytes)
}

/// [`read_bytes`] as UTF-8 text (a leading byte-order mark is kept, as `read_to_string` does).
pub fn read_text(path: &Path, cap: u64) -> std::io::Result<String> {
    let bytes = read_bytes(path, cap)?;
    if bytes.starts_with(b"\xFF\xFE") || bytes.starts_with(b"\xFE\xFF") {
        return Err(Error::new(
            ErrorKind::InvalidData,
            "UTF-16 text (byte-order mark): only UTF-8 is read; convert the file to UTF-8",
        ));
    }
    String::from_utf8(bytes).map_err(|e| {
        Error::new(
            ErrorKind::InvalidData,
            format!(
                "not UTF-8 text (invalid byte at offset {})",
                e.utf8_error().valid_up_to()
            ),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn special_files_are_refused_without_reading() {
        for (path, kind) in [
            ("/dev/zero", "character device"),
            ("/dev/null", "character device"),
            ("/", "directory"),
        ] {
            let e = read_bytes(Path::new(path), 1 << 20).unwrap_err();
            assert!(e.to_string().contains(kind), "{path}: {e}");
            assert!(e.to_string().contains("only regular files"), "{path}: {e}");
        }
    }

    #[test]
    fn caps_and_lengths() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f.txt");
        std::fs::write(&path, "0123456789").unwrap();
        assert_eq!(read_text(&path, 10).unwrap(), "0123456789");
        let e = read_bytes(&path, 9).unwrap_err();
        assert!(e.to_string().contains("10 bytes, over the 9 bytes limit"), "{e}");
        std::fs::write(&path, b"ab\xffcd").unwrap();
        let e = read_text(&path, 10).unwrap_err();
        assert!(e.to_string().contains("not UTF-8 text"), "{e}");
        assert_eq!(
            read_bytes(&dir.path().join("none"), 10).unwrap_err().kind(),
            ErrorKind::NotFound
        );
    }
}
