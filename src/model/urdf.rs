//! Loading URDF files into a [`Model`]: urdf-rs for the parsing, plus an XML pre-scan with
//! roxmltree for what urdf-rs cannot tell or chokes on.
//!
//! What this adds to urdf-rs (see `design/urdf.md`):
//!
//! - **Missing versus zero inertial.** urdf-rs reads a link without `<inertial>` as mass 0 and
//!   zero inertia. The pre-scan records which links have the element: those without it get
//!   [`InertiaSource::Missing`] and `inertial: None`; an explicit `<mass value="0"/>` stays
//!   [`InertiaSource::Urdf`] with mass 0 and a problem on the link.
//! - **Inertial frame.** `<inertial><origin xyz rpy>`: `xyz` is the centre of mass in the link
//!   frame; the tensor `I'` is given in the frame rotated by `R = Rz(y) Ry(p) Rx(r)`, so the link
//!   frame tensor is `I = R I' Rᵀ`. `ixy`, `ixz`, `iyz` are the matrix entries themselves
//!   (`I'₀₁ = ixy`), not negated products of inertia.
//! - **Validation.** Every link's mass properties are checked ([`MassProperties::validate`]);
//!   findings go to `Link::problems` (loading succeeds so that `inspect` can show them all);
//!   [`Model::check_simulable`] turns them into an error for the simulator.
//! - **Errors name the file**, and the link/joint and rule when there is one. urdf-rs's own
//!   messages carry no element names; when urdf-rs fails, the pre-scan looks for the first
//!   link or joint it cannot read and names it.
//! - **`<texture/>` without `filename`** (valid for urdfdom, e.g. icub, romeo_laas_small) is an
//!   error in urdf-rs: such elements are cut out of the text before urdf-rs sees it (textures
//!   are not used by tumble).
//! - **Mesh URIs** are resolved by [`super::package`], never by urdf-rs (which needs ROS and
//!   panics without it). An unresolved visual mesh is a problem on the link, not an error.
//! - **Collision geometry** is kept (`Link::collisions`) for mass properties from geometry
//!   ([`super::policy`]); its defects are reported when it is used, not at load time.
//! - **The URDF's own values** stay in `Link::urdf_inertial` whatever an inertia policy later
//!   puts in `Link::inertial`.
//! - **Oddities urdfdom loads** (a misplaced XML declaration, `<plane>` geometry, identical
//!   repeated elements, a `"1 1 1 1"` mesh scale, a stray element in `<geometry>`, a mimic of a
//!   missing joint) load too, each with one [`LoadWarning`] in `Model::warnings`, unless
//!   [`Strictness::Strict`] asks for the refusal ([`lenient`]; docs/urdf.md).
//!
//! The steps of a load, one file each under `urdf/`: `prescan` (the XML before and around
//! urdf-rs), `locate` (naming the element urdf-rs could not read), `joints` (the tree and the
//! links' poses), `links` (mass properties and problems), `geometry` (visuals, collisions,
//! meshes); `error` holds [`ModelError`], `simulable` what is asked of a loaded [`Model`].

mod error;
mod geometry;
mod joints;
mod lenient;
mod links;
mod locate;
mod prescan;
mod simulable;

pub use error::{MASSLESS_REMEDY, ModelError};
pub use lenient::{LoadWarning, Oddity, Strictness};
pub use links::mass_properties_from_urdf;

use super::Model;
use super::confine::MeshAccess;
use geometry::Meshes;
use joints::{joints, link_indices, place_links};
use links::links;
use prescan::{checked_text, links_with_inertial, parse_robot_xml, read_robot};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// What a load varies in, besides the file: everything but the file has a default (no package
/// paths, the zero joint configuration, [`Strictness::Lenient`], meshes read from the default
/// folders only).
#[derive(Debug, Clone, Default)]
pub struct LoadOptions {
    /// Searched first for `package://` meshes (`--package-path`; see [`super::package`]).
    pub package_paths: Vec<PathBuf>,
    /// The joint configuration the links are placed at (joint name → rad or m; missing joints
    /// at 0; see [`super::kinematics::forward_kinematics`]).
    pub joint_positions: HashMap<String, f64>,
    /// Whether the oddities of [`lenient`] load (with warnings in `Model::warnings`) or are
    /// refused.
    pub strictness: Strictness,
    /// Folders mesh files may also be read from (`--allow-mesh-path`, the scene's folder and
    /// `allow_mesh_paths`; [`super::confine`]).
    pub mesh_access: MeshAccess,
}

/// Loads the URDF at `path` as `options` say (the defaults: [`LoadOptions::default`]).
pub fn load(path: &Path, options: &LoadOptions) -> Result<Model, ModelError> {
    let xml = crate::input::read_text(path, crate::input::URDF_MAX_BYTES).map_err(|error| {
        ModelError::Read {
            path: path.to_path_buf(),
            error,
        }
    })?;
    load_str(&xml, path, options)
}

/// [`load`] from text already read; `path` names the file in messages and anchors relative
/// mesh paths and the parent-folder package search.
pub fn load_str(xml: &str, path: &Path, options: &LoadOptions) -> Result<Model, ModelError> {
    let lenient = options.strictness == Strictness::Lenient;
    let mut warnings = Vec::new();
    let xml = checked_text(xml, path, lenient, &mut warnings)?;
    let doc = parse_robot_xml(&xml, path)?;
    let links_with_inertial = links_with_inertial(&doc);
    let robot = read_robot(&xml, &doc, path, lenient, &mut warnings)?;
    let index = link_indices(&robot, path)?;
    let (joints, missing_mimics) = joints(&robot, &index, lenient, path)?;
    warnings.extend(lenient::mimics_of_missing_joints(
        &doc,
        path,
        &missing_mimics,
    ));
    // In file order (stable: the warnings of one element keep the order of the rules).
    warnings.sort_by_key(|w| w.line);
    let (root, poses) = place_links(&robot, &joints, &options.joint_positions, path)?;
    let mut meshes = Meshes::new(path, &options.package_paths, &options.mesh_access);
    let links = links(&robot, poses, &links_with_inertial, &mut meshes);
    Ok(Model {
        name: robot.name.clone(),
        path: path.to_path_buf(),
        links,
        root,
        joints,
        warnings,
        meshes: meshes.uses,
    })
}
