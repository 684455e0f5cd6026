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

/// Least expanded text allowed for any XML file: 1 MiB (see [`xml_expansion_cap`]).
pub const XML_EXPANSION_MIN_BYTES: u64 = 1 << 20;

/// Most text an XML file of `len` bytes may become once its entity references are expanded:
/// twice its size, and at least [`XML_EXPANSION_MIN_BYTES`]. URDF and Collada files need no
/// entities at all (xacro writes none; urdf-rs cannot read a URDF that uses one), so any real
/// use is far below; a file that expands further is an entity bomb, e.g. a 110 KB URDF that
/// references one 50 KB entity 1 200 times became 1.96 GB of text in 4 s (issue 28).
pub fn xml_expansion_cap(len: usize) -> u64 {
    XML_EXPANSION_MIN_BYTES.max(2u64.saturating_mul(len as u64))
}

/// Most bytes the XML parser may copy while joining the pieces of runs of text, as a multiple
/// of [`xml_expansion_cap`]. roxmltree joins a text run's pieces (plain text, CDATA sections,
/// entity expansions) one at a time, copying the run so far each time: the work is quadratic
/// in the pieces of one run (a 1.1 MB URDF of 80 000 `a<![CDATA[b]]>` took 0.7 s, and 28 MB
/// of them would take over 7 minutes). One piece per run, as real files have, copies each
/// byte once.
pub const XML_MERGE_WORK_FACTOR: u64 = 8;

/// Checks, with a scan of the text alone, that parsing `xml` stays within bounds of its size:
/// its element nesting ([`check_xml_depth`]), the text its entity references expand to
/// ([`xml_expansion_cap`]), and the copying the parser does to join pieces of text
/// ([`XML_MERGE_WORK_FACTOR`]). Run it before any XML parser sees the text.
pub fn check_xml(xml: &str) -> Result<(), String> {
    check_xml_depth(xml)?;
    check_xml_expansion(xml)
}

/// The internal general entities (`<!ENTITY name "value">`) of an XML text: names, values,
/// and their expanded sizes once computed ([`Entities::size`]).
#[derive(Default)]
struct Entities<'a> {
    index: std::collections::HashMap<&'a [u8], usize>,
    values: Vec<&'a [u8]>,
    /// Expanded length and text pieces, once computed.
    sizes: Vec<Option<(u64, u64)>>,
}

impl<'a> Entities<'a> {
    /// Declares `name` (the first declaration of a name wins, as in roxmltree and the XML
    /// specification).
    fn declare(&mut self, name: &'a [u8], value: &'a [u8]) {
        if !self.index.contains_key(name) {
            self.index.insert(name, self.values.len());
            self.values.push(value);
            self.sizes.push(None);
        }
    }

    /// Expanded length and number of text pieces (maximal runs of characters between
    /// references) of entity `e`, computed without recursion: an entity may reference another
    /// to any depth. A reference back to an entity being expanded (a loop, which the parser
    /// refuses when it meets it) adds nothing.
    fn size(&mut self, e: usize) -> (u64, u64) {
        if let Some(size) = self.sizes[e] {
            return size;
        }
        let mut visiting = vec![false; self.values.len()];
        // Frames: entity, scan position, length and pieces so far, inside a text piece.
        let mut stack: Vec<(usize, usize, u64, u64, bool)> = vec![(e, 0, 0, 0, false)];
        visiting[e] = true;
        while let Some(&(e, mut pos, mut len, mut pieces, mut in_text)) = stack.last() {
            let value = self.values[e];
            let mut child = None;
            while pos < value.len() {
                if let Some((name, end)) = entity_reference(value, pos)
                    && let Some(&c) = self.index.get(name)
                {
                    match self.sizes[c] {
                        Some((l, p)) => {
                            len = len.saturating_add(l);
                            pieces = pieces.saturating_add(p);
                        }
                        None if visiting[c] => {}
                        None => {
                            child = Some(c);
                            break;
                        }
                    }
                    in_text = false;
                    pos = end;
                    continue;
                }
                len += 1;
                if !in_text {
                    pieces += 1;
                    in_text = true;
                }
                pos += 1;
            }
            if let Some(c) = child {
                // Back to this reference once `c` is done (its size then memoised).
                *stack.last_mut().expect("non-empty") = (e, pos, len, pieces, in_text);
                visiting[c] = true;
                stack.push((c, 0, 0, 0, false));
            } else {
                stack.pop();
                visiting[e] = false;
                self.sizes[e] = Some((len, pieces));
            }
        }
        self.sizes[e].expect("computed above")
    }
}

/// Scans a reference at `b[i] == b'&'`: `Some((name, end))` for `&name;` (not a character
/// reference), `end` past the `;`.
fn entity_reference(b: &[u8], i: usize) -> Option<(&[u8], usize)> {
    if b.get(i) != Some(&b'&') {
        return None;
    }
    let rest = &b[i + 1..];
    let len = rest
        .iter()
        .take(256)
        .position(|&c| c == b';' || c.is_ascii_whitespace() || matches!(c, b'&' | b'<' | b'>'))?;
    if rest[len] != b';' || len == 0 || rest[0] == b'#' {
        return None;
    }
    Some((&rest[..len], i + 1 + len + 1))
}

/// The end of `pattern` searched from `from` (or the end of `b`).
fn skip_past(b: &[u8], from: usize, pattern: &[u8]) -> usize {
    b[from.min(b.len())..]
        .windows(pattern.len())
        .position(|w| w == pattern)
        .map_or(b.len(), |p| from + p + pattern.len())
}

/// The end of a quoted literal starting at `b[i]` (a quote), past the closing quote.
fn skip_quoted(b: &[u8], i: usize) -> usize {
    let q = b[i];
    b[i + 1..]
        .iter()
        .position(|&c| c == q)
        .map_or(b.len(), |p| i + 1 + p + 1)
}

/// The internal general entities of the DOCTYPE's internal subset, first declaration of a
/// name winning (as roxmltree and the XML specification have it), and where the content after
/// the DOCTYPE starts (0 without one).
fn internal_entities(b: &[u8]) -> (Entities<'_>, usize) {
    let mut entities = Entities::default();
    // The prolog: XML declaration, comments, processing instructions, blanks, DOCTYPE.
    let mut i = 0;
    loop {
        while i < b.len() && (b[i].is_ascii_whitespace() || b[i] >= 0x80 && i < 3) {
            i += 1;
        }
        let rest = &b[i.min(b.len())..];
        if rest.starts_with(b"<?") {
            i = skip_past(b, i + 2, b"?>");
        } else if rest.starts_with(b"<!--") {
            i = skip_past(b, i + 4, b"-->");
        } else if rest.starts_with(b"<!DOCTYPE") {
            break;
        } else {
            return (entities, 0);
        }
    }
    // `<!DOCTYPE name ExternalID? [ subset ]>`
    let mut j = i + 9;
    while j < b.len() && b[j] != b'[' && b[j] != b'>' {
        j = if b[j] == b'"' || b[j] == b'\'' {
            skip_quoted(b, j)
        } else {
            j + 1
        };
    }
    if j >= b.len() || b[j] == b'>' {
        return (entities, (j + 1).min(b.len()));
    }
    j += 1;
    while j < b.len() && b[j] != b']' {
        let rest = &b[j..];
        if rest.starts_with(b"<!--") {
            j = skip_past(b, j + 4, b"-->");
        } else if rest.starts_with(b"<?") {
            j = skip_past(b, j + 2, b"?>");
        } else if rest.starts_with(b"<!ENTITY") {
            let mut k = j + 8;
            let blanks = |k: &mut usize| {
                while *k < b.len() && b[*k].is_ascii_whitespace() {
                    *k += 1;
                }
            };
            blanks(&mut k);
            let parameter = b.get(k) == Some(&b'%');
            if parameter {
                k += 1;
                blanks(&mut k);
            }
            let start = k;
            while k < b.len() && !b[k].is_ascii_whitespace() && b[k] != b'>' {
                k += 1;
            }
            let name = &b[start..k];
            blanks(&mut k);
            if matches!(b.get(k), Some(b'"' | b'\'')) {
                let end = skip_quoted(b, k);
                if !parameter {
                    entities.declare(name, &b[k + 1..end.saturating_sub(1).max(k + 1)]);
                }
                k = end;
            }
            // To the declaration's `>` (an external entity's SYSTEM/PUBLIC literals skipped).
            while k < b.len() && b[k] != b'>' {
                k = if b[k] == b'"' || b[k] == b'\'' {
                    skip_quoted(b, k)
                } else {
                    k + 1
                };
            }
            j = k + 1;
        } else if rest.starts_with(b"<!") {
            let mut k = j + 2;
            while k < b.len() && b[k] != b'>' {
                k = if b[k] == b'"' || b[k] == b'\'' {
                    skip_quoted(b, k)
                } else {
                    k + 1
                };
            }
            j = k + 1;
        } else {
            j += 1;
        }
    }
    // Past `]` and the DOCTYPE's closing `>`.
    let end = b[j.min(b.len())..]
        .iter()
        .position(|&c| c == b'>')
        .map_or(b.len(), |p| j + p + 1);
    (entities, end)
}

/// The expansion and merge checks of [`check_xml`] (its depth check aside).
pub fn check_xml_expansion(xml: &str) -> Result<(), String> {
    let b = xml.as_bytes();
    let cap = xml_expansion_cap(b.len());
    let work_cap = cap.saturating_mul(XML_MERGE_WORK_FACTOR);
    let (mut entities, start) = internal_entities(b);
    // Expanded text so far; copying work of finished runs; the current run of text.
    let (mut expanded, mut work) = (start as u64, 0u64);
    let (mut run_len, mut run_pieces, mut in_text) = (0u64, 0u64, false);
    let mut i = start;
    let too_big = |expanded: u64| {
        format!(
            "its entity references expand the file's {} bytes to more than {} bytes of text, \
             over the limit of {} bytes (twice the file's size, at least 1 MiB): an entity \
             bomb. Write the text out in the file instead of through entities (URDF and \
             Collada files need none)",
            crate::budget::grouped(b.len() as u64),
            crate::budget::grouped(expanded),
            crate::budget::grouped(cap)
        )
    };
    // A markup token ends the run of text: its joining work is done.
    let mut worst = (0u64, 0u64);
    let mut end_run = |work: &mut u64, run_len: &mut u64, run_pieces: &mut u64| {
        let cost = run_pieces.saturating_mul(*run_len);
        if cost > worst.0.saturating_mul(worst.1) {
            worst = (*run_pieces, *run_len);
        }
        *work = work.saturating_add(cost);
        *run_len = 0;
        *run_pieces = 0;
    };
    while i < b.len() {
        let c = b[i];
        if c == b'<' {
            let rest = &b[i..];
            if rest.starts_with(b"<![CDATA[") {
                let end = skip_past(b, i + 9, b"]]>");
                let n = (end - i) as u64;
                expanded = expanded.saturating_add(n);
                run_len = run_len.saturating_add(n);
                run_pieces += 1;
                in_text = false;
                i = end;
            } else {
                end_run(&mut work, &mut run_len, &mut run_pieces);
                in_text = false;
                let end = if rest.starts_with(b"<!--") || rest.starts_with(b"<?") {
                    let end = if rest.starts_with(b"<?") {
                        skip_past(b, i + 2, b"?>")
                    } else {
                        skip_past(b, i + 4, b"-->")
                    };
                    expanded = expanded.saturating_add((end - i) as u64);
                    end
                } else {
                    // A tag: to its `>`, expanding references in quoted attribute values.
                    let mut k = i + 1;
                    while k < b.len() && b[k] != b'>' {
                        if b[k] == b'"' || b[k] == b'\'' {
                            let q = skip_quoted(b, k);
                            // The two quotes, then the value.
                            expanded += 2;
                            let mut m = k + 1;
                            while m + 1 < q {
                                if let Some((name, end)) = entity_reference(b, m)
                                    && let Some(&e) = entities.index.get(name)
                                {
                                    let (l, _) = entities.size(e);
                                    expanded = expanded.saturating_add(l);
                                    m = end;
                                } else {
                                    expanded += 1;
                                    m += 1;
                                }
                            }
                            k = q;
                        } else {
                            expanded += 1;
                            k += 1;
                        }
                    }
                    // `<` and `>`.
                    expanded += 2;
                    k + 1
                };
                i = end;
            }
        } else if let Some((name, end)) = entity_reference(b, i)
            && let Some(&e) = entities.index.get(name)
        {
            let (l, p) = entities.size(e);
            expanded = expanded.saturating_add(l);
            run_len = run_len.saturating_add(l);
            run_pieces = run_pieces.saturating_add(p);
            in_text = false;
            i = end;
        } else {
            expanded += 1;
            run_len += 1;
            if !in_text {
                run_pieces += 1;
                in_text = true;
            }
            i += 1;
        }
        if expanded > cap {
            return Err(too_big(expanded));
        }
    }
    // The expansion is within its cap (the scan stopped otherwise), so the joining work is
    // judged once the whole text is seen: an entity bomb is named as such.
    end_run(&mut work, &mut run_len, &mut run_pieces);
    if work > work_cap {
        return Err(format!(
            "joining its runs of text would cost the XML parser more than {} bytes of copying, \
             over the limit of {} ({} times the {}-byte expansion limit): the parser joins the \
             pieces of a run (plain text, CDATA sections, entity references) one at a time, \
             and one run has {} pieces in {} bytes. Put such text in one piece",
            crate::budget::grouped(work),
            crate::budget::grouped(work_cap),
            XML_MERGE_WORK_FACTOR,
            crate::budget::grouped(cap),
            crate::budget::grouped(worst.0),
            crate::budget::grouped(worst.1)
        ));
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

    /// `<robot>` with `body` inside, after a DOCTYPE declaring `decls`.
    fn with_entities(decls: &str, body: &str) -> String {
        format!(
            "<?xml version='1.0'?>\n<!DOCTYPE robot [{decls}]>\n<robot name='r'>{body}</robot>\n"
        )
    }

    #[test]
    fn xml_expansion_cap_is_twice_the_size_and_at_least_a_mebibyte() {
        assert_eq!(xml_expansion_cap(0), 1 << 20);
        assert_eq!(xml_expansion_cap(1 << 19), 1 << 20);
        assert_eq!(xml_expansion_cap((1 << 19) + 1), (1 << 20) + 2);
        assert_eq!(xml_expansion_cap(100 << 20), 200 << 20);
    }

    /// The amplification: one 50 KB entity referenced 20 000 times in a 110 KB file
    /// (1 GB of text) is refused; the same entity referenced a few times is not.
    #[test]
    fn entity_amplification_is_refused_in_text_and_attributes() {
        let decl = format!("<!ENTITY e \"{}\">", "x".repeat(50_000));
        for body in [
            format!("<material name='m'>{}</material>", "&e;".repeat(20_000)),
            format!("<material name='{}'/>", "&e;".repeat(20_000)),
        ] {
            let xml = with_entities(&decl, &body);
            assert!(xml.len() < 120_000, "{}", xml.len());
            let e = check_xml(&xml).unwrap_err();
            assert!(e.contains("entity bomb"), "{e}");
            assert!(e.contains("over the limit of 1,048,576 bytes"), "{e}");
        }
        // Three references: 150 KB of text, under 1 MiB.
        let xml = with_entities(&decl, "<material name='&e;'>&e; &e;</material>");
        assert_eq!(check_xml(&xml), Ok(()));
    }

    /// Expansion through nested entities is multiplied out, however deep, without recursion;
    /// the cap is exact: the expanded document may be exactly the cap, not one byte more.
    #[test]
    fn nested_entities_are_multiplied_out_and_the_cap_is_exact() {
        let laughs = "<!ENTITY a \"0123456789\"><!ENTITY b \"&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;\">\
                      <!ENTITY c \"&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;\"><!ENTITY d \"&c;&c;&c;&c;&c;&c;&c;&c;&c;&c;\">\
                      <!ENTITY f \"&d;&d;&d;&d;&d;&d;&d;&d;&d;&d;\">";
        // &f; is 10^5 bytes; 11 of them pass 1 MiB (1 048 576) with the rest of the file
        // (in attribute values: no text run to join).
        let ok = with_entities(laughs, &"<m a='&f;'/>".repeat(10));
        assert_eq!(check_xml(&ok), Ok(()));
        let bomb = with_entities(laughs, &"<m a='&f;'/>".repeat(11));
        assert!(check_xml(&bomb).unwrap_err().contains("entity bomb"));
        // In text, &f; is 10^4 pieces (its leaves) joined one by one: one of them, 10^5 bytes,
        // is already past the joining limit (10^4 x 10^5 > 8 MiB).
        let text = with_entities(laughs, "<m>&f;</m>");
        let e = check_xml(&text).unwrap_err();
        assert!(e.contains("10,000 pieces"), "{e}");
        // Exactness: a document expanding to exactly the cap passes, one byte more does not.
        // `&g;` (3 bytes) becomes twice `h`'s V bytes; `pad` plain bytes fill up to 1 MiB
        // while the file stays under 512 KiB (so its cap is 1 MiB, not twice its size).
        let doc = |v: usize, pad: usize| {
            with_entities(
                &format!("<!ENTITY g \"&h;&h;\"><!ENTITY h \"{}\">", "x".repeat(v)),
                &format!("&g;{}", "y".repeat(pad)),
            )
        };
        let base = doc(0, 0).len();
        let v = 300_000;
        // Expanded: base + V (the declaration) + pad - 3 + 2 V.
        let pad = (1 << 20) + 3 - base - 3 * v;
        assert!(doc(v, pad).len() < 1 << 19);
        assert_eq!(check_xml(&doc(v, pad)), Ok(()));
        let e = check_xml(&doc(v, pad + 1)).unwrap_err();
        assert!(e.contains("to more than 1,048,577 bytes"), "{e}");
        // A chain of 100 000 entities, each referencing the next: no recursion, linear time.
        let n = 100_000;
        let chain: String = (0..n)
            .map(|i| format!("<!ENTITY e{i} \"&e{};\">", i + 1))
            .chain([format!("<!ENTITY e{n} \"z\">")])
            .collect();
        assert_eq!(check_xml(&with_entities(&chain, "&e0;")), Ok(()));
    }

    /// Loops, undeclared names, character references, parameter entities, external entities,
    /// references in comments and CDATA: left to the parser (which reports or ignores them),
    /// never a hang or a false refusal here.
    #[test]
    fn what_the_parser_reports_is_left_to_it() {
        for (decls, body) in [
            ("<!ENTITY a \"&b;\"><!ENTITY b \"&a;\">", "&a;"),
            ("<!ENTITY a \"&a;&a;\">", "&a;&a;"),
            ("", "&undeclared; &#x41; &#65; &amp; &lt;"),
            (
                "<!ENTITY % p \"x\"><!ENTITY q SYSTEM \"file:///etc/passwd\">",
                "&q;",
            ),
            (
                "<!-- <!ENTITY a 'x'> --><!ELEMENT robot ANY><!ATTLIST robot name CDATA #IMPLIED>",
                "x",
            ),
            ("<!ENTITY a \"1\">", "<!-- &a; --><![CDATA[&a;]]>"),
            ("<!ENTITY a 'single quoted'>", "&a"),
        ] {
            let xml = with_entities(decls, body);
            assert_eq!(check_xml(&xml), Ok(()), "{xml}");
        }
        // A reference without its `;` is malformed (the parser's to report), not expanded
        // here: 30 of them would be 1.5 MB of text.
        let big = format!("<!ENTITY e \"{}\">", "x".repeat(50_000));
        assert_eq!(check_xml(&with_entities(&big, &"&e x".repeat(30))), Ok(()));
        // The first declaration of a name wins (as in roxmltree): the second one's 2 MB is
        // never referenced.
        let twice = format!("<!ENTITY a 'x'><!ENTITY a '{}'>", "y".repeat(2 << 20));
        assert_eq!(
            check_xml(&with_entities(&twice, &"&a;".repeat(100))),
            Ok(())
        );
        // A DOCTYPE without an internal subset, and none at all.
        assert_eq!(
            check_xml("<!DOCTYPE robot SYSTEM 'x[.dtd'><robot/>"),
            Ok(())
        );
        assert_eq!(check_xml("\u{feff}<robot name='a'>&amp;</robot>"), Ok(()));
    }

    /// Joining the pieces of one run of text copies the run so far per piece (quadratic):
    /// 80 000 CDATA sections in one run (1.1 MB, 0.7 s in roxmltree, 4x per doubling) are
    /// refused, the same sections each in their own element pass.
    #[test]
    fn many_pieces_in_one_run_of_text_are_refused() {
        let run = format!(
            "<robot name='r'><m>{}</m></robot>",
            "a<![CDATA[b]]>".repeat(80_000)
        );
        let e = check_xml(&run).unwrap_err();
        assert!(e.contains("pieces"), "{e}");
        let apart = format!(
            "<robot name='r'>{}</robot>",
            "<m>a<![CDATA[b]]></m>".repeat(80_000)
        );
        assert_eq!(check_xml(&apart), Ok(()));
        // A few pieces in a long run (a big float array with two CDATA sections) pass.
        let long = format!(
            "<robot name='r'><m>{}<![CDATA[1]]>{}<![CDATA[2]]></m></robot>",
            "1 ".repeat(1 << 20),
            "2 ".repeat(1 << 20)
        );
        assert_eq!(check_xml(&long), Ok(()));
        // Entity text joins the run too: 1 000 references to a 1-byte entity in one run.
        let refs = with_entities(
            "<!ENTITY a 'x'>",
            &format!("<m>{}</m>", "&a;-".repeat(1000)),
        );
        assert_eq!(check_xml(&refs), Ok(()));
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
