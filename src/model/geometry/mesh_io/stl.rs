//! STL, binary and ASCII, parsed by the `stl_io` crate; the flavour is decided here.
//!
//! Binary STL: an 80-byte header, a little-endian `u32` triangle count `n`, then `n` records of
//! 50 bytes (normal, three vertices as `f32` triples, a 2-byte attribute), so the file has
//! exactly `84 + 50 n` bytes. ASCII STL: `solid name`, then `facet normal ... outer loop`,
//! three `vertex x y z` lines, `endloop endfacet`, ..., `endsolid`.
//!
//! Sniffing, in order (many binary exporters start the header with `solid` too, so the text
//! prefix alone cannot decide):
//! 1. at least 84 bytes and exactly `84 + 50 n` bytes → binary;
//! 2. starts with `solid` (after an optional byte-order mark and blanks) → ASCII;
//! 3. otherwise an error naming the header count and the file size (truncated or padded binary,
//!    or not an STL at all).
//!
//! Work-arounds around `stl_io` 0.11: it takes any file whose first line starts with `solid `
//! for ASCII, so the header of a binary file is blanked before parsing; its ASCII reader wants
//! `solid ` with a space, lowercase keywords and one solid per file, so ASCII text is lowercased
//! and each `solid ... endsolid` block is parsed on its own. Coordinates are `f32` in both
//! flavours (ASCII parsed as `f32` by `stl_io`), widened exactly to `f64`.

use super::{MAX_MESH_TRIANGLES, check_triangle_count, index_u32, weld};
use crate::model::geometry::mesh::TriangleMesh;
use nalgebra::Vector3;
use std::io::{Cursor, Read};
use std::path::Path;

const HEADER_BYTES: usize = 84;
const RECORD_BYTES: usize = 50;

/// The triangle count of a binary STL: its header's count when the file has exactly the
/// size that count implies (`84 + 50 n` bytes), else `None` (not a binary STL).
fn binary_count(header: &[u8], file_len: u64) -> Option<u64> {
    let count = header.get(80..84)?;
    let n = u64::from(u32::from_le_bytes([count[0], count[1], count[2], count[3]]));
    let size = HEADER_BYTES as u64 + RECORD_BYTES as u64 * n;
    (size == file_len).then_some(n)
}

/// Refuses a binary STL whose header counts more than [`MAX_MESH_TRIANGLES`], reading its
/// first 84 bytes only (a 500 MB file, or a sparse one of any size, is judged unread). Any
/// other file passes (it is judged when read).
pub fn check_header(path: &Path) -> Result<(), String> {
    let Ok(file) = std::fs::File::open(path) else {
        return Ok(()); // the reader reports it
    };
    let Ok(len) = file.metadata().map(|m| m.len()) else {
        return Ok(());
    };
    let mut header = Vec::with_capacity(HEADER_BYTES);
    if file
        .take(HEADER_BYTES as u64)
        .read_to_end(&mut header)
        .is_err()
    {
        return Ok(());
    }
    match binary_count(&header, len) {
        Some(n) => check_triangle_count(n, true, "binary STL header, file not read"),
        None => Ok(()),
    }
}

/// Case-insensitive occurrences of `endfacet` in `bytes` (one per ASCII STL facet), counted
/// until `limit` is passed (the count returned is then `limit + 1`).
fn count_endfacets(bytes: &[u8], limit: u64) -> u64 {
    let mut count = 0;
    for w in bytes.windows(8) {
        if w.eq_ignore_ascii_case(b"endfacet") {
            count += 1;
            if count > limit {
                break;
            }
        }
    }
    count
}

/// The triangles of the STL at `path` and whether that is the whole count: a binary STL's
/// header count (84 bytes read); an ASCII STL's facets counted in one pass, 64 KiB at a time,
/// stopping past [`MAX_MESH_TRIANGLES`]; 0 for a file that is neither (its reader reports it).
pub fn count_triangles(path: &Path) -> std::io::Result<(u64, bool, &'static str)> {
    let mut file = std::fs::File::open(path)?;
    let len = file.metadata()?.len();
    let mut chunk = vec![0u8; 1 << 16];
    let mut header = Vec::with_capacity(HEADER_BYTES);
    (&mut file)
        .take(HEADER_BYTES as u64)
        .read_to_end(&mut header)?;
    if let Some(n) = binary_count(&header, len) {
        return Ok((n, true, "binary STL header, file not read"));
    }
    if !starts_with_solid(&header) {
        return Ok((0, true, "not an STL"));
    }
    const HOW: &str = "ASCII STL facets counted without parsing";
    // The last 7 bytes of the previous chunk join the next one (a token split between them).
    let mut carry = header;
    let mut count = 0u64;
    let mut file = file.take(len);
    loop {
        let n = file.read(&mut chunk)?;
        if n == 0 && carry.len() < 8 {
            break;
        }
        carry.extend_from_slice(&chunk[..n]);
        count += count_endfacets(&carry, MAX_MESH_TRIANGLES - count.min(MAX_MESH_TRIANGLES));
        if count > MAX_MESH_TRIANGLES {
            return Ok((count, false, HOW));
        }
        if n == 0 {
            break;
        }
        let keep = carry.len().min(7);
        carry.drain(..carry.len() - keep);
    }
    Ok((count, true, HOW))
}

/// Parses an STL file's bytes (see the module documentation), welded. More than
/// [`MAX_MESH_TRIANGLES`] is refused before parsing: a binary file by its header, an ASCII
/// one by its facets counted first.
pub fn read_stl(bytes: &[u8]) -> Result<TriangleMesh, String> {
    let header_count = bytes
        .get(80..84)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize);
    let binary_size = header_count.map(|n| HEADER_BYTES as u128 + RECORD_BYTES as u128 * n as u128);
    if binary_size == Some(bytes.len() as u128) {
        check_triangle_count(header_count.unwrap_or(0) as u64, true, "binary STL header")?;
        return read_binary(bytes);
    }
    if starts_with_solid(bytes) {
        let facets = count_endfacets(bytes, MAX_MESH_TRIANGLES);
        check_triangle_count(
            facets,
            facets <= MAX_MESH_TRIANGLES,
            "ASCII STL facets counted before parsing",
        )?;
        return read_ascii(bytes).map_err(|ascii_error| match (header_count, binary_size) {
            (Some(n), Some(size)) => format!(
                "neither ASCII STL ({ascii_error}) nor binary STL (header says {n} triangles = \
                 {size} bytes, the file has {} bytes)",
                bytes.len()
            ),
            _ => format!("ASCII STL: {ascii_error}"),
        });
    }
    match (header_count, binary_size) {
        (Some(n), Some(size)) => Err(format!(
            "binary STL header says {n} triangles ({size} bytes) but the file has {} bytes \
             (truncated, padded, or not an STL)",
            bytes.len()
        )),
        _ => Err(format!(
            "{} bytes: too short for a binary STL (84-byte header) and not ASCII (no `solid`)",
            bytes.len()
        )),
    }
}

/// The text after an optional UTF-8 byte-order mark and leading blanks.
fn text_start(bytes: &[u8]) -> &[u8] {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let blanks = bytes.iter().take_while(|b| b.is_ascii_whitespace()).count();
    &bytes[blanks..]
}

fn starts_with_solid(bytes: &[u8]) -> bool {
    text_start(bytes)
        .get(..5)
        .is_some_and(|s| s.eq_ignore_ascii_case(b"solid"))
}

fn read_binary(bytes: &[u8]) -> Result<TriangleMesh, String> {
    let mut data = bytes.to_vec();
    // The header is free text; blank it so that stl_io does not take the file for ASCII.
    data[..80].fill(0);
    let mut cursor = Cursor::new(data);
    let reader = stl_io::create_stl_reader(&mut cursor).map_err(|e| format!("binary STL: {e}"))?;
    collect(reader).map_err(|e| format!("binary STL: {e}"))
}

fn read_ascii(bytes: &[u8]) -> Result<TriangleMesh, String> {
    let text = String::from_utf8_lossy(text_start(bytes)).to_ascii_lowercase();
    let mut vertices = Vec::new();
    let mut triangles = Vec::new();
    for (k, block) in solid_blocks(&text).into_iter().enumerate() {
        let mut cursor = Cursor::new(block.into_bytes());
        let reader =
            stl_io::create_stl_reader(&mut cursor).map_err(|e| format!("solid {}: {e}", k + 1))?;
        let part = collect(reader).map_err(|e| format!("solid {}: {e}", k + 1))?;
        let offset = index_u32(vertices.len())?;
        vertices.extend(part.vertices);
        triangles.extend(part.triangles.iter().map(|t| t.map(|i| i + offset)));
    }
    index_u32(vertices.len())?;
    Ok(weld(&vertices, &triangles))
}

/// Splits ASCII STL text into `solid ... endsolid` blocks, each starting `solid <name>` (a
/// nameless `solid` line gets a name: `stl_io` needs the space).
fn solid_blocks(text: &str) -> Vec<String> {
    let mut blocks: Vec<String> = Vec::new();
    for line in text.lines() {
        let trimmed = line.trim();
        let is_solid = trimmed == "solid"
            || trimmed
                .strip_prefix("solid")
                .is_some_and(|rest| rest.starts_with(char::is_whitespace));
        if is_solid {
            blocks.push(String::from("solid unnamed\n"));
        } else if let Some(block) = blocks.last_mut() {
            block.push_str(trimmed);
            block.push('\n');
        }
    }
    blocks
}

fn collect(
    triangles: Box<dyn stl_io::TriangleIterator<Item = std::io::Result<stl_io::Triangle>> + '_>,
) -> Result<TriangleMesh, String> {
    let mut vertices = Vec::new();
    let mut indices = Vec::new();
    for triangle in triangles {
        let triangle = triangle.map_err(|e| e.to_string())?;
        let first = index_u32(vertices.len())?;
        for v in triangle.vertices {
            vertices.push(Vector3::new(
                f64::from(v[0]),
                f64::from(v[1]),
                f64::from(v[2]),
            ));
        }
        index_u32(vertices.len())?;
        indices.push([first, first + 1, first + 2]);
    }
    Ok(weld(&vertices, &indices))
}
