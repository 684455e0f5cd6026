//! Closed triangle meshes and the mass properties of the solid they bound.
//!
//! A [`TriangleMesh`] is an indexed triangle list in metres. [`TriangleMesh::mass_properties`]
//! checks that the mesh is the boundary of a solid ([`TriangleMesh::check`], the `topology`
//! submodule), then integrates volume, centre of mass and inertia from the triangles alone
//! (the `volume` submodule):
//!
//! ```text
//! per triangle (a, b, c), taken relative to a reference point p near the mesh:
//!   V_t = a · (b × c) / 6                              signed volume of the tetrahedron (p, a, b, c)
//!   V   = Σ V_t
//!   c   = Σ V_t (a + b + c) / 4 / V                    centroid (relative to p)
//!   C_p = Σ V_t / 20 (a aᵀ + b bᵀ + c cᵀ + s sᵀ)       s = a + b + c, covariance ∫ x xᵀ dV about p
//!   C   = C_p − V c cᵀ                                 covariance about the centroid
//!   I   = ρ (tr(C) E − C),  m = ρ V,  com = p + c
//! ```
//!
//! Decisions:
//! - **Open, non-manifold and inconsistently oriented meshes are errors** ([`MeshError::Open`],
//!   [`MeshError::NonManifold`], [`MeshError::InconsistentOrientation`]): the divergence theorem
//!   needs a closed, consistently oriented surface, and without it the numbers are silently wrong.
//!   (An OBJ or DAE that welding by position makes non-manifold only where its surface touches
//!   itself keeps its own indexing: `mesh_io::weld_indexed`.)
//! - **An inside-out mesh is an error too** ([`MeshError::InsideOut`]): a closed, consistently
//!   oriented mesh whose signed volume is negative has every triangle wound clockwise seen from
//!   outside. Flipping it silently would hide a broken export (or a mirroring scale applied
//!   twice); a caller who knows the file is inverted says so with [`TriangleMesh::flipped`].
//! - Triangles that repeat a vertex index (`[a, a, b]`) bound no area and are skipped (counted
//!   in [`MeshReport::repeated_index_triangles`]); zero-area triangles with three distinct
//!   vertices (slivers) are kept, they contribute nothing to the integrals.

mod topology;
mod volume;

pub use topology::MeshReport;
pub use volume::{DEGENERATE_VOLUME_RATIO, VolumeProperties};

use crate::model::MassProperties;
use nalgebra::{Isometry3, Vector3};
use std::path::{Path, PathBuf};

/// A triangle mesh in metres, in the frame of the geometry that holds it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TriangleMesh {
    pub vertices: Vec<Vector3<f64>>,
    /// Counter-clockwise seen from outside (outward normals by the right-hand rule).
    pub triangles: Vec<[u32; 3]>,
}

/// What is wrong with a mesh as the boundary of a solid, or with the file it came from.
///
/// Errors about a file name it ([`MeshError::Read`], [`MeshError::UnknownFormat`],
/// [`MeshError::Parse`], and [`MeshError::InFile`] around a geometry error found in a loaded
/// mesh, see [`MeshError::in_file`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeshError {
    /// The file could not be read (missing, permissions, I/O error).
    #[error("cannot read mesh {}: {message}", path.display())]
    Read { path: PathBuf, message: String },
    /// The extension is none of the formats read ([`super::mesh_io::MeshFormat`]).
    #[error(
        "{}: unknown mesh format (the extension must be .stl, .obj or .dae, in any case)",
        path.display()
    )]
    UnknownFormat { path: PathBuf },
    /// The file is not a valid file of its format (truncated, lying header, syntax).
    #[error("{}: not a valid {format} file: {message}", path.display())]
    Parse {
        path: PathBuf,
        format: &'static str,
        message: String,
    },
    /// The file holds more triangles than one mesh may ([`super::mesh_io::MAX_MESH_TRIANGLES`]):
    /// refused before it is read in full (binary STL: from its header) or parsed.
    #[error(
        "{}: {} mesh with {count}, over the cap of {} triangles per mesh (reading takes \
         about 560 bytes of memory per triangle): simplify it, e.g. \
         with MeshLab's \"Quadric Edge Collapse Decimation\" or Blender's Decimate modifier \
         (for inertia = \"geometry\" a coarse collision mesh gives the same mass properties)",
        path.display(),
        format,
        crate::budget::grouped(super::mesh_io::MAX_MESH_TRIANGLES)
    )]
    TooManyTriangles {
        path: PathBuf,
        format: &'static str,
        /// The count in words: `10,000,000 triangles (binary STL header)`, or `more than
        /// 2,000,000 triangles (...)` when counting stopped at the cap.
        count: String,
    },
    /// Reading this mesh would pass the triangles allowed for all the meshes one scene (or
    /// one model's mass properties) reads ([`super::mesh_io::MAX_SCENE_TRIANGLES`]).
    #[error(
        "{}: its {} triangles would bring the meshes read for this scene to {} triangles, \
         over the cap of {} per scene (every mesh load counts, a file used by many links once \
         per use): use fewer or simpler meshes, or inertia = \"urdf\" for links whose \
         <inertial> is right",
        path.display(),
        crate::budget::grouped(*count),
        crate::budget::grouped(*total),
        crate::budget::grouped(super::mesh_io::MAX_SCENE_TRIANGLES)
    )]
    SceneTriangles {
        path: PathBuf,
        count: u64,
        total: u64,
    },
    /// A geometry error found in the mesh read from `path`.
    #[error("{}: {error}", path.display())]
    InFile {
        path: PathBuf,
        error: Box<MeshError>,
    },
    /// No triangles at all (after skipping those that repeat a vertex index).
    #[error("empty mesh: no triangles")]
    Empty,
    /// Triangles that name a vertex index past the end of the vertex list.
    #[error("{triangles} triangles index past the {vertices} vertices (corrupt index list)")]
    IndexOutOfRange { triangles: usize, vertices: usize },
    /// Vertices used by triangles with a NaN or infinite coordinate.
    #[error("{vertices} vertices have NaN or infinite coordinates")]
    NonFiniteVertices { vertices: usize },
    /// Edges used by one triangle only: the surface has holes and bounds no solid.
    #[error(
        "open mesh: {boundary_edges} boundary edges (edges of one triangle only); the surface \
         has holes and bounds no solid"
    )]
    Open { boundary_edges: usize },
    /// Edges shared by more than two triangles.
    #[error(
        "non-manifold mesh: {edges} edges shared by more than two triangles; the surface does \
         not bound a single solid"
    )]
    NonManifold { edges: usize },
    /// Edges used twice in the same direction: two neighbouring triangles wound oppositely.
    #[error(
        "inconsistently oriented mesh: {edges} edges used twice in the same direction \
         (neighbouring triangles wound oppositely)"
    )]
    InconsistentOrientation { edges: usize },
    /// Closed and consistently oriented, but every triangle is wound clockwise seen from
    /// outside (negative signed volume).
    #[error(
        "inside-out mesh: signed volume {volume_m3:e} m^3 is negative (triangles wound clockwise \
         seen from outside); if the file is known to be inverted, flip its winding"
    )]
    InsideOut { volume_m3: f64 },
    /// The enclosed volume is zero to round-off (flat mesh, zero scale, all vertices equal).
    #[error(
        "degenerate mesh: encloses no volume ({volume_m3:e} m^3, at most {limit_m3:e} m^3 of \
         round-off for its size)"
    )]
    Degenerate { volume_m3: f64, limit_m3: f64 },
    /// The density is not a positive finite number.
    #[error("density must be positive and finite, got {density_kg_per_m3} kg/m^3")]
    InvalidDensity { density_kg_per_m3: f64 },
    /// Anything else.
    #[error("{0}")]
    Other(String),
}

impl MeshError {
    /// This error as found in the mesh read from `path` (unchanged when it already names a file).
    pub fn in_file(self, path: &Path) -> MeshError {
        match self {
            MeshError::Read { .. }
            | MeshError::UnknownFormat { .. }
            | MeshError::Parse { .. }
            | MeshError::TooManyTriangles { .. }
            | MeshError::SceneTriangles { .. }
            | MeshError::InFile { .. } => self,
            error => MeshError::InFile {
                path: path.to_path_buf(),
                error: Box::new(error),
            },
        }
    }

    /// The geometry error, without the file it was found in.
    pub fn root(&self) -> &MeshError {
        match self {
            MeshError::InFile { error, .. } => error.root(),
            other => other,
        }
    }
}

impl TriangleMesh {
    /// Scaled by `scale` per axis: vertex `v` becomes `(sx vx, sy vy, sz vz)`.
    ///
    /// A negative determinant `sx sy sz < 0` mirrors the mesh: each triangle `[a, b, c]` becomes
    /// `[a, c, b]` so that the mesh stays outward-facing and its volume positive. A zero scale
    /// flattens the mesh; [`TriangleMesh::mass_properties`] then reports it as degenerate.
    pub fn scaled(&self, scale: &Vector3<f64>) -> TriangleMesh {
        let vertices = self
            .vertices
            .iter()
            .map(|v| v.component_mul(scale))
            .collect();
        let mirrored = scale.x * scale.y * scale.z < 0.0;
        TriangleMesh {
            vertices,
            triangles: if mirrored {
                self.flipped().triangles
            } else {
                self.triangles.clone()
            },
        }
    }

    /// The same surface with every triangle's winding reversed (`[a, b, c]` → `[a, c, b]`):
    /// the explicit fix for a mesh known to be inside-out.
    pub fn flipped(&self) -> TriangleMesh {
        TriangleMesh {
            vertices: self.vertices.clone(),
            triangles: self.triangles.iter().map(|&[a, b, c]| [a, c, b]).collect(),
        }
    }

    /// Moved rigidly: vertex `v` becomes `b_from_mesh · v`.
    pub fn transformed(&self, b_from_mesh: &Isometry3<f64>) -> TriangleMesh {
        TriangleMesh {
            vertices: self
                .vertices
                .iter()
                .map(|v| b_from_mesh.transform_point(&(*v).into()).coords)
                .collect(),
            triangles: self.triangles.clone(),
        }
    }

    /// Topology and vertex findings (never fails; see [`MeshReport`]).
    pub fn check(&self) -> MeshReport {
        topology::check(self)
    }

    /// Volume, centroid and second moments of the solid the mesh bounds (unit density), after
    /// the checks of [`MeshReport::error`] and the degenerate and inside-out checks.
    pub fn volume_properties(&self) -> Result<VolumeProperties, MeshError> {
        if let Some(error) = self.check().error() {
            return Err(error);
        }
        let props = volume::integrate(self);
        props.checked()
    }

    /// Mass properties of the solid the mesh bounds, at uniform `density` (kg/m^3): see the
    /// module documentation for the checks and equations.
    pub fn mass_properties(&self, density: f64) -> Result<MassProperties, MeshError> {
        if !(density.is_finite() && density > 0.0) {
            return Err(MeshError::InvalidDensity {
                density_kg_per_m3: density,
            });
        }
        Ok(self.volume_properties()?.mass_properties(density))
    }
}
