//! A model's URDF rewritten for publishing next to tumble's `/tf` (a ROS 2
//! `/robot_description`): RViz2's RobotModel display places each `<link>` at the TF frame of the
//! same name, so the link names must be tumble's frame ids, and it loads meshes by URI, so the
//! mesh paths must not depend on a ROS workspace being installed.
//!
//! The rewrite edits attribute values in place and keeps every other byte of the file (comments,
//! formatting, elements tumble does not read):
//!
//! | attribute                                   | becomes                                   |
//! |---------------------------------------------|-------------------------------------------|
//! | `robot/link@name`                           | the frame id: `prefix/name` with a prefix (the scene's `name` for the model), else `name` |
//! | `robot/joint@name`, `joint/parent@link`, `joint/child@link`, `joint/mimic@joint`, `transmission/joint@name`, `gazebo@reference` | the same rule (joints share the prefix, so two copies of one robot keep distinct joint names, as `/joint_states` needs) |
//! | `mesh@filename` (visual and collision)      | `file:///absolute/path`, resolved as tumble resolves meshes ([`super::package::resolve`]: `--package-path`, `ROS_PACKAGE_PATH`, the URDF's folders); a mesh that does not resolve keeps its URI |
//!
//! Links without mass in a `bodies = "links"` model are no body and have no `/tf` frame; they
//! stay in the description (a URDF must remain one tree) under their prefixed names, and RViz2
//! reports them as having no transform.

use std::path::{Path, PathBuf};

/// The URDF text `xml` (read from `urdf_path`) with its link and joint names turned into frame
/// ids (`prefix/name`, or unchanged without a prefix) and its mesh filenames into absolute
/// `file://` URIs (see the module documentation). Fails only when the text is not well-formed
/// XML.
pub fn for_frame_ids(
    xml: &str,
    urdf_path: &Path,
    package_paths: &[PathBuf],
    prefix: Option<&str>,
) -> Result<String, String> {
    // The text is read again from the file: check it again before parsing.
    crate::input::check_xml(xml)?;
    let options = roxmltree::ParsingOptions {
        allow_dtd: true,
        ..Default::default()
    };
    let doc = roxmltree::Document::parse_with_options(xml, options).map_err(|e| e.to_string())?;
    let rename = |name: &str| match prefix {
        Some(p) => format!("{p}/{name}"),
        None => name.to_string(),
    };
    let mut edits: Vec<(std::ops::Range<usize>, String)> = Vec::new();
    for node in doc.descendants().filter(|n| n.is_element()) {
        let tag = node.tag_name().name();
        let parent = node
            .parent_element()
            .map(|p| p.tag_name().name())
            .unwrap_or("");
        let renamed_attribute = match (parent, tag) {
            ("robot", "link") | ("robot", "joint") | ("transmission", "joint") => Some("name"),
            ("joint", "parent") | ("joint", "child") => Some("link"),
            ("joint", "mimic") => Some("joint"),
            (_, "gazebo") => Some("reference"),
            _ => None,
        };
        for attr in node.attributes() {
            let new_value = if Some(attr.name()) == renamed_attribute && prefix.is_some() {
                Some(rename(attr.value()))
            } else if tag == "mesh" && attr.name() == "filename" {
                super::package::resolve(attr.value(), urdf_path, package_paths)
                    .map(|path| file_uri(&path))
            } else {
                None
            };
            if let Some(value) = new_value {
                edits.push((attr.range_value(), escape_attribute(&value)));
            }
        }
    }
    edits.sort_by_key(|(range, _)| range.start);
    let mut out = String::with_capacity(xml.len() + edits.len() * 16);
    let mut at = 0;
    for (range, value) in edits {
        out.push_str(&xml[at..range.start]);
        out.push_str(&value);
        at = range.end;
    }
    out.push_str(&xml[at..]);
    Ok(out)
}

/// `file://` followed by the absolute path of `path` (symlinks resolved when possible), every
/// byte other than ASCII letters, digits, `-._~/` percent-encoded (RFC 3986 §2.1, §3.3).
pub fn file_uri(path: &Path) -> String {
    let absolute = std::fs::canonicalize(path)
        .or_else(|_| std::path::absolute(path))
        .unwrap_or_else(|_| path.to_path_buf());
    let mut uri = String::from("file://");
    for &b in absolute.as_os_str().as_encoded_bytes() {
        if b.is_ascii_alphanumeric() || b"-._~/".contains(&b) {
            uri.push(b as char);
        } else {
            uri.push_str(&format!("%{b:02X}"));
        }
    }
    uri
}

/// `value` safe inside a double- or single-quoted XML attribute.
fn escape_attribute(value: &str) -> String {
    let mut s = String::with_capacity(value.len());
    for c in value.chars() {
        match c {
            '&' => s.push_str("&amp;"),
            '<' => s.push_str("&lt;"),
            '>' => s.push_str("&gt;"),
            '"' => s.push_str("&quot;"),
            '\'' => s.push_str("&apos;"),
            c => s.push(c),
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    const URDF: &str = r#"<?xml version="1.0"?>
<!-- kept -->
<robot name="r">
  <link name="base"><visual><geometry><mesh filename="package://pkg/m.stl" scale="1 1 1"/></geometry></visual></link>
  <link name="arm"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="arm"/><mimic joint="j0"/></joint>
  <transmission name="t"><joint name="j1"/></transmission>
  <gazebo reference="arm"/>
</robot>
"#;

    /// Every name that refers to a link or joint gets the prefix; everything else, comments
    /// included, is byte for byte the input.
    #[test]
    fn prefixes_link_and_joint_references_and_keeps_the_rest() {
        let out = for_frame_ids(URDF, Path::new("/nonexistent/r.urdf"), &[], Some("a")).unwrap();
        let expected = URDF
            .replace("name=\"base\"", "name=\"a/base\"")
            .replace("name=\"arm\"", "name=\"a/arm\"")
            .replace("joint name=\"j1\"", "joint name=\"a/j1\"")
            .replace("link=\"base\"", "link=\"a/base\"")
            .replace("link=\"arm\"", "link=\"a/arm\"")
            .replace("joint=\"j0\"", "joint=\"a/j0\"")
            .replace("reference=\"arm\"", "reference=\"a/arm\"");
        assert_eq!(out, expected);
    }

    /// Without a prefix and with no mesh resolving (an unresolved mesh keeps its URI), the text
    /// comes back unchanged.
    #[test]
    fn without_prefix_and_with_unresolvable_meshes_nothing_changes() {
        let out = for_frame_ids(URDF, Path::new("/nonexistent/r.urdf"), &[], None).unwrap();
        assert_eq!(out, URDF);
    }

    /// A package:// mesh found next to the URDF becomes an absolute file:// URI; a path with a
    /// space and an ampersand is percent-encoded (no XML escape needed after that).
    #[test]
    fn resolved_mesh_becomes_an_absolute_percent_encoded_file_uri() {
        let dir = tempfile::tempdir().unwrap();
        let pkg = dir.path().join("pkg");
        std::fs::create_dir_all(pkg.join("a b&c")).unwrap();
        std::fs::write(pkg.join("a b&c/m.stl"), b"solid x\nendsolid x\n").unwrap();
        let urdf_path = pkg.join("r.urdf");
        let xml = URDF.replace("package://pkg/m.stl", "package://pkg/a b&amp;c/m.stl");
        let out = for_frame_ids(&xml, &urdf_path, &[], None).unwrap();
        let root = std::fs::canonicalize(dir.path()).unwrap();
        let expected_uri = format!("file://{}/pkg/a%20b%26c/m.stl", root.display());
        assert!(
            out.contains(&format!("filename=\"{expected_uri}\"")),
            "{out}"
        );
    }

    /// Malformed XML is an error, never a panic or a half-rewritten text.
    #[test]
    fn malformed_xml_is_an_error() {
        let e = for_frame_ids(
            "<robot><link name='x'>",
            Path::new("r.urdf"),
            &[],
            Some("a"),
        );
        assert!(e.is_err());
    }
}
