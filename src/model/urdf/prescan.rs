//! The XML side of a load: the text checked and parsed with roxmltree before urdf-rs sees it
//! (size rules, the `<robot>` root, which links have an `<inertial>`), the edits urdf-rs needs
//! (empty `<texture/>`s and, in lenient mode, the oddities of [`super::lenient`]), and
//! urdf-rs's reading of the edited text, its failures located by [`super::locate`].

use super::ModelError;
use super::lenient::{self, LoadWarning};
use super::locate::locate_parse_problem;
use std::borrow::Cow;
use std::collections::HashSet;
use std::path::Path;

/// The text as the pre-scan reads it: in lenient mode with misplaced XML declarations blanked
/// out (a warning each), then checked for XML whose parsing would take work out of proportion
/// to its size ([`crate::input::check_xml`]: [`ModelError::XmlRefused`]).
pub(super) fn checked_text<'a>(
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
pub(super) fn parse_robot_xml<'a>(
    xml: &'a str,
    path: &Path,
) -> Result<roxmltree::Document<'a>, ModelError> {
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
/// mass 0: only the pre-scan can tell
/// [`InertiaSource::Missing`](crate::model::InertiaSource::Missing) from an explicit zero).
pub(super) fn links_with_inertial<'a>(doc: &'a roxmltree::Document) -> HashSet<&'a str> {
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
pub(super) fn read_robot(
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
