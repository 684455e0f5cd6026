//! Reading mesh files into [`TriangleMesh`] (SKELETON: issue 5 fills it in).

use super::mesh::{MeshError, TriangleMesh};
use std::path::Path;

/// Reads an STL (binary or ASCII), OBJ or Collada DAE file, in metres, z up.
pub fn load_mesh(path: &Path) -> Result<TriangleMesh, MeshError> {
    Err(MeshError::Other(format!(
        "{}: mesh reading is not implemented yet",
        path.display()
    )))
}
