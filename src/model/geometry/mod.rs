//! Mass properties from geometry: closed triangle meshes ([`mesh`], read by [`mesh_io`]), the
//! URDF primitives ([`primitives`]), and a link's shapes summed ([`compose`]).

pub mod compose;
pub mod mesh;
pub mod mesh_io;
pub mod primitives;

pub use compose::{GeometryError, GeometryUsed, LinkGeometryMass, link_mass_properties};
