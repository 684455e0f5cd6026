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

mod lenient;

pub use lenient::{LoadWarning, Oddity, Strictness};

use super::confine::{MeshAccess, MeshRoots, MeshStatus, MeshUse, Refusal};
use super::kinematics::{self, Joint, JointKind, KinematicsError, Mimic};
use super::package;
use super::{Collision, Geometry, InertiaSource, Link, MassProperties, Model, Visual};
use nalgebra::{Isometry3, Matrix3, Vector3};
use std::borrow::Cow;
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

/// Why a URDF could not be turned into a [`Model`] (or a model cannot be simulated).
/// Every message starts with the file.
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    /// (The I/O error is part of the message, not a `source`, so that `{:#}` does not print
    /// it twice.)
    #[error("{}: cannot read the file: {error}", .path.display())]
    Read {
        path: PathBuf,
        error: std::io::Error,
    },
    #[error("{}: not well-formed XML: {message}", .path.display())]
    Xml { path: PathBuf, message: String },
    /// Well-formed or not, XML whose parsing would take work out of proportion to its size
    /// (element nesting, entity expansion, text joining: [`crate::input::check_xml`]).
    #[error("{}: XML refused before parsing: {message}", .path.display())]
    XmlRefused { path: PathBuf, message: String },
    #[error(
        "{}: cannot parse URDF{}: {message}",
        .path.display(),
        .location.as_deref().map(|l| format!(" ({l})")).unwrap_or_default()
    )]
    Parse {
        path: PathBuf,
        /// The link or joint at fault and what is wrong with it, when the pre-scan found it.
        location: Option<String>,
        /// urdf-rs's message.
        message: String,
    },
    #[error("{}: the robot has no links", .path.display())]
    NoLinks { path: PathBuf },
    #[error("{}: link `{link}` is defined more than once (link names must be unique)", .path.display())]
    DuplicateLink { path: PathBuf, link: String },
    #[error("{}: joint `{joint}` is defined more than once (joint names must be unique)", .path.display())]
    DuplicateJoint { path: PathBuf, joint: String },
    #[error("{}: joint `{joint}`: {role} link `{link}` is not a link of the robot", .path.display())]
    UnknownLink {
        path: PathBuf,
        joint: String,
        role: &'static str,
        link: String,
    },
    #[error(
        "{}: link `{link}` is the child of more than one joint (`{first}` and `{second}`): \
         the joints must form a tree",
        .path.display()
    )]
    SeveralParents {
        path: PathBuf,
        link: String,
        first: String,
        second: String,
    },
    #[error(
        "{}: more than one root link ({}): exactly one link may be no joint's child",
        .path.display(),
        .roots.iter().map(|r| format!("`{r}`")).collect::<Vec<_>>().join(", ")
    )]
    SeveralRoots { path: PathBuf, roots: Vec<String> },
    #[error(
        "{}: the joints form a cycle ({}): the joints must form a tree",
        .path.display(),
        .links.iter().map(|r| format!("`{r}`")).collect::<Vec<_>>().join(" -> ")
    )]
    Cycle { path: PathBuf, links: Vec<String> },
    /// (The kinematics error is part of the message, not a `source`, so that `{:#}` does not
    /// print it twice.)
    #[error("{}: {error}", .path.display())]
    Configuration {
        path: PathBuf,
        error: KinematicsError,
    },
    #[error("{}: link `{link}` cannot be simulated: {rule}", .path.display())]
    NotSimulable {
        path: PathBuf,
        link: String,
        rule: String,
    },
    #[error("{}: no link has a positive mass: nothing to simulate", .path.display())]
    NothingToSimulate { path: PathBuf },
}

/// What a load varies in, besides the file: everything but the file has a default (no package
/// paths, the zero joint configuration, [`Strictness::Lenient`], meshes read from the default
/// folders only).
#[derive(Debug, Clone, Default)]
pub struct LoadOptions {
    /// Searched first for `package://` meshes (`--package-path`; see [`super::package`]).
    pub package_paths: Vec<PathBuf>,
    /// The joint configuration the links are placed at (joint name → rad or m; missing joints
    /// at 0; see [`kinematics::forward_kinematics`]).
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

/// The text as the pre-scan reads it: in lenient mode with misplaced XML declarations blanked
/// out (a warning each), then checked for XML whose parsing would take work out of proportion
/// to its size ([`crate::input::check_xml`]: [`ModelError::XmlRefused`]).
fn checked_text<'a>(
    xml: &'a str,
    path: &Path,
    lenient: bool,
    warnings: &mut Vec<LoadWarning>,
) -> Result<Cow<'a, str>, ModelError> {
    let xml = if lenient {
        lenient::blank_misplaced_declarations(xml, path, warnings)
    } else {
        xml.into()
    };
    crate::input::check_xml(&xml).map_err(|message| ModelError::XmlRefused {
        path: path.to_path_buf(),
        message,
    })?;
    Ok(xml)
}

/// How roxmltree parses a URDF: DTDs allowed (entities are bounded by
/// [`crate::input::check_xml`] first).
fn xml_options() -> roxmltree::ParsingOptions {
    roxmltree::ParsingOptions {
        allow_dtd: true,
        ..Default::default()
    }
}

/// The pre-scan's document: well-formed XML ([`ModelError::Xml`]) whose root element is
/// `<robot>` ([`ModelError::Parse`] otherwise).
fn parse_robot_xml<'a>(xml: &'a str, path: &Path) -> Result<roxmltree::Document<'a>, ModelError> {
    let doc = roxmltree::Document::parse_with_options(xml, xml_options()).map_err(|e| {
        ModelError::Xml {
            path: path.to_path_buf(),
            message: e.to_string(),
        }
    })?;
    let root = doc.root_element();
    if root.tag_name().name() != "robot" {
        return Err(ModelError::Parse {
            path: path.to_path_buf(),
            location: None,
            message: format!(
                "the root element is <{}>, expected <robot>",
                root.tag_name().name()
            ),
        });
    }
    Ok(doc)
}

/// The names of the links that have an `<inertial>` element (urdf-rs reads a missing one as
/// mass 0: only the pre-scan can tell [`InertiaSource::Missing`] from an explicit zero).
fn links_with_inertial<'a>(doc: &'a roxmltree::Document) -> HashSet<&'a str> {
    doc.root_element()
        .children()
        .filter(|n| n.has_tag_name("link"))
        .filter(|n| n.children().any(|c| c.has_tag_name("inertial")))
        .filter_map(|n| n.attribute("name"))
        .collect()
}

/// urdf-rs's reading of the text, after cutting out what it cannot read and URDF allows
/// (empty `<texture/>`s) and, in lenient mode, the oddities of [`lenient`] (a warning each).
/// When urdf-rs fails, [`ModelError::Parse`] names the first link or joint it cannot read
/// ([`locate_parse_problem`]), located in the text urdf-rs read (what the leniency fixed is no
/// longer a problem), with urdf-rs's message on one line.
fn read_robot(
    xml: &str,
    doc: &roxmltree::Document,
    path: &Path,
    lenient: bool,
    warnings: &mut Vec<LoadWarning>,
) -> Result<urdf_rs::Robot, ModelError> {
    let mut edits = empty_textures(doc);
    if lenient {
        let (more, found) = lenient::document_edits(doc, path);
        edits.extend(more);
        warnings.extend(found);
    }
    let cleaned = lenient::apply(xml, edits);
    urdf_rs::read_from_string(&cleaned).map_err(|e| ModelError::Parse {
        path: path.to_path_buf(),
        location: match &cleaned {
            Cow::Borrowed(_) => locate_parse_problem(doc),
            Cow::Owned(text) => {
                match roxmltree::Document::parse_with_options(text, xml_options()) {
                    Ok(edited) => locate_parse_problem(&edited),
                    Err(_) => locate_parse_problem(doc),
                }
            }
        },
        // urdf-rs's messages may span lines (serde-xml-rs token dumps): one line here.
        message: e
            .to_string()
            .split_whitespace()
            .collect::<Vec<_>>()
            .join(" "),
    })
}

/// Each link's index in file order, checking that there is at least one link
/// ([`ModelError::NoLinks`]) and that no name is used twice ([`ModelError::DuplicateLink`]).
fn link_indices<'r>(
    robot: &'r urdf_rs::Robot,
    path: &Path,
) -> Result<HashMap<&'r str, usize>, ModelError> {
    if robot.links.is_empty() {
        return Err(ModelError::NoLinks {
            path: path.to_path_buf(),
        });
    }
    let mut index: HashMap<&str, usize> = HashMap::new();
    for (i, link) in robot.links.iter().enumerate() {
        if index.insert(link.name.as_str(), i).is_some() {
            return Err(ModelError::DuplicateLink {
                path: path.to_path_buf(),
                link: link.name.clone(),
            });
        }
    }
    Ok(index)
}

/// A `<mimic>` dropped because the joint it mimics does not exist: (joint, mimicked joint).
type DroppedMimic<'r> = (&'r str, &'r str);

/// The joints in file order, their links by index: checks that no joint name is used twice
/// ([`ModelError::DuplicateJoint`]) and that parent and child are links of the robot
/// ([`ModelError::UnknownLink`]). Limits are kept for revolute and prismatic joints whose
/// upper bound is above the lower. In lenient mode a `<mimic>` of a joint that does not exist
/// is dropped and returned as a (joint, mimicked) pair for its warning.
fn joints<'r>(
    robot: &'r urdf_rs::Robot,
    index: &HashMap<&str, usize>,
    lenient: bool,
    path: &Path,
) -> Result<(Vec<Joint>, Vec<DroppedMimic<'r>>), ModelError> {
    let all_joint_names: HashSet<&str> = robot.joints.iter().map(|j| j.name.as_str()).collect();
    let mut joint_names = HashSet::new();
    let mut missing_mimics = Vec::new();
    let mut joints = Vec::with_capacity(robot.joints.len());
    for j in &robot.joints {
        if !joint_names.insert(j.name.as_str()) {
            return Err(ModelError::DuplicateJoint {
                path: path.to_path_buf(),
                joint: j.name.clone(),
            });
        }
        let find = |role: &'static str, name: &str| {
            index
                .get(name)
                .copied()
                .ok_or_else(|| ModelError::UnknownLink {
                    path: path.to_path_buf(),
                    joint: j.name.clone(),
                    role,
                    link: name.to_string(),
                })
        };
        joints.push(Joint {
            name: j.name.clone(),
            kind: JointKind::from(&j.joint_type),
            parent: find("parent", &j.parent.link)?,
            child: find("child", &j.child.link)?,
            parent_from_joint: kinematics::isometry_from_pose(&j.origin),
            axis: Vector3::from(j.axis.xyz.0),
            mimic: j
                .mimic
                .as_ref()
                .filter(|m| {
                    let keep = !lenient || all_joint_names.contains(m.joint.as_str());
                    if !keep {
                        missing_mimics.push((j.name.as_str(), m.joint.as_str()));
                    }
                    keep
                })
                .map(|m| Mimic {
                    joint: m.joint.clone(),
                    multiplier: m.multiplier.unwrap_or(1.0),
                    offset: m.offset.unwrap_or(0.0),
                }),
            limits: matches!(
                j.joint_type,
                urdf_rs::JointType::Revolute | urdf_rs::JointType::Prismatic
            )
            .then_some([j.limit.lower, j.limit.upper])
            .filter(|[lo, hi]| hi > lo),
        });
    }
    Ok((joints, missing_mimics))
}

/// The root link's index and every link's pose in the model (root link) frame at
/// `joint_positions`: checks that the joints form a tree with one root
/// ([`ModelError::SeveralParents`], [`ModelError::SeveralRoots`], [`ModelError::Cycle`]) and
/// that the configuration names joints that exist and can take it
/// ([`ModelError::Configuration`]).
fn place_links(
    robot: &urdf_rs::Robot,
    joints: &[Joint],
    joint_positions: &HashMap<String, f64>,
    path: &Path,
) -> Result<(usize, Vec<Isometry3<f64>>), ModelError> {
    let file = || path.to_path_buf();
    let names: Vec<String> = robot.links.iter().map(|l| l.name.clone()).collect();
    let tree_error = |e: KinematicsError| match e {
        KinematicsError::SeveralParents {
            link,
            first,
            second,
        } => ModelError::SeveralParents {
            path: file(),
            link,
            first,
            second,
        },
        KinematicsError::SeveralRoots { roots } => ModelError::SeveralRoots {
            path: file(),
            roots,
        },
        KinematicsError::Cycle { links } => ModelError::Cycle {
            path: file(),
            links,
        },
        error => ModelError::Configuration {
            path: file(),
            error,
        },
    };
    let (root_index, _) = kinematics::tree_order(&names, joints).map_err(tree_error)?;
    let poses =
        kinematics::forward_kinematics(&names, joints, joint_positions).map_err(tree_error)?;
    Ok((root_index, poses))
}

/// The named `<material>`s of the robot with a colour, by name (what a visual's
/// `<material name="..."/>` refers to).
fn materials(robot: &urdf_rs::Robot) -> HashMap<&str, [f32; 4]> {
    robot
        .materials
        .iter()
        .filter_map(|m| Some((m.name.as_str(), rgba(m.color.as_ref()?))))
        .collect()
}

/// The links in file order, each at its pose in `poses` (see [`link`]).
fn links<'a>(
    robot: &'a urdf_rs::Robot,
    poses: Vec<Isometry3<f64>>,
    links_with_inertial: &HashSet<&str>,
    meshes: &mut Meshes<'a>,
) -> Vec<Link> {
    let materials = materials(robot);
    robot
        .links
        .iter()
        .zip(poses)
        .map(|(l, model_from_link)| {
            let has_inertial = links_with_inertial.contains(l.name.as_str());
            link(l, model_from_link, has_inertial, &materials, meshes)
        })
        .collect()
}

/// One link: its mass properties from `<inertial>` when it has one
/// ([`InertiaSource::Urdf`], validated: [`MassProperties::validate`]) or none
/// ([`InertiaSource::Missing`]), its visuals and collisions with their meshes resolved and
/// confined. Its problems: the validation's findings, a pose that is not finite, bad visual
/// geometry, unresolved visual meshes, refused meshes (visual or collision).
fn link<'a>(
    l: &'a urdf_rs::Link,
    model_from_link: Isometry3<f64>,
    has_inertial: bool,
    materials: &HashMap<&str, [f32; 4]>,
    meshes: &mut Meshes<'a>,
) -> Link {
    let mut problems = Vec::new();
    meshes.link = &l.name;
    let first_mesh = meshes.uses.len();
    let (inertial, source) = if has_inertial {
        let mp = mass_properties_from_urdf(&l.inertial);
        problems.extend(mp.validate());
        (Some(mp), InertiaSource::Urdf)
    } else {
        (None, InertiaSource::Missing)
    };
    if !pose_is_finite(&model_from_link) {
        problems.push(NON_FINITE_POSE.to_string());
    }
    let visuals = l
        .visual
        .iter()
        .enumerate()
        .map(|(k, v)| visual(v, k, meshes, materials, &mut problems))
        .collect();
    let collisions = l
        .collision
        .iter()
        .enumerate()
        .map(|(k, c)| collision(c, k, meshes))
        .collect();
    // A refused mesh, visual or collision, is a problem of its link.
    problems.extend(meshes.uses[first_mesh..].iter().filter_map(|m| {
        let why = m.refusal()?;
        Some(format!("{}: mesh `{}`: {why}", m.element, m.uri))
    }));
    Link {
        name: l.name.clone(),
        model_from_link,
        inertial,
        source,
        problems,
        visuals,
        collisions,
        urdf_inertial: inertial,
        geometry_used: None,
        notes: Vec::new(),
    }
}

const NON_FINITE_POSE: &str = "pose in the model frame is not finite (a joint origin on the path from the root is NaN or infinite)";

fn pose_is_finite(pose: &nalgebra::Isometry3<f64>) -> bool {
    pose.translation.vector.iter().all(|x| x.is_finite())
        && pose.rotation.coords.iter().all(|x| x.is_finite())
}

/// Mass properties in the link frame from a URDF `<inertial>`:
/// `com = xyz`, `I = R I' Rᵀ` with `R = Rz(y) Ry(p) Rx(r)` from the inertial origin's `rpy` and
///
/// ```text
///      | ixx ixy ixz |
/// I' = | ixy iyy iyz |
///      | ixz iyz izz |
/// ```
pub fn mass_properties_from_urdf(inertial: &urdf_rs::Inertial) -> MassProperties {
    let i = &inertial.inertia;
    #[rustfmt::skip]
    let local = Matrix3::new(
        i.ixx, i.ixy, i.ixz,
        i.ixy, i.iyy, i.iyz,
        i.ixz, i.iyz, i.izz,
    );
    let r = kinematics::rotation_from_rpy(inertial.origin.rpy.0).to_rotation_matrix();
    let r = r.matrix();
    MassProperties {
        mass: inertial.mass.value,
        com: Vector3::from(inertial.origin.xyz.0),
        inertia: r * local * r.transpose(),
    }
}

fn rgba(color: &urdf_rs::Color) -> [f32; 4] {
    color.rgba.0.map(|c| c as f32)
}

/// How a load resolves and confines mesh URIs, and what it found (one [`MeshUse`] per
/// `<mesh>`, in file order).
struct Meshes<'a> {
    urdf_path: &'a Path,
    package_paths: &'a [PathBuf],
    ros_paths: Vec<PathBuf>,
    roots: MeshRoots,
    /// The link being read.
    link: &'a str,
    uses: Vec<MeshUse>,
}

impl<'a> Meshes<'a> {
    /// Resolution and confinement for the URDF at `urdf_path` (package paths first, then
    /// `ROS_PACKAGE_PATH`; the folders of [`MeshRoots`]), nothing found yet.
    fn new(urdf_path: &'a Path, package_paths: &'a [PathBuf], access: &MeshAccess) -> Self {
        let ros_paths = package::ros_package_path();
        Meshes {
            urdf_path,
            package_paths,
            roots: MeshRoots::new(urdf_path, package_paths, &ros_paths, access),
            ros_paths,
            link: "",
            uses: Vec::new(),
        }
    }
}

fn visual(
    v: &urdf_rs::Visual,
    k: usize,
    meshes: &mut Meshes,
    materials: &HashMap<&str, [f32; 4]>,
    problems: &mut Vec<String>,
) -> Visual {
    let label = match &v.name {
        Some(name) => format!("visual `{name}`"),
        None => format!("visual #{k}"),
    };
    let geometry = geometry(&v.geometry, &label, meshes, problems);
    let rgba = v.material.as_ref().and_then(|m| match &m.color {
        Some(c) => Some(rgba(c)),
        None => materials.get(m.name.as_str()).copied(),
    });
    Visual {
        name: v.name.clone(),
        link_from_visual: kinematics::isometry_from_pose(&v.origin),
        geometry,
        rgba,
    }
}

/// A `<collision>` element. Its geometry is only used for mass properties (inertia policy
/// `geometry` or `auto`, `inspect --compare`), so what is wrong with it (an unresolved mesh, a
/// zero size) is reported when it is used, not as a problem of the link at load time; a mesh
/// refused by [`super::confine`] is a problem of the link all the same.
fn collision(c: &urdf_rs::Collision, k: usize, meshes: &mut Meshes) -> Collision {
    let label = match &c.name {
        Some(name) => format!("collision `{name}`"),
        None => format!("collision #{k}"),
    };
    let mut unused = Vec::new();
    Collision {
        name: c.name.clone(),
        link_from_collision: kinematics::isometry_from_pose(&c.origin),
        geometry: geometry(&c.geometry, &label, meshes, &mut unused),
    }
}

/// A URDF geometry in SI units, with `package://` and relative mesh paths resolved and
/// confined ([`super::confine`]: a refused mesh gets no path); what is wrong with it goes to
/// `problems`, prefixed by `label` (refusals go to `meshes.uses` only).
fn geometry(
    g: &urdf_rs::Geometry,
    label: &str,
    meshes: &mut Meshes,
    problems: &mut Vec<String>,
) -> Geometry {
    let positive = |values: &[f64]| values.iter().all(|x| x.is_finite() && *x > 0.0);
    match g {
        urdf_rs::Geometry::Box { size } => {
            if !positive(&size.0) {
                problems.push(format!(
                    "{label}: box size {:?} must be positive and finite",
                    size.0
                ));
            }
            Geometry::Box {
                size: Vector3::from(size.0),
            }
        }
        urdf_rs::Geometry::Cylinder { radius, length } => {
            if !positive(&[*radius, *length]) {
                problems.push(format!(
                "{label}: cylinder radius {radius} and length {length} must be positive and finite"
            ));
            }
            Geometry::Cylinder {
                radius: *radius,
                length: *length,
            }
        }
        urdf_rs::Geometry::Capsule { radius, length } => {
            if !(positive(&[*radius]) && length.is_finite() && *length >= 0.0) {
                problems.push(format!(
                "{label}: capsule radius {radius} must be positive and length {length} non-negative"
            ));
            }
            Geometry::Capsule {
                radius: *radius,
                length: *length,
            }
        }
        urdf_rs::Geometry::Sphere { radius } => {
            if !positive(&[*radius]) {
                problems.push(format!(
                    "{label}: sphere radius {radius} must be positive and finite"
                ));
            }
            Geometry::Sphere { radius: *radius }
        }
        urdf_rs::Geometry::Mesh { filename, scale } => {
            let scale = scale.map_or(Vector3::repeat(1.0), |s| Vector3::from(s.0));
            if !scale.iter().all(|s| s.is_finite() && *s != 0.0) {
                problems.push(format!(
                    "{label}: mesh scale [{}, {}, {}] must be finite and non-zero",
                    scale.x, scale.y, scale.z
                ));
            }
            let (found, unresolved) = match package::resolve_detailed(
                filename,
                meshes.urdf_path,
                meshes.package_paths,
                &meshes.ros_paths,
            ) {
                Ok(path) => (Some(path), None),
                // A file that exists but must not be read (a device, a FIFO, over the size
                // cap) is kept, so that whoever reads it says why it cannot (`crate::input`),
                // unless it is outside the folders meshes are read from.
                Err(package::Unresolved::NotReadable { path, reason }) => (
                    Some(path.clone()),
                    Some(package::Unresolved::NotReadable { path, reason }),
                ),
                Err(why) => (None, Some(why)),
            };
            let mut unresolved_problem = || {
                unresolved.as_ref().map(|why| {
                    let sep = if *why == package::Unresolved::NotFound {
                        " "
                    } else {
                        ": "
                    };
                    problems.push(format!("{label}: mesh `{filename}`{sep}{why}"));
                    MeshStatus::Unresolved(why.to_string())
                })
            };
            let (path, real_path, status) = match found.as_ref().map(|p| meshes.roots.check(p)) {
                Some(Ok((real, root))) => {
                    let allowed = MeshStatus::Allowed {
                        root: root.to_string(),
                    };
                    let status = unresolved_problem().unwrap_or(allowed);
                    (found.clone(), Some(real), status)
                }
                Some(Err(refusal)) => {
                    let real = match &refusal {
                        Refusal::Outside { real_path, .. } => Some(real_path.clone()),
                        Refusal::NoRealPath { .. } => None,
                    };
                    (None, real, MeshStatus::Refused(refusal))
                }
                None => {
                    let status = unresolved_problem()
                        .unwrap_or_else(|| MeshStatus::Unresolved(String::new()));
                    (None, None, status)
                }
            };
            meshes.uses.push(MeshUse {
                link: meshes.link.to_string(),
                element: label.to_string(),
                uri: filename.clone(),
                path: found,
                real_path,
                status,
            });
            Geometry::Mesh {
                uri: filename.clone(),
                path,
                scale,
            }
        }
    }
}

/// Edits cutting `<texture>` elements without a `filename` out of the text (urdf-rs requires
/// the attribute; urdfdom does not, so this is valid URDF and needs no warning).
fn empty_textures(doc: &roxmltree::Document) -> Vec<lenient::Edit> {
    doc.descendants()
        .filter(|n| n.has_tag_name("texture") && n.attribute("filename").is_none())
        .map(|n| lenient::Edit {
            range: n.range(),
            text: String::new(),
        })
        .collect()
}

/// After urdf-rs failed: find the first link or joint whose content urdf-rs cannot read,
/// mirroring urdf-rs's requirements (required elements and attributes, numbers and vectors).
/// Best effort: `None` when nothing specific is found.
fn locate_parse_problem(doc: &roxmltree::Document) -> Option<String> {
    let robot = doc.root_element();
    let version_1_2 = robot
        .attribute("version")
        .and_then(|v| v.trim().split_once('.'))
        .and_then(|(a, b)| Some((a.parse::<u32>().ok()?, b.parse::<u32>().ok()?)))
        .is_some_and(|v| v >= (1, 2));
    for node in robot.children().filter(|n| n.is_element()) {
        let tag = node.tag_name().name();
        let what = match tag {
            "link" | "joint" | "material" => tag,
            _ => continue,
        };
        let name = node.attribute("name");
        let problem = match name {
            None => Some(format!("a <{what}> has no `name` attribute")),
            Some(_) => match what {
                "link" => check_link(node),
                "joint" => check_joint(node, version_1_2),
                _ => check_material(node),
            },
        };
        if let Some(p) = problem {
            return Some(match name {
                Some(n) => format!("{what} `{n}`: {p}"),
                None => p,
            });
        }
    }
    None
}

type Check = Option<String>;

fn child<'a, 'i>(node: roxmltree::Node<'a, 'i>, tag: &str) -> Option<roxmltree::Node<'a, 'i>> {
    node.children().find(|c| c.has_tag_name(tag))
}

fn check_number(node: roxmltree::Node, attr: &str, required: bool) -> Check {
    match node.attribute(attr) {
        None if required => Some(format!(
            "<{}> has no `{attr}` attribute",
            node.tag_name().name()
        )),
        None => None,
        Some(v) if v.trim().parse::<f64>().is_err() => Some(format!(
            "<{}> {attr}=\"{v}\" is not a number",
            node.tag_name().name()
        )),
        Some(_) => None,
    }
}

fn check_vector(node: roxmltree::Node, attr: &str, n: usize, required: bool) -> Check {
    match node.attribute(attr) {
        None if required => Some(format!(
            "<{}> has no `{attr}` attribute",
            node.tag_name().name()
        )),
        None => None,
        Some(v) => {
            let count = v
                .split_whitespace()
                .filter(|s| s.parse::<f64>().is_ok())
                .count();
            let words = v.split_whitespace().count();
            (count != n || words != n).then(|| {
                format!(
                    "<{}> {attr}=\"{v}\" is not {n} numbers",
                    node.tag_name().name()
                )
            })
        }
    }
}

fn check_origin(node: roxmltree::Node) -> Check {
    let origin = child(node, "origin")?;
    check_vector(origin, "xyz", 3, false).or_else(|| check_vector(origin, "rpy", 3, false))
}

fn check_required(node: roxmltree::Node, tag: &str) -> Result<(), String> {
    match child(node, tag) {
        Some(_) => Ok(()),
        None => Err(format!("<{}> has no <{tag}>", node.tag_name().name())),
    }
}

/// The first of `tags` that appears more than once among `node`'s children (urdf-rs refuses
/// a repeated field with "duplicate field", naming neither the element nor where it is). Says
/// when the copies differ (identical copies load leniently: [`lenient`]).
fn check_unique(node: roxmltree::Node, tags: &[&str]) -> Check {
    tags.iter().find_map(|&tag| {
        let copies: Vec<roxmltree::Node> =
            node.children().filter(|c| c.has_tag_name(tag)).collect();
        (copies.len() > 1).then(|| {
            let differ = if copies[1..]
                .iter()
                .all(|c| lenient::same_content(copies[0], *c))
            {
                ""
            } else {
                "; the copies differ, so which one is meant is unclear"
            };
            format!(
                "<{}> has more than one <{tag}> (at most one is allowed{differ})",
                node.tag_name().name()
            )
        })
    })
}

fn check_link(link: roxmltree::Node) -> Check {
    if let Some(p) = check_unique(link, &["inertial"]) {
        return Some(p);
    }
    if let Some(inertial) = child(link, "inertial") {
        if let Some(p) = check_unique(inertial, &["origin", "mass", "inertia"]) {
            return Some(format!("inertial {p}"));
        }
        if let Some(p) = check_origin(inertial) {
            return Some(format!("inertial {p}"));
        }
        match child(inertial, "mass") {
            None => return Some("<inertial> has no <mass>".into()),
            Some(mass) => {
                if let Some(p) = check_number(mass, "value", true) {
                    return Some(p);
                }
            }
        }
        match child(inertial, "inertia") {
            None => return Some("<inertial> has no <inertia>".into()),
            Some(inertia) => {
                for attr in ["ixx", "ixy", "ixz", "iyy", "iyz", "izz"] {
                    if let Some(p) = check_number(inertia, attr, true) {
                        return Some(p);
                    }
                }
            }
        }
    }
    // Numbered per kind (the first collision is #0 even after visuals), as in the link's
    // problems and the load warnings.
    let (mut visuals, mut collisions) = (0, 0);
    for element in link
        .children()
        .filter(|c| c.has_tag_name("visual") || c.has_tag_name("collision"))
    {
        let counter = if element.has_tag_name("visual") {
            &mut visuals
        } else {
            &mut collisions
        };
        let k = *counter;
        *counter += 1;
        let label = format!(
            "<{}> #{k}{}",
            element.tag_name().name(),
            element
                .attribute("name")
                .map(|n| format!(" `{n}`"))
                .unwrap_or_default()
        );
        let problem = check_unique(element, &["origin", "geometry", "material"])
            .or_else(|| check_origin(element))
            .or_else(|| check_geometry(element).err())
            .or_else(|| {
                child(element, "material")
                    .filter(|_| element.has_tag_name("visual"))
                    .and_then(check_material)
            });
        if let Some(p) = problem {
            return Some(format!("{label}: {p}"));
        }
    }
    None
}

fn check_geometry(element: roxmltree::Node) -> Result<(), String> {
    check_required(element, "geometry")?;
    let geometry = child(element, "geometry").ok_or_else(String::new)?;
    let Some(shape) = geometry.children().find(|c| c.is_element()) else {
        return Err("<geometry> is empty".into());
    };
    let problem = match shape.tag_name().name() {
        "box" => check_vector(shape, "size", 3, true),
        "cylinder" | "capsule" => {
            check_number(shape, "radius", true).or_else(|| check_number(shape, "length", true))
        }
        "sphere" => check_number(shape, "radius", true),
        "mesh" => shape
            .attribute("filename")
            .is_none()
            .then(|| "<mesh> has no `filename` attribute".to_string())
            .or_else(|| check_vector(shape, "scale", 3, false)),
        other => Some(format!("unknown geometry <{other}>")),
    };
    if let Some(p) = problem {
        return Err(p);
    }
    match geometry.children().filter(|c| c.is_element()).nth(1) {
        Some(extra) => Err(format!(
            "<geometry> holds <{}> after its <{}> (URDF allows one shape there)",
            extra.tag_name().name(),
            shape.tag_name().name()
        )),
        None => Ok(()),
    }
}

fn check_material(material: roxmltree::Node) -> Check {
    if material.attribute("name").is_none() {
        return Some("<material> has no `name` attribute".into());
    }
    child(material, "color").and_then(|c| check_vector(c, "rgba", 4, true))
}

fn check_joint(joint: roxmltree::Node, version_1_2: bool) -> Check {
    const TYPES: [&str; 7] = [
        "revolute",
        "continuous",
        "prismatic",
        "fixed",
        "floating",
        "planar",
        "spherical",
    ];
    match joint.attribute("type") {
        None => return Some("<joint> has no `type` attribute".into()),
        Some(t) if !TYPES.contains(&t) => {
            return Some(format!(
                "unknown joint type `{t}` (expected one of {})",
                TYPES.join(", ")
            ));
        }
        Some(_) => {}
    }
    let single = [
        "parent",
        "child",
        "origin",
        "axis",
        "limit",
        "dynamics",
        "mimic",
        "safety_controller",
        "calibration",
    ];
    if let Some(p) = check_unique(joint, &single) {
        return Some(p);
    }
    for role in ["parent", "child"] {
        match child(joint, role) {
            None => return Some(format!("<joint> has no <{role}>")),
            Some(n) if n.attribute("link").is_none() => {
                return Some(format!("<{role}> has no `link` attribute"));
            }
            Some(_) => {}
        }
    }
    if let Some(p) = check_origin(joint) {
        return Some(p);
    }
    if let Some(p) = child(joint, "axis").and_then(|a| check_vector(a, "xyz", 3, true)) {
        return Some(p);
    }
    if let Some(limit) = child(joint, "limit") {
        for attr in ["lower", "upper", "effort"] {
            if let Some(p) = check_number(limit, attr, false) {
                return Some(p);
            }
        }
        if let Some(p) = check_number(limit, "velocity", !version_1_2) {
            return Some(p);
        }
    }
    if let Some(mimic) = child(joint, "mimic") {
        if mimic.attribute("joint").is_none() {
            return Some("<mimic> has no `joint` attribute".into());
        }
        for attr in ["multiplier", "offset"] {
            if let Some(p) = check_number(mimic, attr, false) {
                return Some(p);
            }
        }
    }
    if let Some(s) = child(joint, "safety_controller")
        && let Some(p) = check_number(s, "k_velocity", true)
    {
        return Some(p);
    }
    None
}

impl Model {
    /// Index of the link named `name`.
    pub fn link_index(&self, name: &str) -> Option<usize> {
        self.links.iter().position(|l| l.name == name)
    }

    /// Whether any link has a problem (validation finding, unresolved mesh, bad visual).
    pub fn has_problems(&self) -> bool {
        self.links.iter().any(|l| !l.problems.is_empty())
    }

    /// Errors, naming the file, link and rule, when a link that should become a body cannot:
    /// a link with an `<inertial>` and a mass other than 0 whose mass properties break a rule of
    /// [`MassProperties::validate`] (negative or NaN mass, non-finite values, not positive
    /// definite, triangle inequality) or whose pose is not finite; or when no link has a
    /// positive mass at all. Links without `<inertial>` or with mass exactly 0 are frames, not
    /// bodies, and are skipped. Visual problems (unresolved meshes) do not block simulation.
    /// `allow_non_physical_inertia` waives the triangle-inequality rule only (the user's opt-in,
    /// `allow_non_physical_inertia = true` on a scene's `[[model]]`); when that rule is what
    /// fails, the error says how to opt in.
    pub fn check_simulable(&self, allow_non_physical_inertia: bool) -> Result<(), ModelError> {
        for link in &self.links {
            let Some(mp) = &link.inertial else { continue };
            if mp.mass == 0.0 {
                continue;
            }
            let mut rules = mp.validate_with(allow_non_physical_inertia);
            if !allow_non_physical_inertia && rules.len() == 1 && mp.breaks_triangle_inequality() {
                rules[0].push_str(
                    "; to simulate it anyway set allow_non_physical_inertia = true on its [[model]] \
                     (or pass --allow-non-physical-inertia)",
                );
            }
            if !pose_is_finite(&link.model_from_link) {
                rules.push(NON_FINITE_POSE.to_string());
            }
            if !rules.is_empty() {
                return Err(ModelError::NotSimulable {
                    path: self.path.clone(),
                    link: link.name.clone(),
                    rule: rules.join("; "),
                });
            }
        }
        if !self.links.iter().any(Link::has_mass) {
            return Err(ModelError::NothingToSimulate {
                path: self.path.clone(),
            });
        }
        Ok(())
    }

    /// The whole model as one rigid body in the model (root link) frame: the sum of the links
    /// with a positive mass ([`Link::has_mass`]), each moved by its `model_from_link`. Inertia
    /// about the total centre of mass, model axes. `None` when no link has mass.
    pub fn total_mass_properties(&self) -> Option<MassProperties> {
        let parts: Vec<MassProperties> = self
            .links
            .iter()
            .filter(|l| l.has_mass())
            .filter_map(|l| Some(l.inertial?.transformed(&l.model_from_link)))
            .collect();
        MassProperties::combine(&parts)
    }
}
