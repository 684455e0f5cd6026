//! Leniency: the oddities of real URDFs that urdfdom (the ROS reference parser, used by
//! Pinocchio, RViz, MoveIt) loads and that tumble loads too, each with one [`LoadWarning`]
//! naming the file, the element and what was done. `--strict` (`Strictness::Strict`) skips
//! all of this and refuses such files with the error they gave before the leniency existed.
//!
//! The rules (docs/urdf.md has the full table, with the urdfdom source each one was checked
//! against: `urdf_parser/src/{model,link,joint}.cpp`, `urdf_model/pose.h`, tinyxml2's
//! `XMLNode::ParseDeep`):
//!
//! - **XML declaration after leading whitespace, or a second one** ([`Oddity::XmlDeclaration`]):
//!   XML allows one declaration, as the very first bytes; tinyxml2 skips leading whitespace and
//!   accepts any number of declarations before the first other node. Such declarations are
//!   blanked out (replaced by spaces, so line and column numbers stay right).
//! - **Geometry URDF does not define** (`<plane>`, `<cdf>`; [`Oddity::UnknownGeometry`]): urdfdom
//!   logs "Unknown geometry type" and leaves that `<visual>`/`<collision>` out. tumble leaves out
//!   the element too, and only it (urdfdom, which ignores `parseLink`'s result, also stops
//!   reading the link's later visuals and collisions: that loss is not copied).
//! - **An element after the shape in `<geometry>`** (`<material>` in racecar.urdf;
//!   [`Oddity::ExtraGeometryElement`]): urdfdom reads the first child element of `<geometry>`
//!   only; tumble ignores the others when they are not shapes. A second shape is ambiguous
//!   (which one did the author mean?) and still refused.
//! - **A repeated element where URDF allows one** (two `<axis>` in a joint;
//!   [`Oddity::RepeatedElement`]): urdfdom reads the first (`FirstChildElement`). tumble does so
//!   when every copy has the same content (same attributes, numbers compared as numbers, same
//!   children); copies that differ are ambiguous and still refused.
//! - **A mesh `scale` of other than 3 numbers, all equal** (`"1 1 1 1"`;
//!   [`Oddity::MeshScale`]): urdfdom refuses it (`Vector3::init`: "Parser found 4 elements but
//!   3 expected") and leaves the visual out (with the rest of the link's geometry). Numbers that
//!   are all equal have one meaning, a uniform scale, which tumble uses; unequal numbers are
//!   ambiguous and still refused.
//! - **A mimic of a joint that does not exist** ([`Oddity::MimicOfMissingJoint`], applied in
//!   [`super`] once the joints are read): urdfdom does not check mimic targets (`initTree` checks
//!   links only) and Pinocchio ignores mimics unless asked; tumble drops the mimic, so the joint
//!   moves on its own (at 0 unless the scene's `joints` sets it).

use std::borrow::Cow;
use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};

/// How a URDF is read.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Strictness {
    /// Load the oddities of this module's rules, each with a [`LoadWarning`].
    #[default]
    Lenient,
    /// Refuse them, with the error each gave before the leniency (`--strict`, `strict = true`).
    Strict,
}

impl Strictness {
    /// `Strict` when `strict` is true.
    pub fn from_strict(strict: bool) -> Self {
        if strict {
            Strictness::Strict
        } else {
            Strictness::Lenient
        }
    }
}

/// Which leniency rule a [`LoadWarning`] comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Oddity {
    /// An XML declaration after leading whitespace, or a second one: ignored.
    XmlDeclaration,
    /// A `<visual>`/`<collision>` whose geometry URDF does not define: left out.
    UnknownGeometry,
    /// An element that is not a shape after the shape in `<geometry>`: ignored.
    ExtraGeometryElement,
    /// Identical copies of an element URDF allows once: the first used.
    RepeatedElement,
    /// A mesh `scale` of other than 3 numbers, all equal: the uniform scale used.
    MeshScale,
    /// A `<mimic>` of a joint that does not exist: dropped.
    MimicOfMissingJoint,
}

/// One oddity the loader accepted: the file, where in it, and what was done.
/// Displayed as `FILE: ELEMENT: MESSAGE` (one line).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LoadWarning {
    pub path: PathBuf,
    pub oddity: Oddity,
    /// Where: `link `chassis`: visual #0 (line 16)`, `joint `j` (line 40)`, `line 2`.
    pub element: String,
    /// The 1-based line the element starts on (0 when unknown).
    pub line: usize,
    /// What was found and what was done, naming urdfdom's behaviour.
    pub message: String,
}

impl fmt::Display for LoadWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}: {}: {}",
            self.path.display(),
            self.element,
            self.message
        )
    }
}

/// A replacement of a byte range of the URDF text (empty `text`: a deletion).
#[derive(Debug, Clone)]
pub(super) struct Edit {
    pub range: Range<usize>,
    pub text: String,
}

/// Applies `edits` to `xml`. An edit inside an earlier one (an attribute of a removed element)
/// is skipped. Returns `xml` unchanged when there are none.
pub(super) fn apply(xml: &str, mut edits: Vec<Edit>) -> Cow<'_, str> {
    if edits.is_empty() {
        return xml.into();
    }
    edits.sort_by_key(|e| (e.range.start, std::cmp::Reverse(e.range.end)));
    let mut out = String::with_capacity(xml.len());
    let mut last = 0;
    for e in edits {
        if e.range.start < last {
            continue;
        }
        out.push_str(&xml[last..e.range.start]);
        out.push_str(&e.text);
        last = e.range.end;
    }
    out.push_str(&xml[last..]);
    out.into()
}

/// 1-based line numbers of byte offsets, from an index of the newlines built on first use (so that a
/// file with many warnings costs `O(n log n)`, and one without none at all; roxmltree's
/// `text_pos_at` scans from the start at every call).
struct Lines<'t> {
    text: &'t str,
    newlines: Option<Vec<usize>>,
}

impl<'t> Lines<'t> {
    fn new(text: &'t str) -> Self {
        Self {
            text,
            newlines: None,
        }
    }

    fn at(&mut self, offset: usize) -> usize {
        let text = self.text;
        let newlines = self.newlines.get_or_insert_with(|| {
            text.bytes()
                .enumerate()
                .filter(|&(_, b)| b == b'\n')
                .map(|(i, _)| i)
                .collect()
        });
        newlines.partition_point(|&n| n < offset) + 1
    }
}

/// Blanks out the XML declarations tinyxml2 accepts and XML does not: one after leading
/// whitespace, and every declaration after the first, as long as only whitespace and
/// declarations precede them (tinyxml2 refuses a declaration after any other node, and so does
/// tumble). Each becomes as many spaces as it had bytes (newlines kept), so positions in later
/// error messages stay right.
pub(super) fn blank_misplaced_declarations<'a>(
    xml: &'a str,
    path: &Path,
    warnings: &mut Vec<LoadWarning>,
) -> Cow<'a, str> {
    let bom = if xml.starts_with('\u{feff}') { 3 } else { 0 };
    let mut blanks: Vec<(Range<usize>, bool)> = Vec::new();
    let mut pos = bom;
    let mut first = true;
    loop {
        let start = pos
            + xml[pos..]
                .find(|c: char| !matches!(c, ' ' | '\t' | '\r' | '\n'))
                .unwrap_or(xml.len() - pos);
        let rest = &xml[start..];
        let is_declaration = rest.starts_with("<?xml")
            && rest[5..]
                .chars()
                .next()
                .is_some_and(|c| c.is_whitespace() || c == '?');
        if !is_declaration {
            break;
        }
        let Some(end) = rest.find("?>").map(|e| start + e + 2) else {
            break; // unterminated: the XML parser's to report
        };
        if start != bom || !first {
            blanks.push((start..end, first));
        }
        first = false;
        pos = end;
    }
    if blanks.is_empty() {
        return xml.into();
    }
    let mut out = xml.to_string();
    let mut lines = Lines::new(xml);
    for (range, was_first) in blanks {
        let blank: String = xml[range.clone()]
            .chars()
            .map(|c| match c {
                '\n' | '\r' => c.to_string(),
                c => " ".repeat(c.len_utf8()),
            })
            .collect();
        out.replace_range(range.clone(), &blank);
        let what = if was_first {
            "the XML declaration comes after leading whitespace (XML allows it only as the \
             file's first bytes)"
        } else {
            "a second XML declaration (XML allows one)"
        };
        let line = lines.at(range.start);
        warnings.push(LoadWarning {
            path: path.to_path_buf(),
            oddity: Oddity::XmlDeclaration,
            element: format!("line {line}"),
            line,
            message: format!("{what}: ignored, as tinyxml2 (urdfdom's XML parser) ignores it"),
        });
    }
    out.into()
}

/// The geometry elements URDF defines (capsule: URDF 1.1, read by urdf-rs and tumble).
pub(super) const SHAPES: [&str; 5] = ["box", "cylinder", "sphere", "capsule", "mesh"];

/// Children URDF allows once, per parent element (the lists `super::locate::check_unique` refuses
/// repeats of).
const SINGLE_IN_LINK: [&str; 1] = ["inertial"];
const SINGLE_IN_INERTIAL: [&str; 3] = ["origin", "mass", "inertia"];
const SINGLE_IN_SHAPE_HOLDER: [&str; 3] = ["origin", "geometry", "material"];
const SINGLE_IN_JOINT: [&str; 9] = [
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

type Node<'a, 'i> = roxmltree::Node<'a, 'i>;

/// What the document-level rules change: the edits to the text and their warnings.
struct Pass<'p> {
    path: &'p Path,
    lines: Lines<'p>,
    edits: Vec<Edit>,
    warnings: Vec<LoadWarning>,
}

impl Pass<'_> {
    /// A warning about the element `label`, which starts where `at` does.
    fn warn(&mut self, oddity: Oddity, label: &str, at: Node, message: String) {
        let line = self.lines.at(at.range().start);
        self.warnings.push(LoadWarning {
            path: self.path.to_path_buf(),
            oddity,
            element: format!("{label} (line {line})"),
            line,
            message,
        });
    }

    fn remove(&mut self, node: Node) {
        self.edits.push(Edit {
            range: node.range(),
            text: String::new(),
        });
    }
}

/// The edits and warnings of the document-level rules (unknown geometry, extra elements in
/// `<geometry>`, identical repeats, mesh scales), for the robot's links and joints.
pub(super) fn document_edits<'t>(
    doc: &roxmltree::Document<'t>,
    path: &Path,
) -> (Vec<Edit>, Vec<LoadWarning>) {
    let mut pass = Pass {
        path,
        lines: Lines::new(doc.input_text()),
        edits: Vec::new(),
        warnings: Vec::new(),
    };
    for node in doc.root_element().children().filter(|n| n.is_element()) {
        let Some(name) = node.attribute("name") else {
            continue;
        };
        match node.tag_name().name() {
            "link" => {
                let label = format!("link `{name}`");
                repeated(&mut pass, node, &SINGLE_IN_LINK, &label, node);
                if let Some(inertial) = first_child(node, "inertial") {
                    let label = format!("{label}: inertial");
                    repeated(&mut pass, inertial, &SINGLE_IN_INERTIAL, &label, inertial);
                }
                for kind in ["visual", "collision"] {
                    for (k, element) in node.children().filter(|c| c.has_tag_name(kind)).enumerate()
                    {
                        let label = match element.attribute("name") {
                            Some(n) => format!("link `{name}`: {kind} `{n}`"),
                            None => format!("link `{name}`: {kind} #{k}"),
                        };
                        shape_holder(&mut pass, element, kind, &label);
                    }
                }
            }
            "joint" => {
                let label = format!("joint `{name}`");
                repeated(&mut pass, node, &SINGLE_IN_JOINT, &label, node);
            }
            _ => {}
        }
    }
    (pass.edits, pass.warnings)
}

/// The first child element of `node` named `tag`.
pub(super) fn first_child<'a, 'i>(node: Node<'a, 'i>, tag: &str) -> Option<Node<'a, 'i>> {
    node.children().find(|c| c.has_tag_name(tag))
}

/// A `<visual>` or `<collision>`: its repeats, then its geometry.
fn shape_holder(pass: &mut Pass, element: Node, kind: &str, label: &str) {
    let Some(geometry) = first_child(element, "geometry") else {
        return;
    };
    let mut children = geometry.children().filter(|c| c.is_element());
    let Some(shape) = children.next() else {
        return; // an empty <geometry>: still refused
    };
    let tag = shape.tag_name().name();
    if !SHAPES.contains(&tag) {
        pass.remove(element);
        pass.warn(
            Oddity::UnknownGeometry,
            label,
            element,
            format!(
                "<{tag}> is not a URDF geometry ({}): this {kind} is left out, as urdfdom leaves \
                 it out",
                SHAPES.join(", ")
            ),
        );
        return;
    }
    repeated(pass, element, &SINGLE_IN_SHAPE_HOLDER, label, element);
    for extra in children {
        let extra_tag = extra.tag_name().name();
        if SHAPES.contains(&extra_tag) {
            continue; // a second shape: ambiguous, refused by the parser
        }
        pass.remove(extra);
        pass.warn(
            Oddity::ExtraGeometryElement,
            label,
            element,
            format!(
                "<geometry> holds <{extra_tag}> after its <{tag}> (URDF allows one shape there): \
                 <{extra_tag}> is ignored, as urdfdom reads only the first element of <geometry>"
            ),
        );
    }
    if tag == "mesh" {
        mesh_scale(pass, shape, kind, label, element);
    }
}

/// A `scale` of other than 3 numbers, all equal, becomes that number three times.
fn mesh_scale(pass: &mut Pass, mesh: Node, kind: &str, label: &str, element: Node) {
    let Some(attribute) = mesh.attributes().find(|a| a.name() == "scale") else {
        return;
    };
    let words: Vec<&str> = attribute.value().split_whitespace().collect();
    let Ok(numbers) = words
        .iter()
        .map(|w| w.parse::<f64>())
        .collect::<Result<Vec<f64>, _>>()
    else {
        return;
    };
    if numbers.len() == 3 || numbers.is_empty() || numbers.iter().any(|&x| x != numbers[0]) {
        return;
    }
    let uniform = format!("{0} {0} {0}", words[0]);
    pass.edits.push(Edit {
        range: attribute.range_value(),
        text: uniform.clone(),
    });
    pass.warn(
        Oddity::MeshScale,
        label,
        element,
        format!(
            "mesh scale=\"{}\" has {} numbers, not 3; all are equal: read as the uniform scale \
             \"{uniform}\" (urdfdom refuses the scale and leaves this {kind} out, with the \
             link's later visuals and collisions)",
            attribute.value(),
            numbers.len()
        ),
    );
}

/// Later copies of a child that `parent` may hold once are removed when every copy has the
/// same content as the first; when one differs, nothing is done (the parser refuses it).
fn repeated(pass: &mut Pass, parent: Node, tags: &[&str], label: &str, at: Node) {
    for tag in tags {
        let copies: Vec<Node> = parent.children().filter(|c| c.has_tag_name(*tag)).collect();
        if copies.len() < 2 || !copies[1..].iter().all(|c| same_content(copies[0], *c)) {
            continue;
        }
        for copy in &copies[1..] {
            pass.remove(*copy);
        }
        pass.warn(
            Oddity::RepeatedElement,
            label,
            at,
            format!(
                "<{tag}> appears {} times with the same content (URDF allows one): the first is \
                 used, as urdfdom uses the first",
                copies.len()
            ),
        );
    }
}

/// Same tag, same attributes (values compared as numbers when every word of both is one,
/// else word by word), same child elements in the same order, same text (trimmed).
pub(super) fn same_content(a: Node, b: Node) -> bool {
    if a.tag_name() != b.tag_name() {
        return false;
    }
    let attributes = |n: Node| {
        let mut v: Vec<(String, String)> = n
            .attributes()
            .map(|at| (at.name().to_string(), at.value().to_string()))
            .collect();
        v.sort();
        v
    };
    let (aa, ba) = (attributes(a), attributes(b));
    if aa.len() != ba.len()
        || !aa
            .iter()
            .zip(&ba)
            .all(|((an, av), (bn, bv))| an == bn && same_value(av, bv))
    {
        return false;
    }
    let text = |n: Node| -> String {
        n.children()
            .filter(|c| c.is_text())
            .filter_map(|c| c.text())
            .collect::<String>()
            .split_whitespace()
            .collect::<Vec<_>>()
            .join(" ")
    };
    if text(a) != text(b) {
        return false;
    }
    let (ac, bc): (Vec<Node>, Vec<Node>) = (
        a.children().filter(|c| c.is_element()).collect(),
        b.children().filter(|c| c.is_element()).collect(),
    );
    ac.len() == bc.len() && ac.iter().zip(&bc).all(|(x, y)| same_content(*x, *y))
}

/// `"0 1 0"` and `"0.0 1.0 0"` are the same value; NaN is never the same as anything.
fn same_value(a: &str, b: &str) -> bool {
    let (aw, bw): (Vec<&str>, Vec<&str>) = (
        a.split_whitespace().collect(),
        b.split_whitespace().collect(),
    );
    if aw.len() != bw.len() {
        return false;
    }
    aw.iter()
        .zip(&bw)
        .all(|(x, y)| match (x.parse::<f64>(), y.parse::<f64>()) {
            (Ok(p), Ok(q)) => p == q,
            _ => x == y,
        })
}

/// The warnings for `<mimic>`s of joints that do not exist, as (joint, mimicked) pairs (the
/// caller drops those mimics).
pub(super) fn mimics_of_missing_joints(
    doc: &roxmltree::Document,
    path: &Path,
    missing: &[(&str, &str)],
) -> Vec<LoadWarning> {
    if missing.is_empty() {
        return Vec::new();
    }
    let mut lines = Lines::new(doc.input_text());
    let starts: std::collections::HashMap<&str, usize> = doc
        .root_element()
        .children()
        .filter(|n| n.has_tag_name("joint"))
        .filter_map(|n| Some((n.attribute("name")?, n.range().start)))
        .collect();
    missing
        .iter()
        .map(|&(joint, mimicked)| {
            let line = starts.get(joint).map_or(0, |&start| lines.at(start));
            let at = if line > 0 {
                format!(" (line {line})")
            } else {
                String::new()
            };
            LoadWarning {
                path: path.to_path_buf(),
                oddity: Oddity::MimicOfMissingJoint,
                element: format!("joint `{joint}`{at}"),
                line,
                message: format!(
                    "mimics `{mimicked}`, which does not exist: the mimic is ignored and the \
                     joint moves on its own (at 0 unless `joints` sets it), as urdfdom (which \
                     does not check mimic targets) and Pinocchio read it"
                ),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn blank(xml: &str) -> (String, Vec<LoadWarning>) {
        let mut w = Vec::new();
        let out = blank_misplaced_declarations(xml, Path::new("r.urdf"), &mut w).into_owned();
        (out, w)
    }

    #[test]
    fn declarations_at_the_start_are_kept_and_the_others_blanked_in_place() {
        let ok = "<?xml version=\"1.0\"?>\n<robot/>";
        assert_eq!(blank(ok), (ok.to_string(), vec![]));
        let (out, w) = blank("\n<?xml version=\"1.0\" ?>\n<robot/>");
        assert_eq!(out, format!("\n{}\n<robot/>", " ".repeat(22)));
        assert_eq!(w.len(), 1);
        assert_eq!(w[0].element, "line 2");
        assert!(w[0].message.contains("after leading whitespace"), "{w:?}");
        let (out, w) = blank("<?xml version='1.0'?><?xml version='1.0'?> <r/>");
        assert_eq!(out, format!("<?xml version='1.0'?>{} <r/>", " ".repeat(21)));
        assert!(w[0].message.contains("a second XML declaration"), "{w:?}");
        // After a comment or an element, tinyxml2 refuses a declaration: so does tumble.
        for late in [
            "<!-- c --><?xml version='1.0'?><r/>",
            "<r/><?xml version='1.0'?>",
        ] {
            assert_eq!(blank(late), (late.to_string(), vec![]), "{late}");
        }
        // A processing instruction named like `xml-stylesheet` is no declaration.
        let pi = " <?xml-stylesheet href='a'?><r/>";
        assert_eq!(blank(pi).1, vec![]);
    }

    #[test]
    fn same_content_compares_numbers_as_numbers() {
        let doc = roxmltree::Document::parse(
            "<j><axis xyz='0 1 0'/><axis xyz=' 0.0 1  0 '/><axis xyz='0 1 1e-300'/>\
             <axis xyz='nan 0 0'/><axis xyz='nan 0 0'/></j>",
        )
        .unwrap();
        let axes: Vec<Node> = doc.root_element().children().collect();
        assert!(same_content(axes[0], axes[1]));
        assert!(!same_content(axes[0], axes[2]));
        assert!(!same_content(axes[3], axes[4]));
    }

    #[test]
    fn nested_edits_are_skipped() {
        let xml = "abcdefgh";
        let edits = vec![
            Edit {
                range: 2..6,
                text: "X".into(),
            },
            Edit {
                range: 3..4,
                text: "Y".into(),
            },
            Edit {
                range: 7..8,
                text: String::new(),
            },
        ];
        assert_eq!(apply(xml, edits), "abXg");
    }
}
