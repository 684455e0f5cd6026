//! Reading mesh files into [`TriangleMesh`]: STL (binary and ASCII), Wavefront OBJ, Collada DAE.
//!
//! | format | reader | notes |
//! |--------|--------|-------|
//! | STL | the `stl_io` crate, after sniffing binary vs ASCII here ([`stl`]) | triangle soup, welded |
//! | OBJ | the `tobj` crate, polygons triangulated as fans, all objects and groups merged ([`obj`]) | welded across groups |
//! | DAE | our own reader on `roxmltree` ([`dae`]) | `<unit>` applied, `<up_axis>` ignored (see [`dae`]) |
//!
//! The format comes from the extension, in any case. Every reader welds equal vertices
//! ([`weld`]): STL stores each triangle's corners separately and OBJ/DAE files may repeat a
//! position across groups, and the topology checks of [`TriangleMesh::check`] compare vertices
//! by index. Equal means bit-equal, or within 1e-12 of the mesh size
//! ([`WELD_RELATIVE_TOLERANCE`], for the `4e-20`-instead-of-`0` round-off CAD exporters write);
//! real gaps and cracks stay, and are reported by the topology checks, not repaired.
//!
//! No reader checks topology; an empty file is an error ([`MeshError::Empty`] in the file).
//! Every error names the file.

pub mod dae;
pub mod obj;
pub mod stl;

pub use dae::{DaeOptions, UpAxis};

use super::mesh::{MeshError, TriangleMesh};
use crate::model::MassProperties;
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
    load_mesh_file(path).map(|(_, mesh)| mesh)
}

/// [`load_mesh`], also returning the bytes read: the very bytes the mesh was read from (what a
/// recording may embed as the file: only bytes this reader accepted, read once).
pub fn load_mesh_file(path: &Path) -> Result<(Vec<u8>, TriangleMesh), MeshError> {
    // What the file is (regular, under the size cap) before what its name says.
    crate::input::check(path, crate::input::MESH_MAX_BYTES).map_err(|e| MeshError::Read {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    let format = MeshFormat::from_path(path).ok_or_else(|| MeshError::UnknownFormat {
        path: path.to_path_buf(),
    })?;
    let bytes = crate::input::read_bytes(path, crate::input::MESH_MAX_BYTES).map_err(|e| {
        MeshError::Read {
            path: path.to_path_buf(),
            message: e.to_string(),
        }
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
    Ok((bytes, mesh))
}

/// Vertices closer than `WELD_RELATIVE_TOLERANCE · D` (per coordinate; `D` the diagonal of the
/// bounding box of the used vertices) are one vertex.
///
/// Why not exact equality alone: CAD exporters write round-off for coordinates that are zero,
/// e.g. `4e-20` in one triangle and `0` in its neighbour. In `example-robot-data` 6.0.0, 51 of
/// the meshes that exact welding leaves open (solo, bolt, allegro, finger_edu, g1 hands, tiago
/// hey5, z1, ...) close with this tolerance, and no closed mesh becomes non-manifold (measured:
/// exact 0, 1e-12 +51 closed; 1e-7 would close 10 more but turn 5 open meshes non-manifold).
/// 1e-12 is far below the precision of the files themselves (an `f32` STL resolves 6e-8 of its
/// size; an OBJ or DAE rarely more than 1e-9), so it merges only points the file cannot tell
/// apart at its own scale, and moves them by at most 1e-12 D.
pub const WELD_RELATIVE_TOLERANCE: f64 = 1e-12;

/// Mass properties of the solid a mesh file bounds, scaled per axis by `scale` (a URDF
/// `<mesh scale>`) at `density` (kg/m^3): [`load_mesh`], [`TriangleMesh::scaled`],
/// [`TriangleMesh::mass_properties`], with every error naming the file.
pub fn load_mass_properties(
    path: &Path,
    scale: &Vector3<f64>,
    density: f64,
) -> Result<MassProperties, MeshError> {
    load_mesh(path)?
        .scaled(scale)
        .mass_properties(density)
        .map_err(|e| e.in_file(path))
}

/// Merges equal vertices and renumbers the triangles; vertices come out in order of first use.
///
/// Equal means bit-equal after mapping `-0.0` to `0.0`, or within [`WELD_RELATIVE_TOLERANCE`] of
/// the mesh size in every coordinate (each vertex joins the first earlier one within the
/// tolerance). Non-finite coordinates are compared by bits only. Indices out of range are kept
/// out of range, for [`TriangleMesh::check`] to report.
pub fn weld(vertices: &[Vector3<f64>], triangles: &[[u32; 3]]) -> TriangleMesh {
    let finite = |v: &Vector3<f64>| v.iter().all(|x| x.is_finite());
    let (mut lo, mut hi) = (
        Vector3::repeat(f64::INFINITY),
        Vector3::repeat(f64::NEG_INFINITY),
    );
    for v in triangles
        .iter()
        .flatten()
        .filter_map(|&i| vertices.get(i as usize))
        .filter(|v| finite(v))
    {
        lo = lo.inf(v);
        hi = hi.sup(v);
    }
    let tolerance = WELD_RELATIVE_TOLERANCE * (hi - lo).norm();
    let tolerance = if tolerance.is_finite() {
        tolerance
    } else {
        0.0
    };
    let mut exact: HashMap<[u64; 3], u32> = HashMap::with_capacity(vertices.len());
    // Tolerance grid: cell of side `tolerance` -> welded vertices in it.
    let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
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
                let v = v + Vector3::zeros();
                let key = v.map(f64::to_bits).into();
                if let Some(&j) = exact.get(&key) {
                    return j;
                }
                let cell = (tolerance > 0.0 && finite(&v))
                    .then(|| v.map(|x| (x / tolerance).floor() as i64));
                if let Some(cell) = cell {
                    let near = neighbour_cells(cell)
                        .filter_map(|c| grid.get(&c))
                        .flatten()
                        .find(|&&j| (welded[j as usize] - v).amax() <= tolerance);
                    if let Some(&j) = near {
                        exact.insert(key, j);
                        return j;
                    }
                }
                let j = welded.len() as u32;
                welded.push(v);
                exact.insert(key, j);
                if let Some(cell) = cell {
                    grid.entry(cell.into()).or_default().push(j);
                }
                j
            });
        }
        out.push(new);
    }
    TriangleMesh {
        vertices: welded,
        triangles: out,
    }
}

/// The 27 grid cells around and including `cell`.
fn neighbour_cells(cell: Vector3<i64>) -> impl Iterator<Item = [i64; 3]> {
    (0..27).map(move |n| {
        let d = Vector3::new(n % 3 - 1, (n / 3) % 3 - 1, n / 9 - 1);
        cell.zip_map(&d, i64::saturating_add).into()
    })
}

/// Vertex count as a `u32` index, or a message when a file holds more than `u32::MAX`.
pub(crate) fn index_u32(n: usize) -> Result<u32, String> {
    u32::try_from(n).map_err(|_| format!("more than {} vertices", u32::MAX))
}
