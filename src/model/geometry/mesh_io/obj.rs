//! Wavefront OBJ, parsed by the `tobj` crate (positions read as `f64`).
//!
//! Faces with more than three corners are triangulated by `tobj` as fans `(v0, vi, vi+1)`: for
//! a planar polygon the fan's signed volumes add up to the polygon's whatever its convexity,
//! and the fan's inner edges are used once each way, so topology and integrals are those of
//! the polygon. Points and lines are ignored. All objects (`o`) and groups (`g`) are merged into
//! one mesh and welded, so faces of different groups that share a position are connected.
//! Material libraries (`mtllib`) are not opened.

use super::{MAX_MESH_TRIANGLES, check_triangle_count, index_u32, weld_indexed};
use crate::model::geometry::mesh::TriangleMesh;
use nalgebra::Vector3;
use std::io::BufRead;
use std::path::Path;

/// The triangles one OBJ line makes: a face `f v1 v2 ... vk` (the first word `f`, as `tobj`
/// splits lines on whitespace) is a fan of `k - 2`; any other line none.
fn line_triangles(line: &[u8]) -> u64 {
    let mut words = line
        .split(|c| c.is_ascii_whitespace())
        .filter(|w| !w.is_empty());
    if words.next() != Some(b"f".as_slice()) {
        return 0;
    }
    (words.count() as u64).saturating_sub(2)
}

/// The triangles of OBJ text, counted line by line until `limit` is passed.
fn count_in(bytes: &[u8], limit: u64) -> u64 {
    let mut count = 0u64;
    for line in bytes.split(|&c| c == b'\n') {
        count = count.saturating_add(line_triangles(line));
        if count > limit {
            break;
        }
    }
    count
}

/// The triangles of the OBJ at `path` and whether that is the whole count: faces counted in
/// one pass over the file, line by line, stopping past [`MAX_MESH_TRIANGLES`].
pub fn count_triangles(path: &Path) -> std::io::Result<(u64, bool, &'static str)> {
    const HOW: &str = "OBJ faces counted without parsing";
    let file = std::fs::File::open(path)?;
    let len = file.metadata()?.len();
    let mut reader = std::io::BufReader::with_capacity(1 << 16, std::io::Read::take(file, len));
    let mut line = Vec::new();
    let mut count = 0u64;
    loop {
        line.clear();
        if reader.read_until(b'\n', &mut line)? == 0 {
            return Ok((count, true, HOW));
        }
        count = count.saturating_add(line_triangles(&line));
        if count > MAX_MESH_TRIANGLES {
            return Ok((count, false, HOW));
        }
    }
}

/// Parses an OBJ file's bytes, all objects and groups merged, welded. More than
/// [`MAX_MESH_TRIANGLES`] (faces counted first) is refused before parsing.
pub fn read_obj(bytes: &[u8]) -> Result<TriangleMesh, String> {
    let faces = count_in(bytes, MAX_MESH_TRIANGLES);
    check_triangle_count(
        faces,
        faces <= MAX_MESH_TRIANGLES,
        "OBJ faces counted before parsing",
    )?;
    // `..Default::default()` fills the fields behind tobj's optional `merging` and
    // `reordering` features (off here, but features are unified across a build).
    #[allow(clippy::needless_update)]
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
        ..Default::default()
    };
    let mut reader = std::io::BufReader::new(bytes);
    let (models, _materials) = tobj::load_obj_buf(&mut reader, &options, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    })
    .map_err(|e| format!("OBJ: {e}"))?;
    let mut vertices: Vec<Vector3<f64>> = Vec::new();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    for model in &models {
        let mesh = &model.mesh;
        let offset = index_u32(vertices.len())?;
        vertices.extend(
            mesh.positions
                .chunks_exact(3)
                .map(|p| Vector3::new(p[0], p[1], p[2])),
        );
        index_u32(vertices.len())?;
        if mesh.indices.len() % 3 != 0 {
            return Err(format!(
                "object `{}`: {} face indices, not a multiple of 3 after triangulation",
                model.name,
                mesh.indices.len()
            ));
        }
        triangles.extend(
            mesh.indices
                .chunks_exact(3)
                .map(|t| [t[0], t[1], t[2]].map(|i| i.saturating_add(offset))),
        );
    }
    Ok(weld_indexed(&vertices, &triangles))
}
