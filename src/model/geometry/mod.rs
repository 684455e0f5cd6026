//! Mass properties from geometry: closed triangle meshes ([`mesh`], read by [`mesh_io`]) and the
//! URDF primitives ([`primitives`]).

pub mod mesh;
pub mod mesh_io;
pub mod primitives;
