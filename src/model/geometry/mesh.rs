//! Closed triangle meshes and their mass properties (SKELETON: issue 5 fills it in).

use crate::model::MassProperties;
use nalgebra::Vector3;

/// A triangle mesh in metres, in the frame of the geometry that holds it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TriangleMesh {
    pub vertices: Vec<Vector3<f64>>,
    /// Counter-clockwise seen from outside (outward normals by the right-hand rule).
    pub triangles: Vec<[u32; 3]>,
}

/// What is wrong with a mesh as the boundary of a solid.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeshError {
    #[error("{0}")]
    Other(String),
}

impl TriangleMesh {
    /// Scaled by `scale` (per axis; a negative determinant mirrors, and the winding is flipped
    /// so the mesh stays outward-facing).
    pub fn scaled(&self, _scale: &Vector3<f64>) -> TriangleMesh {
        unimplemented!("issue 5")
    }

    /// Mass properties of the solid the mesh bounds, at uniform `density` (kg/m^3).
    pub fn mass_properties(&self, _density: f64) -> Result<MassProperties, MeshError> {
        Err(MeshError::Other("not implemented".into()))
    }
}
