//! Collada DAE (1.4.0, 1.4.1, 1.5), read with `roxmltree`: the triangles of the geometries the
//! visual scene instantiates, placed by the scene's node transforms, in metres.
//!
//! # Why our own reader
//! Measured on the 286 DAE files of `example-robot-data` 6.0.0: `dae-parser` 0.11 rejects 85
//! of them (68 "Unsupported COLLADA version" for 1.4.0 files, 17 "expected <created>"), and
//! `collada` 0.17 (xml-rs, 4.7 s for the set against 0.7 s) reads geometry but neither node
//! transforms nor `<unit>`. The subset a mass-property reader needs is small, and `roxmltree`
//! is already a dependency.
//!
//! # What is read
//! - Geometry: `<geometry><mesh>` with `<triangles>`, `<polylist>` (`<vcount>`), `<polygons>`
//!   (one `<p>` per polygon; holes `<ph>` are an error), `<tristrips>` and `<trifans>`.
//!   Polygons are triangulated as fans. The position of a corner is the `VERTEX` input (through
//!   `<vertices>`' `POSITION` input) or a direct `POSITION` input, at its `offset` in the
//!   interleaved `<p>` indices (stride = largest input offset + 1). Positions come from
//!   `<source><float_array>` through its `<accessor>` (`count`, `stride`, `offset`).
//!   `<lines>`, `<linestrips>`, `<convex_mesh>`, `<spline>` and skinned `<instance_controller>`
//!   geometry are ignored.
//! - Placement: the visual scene named by `<scene><instance_visual_scene>` (else the first
//!   one) is walked from its root nodes; each `<node>`'s transform is the product, in document
//!   order, of its `<matrix>` (row-major 4×4), `<translate>`, `<rotate>` (axis, degrees) and
//!   `<scale>` elements, composed with its parents'; `<instance_geometry>` and `<instance_node>`
//!   (from `<library_nodes>`) are followed. A node whose transform mirrors (negative
//!   determinant) has its triangles' winding reversed. `<lookat>` and `<skew>` are errors when
//!   they place geometry. A file without a visual scene, or whose scene instantiates no
//!   geometry, has all of `<library_geometries>` taken as placed at the origin.
//! - Units: `<asset><unit meter="s">` scales every coordinate by `s` (default 1): what RViz
//!   (`getMeshUnitRescale`), Gazebo, Pinocchio/coal and trimesh do, so that a mesh authored in
//!   millimetres gets the size those tools show.
//! - Up axis: **`<up_axis>` is ignored by default** ([`UpAxis::Ignore`]): coordinates are used
//!   as written, in the link frame. That is what the URDF tools agree on in effect: RViz drops
//!   the rotation assimp adds for it (keeping only the unit scale), MoveIt's `geometric_shapes`
//!   clears the root transform of Collada files, Gazebo classic does not read the tag, and
//!   assimp-based readers (Pinocchio/coal, gepetto-viewer) leave Y_UP files unrotated. Robot
//!   meshes are authored in the link frame whatever the tag says: 87 of the 286 DAE files in
//!   example-robot-data 6.0.0 say Y_UP, and e.g. tiago's `arm_{1..6}_collision.dae` (Y_UP)
//!   match the bounding boxes of the `arm_{1..6}.stl` visuals of the same links to 2 mm as
//!   written, which a Y_UP → Z_UP rotation would break. [`UpAxis::RotateToZUp`] applies the COLLADA specification instead:
//!   `Y_UP` maps (x, y, z) to (x, −z, y) and `X_UP` maps (x, y, z) to (−y, −z, x) (the spec's
//!   right/up/in axes), both proper rotations.

use super::{MAX_MESH_TRIANGLES, check_triangle_count, index_u32, weld_indexed};
use crate::model::geometry::mesh::TriangleMesh;
use nalgebra::{Matrix3, Matrix4, Rotation3, Unit, Vector3};
use roxmltree::{Document, Node};
use std::collections::HashMap;

/// What to do with `<up_axis>`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum UpAxis {
    /// Use coordinates as written (the URDF tools' behaviour; see the module documentation).
    #[default]
    Ignore,
    /// Rotate `Y_UP` and `X_UP` files to Z up, per the COLLADA 1.4 specification.
    RotateToZUp,
}

/// How to read a DAE file. `<unit>` is always applied.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DaeOptions {
    pub up_axis: UpAxis,
}

/// Deepest `<node>`/`<instance_node>` nesting followed (a guard against reference cycles).
const MAX_NODE_DEPTH: usize = 64;

/// Most `<node>`s visited while walking the visual scene, counting every visit through
/// `<instance_node>` (a guard against instancing bombs: ten `<instance_node>`s of the node
/// below on each of twelve levels are 10^12 visits in a 2 kB file); a bomb stops after about
/// a second. Real robot meshes have orders of magnitude fewer nodes.
const MAX_NODE_VISITS: usize = 1_000_000;

/// Most vertices placed in all: three per triangle of a mesh at [`MAX_MESH_TRIANGLES`] (a
/// bound on memory, 144 MB; a geometry instanced many times places its positions each time).
const MAX_PLACED_VERTICES: usize = 3 * MAX_MESH_TRIANGLES as usize;

/// Parses a DAE file's bytes (see the module documentation), welded.
pub fn read_dae(bytes: &[u8], options: &DaeOptions) -> Result<TriangleMesh, String> {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let text = String::from_utf8_lossy(bytes);
    crate::input::check_xml(&text).map_err(|e| format!("XML refused before parsing: {e}"))?;
    let parsing = roxmltree::ParsingOptions {
        allow_dtd: true,
        ..roxmltree::ParsingOptions::default()
    };
    let doc = Document::parse_with_options(&text, parsing).map_err(|e| format!("XML: {e}"))?;
    let root = doc.root_element();
    if root.tag_name().name() != "COLLADA" {
        return Err(format!(
            "root element is <{}>, not <COLLADA>",
            root.tag_name().name()
        ));
    }
    let asset = child(root, "asset");
    let meter = match asset
        .and_then(|a| child(a, "unit"))
        .and_then(|u| u.attribute("meter"))
    {
        None => 1.0,
        Some(s) => match s.trim().parse::<f64>() {
            Ok(m) if m.is_finite() && m > 0.0 => m,
            _ => return Err(format!("<unit meter=\"{s}\">: not a positive number")),
        },
    };
    let up_axis = asset
        .and_then(|a| child(a, "up_axis"))
        .and_then(|u| u.text())
        .map(str::trim)
        .unwrap_or("Y_UP");
    let up_rotation = match (options.up_axis, up_axis) {
        (UpAxis::Ignore, _) | (_, "Z_UP") => Matrix3::identity(),
        (_, "Y_UP") => Matrix3::new(1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0),
        (_, "X_UP") => Matrix3::new(0.0, -1.0, 0.0, 0.0, 0.0, -1.0, 1.0, 0.0, 0.0),
        (_, other) => {
            return Err(format!(
                "<up_axis>{other}</up_axis>: not X_UP, Y_UP or Z_UP"
            ));
        }
    };
    let mut reader = Reader {
        ids: doc
            .descendants()
            .filter_map(|n| Some((n.attribute("id")?, n)))
            .collect(),
        positions: HashMap::new(),
        vertices: Vec::new(),
        triangles: Vec::new(),
        instances: 0,
        visits: 0,
    };
    if let Some(scene) = visual_scene(root, &reader.ids) {
        for node in children(scene, "node") {
            reader.walk(node, Ok(Matrix4::identity()), 0)?;
        }
    }
    if reader.instances == 0 {
        let geometries = child(root, "library_geometries");
        for geometry in geometries.into_iter().flat_map(|g| children(g, "geometry")) {
            reader.add_geometry(geometry, &Matrix4::identity())?;
        }
    }
    let to_metres = up_rotation * meter;
    let vertices: Vec<Vector3<f64>> = reader.vertices.iter().map(|v| to_metres * v).collect();
    Ok(weld_indexed(&vertices, &reader.triangles))
}

/// The first child element named `name` (namespace ignored).
fn child<'a, 'i>(node: Node<'a, 'i>, name: &'static str) -> Option<Node<'a, 'i>> {
    node.children()
        .find(|c| c.is_element() && c.tag_name().name() == name)
}

/// The child elements named `name` (namespace ignored).
fn children<'a, 'i>(node: Node<'a, 'i>, name: &'static str) -> impl Iterator<Item = Node<'a, 'i>> {
    node.children()
        .filter(move |c| c.is_element() && c.tag_name().name() == name)
}

/// `<x id="...">` of a `#id` URL (local references only).
fn target<'a, 'i>(ids: &HashMap<&'a str, Node<'a, 'i>>, url: Option<&str>) -> Option<Node<'a, 'i>> {
    ids.get(url?.strip_prefix('#')?).copied()
}

fn label(node: Node) -> String {
    match node.attribute("id").or(node.attribute("name")) {
        Some(id) => format!("<{} id=\"{id}\">", node.tag_name().name()),
        None => format!("<{}>", node.tag_name().name()),
    }
}

/// The visual scene to place geometry with: `<scene><instance_visual_scene url>`, else the
/// first of `<library_visual_scenes>`.
fn visual_scene<'a, 'i>(
    root: Node<'a, 'i>,
    ids: &HashMap<&'a str, Node<'a, 'i>>,
) -> Option<Node<'a, 'i>> {
    let named = child(root, "scene")
        .and_then(|s| child(s, "instance_visual_scene"))
        .and_then(|i| target(ids, i.attribute("url")));
    named.or_else(|| children(child(root, "library_visual_scenes")?, "visual_scene").next())
}

fn floats(node: Node) -> Result<Vec<f64>, String> {
    node.text()
        .unwrap_or("")
        .split_ascii_whitespace()
        .map(|s| {
            s.parse::<f64>()
                .map_err(|_| format!("{}: `{s}` is not a number", label(node)))
        })
        .collect()
}

fn indices(node: Node) -> Result<Vec<usize>, String> {
    node.text()
        .unwrap_or("")
        .split_ascii_whitespace()
        .map(|s| {
            s.parse::<usize>()
                .map_err(|_| format!("{}: `{s}` is not an index", label(node)))
        })
        .collect()
}

/// The transform of one `<node>` itself: its transform elements multiplied in document order.
/// `Err` (kept, raised only if the node places geometry) for `<lookat>`, `<skew>` or a
/// malformed element.
fn local_transform(node: Node) -> Result<Matrix4<f64>, String> {
    let mut m = Matrix4::identity();
    for element in node.children().filter(Node::is_element) {
        let name = element.tag_name().name();
        let values = || -> Result<Vec<f64>, String> {
            let v = floats(element)?;
            if v.iter().any(|x| !x.is_finite()) {
                return Err(format!(
                    "{} <{name}> has a NaN or infinite number",
                    label(node)
                ));
            }
            let expected = match name {
                "matrix" => 16,
                "rotate" => 4,
                _ => 3,
            };
            if v.len() == expected {
                Ok(v)
            } else {
                Err(format!(
                    "{} <{name}> has {} numbers, expected {expected}",
                    label(node),
                    v.len()
                ))
            }
        };
        let step = match name {
            "matrix" => Matrix4::from_row_slice(&values()?),
            "translate" => {
                let v = values()?;
                Matrix4::new_translation(&Vector3::new(v[0], v[1], v[2]))
            }
            "scale" => {
                let v = values()?;
                Matrix4::new_nonuniform_scaling(&Vector3::new(v[0], v[1], v[2]))
            }
            "rotate" => {
                let v = values()?;
                let axis = Vector3::new(v[0], v[1], v[2]);
                if v[3] == 0.0 {
                    Matrix4::identity()
                } else if axis.norm() == 0.0 || !axis.iter().all(|x| x.is_finite()) {
                    return Err(format!(
                        "{} <rotate> about a zero or non-finite axis",
                        label(node)
                    ));
                } else {
                    Rotation3::from_axis_angle(&Unit::new_normalize(axis), v[3].to_radians())
                        .to_homogeneous()
                }
            }
            "lookat" | "skew" => {
                return Err(format!(
                    "{} <{name}> transforms are not supported",
                    label(node)
                ));
            }
            _ => continue,
        };
        m *= step;
    }
    Ok(m)
}

struct Reader<'a, 'i> {
    ids: HashMap<&'a str, Node<'a, 'i>>,
    /// Positions of each `<source>` already read, by id.
    positions: HashMap<&'a str, Vec<Vector3<f64>>>,
    /// All placed positions, in file units and axes.
    vertices: Vec<Vector3<f64>>,
    triangles: Vec<[u32; 3]>,
    /// Geometry instances placed by the visual scene.
    instances: usize,
    /// `<node>` visits so far (bounded by [`MAX_NODE_VISITS`]).
    visits: usize,
}

impl<'a, 'i> Reader<'a, 'i> {
    /// Places the geometry under `node` with `parent` the transform of its parent.
    fn walk(
        &mut self,
        node: Node<'a, 'i>,
        parent: Result<Matrix4<f64>, String>,
        depth: usize,
    ) -> Result<(), String> {
        if depth > MAX_NODE_DEPTH {
            return Err(format!(
                "{}: nodes nested deeper than {MAX_NODE_DEPTH} (an <instance_node> cycle?)",
                label(node)
            ));
        }
        self.visits += 1;
        if self.visits > MAX_NODE_VISITS {
            return Err(format!(
                "{}: more than {MAX_NODE_VISITS} <node> visits (an <instance_node> bomb?)",
                label(node)
            ));
        }
        let transform = parent.and_then(|p| Ok(p * local_transform(node)?));
        for c in node.children().filter(Node::is_element) {
            match c.tag_name().name() {
                "node" => self.walk(c, transform.clone(), depth + 1)?,
                "instance_node" => {
                    let target = target(&self.ids, c.attribute("url"))
                        .ok_or_else(|| format!("{}: <instance_node> url not found", label(node)))?;
                    self.walk(target, transform.clone(), depth + 1)?;
                }
                "instance_geometry" => {
                    let geometry = target(&self.ids, c.attribute("url")).ok_or_else(|| {
                        format!("{}: <instance_geometry> url not found", label(node))
                    })?;
                    let transform = transform.clone()?;
                    self.instances += 1;
                    self.add_geometry(geometry, &transform)?;
                }
                _ => {}
            }
        }
        Ok(())
    }

    /// Adds the triangles of one `<geometry>`, placed by `transform`.
    fn add_geometry(
        &mut self,
        geometry: Node<'a, 'i>,
        transform: &Matrix4<f64>,
    ) -> Result<(), String> {
        let Some(mesh) = child(geometry, "mesh") else {
            return Ok(());
        };
        let linear = transform.fixed_view::<3, 3>(0, 0).into_owned();
        let translation = transform.fixed_view::<3, 1>(0, 3).into_owned();
        let mirrored = linear.determinant() < 0.0;
        let context = |e: String| format!("{}: {e}", label(geometry));
        for primitive in mesh.children().filter(Node::is_element) {
            let kind = primitive.tag_name().name();
            if !matches!(
                kind,
                "triangles" | "polylist" | "polygons" | "tristrips" | "trifans"
            ) {
                continue;
            }
            let (positions_id, position_offset, stride) =
                self.position_input(primitive).map_err(context)?;
            let positions =
                source_positions(&self.ids, &mut self.positions, positions_id).map_err(context)?;
            let offset = index_u32(self.vertices.len())?;
            let count = positions.len();
            if self.vertices.len().saturating_add(count) > MAX_PLACED_VERTICES {
                return Err(context(format!(
                    "more than {MAX_PLACED_VERTICES} vertices placed in all (too many \
                     instances of too large geometry)"
                )));
            }
            self.vertices
                .extend(positions.iter().map(|p| linear * p + translation));
            index_u32(self.vertices.len())?;
            // Every triangle has three corners at least: refused from the indices' count
            // before they are parsed into polygons.
            let indices: u64 = children(primitive, "p")
                .map(|p| p.text().unwrap_or("").split_ascii_whitespace().count() as u64)
                .sum();
            check_triangle_count(
                self.triangles.len() as u64 + indices / stride as u64 / 3,
                false,
                "placed by its visual scene, counted from its <p> indices before parsing them",
            )?;
            let polygons =
                corner_lists(primitive, kind, stride, position_offset).map_err(context)?;
            for (polygon, strip) in polygons {
                check_triangle_count(
                    (self.triangles.len() + polygon.len().saturating_sub(2)) as u64,
                    false,
                    "placed by its visual scene, counted while reading",
                )?;
                if let Some(&bad) = polygon.iter().find(|&&i| i >= count) {
                    return Err(context(format!(
                        "<{kind}> index {bad} past the {count} positions"
                    )));
                }
                let corner = |k: usize| polygon[k] as u32 + offset;
                for k in 1..polygon.len().saturating_sub(1) {
                    let mut t = if strip {
                        // Strip triangle k−1 = (k−1, k, k+1), every other one reversed.
                        if k % 2 == 1 {
                            [corner(k - 1), corner(k), corner(k + 1)]
                        } else {
                            [corner(k), corner(k - 1), corner(k + 1)]
                        }
                    } else {
                        [corner(0), corner(k), corner(k + 1)]
                    };
                    if mirrored {
                        t.swap(1, 2);
                    }
                    self.triangles.push(t);
                }
            }
        }
        Ok(())
    }

    /// The id of the `<source>` of positions of a primitive, the offset of its index in each
    /// corner's tuple, and the tuple length.
    fn position_input(&self, primitive: Node<'a, 'i>) -> Result<(&'a str, usize, usize), String> {
        let mut stride = 1;
        let mut found = None;
        for input in children(primitive, "input") {
            let offset: usize = match input.attribute("offset") {
                Some(s) => s
                    .trim()
                    .parse()
                    .map_err(|_| format!("<input offset=\"{s}\">: not an index"))?,
                None => 0,
            };
            stride = stride.max(offset.saturating_add(1));
            let source = input.attribute("source");
            match input.attribute("semantic") {
                Some("VERTEX") => {
                    let vertices = target(&self.ids, source).ok_or_else(|| {
                        "<input semantic=\"VERTEX\"> source not found".to_string()
                    })?;
                    let position = children(vertices, "input")
                        .find(|i| i.attribute("semantic") == Some("POSITION"))
                        .and_then(|i| i.attribute("source"));
                    let id = position
                        .and_then(|s| s.strip_prefix('#'))
                        .ok_or_else(|| format!("{} has no POSITION input", label(vertices)))?;
                    found = Some((id, offset));
                }
                Some("POSITION") if found.is_none() => {
                    let id = source.and_then(|s| s.strip_prefix('#')).ok_or_else(|| {
                        "<input semantic=\"POSITION\"> without source".to_string()
                    })?;
                    found = Some((id, offset));
                }
                _ => {}
            }
        }
        let (id, offset) = found
            .ok_or_else(|| format!("<{}> has no VERTEX input", primitive.tag_name().name()))?;
        Ok((id, offset, stride))
    }
}

/// The positions of `<source id>` (read once, then cached in `cache`).
fn source_positions<'a, 'i, 'm>(
    ids: &HashMap<&'a str, Node<'a, 'i>>,
    cache: &'m mut HashMap<&'a str, Vec<Vector3<f64>>>,
    id: &'a str,
) -> Result<&'m Vec<Vector3<f64>>, String> {
    if !cache.contains_key(id) {
        let source = *ids
            .get(id)
            .ok_or_else(|| format!("position source `#{id}` not found"))?;
        cache.insert(id, read_source(source)?);
    }
    cache
        .get(id)
        .ok_or_else(|| format!("position source `#{id}` not found"))
}

/// The 3-vectors of a `<source>`: its `<float_array>` read through its `<accessor>`.
fn read_source(source: Node) -> Result<Vec<Vector3<f64>>, String> {
    let array = child(source, "float_array")
        .ok_or_else(|| format!("{} has no <float_array>", label(source)))?;
    let values = floats(array)?;
    let accessor = child(source, "technique_common").and_then(|t| child(t, "accessor"));
    let attribute = |name: &str, default: usize| -> Result<usize, String> {
        match accessor.and_then(|a| a.attribute(name)) {
            None => Ok(default),
            Some(s) => s
                .trim()
                .parse()
                .map_err(|_| format!("{} <accessor {name}=\"{s}\">: not an index", label(source))),
        }
    };
    let stride = attribute("stride", 3)?;
    let offset = attribute("offset", 0)?;
    let count = attribute("count", values.len() / 3)?;
    if stride < 3 {
        return Err(format!(
            "{}: accessor stride {stride}, positions need 3",
            label(source)
        ));
    }
    let needed = count.checked_sub(1).map_or(Some(0), |last| {
        last.checked_mul(stride)?
            .checked_add(offset)?
            .checked_add(3)
    });
    if needed.is_none_or(|n| n > values.len()) {
        return Err(format!(
            "{}: accessor wants {count} positions (stride {stride}, offset {offset}) from {} \
             numbers",
            label(source),
            values.len()
        ));
    }
    Ok((0..count)
        .map(|i| {
            let k = offset + i * stride;
            Vector3::new(values[k], values[k + 1], values[k + 2])
        })
        .collect())
}

/// The polygons of a primitive as lists of position indices, with `true` for strips.
fn corner_lists(
    primitive: Node,
    kind: &str,
    stride: usize,
    position_offset: usize,
) -> Result<Vec<(Vec<usize>, bool)>, String> {
    let corners = |p: Node| -> Result<Vec<usize>, String> {
        let all = indices(p)?;
        if all.len() % stride != 0 {
            return Err(format!(
                "<{kind}> <p> has {} indices, not a multiple of the {stride} inputs",
                all.len()
            ));
        }
        Ok(all
            .chunks_exact(stride)
            .map(|c| c[position_offset])
            .collect())
    };
    let mut out = Vec::new();
    match kind {
        "triangles" => {
            for p in children(primitive, "p") {
                let c = corners(p)?;
                if c.len() % 3 != 0 {
                    return Err(format!(
                        "<triangles> has {} corners, not a multiple of 3",
                        c.len()
                    ));
                }
                out.extend(c.chunks_exact(3).map(|t| (t.to_vec(), false)));
            }
        }
        "polylist" => {
            let counts = match child(primitive, "vcount") {
                Some(v) => indices(v)?,
                None => Vec::new(),
            };
            let c = match child(primitive, "p") {
                Some(p) => corners(p)?,
                None => Vec::new(),
            };
            let total: usize = counts
                .iter()
                .try_fold(0usize, |a, &n| a.checked_add(n))
                .unwrap_or(usize::MAX);
            if total != c.len() {
                return Err(format!(
                    "<polylist> <vcount> adds up to {total} corners, <p> has {}",
                    c.len()
                ));
            }
            let mut start = 0;
            for n in counts {
                out.push((c[start..start + n].to_vec(), false));
                start += n;
            }
        }
        "polygons" => {
            if child(primitive, "ph").is_some() {
                return Err("<polygons> with holes (<ph>) are not supported".into());
            }
            for p in children(primitive, "p") {
                out.push((corners(p)?, false));
            }
        }
        "tristrips" => {
            for p in children(primitive, "p") {
                out.push((corners(p)?, true));
            }
        }
        _ => {
            for p in children(primitive, "p") {
                out.push((corners(p)?, false));
            }
        }
    }
    Ok(out)
}
