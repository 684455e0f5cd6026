//! Reading mesh files into [`TriangleMesh`]: STL (binary and ASCII), Wavefront OBJ, Collada DAE.
//!
//! | format | reader | notes |
//! |--------|--------|-------|
//! | STL | the `stl_io` crate, after sniffing binary vs ASCII here ([`stl`]) | triangle soup, welded |
//! | OBJ | the `tobj` crate, polygons triangulated as fans, all objects and groups merged ([`obj`]) | welded across groups |
//! | DAE | our own reader on `roxmltree` ([`dae`]) | `<unit>` applied, `<up_axis>` ignored (see [`dae`]) |
//!
//! The format comes from the extension, in any case. Every reader welds exactly equal vertices
//! ([`weld`]): STL stores each triangle's corners separately and OBJ/DAE files may repeat a
//! position across groups, and the topology checks of [`TriangleMesh::check`] compare vertices
//! by index. Coordinates are kept as written (no tolerance merging): a file whose neighbouring
//! triangles disagree on a corner in the last bit is reported open, not silently repaired.
//!
//! No reader checks topology; an empty file is an error ([`MeshError::Empty`] in the file).
//! Every error names the file.

pub mod dae;
pub mod obj;
pub mod stl;

pub use dae::{DaeOptions, UpAxis};

use super::mesh::{MeshError, TriangleMesh};
use nalgebra::Vector3;
use std::collections::HashMap;
use std::path::Path;

/// The mesh formats read, chosen by extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MeshFormat {
    Stl,
    Obj,
    Dae,
}

impl MeshFormat {
    /// From the file extension, in any case (`.STL`, `.Dae`, ...). `None` for anything else.
    pub fn from_path(path: &Path) -> Option<MeshFormat> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "stl" => Some(MeshFormat::Stl),
            "obj" => Some(MeshFormat::Obj),
            "dae" => Some(MeshFormat::Dae),
            _ => None,
        }
    }

    /// The name used in messages.
    pub fn name(self) -> &'static str {
        match self {
            MeshFormat::Stl => "STL",
            MeshFormat::Obj => "OBJ",
            MeshFormat::Dae => "Collada DAE",
        }
    }
}

/// Reads an STL (binary or ASCII), OBJ or Collada DAE file, in metres (DAE `<unit>` applied;
/// STL and OBJ carry no unit and are taken as metres, as URDF tools do), welded, not checked.
pub fn load_mesh(path: &Path) -> Result<TriangleMesh, MeshError> {
    let format = MeshFormat::from_path(path).ok_or_else(|| MeshError::UnknownFormat {
        path: path.to_path_buf(),
    })?;
    let bytes = std::fs::read(path).map_err(|e| MeshError::Read {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    let mesh = match format {
        MeshFormat::Stl => stl::read_stl(&bytes),
        MeshFormat::Obj => obj::read_obj(&bytes),
        MeshFormat::Dae => dae::read_dae(&bytes, &DaeOptions::default()),
    }
    .map_err(|message| MeshError::Parse {
        path: path.to_path_buf(),
        format: format.name(),
        message,
    })?;
    if mesh.triangles.is_empty() {
        return Err(MeshError::Empty.in_file(path));
    }
    Ok(mesh)
}

/// Merges exactly equal vertices (after mapping `-0.0` to `0.0`) and renumbers the triangles;
/// vertices come out in order of first use. Non-finite coordinates are kept, compared by bits.
pub fn weld(vertices: &[Vector3<f64>], triangles: &[[u32; 3]]) -> TriangleMesh {
    let mut index_of: HashMap<[u64; 3], u32> = HashMap::with_capacity(vertices.len());
    let mut welded: Vec<Vector3<f64>> = Vec::with_capacity(vertices.len());
    let mut renumber: Vec<Option<u32>> = vec![None; vertices.len()];
    let mut out = Vec::with_capacity(triangles.len());
    for t in triangles {
        let mut new = [0u32; 3];
        for (k, &i) in t.iter().enumerate() {
            let Some(v) = vertices.get(i as usize) else {
                // Out of range: keep an index past the end so that the check reports it.
                new[k] = u32::MAX;
                continue;
            };
            new[k] = *renumber[i as usize].get_or_insert_with(|| {
                // `+ 0.0` turns -0.0 into 0.0 and leaves everything else unchanged.
                let key = [
                    (v.x + 0.0).to_bits(),
                    (v.y + 0.0).to_bits(),
                    (v.z + 0.0).to_bits(),
                ];
                *index_of.entry(key).or_insert_with(|| {
                    welded.push(*v + Vector3::zeros());
                    (welded.len() - 1) as u32
                })
            });
        }
        out.push(new);
    }
    TriangleMesh {
        vertices: welded,
        triangles: out,
    }
}

/// Vertex count as a `u32` index, or a message when a file holds more than `u32::MAX`.
pub(crate) fn index_u32(n: usize) -> Result<u32, String> {
    u32::try_from(n).map_err(|_| format!("more than {} vertices", u32::MAX))
}
