//! Which mesh files tumble reads: every resolved mesh path is confined to a set of folders
//! (issue 28, item 3).
//!
//! A URDF names its mesh files, and a URDF from a stranger could name any file: an absolute
//! path, `../../..`, a `file://` URI, or a symbolic link inside its own folder pointing out of
//! it. Before this rule tumble read such a file and embedded it in the `.rrd`. Now a mesh is
//! read only when its **real path** (every symbolic link resolved, [`std::fs::canonicalize`])
//! lies inside the real path of one of these folders, its *roots*:
//!
//! | root | where it comes from |
//! |------|---------------------|
//! | the URDF's folder | the folder holding the URDF file (its real path); when that folder is named `urdf` (any case), the folder above it: the description layout `robot/urdf/robot.urdf` + `robot/meshes/` |
//! | the URDF's package | the nearest folder above the URDF holding a `package.xml` (the ROS package the URDF belongs to, e.g. example-robot-data's `share/example-robot-data`) |
//! | package paths | each `--package-path` folder (scene: `package_paths`) |
//! | `ROS_PACKAGE_PATH` | each entry of the environment variable |
//! | the scene's folder | the folder of the scene file, when the model comes from one |
//! | allowed folders | each `--allow-mesh-path DIR` and each entry of the `[[model]]`'s `allow_mesh_paths` (relative to the scene's folder) |
//!
//! "Inside" compares whole path components ([`is_inside`]): `/a/bc` is not inside `/a/b`. A
//! root that does not exist is no root. A mesh whose real path cannot be found (a dangling
//! link: then it was not found at all) is refused too.
//!
//! What a refusal does: the mesh is not read by anything (its
//! [`crate::model::Geometry::Mesh`] `path` is `None`), it is a problem of its link (so
//! `inspect` lists it and exits 1), it is listed in [`crate::model::Model::meshes`] with its
//! resolved and real paths, and [`crate::model::Model::check_meshes`] turns it into an error
//! (exit 2) for every command that simulates or records (`simulate`, `trade`, `stability`,
//! `bench`, `dataset`): no output file is created.
//!
//! The check is made when the URDF is loaded. A file swapped for another between the load and
//! the moment a recorder reads it (a concurrent writer in the model's folders) is outside this
//! rule's reach; what a recorder embeds is still only bytes tumble's own mesh reader accepted,
//! read once ([`crate::record::scene_update::MeshCache`]).

use std::path::{Path, PathBuf};

/// Where a model's loading may read meshes beyond its defaults (the URDF's folder and package,
/// the package paths, `ROS_PACKAGE_PATH`).
#[derive(Debug, Clone, Default, PartialEq, Eq, Hash)]
pub struct MeshAccess {
    /// `--allow-mesh-path` folders and the scene's `allow_mesh_paths` (relative ones are taken
    /// relative to the working directory: callers join scene entries to the scene's folder).
    pub allowed: Vec<PathBuf>,
    /// The folder of the scene file the model comes from (`None` for a URDF given directly).
    pub scene_folder: Option<PathBuf>,
}

/// What kind of folder a [`Root`] is (for messages).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RootKind {
    UrdfFolder,
    /// The parent of a URDF folder named `urdf` (`robot/urdf/robot.urdf` reaching
    /// `../meshes/`).
    UrdfLayout,
    UrdfPackage,
    PackagePath,
    RosPackagePath,
    SceneFolder,
    Allowed,
}

impl RootKind {
    /// The kind in words, as messages name it.
    pub fn describe(self) -> &'static str {
        match self {
            RootKind::UrdfFolder => "the URDF's folder",
            RootKind::UrdfLayout => "the folder holding the URDF's urdf/ folder",
            RootKind::UrdfPackage => "the URDF's package",
            RootKind::PackagePath => "package path",
            RootKind::RosPackagePath => "ROS_PACKAGE_PATH entry",
            RootKind::SceneFolder => "the scene's folder",
            RootKind::Allowed => "allowed folder",
        }
    }
}

/// One folder meshes may be read from, by its real path.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Root {
    pub kind: RootKind,
    pub path: PathBuf,
}

impl std::fmt::Display for Root {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} {}", self.kind.describe(), self.path.display())
    }
}

/// Why a resolved mesh is not read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Refusal {
    /// Its real path is inside no root.
    #[error(
        "{}{}: refused: {}",
        .path.display(),
        if .path == .real_path { String::new() } else {
            format!(" (real path {}, after resolving links)", .real_path.display())
        },
        self.reason()
    )]
    Outside {
        /// The file the URI resolved to, as found.
        path: PathBuf,
        /// Its real path.
        real_path: PathBuf,
        roots: Vec<Root>,
    },
    /// Its real path cannot be found (a dangling link, a permission denied on the way).
    #[error("{}: refused: {}", .path.display(), self.reason())]
    NoRealPath { path: PathBuf, error: String },
}

impl Refusal {
    /// Why, without the paths (which the [`std::fmt::Display`] text starts with).
    pub fn reason(&self) -> String {
        match self {
            Refusal::Outside { roots, .. } => format!(
                "outside the folders meshes are read from ({}); to read it, pass \
                 --allow-mesh-path DIR (scene: allow_mesh_paths = [\"DIR\"] in its [[model]]) \
                 with a folder holding it",
                list(roots)
            ),
            Refusal::NoRealPath { error, .. } => {
                format!("its real path cannot be found ({error})")
            }
        }
    }
}

fn list(roots: &[Root]) -> String {
    if roots.is_empty() {
        return "none".into();
    }
    roots
        .iter()
        .map(ToString::to_string)
        .collect::<Vec<_>>()
        .join(", ")
}

/// The folders one URDF's meshes may be read from, by their real paths.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct MeshRoots {
    roots: Vec<Root>,
}

/// Whether `path` is `root` or below it, comparing whole components (`/a/bc` is not inside
/// `/a/b`). Both should be real paths ([`std::fs::canonicalize`]): no `..`, no links.
pub fn is_inside(path: &Path, root: &Path) -> bool {
    path.starts_with(root)
}

/// The nearest folder at or above `dir` holding a `package.xml` (a ROS package's manifest).
fn enclosing_package(dir: &Path) -> Option<PathBuf> {
    dir.ancestors()
        .find(|a| a.join("package.xml").is_file())
        .map(Path::to_path_buf)
}

impl MeshRoots {
    /// The roots of the URDF at `urdf_path` (see the module documentation): its folder and
    /// package, `package_paths`, `ros_paths` (the `ROS_PACKAGE_PATH` entries) and `access`.
    pub fn new(
        urdf_path: &Path,
        package_paths: &[PathBuf],
        ros_paths: &[PathBuf],
        access: &MeshAccess,
    ) -> Self {
        let mut roots = MeshRoots::default();
        let urdf_folder = urdf_path
            .canonicalize()
            .ok()
            .and_then(|p| p.parent().map(Path::to_path_buf));
        if let Some(folder) = urdf_folder {
            if let Some(package) = enclosing_package(&folder) {
                roots.push(RootKind::UrdfPackage, &package);
            }
            match folder.parent() {
                Some(parent)
                    if folder
                        .file_name()
                        .is_some_and(|n| n.eq_ignore_ascii_case("urdf")) =>
                {
                    roots.push(RootKind::UrdfLayout, parent)
                }
                _ => roots.push(RootKind::UrdfFolder, &folder),
            }
        }
        for p in package_paths {
            roots.push(RootKind::PackagePath, p);
        }
        for p in ros_paths {
            roots.push(RootKind::RosPackagePath, p);
        }
        if let Some(scene) = &access.scene_folder {
            // An empty folder is the working directory: a scene named without a folder.
            let scene = if scene.as_os_str().is_empty() {
                Path::new(".")
            } else {
                scene
            };
            roots.push(RootKind::SceneFolder, scene);
        }
        for p in &access.allowed {
            roots.push(RootKind::Allowed, p);
        }
        roots
    }

    /// Adds `path` (by its real path) unless it does not exist or a root already holds it.
    fn push(&mut self, kind: RootKind, path: &Path) {
        let Ok(real) = path.canonicalize() else {
            return;
        };
        if self.roots.iter().any(|r| is_inside(&real, &r.path)) {
            return;
        }
        self.roots.push(Root { kind, path: real });
    }

    /// The roots, by real path, in the order of the module documentation's table (a folder
    /// inside an earlier one is left out).
    pub fn roots(&self) -> &[Root] {
        &self.roots
    }

    /// Whether the resolved mesh file `path` may be read: its real path and the root holding
    /// it, or why not.
    pub fn check(&self, path: &Path) -> Result<(PathBuf, &Root), Refusal> {
        let real_path = path.canonicalize().map_err(|e| Refusal::NoRealPath {
            path: path.to_path_buf(),
            error: e.to_string(),
        })?;
        match self.roots.iter().find(|r| is_inside(&real_path, &r.path)) {
            Some(root) => Ok((real_path, root)),
            None => Err(Refusal::Outside {
                path: path.to_path_buf(),
                real_path,
                roots: self.roots.clone(),
            }),
        }
    }
}

/// One `<mesh>` of a URDF and what became of it ([`crate::model::Model::meshes`], listed by
/// `inspect`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MeshUse {
    pub link: String,
    /// The element, as in link problems: `visual #0`, ``collision `name` ``.
    pub element: String,
    /// The `filename` as the URDF writes it.
    pub uri: String,
    /// The file it resolved to, as found (`None` when nothing was found).
    pub path: Option<PathBuf>,
    /// The real path of `path` (links resolved), when it has one.
    pub real_path: Option<PathBuf>,
    pub status: MeshStatus,
}

/// Whether a mesh is read.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum MeshStatus {
    /// Inside a root (the root, in words: ``the URDF's folder /r/urdf``): read when used.
    Allowed { root: String },
    /// Resolved, but refused by this module's rule: never read.
    Refused(Refusal),
    /// Not resolved (not found, malformed, escaping its package), or not a regular file of at
    /// most [`crate::input::MESH_MAX_BYTES`]: why, in words.
    Unresolved(String),
}

impl MeshUse {
    /// `Some` when the mesh was refused by the confinement rule.
    pub fn refusal(&self) -> Option<&Refusal> {
        match &self.status {
            MeshStatus::Refused(r) => Some(r),
            _ => None,
        }
    }
}

/// A mesh refused by the confinement rule, as an error ([`crate::model::Model::check_meshes`]).
#[derive(Debug, Clone, thiserror::Error)]
#[error(
    "{}: link `{}`: {}: mesh `{}`: {}{}",
    .file.display(),
    .mesh.link,
    .mesh.element,
    .mesh.uri,
    .mesh.refusal().map(ToString::to_string).unwrap_or_default(),
    match .more {
        0 => String::new(),
        1 => " (and 1 more mesh; `tumble inspect` lists them)".into(),
        n => format!(" (and {n} more meshes; `tumble inspect` lists them)"),
    }
)]
pub struct MeshRefused {
    /// The URDF.
    pub file: PathBuf,
    /// The first mesh refused.
    pub mesh: MeshUse,
    /// How many more were.
    pub more: usize,
}

impl crate::model::Model {
    /// An error naming the file, link, mesh and paths of the first mesh refused by the
    /// confinement rule (and how many more were), if any: what commands that simulate or
    /// record call right after loading.
    pub fn check_meshes(&self) -> Result<(), Box<MeshRefused>> {
        let mut refused = self.meshes.iter().filter(|m| m.refusal().is_some());
        match refused.next() {
            None => Ok(()),
            Some(first) => Err(Box::new(MeshRefused {
                file: self.path.clone(),
                mesh: first.clone(),
                more: refused.count(),
            })),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(path: &Path, text: &str) {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, text).unwrap();
    }

    #[test]
    fn inside_compares_whole_components() {
        assert!(is_inside(Path::new("/a/b/c.stl"), Path::new("/a/b")));
        assert!(is_inside(Path::new("/a/b"), Path::new("/a/b")));
        assert!(is_inside(Path::new("/a/b/c.stl"), Path::new("/")));
        assert!(!is_inside(Path::new("/a/bc"), Path::new("/a/b")));
        assert!(!is_inside(Path::new("/a/bc/x.stl"), Path::new("/a/b")));
        assert!(!is_inside(Path::new("/a"), Path::new("/a/b")));
        assert!(!is_inside(Path::new("/x/a/b"), Path::new("/a/b")));
    }

    #[test]
    fn roots_are_real_paths_and_nested_ones_are_dropped() {
        let tmp = tempfile::tempdir().unwrap();
        let base = tmp.path().canonicalize().unwrap();
        let urdf = base.join("pkg/urdf/robot.urdf");
        write(&urdf, "<robot/>");
        write(&base.join("pkg/package.xml"), "<package/>");
        std::fs::create_dir_all(base.join("share")).unwrap();
        std::fs::create_dir_all(base.join("other")).unwrap();
        let access = MeshAccess {
            allowed: vec![base.join("other/../other"), base.join("missing")],
            scene_folder: Some(base.join("pkg/urdf")),
        };
        let roots = MeshRoots::new(
            &urdf,
            &[base.join("share"), base.join("pkg/meshes-not-there")],
            &[base.join("pkg")],
            &access,
        );
        let got: Vec<(RootKind, PathBuf)> = roots
            .roots()
            .iter()
            .map(|r| (r.kind, r.path.clone()))
            .collect();
        // The package holds the URDF's folder, the ROS entry and the scene's folder; the
        // missing folders are no roots; `other/../other` is `other`.
        assert_eq!(
            got,
            vec![
                (RootKind::UrdfPackage, base.join("pkg")),
                (RootKind::PackagePath, base.join("share")),
                (RootKind::Allowed, base.join("other")),
            ]
        );
        assert_eq!(
            roots.roots()[0].to_string(),
            format!("the URDF's package {}", base.join("pkg").display())
        );
    }

    #[test]
    fn without_a_package_the_urdf_folder_is_the_root() {
        let tmp = tempfile::tempdir().unwrap();
        let base = tmp.path().canonicalize().unwrap();
        let urdf = base.join("robot/model/robot.urdf");
        write(&urdf, "<robot/>");
        let roots = MeshRoots::new(&urdf, &[], &[], &MeshAccess::default());
        assert_eq!(
            roots.roots(),
            &[Root {
                kind: RootKind::UrdfFolder,
                path: base.join("robot/model"),
            }]
        );
        // A folder named `urdf` (any case): the folder above it (`robot/meshes` beside it).
        for folder in ["urdf", "URDF"] {
            let urdf = base.join(format!("{folder}_robot/{folder}/robot.urdf"));
            write(&urdf, "<robot/>");
            let roots = MeshRoots::new(&urdf, &[], &[], &MeshAccess::default());
            assert_eq!(
                roots.roots(),
                &[Root {
                    kind: RootKind::UrdfLayout,
                    path: base.join(format!("{folder}_robot")),
                }]
            );
        }
        // Only the folder's own name counts.
        let urdf = base.join("urdf/x/robot.urdf");
        write(&urdf, "<robot/>");
        let roots = MeshRoots::new(&urdf, &[], &[], &MeshAccess::default());
        assert_eq!(roots.roots()[0].path, base.join("urdf/x"));
        // A URDF that does not exist has no folder root.
        let none = MeshRoots::new(&base.join("nope/r.urdf"), &[], &[], &MeshAccess::default());
        assert!(none.roots().is_empty());
    }

    #[cfg(unix)]
    #[test]
    fn links_are_resolved_before_the_check() {
        let tmp = tempfile::tempdir().unwrap();
        let base = tmp.path().canonicalize().unwrap();
        let urdf = base.join("robot/robot.urdf");
        write(&urdf, "<robot/>");
        write(&base.join("robot/meshes/a.obj"), "v 0 0 0\n");
        write(&base.join("secret/s.txt"), "secret\n");
        write(&base.join("robotic/b.obj"), "v 0 0 0\n");
        let link = |target: &Path, name: &str| {
            let at = base.join("robot").join(name);
            std::os::unix::fs::symlink(target, &at).unwrap();
            at
        };
        let out = link(&base.join("secret/s.txt"), "passwd.obj");
        let inside = link(&base.join("robot/meshes/a.obj"), "a_link.obj");
        let sibling = link(&base.join("robotic/b.obj"), "b.obj");
        let dangling = link(&base.join("gone.obj"), "gone.obj");
        let roots = MeshRoots::new(&urdf, &[], &[], &MeshAccess::default());

        let (real, root) = roots.check(&inside).unwrap();
        assert_eq!(real, base.join("robot/meshes/a.obj"));
        assert_eq!(root.kind, RootKind::UrdfFolder);
        let (real, _) = roots
            .check(&base.join("robot/meshes/../meshes/a.obj"))
            .unwrap();
        assert_eq!(real, base.join("robot/meshes/a.obj"));

        for (path, real) in [
            (out.clone(), base.join("secret/s.txt")),
            // `robotic` starts with the characters of `robot`, not with its components.
            (sibling, base.join("robotic/b.obj")),
            (
                base.join("robot/../secret/s.txt"),
                base.join("secret/s.txt"),
            ),
        ] {
            match roots.check(&path).unwrap_err() {
                Refusal::Outside {
                    path: p,
                    real_path,
                    roots: listed,
                } => {
                    assert_eq!(p, path);
                    assert_eq!(real_path, real);
                    assert_eq!(listed, roots.roots());
                }
                e => panic!("{e}"),
            }
        }
        let message = roots.check(&out).unwrap_err().to_string();
        assert!(message.contains(&out.display().to_string()), "{message}");
        assert!(
            message.contains(&format!(
                "real path {}",
                base.join("secret/s.txt").display()
            )),
            "{message}"
        );
        assert!(message.contains("--allow-mesh-path"), "{message}");
        assert!(
            message.contains(&format!(
                "the URDF's folder {}",
                base.join("robot").display()
            )),
            "{message}"
        );
        // A path without links names its real path once.
        let plain = roots.check(&base.join("secret/s.txt")).unwrap_err();
        assert!(!plain.to_string().contains("real path"), "{plain}");
        assert!(matches!(
            roots.check(&dangling).unwrap_err(),
            Refusal::NoRealPath { .. }
        ));

        // Allowing the folder, or its parent, admits the file.
        for allowed in [base.join("secret"), base.clone()] {
            let access = MeshAccess {
                allowed: vec![allowed],
                scene_folder: None,
            };
            let roots = MeshRoots::new(&urdf, &[], &[], &access);
            let (real, root) = roots.check(&out).unwrap();
            assert_eq!(real, base.join("secret/s.txt"));
            assert_eq!(root.kind, RootKind::Allowed);
        }
        // So does the scene's folder, and a package path.
        let access = MeshAccess {
            allowed: Vec::new(),
            scene_folder: Some(base.join("secret")),
        };
        let roots = MeshRoots::new(&urdf, &[], &[], &access);
        assert_eq!(roots.check(&out).unwrap().1.kind, RootKind::SceneFolder);
        let roots = MeshRoots::new(&urdf, &[base.join("secret")], &[], &MeshAccess::default());
        assert_eq!(roots.check(&out).unwrap().1.kind, RootKind::PackagePath);
        let roots = MeshRoots::new(&urdf, &[], &[base.join("secret")], &MeshAccess::default());
        assert_eq!(roots.check(&out).unwrap().1.kind, RootKind::RosPackagePath);
    }

    #[test]
    fn enclosing_package_is_the_nearest_manifest() {
        let tmp = tempfile::tempdir().unwrap();
        let base = tmp.path().canonicalize().unwrap();
        write(&base.join("ws/package.xml"), "");
        write(&base.join("ws/pkg/package.xml"), "");
        std::fs::create_dir_all(base.join("ws/pkg/urdf")).unwrap();
        // A folder named package.xml is no manifest.
        std::fs::create_dir_all(base.join("ws/pkg/urdf/x/package.xml")).unwrap();
        assert_eq!(
            enclosing_package(&base.join("ws/pkg/urdf/x")),
            Some(base.join("ws/pkg"))
        );
        assert_eq!(enclosing_package(&base.join("ws")), Some(base.join("ws")));
        assert_eq!(enclosing_package(&base), None);
    }

    #[test]
    fn an_empty_scene_folder_is_the_working_directory() {
        let roots = MeshRoots::new(
            Path::new("/nonexistent/r.urdf"),
            &[],
            &[],
            &MeshAccess {
                allowed: Vec::new(),
                scene_folder: Some(PathBuf::new()),
            },
        );
        assert_eq!(
            roots.roots(),
            &[Root {
                kind: RootKind::SceneFolder,
                path: std::env::current_dir().unwrap().canonicalize().unwrap(),
            }]
        );
    }
}
