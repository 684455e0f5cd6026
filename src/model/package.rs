//! Mesh URI resolution without ROS.
//!
//! `urdf_rs::utils::expand_package_path` shells out to `rospack` (and panics without ROS) and
//! its pattern stops at a hyphen, so `package://example-robot-data/...` is never expanded. This
//! module resolves URIs itself, returning only files that exist:
//!
//! - `package://pkg/rest` (and Gazebo's `model://pkg/rest`), tried in this order:
//!   1. each search path `dir` given by the caller (`--package-path`): `dir/pkg/rest`, or
//!      `dir/rest` when `dir` is the package folder itself (its name is `pkg`);
//!   2. each entry of `ROS_PACKAGE_PATH` (colon-separated), the same two ways;
//!   3. the URDF's folder and each of its ancestors `a` (what pybullet does): `a/pkg/rest`, and
//!      `a/rest` when `a` is named `pkg`.
//! - `file:///abs/path` (percent-escapes decoded); a relative `file://` path is taken relative
//!   to the URDF's folder.
//! - anything else: an absolute path as is, a relative path relative to the URDF's folder.
//!
//! Package names may contain any character but `/` (hyphens included).
//!
//! Hostile paths (docs/reliability.md, "Hostile input"):
//!
//! - The path inside a package is normalised lexically (`.` and empty segments dropped, `..`
//!   removes the segment before it); a `..` that would climb above the package root is refused
//!   ([`Unresolved::EscapesPackage`]), as is a package named `.` or `..`.
//! - Relative and absolute paths and `file://` URIs may name any file here: URDFs in `urdf/`
//!   folders legitimately reach `../meshes/...`. Which files are then read is decided after
//!   resolution, on the file's real path ([`super::confine`]: the URDF's folder, `urdf/`
//!   layout or ROS package, the package paths, `ROS_PACKAGE_PATH`, the scene's folder, the
//!   allowed folders; anything else is refused). What is opened is bounded too: only a regular file of at most
//!   [`crate::input::MESH_MAX_BYTES`] resolves ([`Unresolved::NotReadable`] otherwise: `/dev/zero`,
//!   `file:///dev/urandom`, a FIFO or a directory never resolve; judged from metadata, never
//!   opened).

use std::path::{Path, PathBuf};

/// The entries of the `ROS_PACKAGE_PATH` environment variable (empty when unset).
pub fn ros_package_path() -> Vec<PathBuf> {
    std::env::var_os("ROS_PACKAGE_PATH")
        .map(|v| {
            std::env::split_paths(&v)
                .filter(|p| !p.as_os_str().is_empty())
                .collect()
        })
        .unwrap_or_default()
}

/// Why a mesh URI did not resolve ([`resolve_detailed`]).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Unresolved {
    /// No candidate path exists.
    #[error("not found (searched --package-path, ROS_PACKAGE_PATH and the URDF's parent folders)")]
    NotFound,
    /// An empty URI, or a `package://` URI without a package or a path in it.
    #[error("malformed URI (expected package://<package>/<path>, file://<path> or a file path)")]
    Malformed,
    /// `package://pkg/rest` whose `rest` climbs above the package root with `..`.
    #[error(
        "the path climbs out of package `{package}` with `..` (package:// paths must stay inside \
         their package)"
    )]
    EscapesPackage { package: String },
    /// A candidate exists but is not a regular file or is over the size cap.
    #[error("{}: {reason}", .path.display())]
    NotReadable { path: PathBuf, reason: String },
}

/// Resolves `uri` found in the URDF at `urdf_path`, searching `search_paths`, then
/// `ROS_PACKAGE_PATH`, then the URDF's parent folders (see the module documentation).
/// `None` when no regular file matches. Never panics.
pub fn resolve(uri: &str, urdf_path: &Path, search_paths: &[PathBuf]) -> Option<PathBuf> {
    resolve_with(uri, urdf_path, search_paths, &ros_package_path())
}

/// [`resolve`] with the `ROS_PACKAGE_PATH` entries given explicitly (for tests and callers that
/// want to ignore the environment).
pub fn resolve_with(
    uri: &str,
    urdf_path: &Path,
    search_paths: &[PathBuf],
    ros_paths: &[PathBuf],
) -> Option<PathBuf> {
    resolve_detailed(uri, urdf_path, search_paths, ros_paths).ok()
}

/// [`resolve_with`], saying why when nothing resolves: the URI is malformed or escapes its
/// package, no candidate exists, or the first existing candidate is not a regular file of at
/// most [`crate::input::MESH_MAX_BYTES`] (nothing is opened to decide).
pub fn resolve_detailed(
    uri: &str,
    urdf_path: &Path,
    search_paths: &[PathBuf],
    ros_paths: &[PathBuf],
) -> Result<PathBuf, Unresolved> {
    let candidates = checked_candidates(uri, urdf_path, search_paths, ros_paths)?;
    let mut unreadable = None;
    for path in candidates {
        match crate::input::check(&path, crate::input::MESH_MAX_BYTES) {
            Ok(_) => return Ok(path),
            // The file exists but breaks a rule of `crate::input` (its metadata was read).
            Err(e) if e.kind() == std::io::ErrorKind::InvalidInput => {
                unreadable.get_or_insert(Unresolved::NotReadable {
                    path,
                    reason: e.to_string(),
                });
            }
            // Missing, a file where a folder is expected, no permission: not this candidate.
            Err(_) => {}
        }
    }
    Err(unreadable.unwrap_or(Unresolved::NotFound))
}

/// What is wrong with `uri` from its form alone, without looking at any file: malformed, or a
/// `package://` path climbing out of its package. `None` when the form is fine.
pub fn uri_problem(uri: &str) -> Option<Unresolved> {
    checked_candidates(uri, Path::new(""), &[], &[]).err()
}

/// Every path [`resolve_with`] would try, in order (existing or not). Useful to explain a miss.
/// Empty for a malformed URI or a package path escaping its package.
pub fn candidates(
    uri: &str,
    urdf_path: &Path,
    search_paths: &[PathBuf],
    ros_paths: &[PathBuf],
) -> Vec<PathBuf> {
    checked_candidates(uri, urdf_path, search_paths, ros_paths).unwrap_or_default()
}

fn checked_candidates(
    uri: &str,
    urdf_path: &Path,
    search_paths: &[PathBuf],
    ros_paths: &[PathBuf],
) -> Result<Vec<PathBuf>, Unresolved> {
    let uri = uri.trim();
    let urdf_dir = urdf_folder(urdf_path);
    let package_uri = uri
        .strip_prefix("package://")
        .or_else(|| uri.strip_prefix("model://"));
    if let Some(rest) = package_uri {
        // `package:///pkg/path` (an empty authority, as in example-robot-data's talos files) is
        // read as `package://pkg/path`, as ROS and pybullet do.
        let rest = rest.trim_start_matches('/');
        let Some((package, rest)) = rest.split_once('/') else {
            return Err(Unresolved::Malformed);
        };
        if package.is_empty() {
            return Err(Unresolved::Malformed);
        }
        if package == "." || package == ".." {
            return Err(Unresolved::EscapesPackage {
                package: package.to_string(),
            });
        }
        let rest = normalise_inside(rest).ok_or_else(|| Unresolved::EscapesPackage {
            package: package.to_string(),
        })?;
        if rest.as_os_str().is_empty() {
            return Err(Unresolved::Malformed);
        }
        let mut out = Vec::new();
        let mut try_dir = |dir: &Path| {
            out.push(dir.join(package).join(&rest));
            if dir.file_name().is_some_and(|n| n == package) {
                out.push(dir.join(&rest));
            }
        };
        for dir in search_paths.iter().chain(ros_paths) {
            try_dir(dir);
        }
        if let Some(dir) = &urdf_dir {
            for ancestor in dir.ancestors() {
                try_dir(ancestor);
            }
        }
        return Ok(out);
    }
    if let Some(rest) = uri.strip_prefix("file://") {
        let path = PathBuf::from(percent_decode(rest));
        return Ok(vec![relative_to(&urdf_dir, path)]);
    }
    if uri.is_empty() {
        return Err(Unresolved::Malformed);
    }
    Ok(vec![relative_to(&urdf_dir, PathBuf::from(uri))])
}

/// `rest` (a `/`-separated path inside a package) with `.` and empty segments dropped and each
/// `..` removing the segment before it; `None` when a `..` would climb above the start.
fn normalise_inside(rest: &str) -> Option<PathBuf> {
    let mut parts: Vec<&str> = Vec::new();
    for part in rest.split('/') {
        match part {
            "" | "." => {}
            ".." => {
                parts.pop()?;
            }
            part => parts.push(part),
        }
    }
    Some(parts.iter().collect())
}

fn relative_to(dir: &Option<PathBuf>, path: PathBuf) -> PathBuf {
    match dir {
        Some(dir) if path.is_relative() => dir.join(path),
        _ => path,
    }
}

/// The URDF's folder as an absolute path (so that its ancestors can be walked even when the
/// URDF was named relative to the working directory).
fn urdf_folder(urdf_path: &Path) -> Option<PathBuf> {
    let absolute = urdf_path
        .canonicalize()
        .or_else(|_| std::path::absolute(urdf_path))
        .ok()?;
    absolute.parent().map(Path::to_path_buf)
}

/// Decodes `%XX` escapes (invalid escapes are kept as written).
fn percent_decode(s: &str) -> String {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%'
            && i + 2 < bytes.len()
            && let Some(h) = std::str::from_utf8(&bytes[i + 1..i + 3])
                .ok()
                .and_then(|h| u8::from_str_radix(h, 16).ok())
        {
            out.push(h);
            i += 3;
            continue;
        }
        out.push(bytes[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percent_decoding() {
        assert_eq!(percent_decode("/a%20b/c%2"), "/a b/c%2");
        assert_eq!(percent_decode("%41%zz"), "A%zz");
    }

    #[test]
    fn package_paths_stay_inside_their_package() {
        assert_eq!(normalise_inside("a/./b//c"), Some(PathBuf::from("a/b/c")));
        assert_eq!(normalise_inside("a/../b"), Some(PathBuf::from("b")));
        assert_eq!(normalise_inside("a/../../b"), None);
        assert_eq!(normalise_inside(".."), None);
        let urdf = Path::new("/nonexistent/robot.urdf");
        for uri in [
            "package://pkg/../x.stl",
            "package://pkg/meshes/../../../../etc/passwd",
            "package://../etc/passwd",
            "model://./x.stl",
        ] {
            let e = resolve_detailed(uri, urdf, &[], &[]).unwrap_err();
            assert!(matches!(e, Unresolved::EscapesPackage { .. }), "{uri}: {e}");
            assert!(e.to_string().contains("climbs out of package"), "{e}");
        }
        let inside = candidates("package://pkg/a/../meshes/x.stl", urdf, &[], &[]);
        assert!(inside.contains(&PathBuf::from("/nonexistent/pkg/meshes/x.stl")));
    }

    #[test]
    fn special_files_never_resolve() {
        let urdf = Path::new("/nonexistent/robot.urdf");
        for uri in ["/dev/zero", "file:///dev/urandom", "/"] {
            let e = resolve_detailed(uri, urdf, &[], &[]).unwrap_err();
            assert!(e.to_string().contains("not a regular file"), "{uri}: {e}");
        }
    }

    #[test]
    fn malformed_package_uris_give_nothing() {
        let urdf = Path::new("/nonexistent/robot.urdf");
        for uri in [
            "package://",
            "package://pkg",
            "package:///x.stl",
            "package://pkg/",
            "",
        ] {
            assert!(candidates(uri, urdf, &[], &[]).is_empty(), "{uri}");
            assert_eq!(resolve_with(uri, urdf, &[], &[]), None);
        }
    }

    #[test]
    fn candidate_order() {
        let urdf = Path::new("/r/pkg/urdf/robot.urdf");
        let c = candidates(
            "package://pkg/meshes/a.stl",
            urdf,
            &[PathBuf::from("/search")],
            &[PathBuf::from("/ros/pkg")],
        );
        assert_eq!(c[0], PathBuf::from("/search/pkg/meshes/a.stl"));
        assert_eq!(c[1], PathBuf::from("/ros/pkg/pkg/meshes/a.stl"));
        assert_eq!(c[2], PathBuf::from("/ros/pkg/meshes/a.stl"));
        assert!(c.contains(&PathBuf::from("/r/pkg/meshes/a.stl")));
        assert!(c.contains(&PathBuf::from("/r/pkg/pkg/meshes/a.stl")));
        // An empty authority (`package:///pkg/...`, example-robot-data's talos) reads the same.
        let empty_authority = candidates(
            "package:///pkg/meshes/a.stl",
            urdf,
            &[PathBuf::from("/search")],
            &[PathBuf::from("/ros/pkg")],
        );
        assert_eq!(empty_authority, c);
    }
}
