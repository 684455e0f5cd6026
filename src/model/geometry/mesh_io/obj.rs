//! Wavefront OBJ, parsed by the `tobj` crate (positions read as `f64`).
//!
//! Faces with more than three corners are triangulated by `tobj` as fans `(v0, vi, vi+1)`: for
//! a planar polygon the fan's signed volumes add up to the polygon's whatever its convexity,
//! and the fan's inner edges are used once each way, so topology and integrals are those of
//! the polygon. Points and lines are ignored. All objects (`o`) and groups (`g`) are merged into
//! one mesh and welded, so faces of different groups that share a position are connected.
//! Material libraries (`mtllib`) are not opened.

use super::{index_u32, weld};
use crate::model::geometry::mesh::TriangleMesh;
use nalgebra::Vector3;

/// Parses an OBJ file's bytes, all objects and groups merged, welded.
pub fn read_obj(bytes: &[u8]) -> Result<TriangleMesh, String> {
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
    Ok(weld(&vertices, &triangles))
}
