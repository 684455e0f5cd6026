//! Locating a urdf-rs failure: urdf-rs's messages name no element, so after it fails the
//! document is checked against its requirements (required elements and attributes, numbers
//! and vectors, elements allowed once) to name the first link, joint or material at fault.

use super::lenient::{self, first_child};

/// After urdf-rs failed: find the first link or joint whose content urdf-rs cannot read,
/// mirroring urdf-rs's requirements (required elements and attributes, numbers and vectors).
/// Best effort: `None` when nothing specific is found.
pub(super) fn locate_parse_problem(doc: &roxmltree::Document) -> Option<String> {
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

/// What is wrong with an element, when something is.
type Check = Option<String>;

/// Attribute `attr` of `node`, when present (or `required`), is a number.
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

/// Attribute `attr` of `node`, when present (or `required`), is `n` numbers.
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

/// The `<origin>` of `node`, if any: `xyz` and `rpy` are 3 numbers each when present.
fn check_origin(node: roxmltree::Node) -> Check {
    let origin = first_child(node, "origin")?;
    check_vector(origin, "xyz", 3, false).or_else(|| check_vector(origin, "rpy", 3, false))
}

/// `node` has a child `<tag>`.
fn check_required(node: roxmltree::Node, tag: &str) -> Result<(), String> {
    match first_child(node, tag) {
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

/// A `<link>`: its `<inertial>` (at most one, with mass and inertia numbers), then each
/// `<visual>` and `<collision>` (origin, geometry, material), labelled by kind and number.
fn check_link(link: roxmltree::Node) -> Check {
    if let Some(p) = check_unique(link, &["inertial"]) {
        return Some(p);
    }
    if let Some(inertial) = first_child(link, "inertial") {
        if let Some(p) = check_unique(inertial, &["origin", "mass", "inertia"]) {
            return Some(format!("inertial {p}"));
        }
        if let Some(p) = check_origin(inertial) {
            return Some(format!("inertial {p}"));
        }
        match first_child(inertial, "mass") {
            None => return Some("<inertial> has no <mass>".into()),
            Some(mass) => {
                if let Some(p) = check_number(mass, "value", true) {
                    return Some(p);
                }
            }
        }
        match first_child(inertial, "inertia") {
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
                first_child(element, "material")
                    .filter(|_| element.has_tag_name("visual"))
                    .and_then(check_material)
            });
        if let Some(p) = problem {
            return Some(format!("{label}: {p}"));
        }
    }
    None
}

/// The `<geometry>` of a visual or collision: present, one shape of a known kind with its
/// required attributes, nothing after it.
fn check_geometry(element: roxmltree::Node) -> Result<(), String> {
    check_required(element, "geometry")?;
    let geometry = first_child(element, "geometry").ok_or_else(String::new)?;
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

/// A `<material>`: named, and its `<color>`, if any, has 4 `rgba` numbers.
fn check_material(material: roxmltree::Node) -> Check {
    if material.attribute("name").is_none() {
        return Some("<material> has no `name` attribute".into());
    }
    first_child(material, "color").and_then(|c| check_vector(c, "rgba", 4, true))
}

/// A `<joint>`: a known type, its elements at most once, parent and child links, then the
/// numbers of origin, axis, limit (`velocity` required before URDF 1.2), mimic and safety
/// controller.
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
        match first_child(joint, role) {
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
    if let Some(p) = first_child(joint, "axis").and_then(|a| check_vector(a, "xyz", 3, true)) {
        return Some(p);
    }
    if let Some(limit) = first_child(joint, "limit") {
        for attr in ["lower", "upper", "effort"] {
            if let Some(p) = check_number(limit, attr, false) {
                return Some(p);
            }
        }
        if let Some(p) = check_number(limit, "velocity", !version_1_2) {
            return Some(p);
        }
    }
    if let Some(mimic) = first_child(joint, "mimic") {
        if mimic.attribute("joint").is_none() {
            return Some("<mimic> has no `joint` attribute".into());
        }
        for attr in ["multiplier", "offset"] {
            if let Some(p) = check_number(mimic, attr, false) {
                return Some(p);
            }
        }
    }
    if let Some(s) = first_child(joint, "safety_controller")
        && let Some(p) = check_number(s, "k_velocity", true)
    {
        return Some(p);
    }
    None
}
