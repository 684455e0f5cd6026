//! Is a triangle mesh the boundary of a solid? Edge counts, vertex and index checks.
//!
//! Every triangle `[i, j, k]` uses the directed edges `i→j`, `j→k`, `k→i`. A closed,
//! consistently oriented 2-manifold uses every undirected edge exactly twice, once in each
//! direction (the two neighbouring triangles traverse it oppositely). So, per undirected edge:
//!
//! | uses | directions            | finding                                        |
//! |------|-----------------------|------------------------------------------------|
//! | 1    | –                     | boundary edge: the mesh is open (has holes)    |
//! | 2    | one each way          | fine                                           |
//! | 2    | both the same way     | misoriented: neighbours wound oppositely       |
//! | > 2  | –                     | non-manifold (e.g. two solids sharing an edge) |
//!
//! The same rule as trimesh's `is_watertight`/`is_winding_consistent` and parry's
//! `TriMesh::topology` checks. Vertices are compared by index only: files that store triangle
//! soup (STL) are welded on reading (see [`crate::model::geometry::mesh_io`]).

use super::{MeshError, TriangleMesh};

/// What [`TriangleMesh::check`] found. Counts only; [`MeshReport::error`] turns them into the
/// first error that stops mass-property integration.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct MeshReport {
    /// Vertices in the mesh (used or not).
    pub vertices: usize,
    /// Triangles in the mesh, including the skipped ones.
    pub triangles: usize,
    /// Triangles naming a vertex index `>= vertices`.
    pub out_of_range_triangles: usize,
    /// Vertices used by some triangle with a NaN or infinite coordinate.
    pub non_finite_vertices: usize,
    /// Triangles repeating a vertex index (`[a, a, b]`): no area, skipped.
    pub repeated_index_triangles: usize,
    /// Undirected edges of the kept triangles.
    pub edges: usize,
    /// Edges used by one triangle only.
    pub boundary_edges: usize,
    /// Edges used by more than two triangles.
    pub non_manifold_edges: usize,
    /// Edges used by two triangles in the same direction.
    pub misoriented_edges: usize,
}

impl MeshReport {
    /// Whether the mesh is a closed, consistently oriented 2-manifold with valid vertices (the
    /// sign of the volume is checked later, by integration).
    pub fn is_closed_manifold(&self) -> bool {
        self.error().is_none()
    }

    /// Triangles that take part in integration and edge counting.
    pub fn kept_triangles(&self) -> usize {
        self.triangles - self.repeated_index_triangles - self.out_of_range_triangles
    }

    /// The first finding that makes the mesh unusable, in this order: indices out of range,
    /// non-finite vertices, no triangles, open, non-manifold, inconsistently oriented.
    pub fn error(&self) -> Option<MeshError> {
        if self.out_of_range_triangles > 0 {
            Some(MeshError::IndexOutOfRange {
                triangles: self.out_of_range_triangles,
                vertices: self.vertices,
            })
        } else if self.non_finite_vertices > 0 {
            Some(MeshError::NonFiniteVertices {
                vertices: self.non_finite_vertices,
            })
        } else if self.kept_triangles() == 0 {
            Some(MeshError::Empty)
        } else if self.boundary_edges > 0 {
            Some(MeshError::Open {
                boundary_edges: self.boundary_edges,
            })
        } else if self.non_manifold_edges > 0 {
            Some(MeshError::NonManifold {
                edges: self.non_manifold_edges,
            })
        } else if self.misoriented_edges > 0 {
            Some(MeshError::InconsistentOrientation {
                edges: self.misoriented_edges,
            })
        } else {
            None
        }
    }
}

/// Whether a triangle takes part in integration: in range and three distinct indices.
pub(super) fn is_kept(triangle: &[u32; 3], vertex_count: usize) -> bool {
    let [a, b, c] = *triangle;
    let in_range = triangle.iter().all(|&i| (i as usize) < vertex_count);
    in_range && a != b && b != c && c != a
}

/// See [`TriangleMesh::check`].
pub(super) fn check(mesh: &TriangleMesh) -> MeshReport {
    let vertex_count = mesh.vertices.len();
    let mut report = MeshReport {
        vertices: vertex_count,
        triangles: mesh.triangles.len(),
        ..MeshReport::default()
    };
    let mut used = vec![false; vertex_count];
    // Directed edges as (undirected key, direction): key = min << 32 | max, `forward` when the
    // edge runs from min to max. Sorting groups the uses of each undirected edge.
    let mut edges: Vec<(u64, bool)> = Vec::with_capacity(3 * mesh.triangles.len());
    for triangle in &mesh.triangles {
        if triangle.iter().any(|&i| i as usize >= vertex_count) {
            report.out_of_range_triangles += 1;
            continue;
        }
        if !is_kept(triangle, vertex_count) {
            report.repeated_index_triangles += 1;
            continue;
        }
        for k in 0..3 {
            let (from, to) = (triangle[k], triangle[(k + 1) % 3]);
            used[from as usize] = true;
            let (lo, hi) = (from.min(to), from.max(to));
            edges.push(((u64::from(lo) << 32) | u64::from(hi), from < to));
        }
    }
    report.non_finite_vertices = mesh
        .vertices
        .iter()
        .zip(&used)
        .filter(|(v, used)| **used && !v.iter().all(|x| x.is_finite()))
        .count();
    edges.sort_unstable();
    for run in edges.chunk_by(|a, b| a.0 == b.0) {
        report.edges += 1;
        match run.len() {
            1 => report.boundary_edges += 1,
            2 if run[0].1 == run[1].1 => report.misoriented_edges += 1,
            2 => {}
            _ => report.non_manifold_edges += 1,
        }
    }
    report
}
