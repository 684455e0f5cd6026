//! Models in: URDF loading and its oddities, the real-URDF corpus, hostile input, bounds, mesh
//! paths, fuzzing, meshes, mass properties and inertia policies, scenes, rigid models.
//!
//! One test binary (it links the library once); each module is a former `tests/<name>.rs`, its
//! tests named `<module>::<test>` (`cargo test --release --test model <module>::`).

#[path = "../common/mod.rs"]
mod common;

mod bounds;
mod contact;
mod corpus;
mod fuzz;
mod hostile;
mod mass_properties;
mod mesh;
mod mesh_paths;
mod policy;
mod rigid;
mod scene;
mod urdf;
mod urdf_lenient;
