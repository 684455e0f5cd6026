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
/// Largest URDF read: 256 MiB (the largest URDF of example-robot-data 6.0.0 is 0.2 MB; a
/// generated chain of 100 000 links is about 30 MB).
pub const URDF_MAX_BYTES: u64 = 256 << 20;
/// Largest mesh file read: 512 MiB (a binary STL of 10 million triangles; the largest mesh of
/// example-robot-data 6.0.0 is a 29 MB DAE).
pub const MESH_MAX_BYTES: u64 = 512 << 20;

/// What `file_type` is, in words ("a FIFO (named pipe)", "a directory", ...).
pub fn describe(file_type: &std::fs::FileType) -> &'static str {
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
    if cap >= 1 << 20 && cap.is_multiple_of(1 << 20) {
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

/// Deepest element nesting accepted in an XML file (URDF, Collada). Real files nest a few
/// levels (URDF) to a few dozen (Collada node hierarchies); the XML readers recurse per level
/// (a 20 000-deep URDF overflowed the 8 MB main stack), so deeper files are
/// refused before any of them parses them.
pub const MAX_XML_DEPTH: usize = 1000;

/// Checks that `xml` nests elements at most [`MAX_XML_DEPTH`] deep, with a scan of the text
/// alone (no tree is built): start tags open a level, end tags and `/>` close one; comments,
/// CDATA sections, processing instructions, `<!DOCTYPE ...>` and quoted attribute values are
/// skipped. Malformed text is left for the XML parser to report; only the depth is judged here.
pub fn check_xml_depth(xml: &str) -> Result<(), String> {
    let b = xml.as_bytes();
    let find = |from: usize, pat: &[u8]| -> usize {
        b[from.min(b.len())..]
            .windows(pat.len())
            .position(|w| w == pat)
            .map_or(b.len(), |p| from + p + pat.len())
    };
    let (mut i, mut depth) = (0usize, 0usize);
    while i < b.len() {
        if b[i] != b'<' {
            i += 1;
            continue;
        }
        let rest = &b[i..];
        if rest.starts_with(b"<!--") {
            i = find(i + 4, b"-->");
        } else if rest.starts_with(b"<![CDATA[") {
            i = find(i + 9, b"]]>");
        } else if rest.starts_with(b"<?") {
            i = find(i + 2, b"?>");
        } else if rest.starts_with(b"<!") {
            // `<!DOCTYPE name [ ... ]>`: skip to the `>` after any internal subset.
            let mut j = i + 2;
            let mut bracket = 0usize;
            while j < b.len() && !(b[j] == b'>' && bracket == 0) {
                match b[j] {
                    b'[' => bracket += 1,
                    b']' => bracket = bracket.saturating_sub(1),
                    _ => {}
                }
                j += 1;
            }
            i = j + 1;
        } else if rest.starts_with(b"</") {
            depth = depth.saturating_sub(1);
            i = find(i + 2, b">");
        } else {
            // A start tag: to its `>` outside quotes; `/>` closes it at once.
            let mut j = i + 1;
            let mut quote = None;
            while j < b.len() {
                match (quote, b[j]) {
                    (None, b'"' | b'\'') => quote = Some(b[j]),
                    (Some(q), c) if c == q => quote = None,
                    (None, b'>') => break,
                    _ => {}
                }
                j += 1;
            }
            if b.get(j.wrapping_sub(1)) != Some(&b'/') {
                depth += 1;
                if depth > MAX_XML_DEPTH {
                    return Err(format!(
                        "elements nested more than {MAX_XML_DEPTH} deep (line {}); real files \
                         nest a few dozen at most",
                        1 + b[..i].iter().filter(|&&c| c == b'\n').count()
                    ));
                }
            }
            i = j + 1;
        }
    }
    Ok(())
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
    fn xml_depth() {
        let nested = |d: usize| format!("{}{}", "<a x='>'>".repeat(d), "</a>".repeat(d));
        assert!(check_xml_depth(&nested(MAX_XML_DEPTH)).is_ok());
        let e = check_xml_depth(&nested(MAX_XML_DEPTH + 1)).unwrap_err();
        assert!(e.contains("nested more than 1000 deep (line 1)"), "{e}");
        // Self-closing tags, comments, CDATA and DOCTYPE open nothing.
        let flat = format!(
            "<?xml version='1.0'?><!DOCTYPE r [<!ENTITY e 'x'>]><r>{}</r>",
            "<b/><!-- <c> --><![CDATA[<d>]]>".repeat(5000)
        );
        assert!(check_xml_depth(&flat).is_ok());
        // Malformed text is the XML parser's to report, not the scan's.
        assert!(check_xml_depth("<<<<'").is_ok());
    }

    #[test]
    fn caps_and_lengths() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f.txt");
        std::fs::write(&path, "0123456789").unwrap();
        assert_eq!(read_text(&path, 10).unwrap(), "0123456789");
        let e = read_bytes(&path, 9).unwrap_err();
        assert!(
            e.to_string().contains("10 bytes, over the 9 bytes limit"),
            "{e}"
        );
        std::fs::write(&path, b"ab\xffcd").unwrap();
        let e = read_text(&path, 10).unwrap_err();
        assert!(e.to_string().contains("not UTF-8 text"), "{e}");
        assert_eq!(
            read_bytes(&dir.path().join("none"), 10).unwrap_err().kind(),
            ErrorKind::NotFound
        );
    }
}
