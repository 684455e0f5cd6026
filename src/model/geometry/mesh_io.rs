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

/// Most triangles one mesh file may hold: 2 million. The largest mesh of example-robot-data
/// 6.0.0 is a 29 MB DAE; reading costs about 560 bytes of memory per triangle at its peak (a
/// binary STL of 10 million triangles, 500 MB and under the size cap, took 5.6 GiB and 125 s
/// to simulate before this cap: issue 28), so a mesh at the cap takes about 1.1 GiB. Binary
/// STL is judged from its header before the rest of the file is read; ASCII STL and OBJ are
/// counted before parsing, DAE while its geometry is placed, each refused once past the cap
/// ([`MeshError::TooManyTriangles`]).
pub const MAX_MESH_TRIANGLES: u64 = 2_000_000;

/// Most triangles all the meshes read for one scene may hold together: 10 million (five
/// meshes at [`MAX_MESH_TRIANGLES`]), every load counted (a file used by many links counts
/// once per use). Counted while a [`TriangleBudget`] is open: for the mass properties of the
/// models of one scene (`crate::scene::Scene::build`) or of one model (`inspect`); the
/// triangles a recording draws, every copy counted, are bounded by the same figure
/// (`crate::scene::triangles`).
pub const MAX_SCENE_TRIANGLES: u64 = 10_000_000;

/// What the mesh readers return when a mesh passes [`MAX_MESH_TRIANGLES`] (the message after
/// this prefix is the count in words); [`load_mesh_file`] turns it into
/// [`MeshError::TooManyTriangles`].
pub(crate) const TOO_MANY_TRIANGLES: &str = "too many triangles: ";

/// The reader error for a mesh of `count` (in words) triangles, over the cap.
pub(crate) fn too_many_triangles(count: String) -> String {
    format!("{TOO_MANY_TRIANGLES}{count}")
}

/// `Err` (a [`too_many_triangles`] message) when `count` passes [`MAX_MESH_TRIANGLES`]; `exact`
/// says whether `count` is the whole count or where counting stopped, `how` how it was found.
pub(crate) fn check_triangle_count(count: u64, exact: bool, how: &str) -> Result<(), String> {
    if count <= MAX_MESH_TRIANGLES {
        return Ok(());
    }
    Err(too_many_triangles(if exact {
        format!("{} triangles ({how})", crate::budget::grouped(count))
    } else {
        format!(
            "more than {} triangles ({how})",
            crate::budget::grouped(count.saturating_sub(1))
        )
    }))
}

thread_local! {
    /// The open [`TriangleBudget`] of this thread: triangles read so far.
    static BUDGET: std::cell::Cell<Option<u64>> = const { std::cell::Cell::new(None) };
}

/// While one is alive, every mesh this thread reads counts against [`MAX_SCENE_TRIANGLES`];
/// past it, the load fails with [`MeshError::SceneTriangles`]. Opening one inside another
/// keeps counting in the outer one (a scene's budget covers its models').
#[must_use = "the budget closes when dropped"]
pub struct TriangleBudget {
    outermost: bool,
}

impl TriangleBudget {
    /// Opens a budget for this thread (or joins the one already open).
    pub fn open() -> Self {
        let outermost = BUDGET.with(|b| {
            if b.get().is_none() {
                b.set(Some(0));
                true
            } else {
                false
            }
        });
        TriangleBudget { outermost }
    }

    /// Triangles read so far under the open budget (`None`: none is open).
    pub fn used() -> Option<u64> {
        BUDGET.with(std::cell::Cell::get)
    }
}

impl Drop for TriangleBudget {
    fn drop(&mut self) {
        if self.outermost {
            BUDGET.with(|b| b.set(None));
        }
    }
}

/// Counts `count` triangles of `path` against the open budget, if any.
fn charge(path: &Path, count: u64) -> Result<(), MeshError> {
    BUDGET.with(|b| {
        let Some(used) = b.get() else {
            return Ok(());
        };
        let total = used.saturating_add(count);
        if total > MAX_SCENE_TRIANGLES {
            return Err(MeshError::SceneTriangles {
                path: path.to_path_buf(),
                count,
                total,
            });
        }
        b.set(Some(total));
        Ok(())
    })
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
    let parse_error = |message: String| match message.strip_prefix(TOO_MANY_TRIANGLES) {
        Some(count) => MeshError::TooManyTriangles {
            path: path.to_path_buf(),
            format: format.name(),
            count: count.to_string(),
        },
        None => MeshError::Parse {
            path: path.to_path_buf(),
            format: format.name(),
            message,
        },
    };
    if format == MeshFormat::Stl {
        // A binary STL over the cap is refused from its header, before its body is read.
        stl::check_header(path).map_err(parse_error)?;
    }
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
    .map_err(parse_error)?;
    if mesh.triangles.is_empty() {
        return Err(MeshError::Empty.in_file(path));
    }
    charge(path, mesh.triangles.len() as u64)?;
    Ok((bytes, mesh))
}

/// The triangles `path` holds, without building the mesh where the format allows: a binary
/// STL's header (84 bytes read), an ASCII STL's `endfacet`s and an OBJ's faces counted in one
/// pass over the file (64 KiB at a time); a DAE is read ([`load_mesh`], its node transforms
/// may instance geometry). Errors as [`load_mesh`]'s, [`MeshError::TooManyTriangles`] past
/// [`MAX_MESH_TRIANGLES`]; not counted against a [`TriangleBudget`].
pub fn count_triangles(path: &Path) -> Result<u64, MeshError> {
    crate::input::check(path, crate::input::MESH_MAX_BYTES).map_err(|e| MeshError::Read {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    let format = MeshFormat::from_path(path).ok_or_else(|| MeshError::UnknownFormat {
        path: path.to_path_buf(),
    })?;
    let read_error = |e: std::io::Error| MeshError::Read {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let over = |count: String| MeshError::TooManyTriangles {
        path: path.to_path_buf(),
        format: format.name(),
        count,
    };
    let counted = match format {
        MeshFormat::Stl => stl::count_triangles(path).map_err(read_error)?,
        MeshFormat::Obj => obj::count_triangles(path).map_err(read_error)?,
        MeshFormat::Dae => {
            let budget = BUDGET.with(|b| b.replace(None));
            let mesh = load_mesh(path);
            BUDGET.with(|b| b.set(budget));
            return Ok(mesh?.triangles.len() as u64);
        }
    };
    match check_triangle_count(counted.0, counted.1, counted.2) {
        Ok(()) => Ok(counted.0),
        Err(message) => Err(over(
            message
                .strip_prefix(TOO_MANY_TRIANGLES)
                .unwrap_or(&message)
                .to_string(),
        )),
    }
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

/// [`weld`] for the formats that index their vertices (OBJ, DAE): the welded mesh, unless
/// welding is what breaks it. A surface that touches itself (two sheets of one solid meeting
/// along an edge, or the hulls of a convex decomposition sharing a corner edge) is written
/// with distinct vertices on each sheet; welding by position joins them, and the joined edge
/// is used by four triangles: "non-manifold". The file's own indices, though, close each
/// sheet, and the divergence theorem needs only that (a closed, consistently oriented surface
/// as a cycle of triangles; where it touches itself in space does not enter the integrals).
/// So when the welded mesh is not a closed 2-manifold but the file's indexing is, the file's
/// indexing is kept (unused vertices dropped).
///
/// Not when welding makes two triangles coincide with the same winding: solids written on top
/// of each other (the same box exported three times) share whole faces, and their volumes
/// would be counted once per copy; the welded mesh keeps reporting them as non-manifold. Two
/// solids touching along a face (hulls of a decomposition) wind it oppositely: kept.
///
/// Issue 32: pybullet_data's laikago chassis (a V-HACD decomposition, 5 such edges, one face
/// shared by two hulls) and 28 of its 1000 `random_urdfs` objects (1 to 7 edges) were refused
/// as non-manifold although every triangle of theirs has its neighbours by index.
pub fn weld_indexed(vertices: &[Vector3<f64>], triangles: &[[u32; 3]]) -> TriangleMesh {
    let welded = weld(vertices, triangles);
    let report = welded.check();
    if report.is_closed_manifold() || report.non_manifold_edges == 0 {
        return welded;
    }
    // Coincident triangles wound the same way after welding: stacked solids, not a surface
    // touching itself (two solids touching along a face wind it oppositely). Each triangle is
    // rotated to start at its smallest index, which keeps its winding.
    let mut faces: Vec<[u32; 3]> = welded
        .triangles
        .iter()
        .map(|t| {
            let k = (0..3).min_by_key(|&k| t[k]).unwrap_or(0);
            [t[k], t[(k + 1) % 3], t[(k + 2) % 3]]
        })
        .collect();
    faces.sort_unstable();
    if faces.windows(2).any(|w| w[0] == w[1]) {
        return welded;
    }
    // The file's indexing, its used vertices renumbered in order of first use.
    let mut renumber: Vec<Option<u32>> = vec![None; vertices.len()];
    let mut kept: Vec<Vector3<f64>> = Vec::new();
    let mut out = Vec::with_capacity(triangles.len());
    for t in triangles {
        out.push(t.map(|i| match vertices.get(i as usize) {
            Some(v) => *renumber[i as usize].get_or_insert_with(|| {
                kept.push(*v);
                (kept.len() - 1) as u32
            }),
            None => u32::MAX,
        }));
    }
    let as_indexed = TriangleMesh {
        vertices: kept,
        triangles: out,
    };
    if as_indexed.check().is_closed_manifold() {
        as_indexed
    } else {
        welded
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A binary STL of `n` triangles as written by [`stl`]'s layout: 84-byte header with the
    /// count, then `n` zeroed 50-byte records (the content does not matter to the caps).
    fn binary_stl_header(n: u32) -> Vec<u8> {
        let mut bytes = vec![0u8; 84];
        bytes[80..84].copy_from_slice(&n.to_le_bytes());
        bytes
    }

    /// The cap is inclusive, and the message gives the count as counted.
    #[test]
    fn triangle_count_check() {
        assert_eq!(check_triangle_count(MAX_MESH_TRIANGLES, true, "x"), Ok(()));
        assert_eq!(
            check_triangle_count(MAX_MESH_TRIANGLES + 1, true, "header"),
            Err("too many triangles: 2,000,001 triangles (header)".into())
        );
        assert_eq!(
            check_triangle_count(MAX_MESH_TRIANGLES + 1, false, "counted"),
            Err("too many triangles: more than 2,000,000 triangles (counted)".into())
        );
    }

    /// A binary STL is judged from its header alone, at the size that header implies: a
    /// sparse file of 10^7 records (500 MB, nothing on disk) is refused without being read; at
    /// the cap (100 MB) it passes; a header count that does not match the size is not judged
    /// here (the reader says what is wrong with such a file).
    #[test]
    fn binary_stl_headers() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.stl");
        let sized = |n: u32, len: u64| {
            std::fs::write(&path, binary_stl_header(n)).unwrap();
            std::fs::OpenOptions::new()
                .write(true)
                .open(&path)
                .unwrap()
                .set_len(len)
                .unwrap();
        };
        sized(10_000_000, 84 + 50 * 10_000_000);
        let started = std::time::Instant::now();
        let e = stl::check_header(&path).unwrap_err();
        assert!(started.elapsed().as_secs_f64() < 1.0);
        assert_eq!(
            e,
            "too many triangles: 10,000,000 triangles (binary STL header, file not read)"
        );
        let e = load_mesh(&path).unwrap_err();
        assert!(
            matches!(&e, MeshError::TooManyTriangles { format: "STL", .. }),
            "{e}"
        );
        assert!(e.to_string().contains("big.stl: STL mesh with 10,000,000 triangles (binary STL header, file not read), over the cap of 2,000,000 triangles per mesh"), "{e}");
        assert_eq!(
            stl::count_triangles(&path).unwrap(),
            (10_000_000, true, "binary STL header, file not read")
        );
        assert!(matches!(
            count_triangles(&path),
            Err(MeshError::TooManyTriangles { .. })
        ));
        sized(2_000_000, 84 + 50 * 2_000_000);
        assert_eq!(stl::check_header(&path), Ok(()));
        assert_eq!(count_triangles(&path).unwrap(), 2_000_000);
        // The header claims 10^7 but the file is 84 + 50 bytes: not a binary STL of 10^7.
        sized(10_000_000, 134);
        assert_eq!(stl::check_header(&path), Ok(()));
        assert_eq!(stl::count_triangles(&path).unwrap().0, 0);
    }

    /// ASCII STL facets and OBJ faces are counted before parsing; counting stops past the cap.
    #[test]
    fn text_formats_are_counted_before_parsing() {
        let over = (MAX_MESH_TRIANGLES + 1) as usize;
        let ascii = format!("solid a\n{}endsolid a\n", "  EndFacet\n".repeat(over));
        let e = stl::read_stl(ascii.as_bytes()).unwrap_err();
        assert_eq!(
            e,
            "too many triangles: more than 2,000,000 triangles (ASCII STL facets counted before parsing)"
        );
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.stl");
        std::fs::write(&path, &ascii).unwrap();
        assert_eq!(
            stl::count_triangles(&path).unwrap(),
            (
                MAX_MESH_TRIANGLES + 1,
                false,
                "ASCII STL facets counted without parsing"
            )
        );
        // A token split across the 64 KiB chunks of the count is still counted: 10 000
        // facets of 11 bytes span several chunks.
        let small = format!("solid a\n{}endsolid a\n", "  endfacet\n".repeat(10_000));
        std::fs::write(&path, &small).unwrap();
        assert_eq!(stl::count_triangles(&path).unwrap().0, 10_000);

        // OBJ: triangles and a fan, `f` lines only (not `vf`, `# f`).
        let path = dir.path().join("a.obj");
        std::fs::write(
            &path,
            "v 0 0 0\nf 1 2 3\nf 1 2 3 4 5\n# f 1 2 3\nvf 1 2 3\nf 1 2\n",
        )
        .unwrap();
        assert_eq!(obj::count_triangles(&path).unwrap().0, 4);
        let faces = format!("v 0 0 0\n{}", "f 1 1 1\n".repeat(over));
        let e = obj::read_obj(faces.as_bytes()).unwrap_err();
        assert_eq!(
            e,
            "too many triangles: more than 2,000,000 triangles (OBJ faces counted before parsing)"
        );
        // One polygon of 2 000 003 corners is a fan of 2 000 001 triangles.
        let corners: String = (0..MAX_MESH_TRIANGLES + 3).map(|_| " 1").collect();
        let fan = format!("v 0 0 0\nf{corners}\n");
        assert!(
            obj::read_obj(fan.as_bytes())
                .unwrap_err()
                .starts_with(TOO_MANY_TRIANGLES)
        );
        std::fs::write(&path, &fan).unwrap();
        assert_eq!(
            obj::count_triangles(&path).unwrap(),
            (
                MAX_MESH_TRIANGLES + 1,
                false,
                "OBJ faces counted without parsing"
            )
        );
    }

    /// A Collada `<triangles>` whose indices are more than the cap's worth is refused before
    /// they are parsed.
    #[test]
    fn dae_indices_are_counted_before_parsing() {
        let n = MAX_MESH_TRIANGLES as usize + 1;
        let dae = format!(
            r##"<COLLADA version="1.4.1"><library_geometries><geometry id="g"><mesh>
<source id="p"><float_array id="a" count="9">0 0 0 1 0 0 0 1 0</float_array>
<technique_common><accessor source="#a" count="3" stride="3"/></technique_common></source>
<vertices id="v"><input semantic="POSITION" source="#p"/></vertices>
<triangles count="{n}"><input semantic="VERTEX" source="#v" offset="0"/><p>{}</p></triangles>
</mesh></geometry></library_geometries></COLLADA>"##,
            "0 1 2 ".repeat(n)
        );
        let e = dae::read_dae(dae.as_bytes(), &DaeOptions::default()).unwrap_err();
        assert_eq!(
            e,
            "too many triangles: more than 2,000,000 triangles (placed by its visual scene, counted from its <p> indices before parsing them)"
        );
    }

    /// Loads under an open budget add up; past the cap the load fails naming the total; a
    /// budget opened inside another keeps counting in it; none is open after the outermost
    /// closes.
    #[test]
    fn the_budget_adds_up_every_load() {
        let path = Path::new("m.stl");
        assert_eq!(TriangleBudget::used(), None);
        assert_eq!(charge(path, u64::MAX), Ok(()));
        {
            let _outer = TriangleBudget::open();
            assert_eq!(charge(path, 6_000_000), Ok(()));
            {
                let _inner = TriangleBudget::open();
                assert_eq!(charge(path, 4_000_000), Ok(()));
                assert_eq!(TriangleBudget::used(), Some(MAX_SCENE_TRIANGLES));
            }
            assert_eq!(TriangleBudget::used(), Some(MAX_SCENE_TRIANGLES));
            let e = charge(path, 1).unwrap_err();
            assert_eq!(
                e,
                MeshError::SceneTriangles {
                    path: path.to_path_buf(),
                    count: 1,
                    total: MAX_SCENE_TRIANGLES + 1
                }
            );
            assert!(e.to_string().contains("m.stl: its 1 triangles would bring the meshes read for this scene to 10,000,001 triangles, over the cap of 10,000,000 per scene"), "{e}");
            // A refused load is not counted.
            assert_eq!(TriangleBudget::used(), Some(MAX_SCENE_TRIANGLES));
        }
        assert_eq!(TriangleBudget::used(), None);
    }
}
