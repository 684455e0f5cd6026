//! [`ModelError`]: why a URDF could not be turned into a [`Model`](crate::model::Model) (or a
//! model cannot be simulated). The warnings of a load that succeeds are [`super::LoadWarning`]s
//! ([`super::lenient`]).

use crate::model::kinematics::KinematicsError;
use std::path::PathBuf;

/// Why a URDF could not be turned into a [`Model`](crate::model::Model) (or a model cannot
/// be simulated).
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
    #[error(
        "{}: no link has a positive mass: nothing to simulate ({})",
        .path.display(),
        MASSLESS_REMEDY
    )]
    NothingToSimulate { path: PathBuf },
}

/// What a refusal of a model without mass says (issue 32: the defect in the file and the key
/// that runs it anyway). Every link's `<mass>` being 0 (or no `<inertial>` at all) is how
/// pybullet_data marks a static object (`plane.urdf`, the tables, the trays): there is no
/// dynamics to integrate, but the links' shapes give a mass at a density.
pub const MASSLESS_REMEDY: &str = "every link's <inertial> has mass 0 or is missing, as pybullet \
     marks a static object; to run it anyway take the links' mass properties from their \
     geometry: `inertia = \"geometry\"` on the model (`--inertia geometry`), at its `density`";
