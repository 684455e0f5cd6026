//! Contact (issue 31), the scene side: a scene's `[ground]` and its models' `collisions` made
//! into the [`ContactModel`] a [`World`] carries (the physics is `crate::sim::contact`).
//!
//! ```toml
//! [ground]                  # a half-space; absent = no ground
//! height = 0.0              # m along −g/|g| (default 0 when `normal` is not given)
//! # normal = [0, 0, 1]      # or: the outward normal (normalized) ...
//! # point = [0, 0, 0]       # ... and a point of the surface (default the origin)
//! friction = 0.8            # Coulomb coefficient, >= 0                   (default 0.8)
//! restitution = 0.0         # in [0, 1]                                   (default 0)
//!
//! [[model]]
//! collisions = "urdf"       # "none" (default) | "urdf" (<collision>) | "visual" (<visual>)
//! self_collision = false    # the links of one copy collide with each other (default false)
//! friction = 0.8            # (default 0.8; a pair takes the smaller)
//! restitution = 0.0         # (default 0; a pair takes the larger)
//! ```
//!
//! Each `<collision>` (or `<visual>`) element of a link is one [`Collider`] on the body the link
//! rides on ([`crate::world::Attachment`]): a box, sphere, cylinder or capsule as itself, a mesh
//! as the convex hull of its vertices, the `<mesh scale>` applied (not decomposed: a concave
//! mesh collides as its hull). Its pose in the body's principal frame is
//! `body_from_link · link_from_shape` (the link's pose in the body, then the element's
//! `<origin>`), the same composition every body mode uses for the frames it records.
//!
//! Geometry no body carries is left out, with a note: a massless link's in `bodies = "links"`
//! (it is no body), a link welded to the world (`base = "fixed"`) or inside a compound joint
//! (nothing moves it). A model asking for collisions whose bodies end up with none is an error.
//!
//! Which pairs never collide: colliders on one body; colliders of one model copy unless the
//! model says `self_collision = true`; and even then a joint's parent and child bodies
//! ([`ContactModel::excluded_body_pairs`]: articulated models' kept joints; in links mode each
//! URDF joint's child link and its nearest ancestor link with mass).

use super::entry::{Collisions, ModelEntry};
use super::{BodiesMode, Scene};
use crate::budget::readable;
use crate::model::geometry::GeometryError;
use crate::model::geometry::compose;
use crate::model::policy::GeometrySource;
use crate::model::{Geometry, Model};
use crate::sim::contact::{Collider, ContactModel, Ground, Shape};
use crate::world::{Attachment, World};
use anyhow::{Context, bail};
use nalgebra::{Isometry3, Point3, Unit, Vector3};
use serde::Deserialize;
use std::collections::HashMap;
use std::ops::Range;
use std::path::PathBuf;
use std::sync::Arc;

/// A surface's Coulomb coefficient when the scene does not say (the ground's, a model's).
pub const DEFAULT_FRICTION: f64 = 0.8;
/// A surface's restitution when the scene does not say.
pub const DEFAULT_RESTITUTION: f64 = 0.0;

/// Points of a mesh closer to a plane than this fraction of the mesh's size are in it (the hull
/// would be flat: no volume to collide with).
const COPLANAR_RELATIVE: f64 = 1e-9;

/// The `[ground]` table as written.
#[derive(Debug, Clone, Default, PartialEq, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct GroundEntry {
    /// m along `−g/|g|`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub height: Option<f64>,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "opt_vec3"
    )]
    pub normal: Option<[f64; 3]>,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "opt_vec3"
    )]
    pub point: Option<[f64; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub restitution: Option<f64>,
}

fn opt_vec3<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<[f64; 3]>, D::Error> {
    super::entry::vec3(d).map(Some)
}

/// Checks a surface's coefficients; `key` names the table (`scene.toml: ground`,
/// `scene.toml: model[0]`).
pub(crate) fn check_coefficients(
    key: &str,
    friction: Option<f64>,
    restitution: Option<f64>,
) -> anyhow::Result<()> {
    if let Some(mu) = friction
        && !(mu.is_finite() && mu >= 0.0)
    {
        bail!(
            "{key}.friction must be a finite number >= 0 (a Coulomb coefficient; got {})",
            readable(mu)
        );
    }
    if let Some(e) = restitution
        && !(e.is_finite() && (0.0..=1.0).contains(&e))
    {
        bail!(
            "{key}.restitution must be a number between 0 and 1 (0: no bounce, 1: elastic; \
             got {})",
            readable(e)
        );
    }
    Ok(())
}

impl GroundEntry {
    /// The ground half-space under gravity `gravity` (m/s²); `key` names the table
    /// (`scene.toml: ground`).
    pub fn resolve(&self, key: &str, gravity: &Vector3<f64>) -> anyhow::Result<Ground> {
        check_coefficients(key, self.friction, self.restitution)?;
        let (normal, point) = match (self.height, self.normal) {
            (Some(_), Some(_)) => bail!(
                "{key}: give either `height` (along −gravity) or `normal` (with `point`), not both"
            ),
            (height, None) => {
                if self.point.is_some() {
                    bail!(
                        "{key}.point goes with `normal` (with `height`, the ground passes through \
                         height · (−g/|g|)); give `normal` too, or `height` alone"
                    );
                }
                let height = height.unwrap_or(0.0);
                if !height.is_finite() {
                    bail!(
                        "{key}.height must be a finite number of metres (got {})",
                        readable(height)
                    );
                }
                let up = -gravity;
                let scale = up.amax();
                if !(scale > 0.0 && scale.is_finite()) {
                    bail!(
                        "{key}.height is measured along −gravity, and sim.gravity is zero: give \
                         the ground's `normal` (and `point`) instead"
                    );
                }
                let n = Unit::new_normalize(up / scale);
                (n, n.into_inner() * height)
            }
            (None, Some(normal)) => {
                let v = Vector3::from(normal);
                if !v.iter().all(|x| x.is_finite()) {
                    bail!("{key}.normal must hold three finite numbers (got {normal:?})");
                }
                let scale = v.amax();
                if scale == 0.0 {
                    bail!(
                        "{key}.normal has zero length: give the ground's outward normal, e.g. \
                         [0, 0, 1]"
                    );
                }
                let point = self.point.unwrap_or([0.0; 3]);
                if !point.iter().all(|x| x.is_finite()) {
                    bail!("{key}.point must hold three finite numbers (got {point:?})");
                }
                (Unit::new_normalize(v / scale), Vector3::from(point))
            }
        };
        Ok(Ground {
            normal,
            point,
            friction: self.friction.unwrap_or(DEFAULT_FRICTION),
            restitution: self.restitution.unwrap_or(DEFAULT_RESTITUTION),
        })
    }
}

impl Scene {
    /// The scene's ground under its gravity (`None`: no `[ground]` table).
    pub fn ground(&self) -> anyhow::Result<Option<Ground>> {
        self.ground
            .as_ref()
            .map(|g| {
                g.resolve(
                    &format!("{}: ground", self.source.display()),
                    &self.gravity(),
                )
            })
            .transpose()
    }
}

/// The contact keys of `[[model]]` table `entry` (`key` names it), checked.
pub(crate) fn check_model_keys(key: &str, entry: &ModelEntry) -> anyhow::Result<()> {
    if let Some(name) = &entry.collisions
        && Collisions::from_name(name).is_none()
    {
        bail!(
            "{key}.collisions: unknown value {name:?} (expected one of: {})",
            Collisions::NAMES.map(|n| format!("\"{n}\"")).join(", ")
        );
    }
    check_coefficients(key, entry.friction, entry.restitution)?;
    if entry.collisions() == Collisions::None {
        let given = [
            ("self_collision", entry.self_collision.is_some()),
            ("friction", entry.friction.is_some()),
            ("restitution", entry.restitution.is_some()),
        ];
        if let Some((name, _)) = given.iter().find(|(_, given)| *given) {
            bail!(
                "{key}.{name} applies to a model that collides: set collisions = \"urdf\" (its \
                 <collision> geometry) or \"visual\" (this model has collisions = \"none\", the \
                 default)"
            );
        }
    }
    Ok(())
}

/// One collider of a link, in the link frame.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct LinkShape {
    /// The element's `<origin>`.
    pub link_from_shape: Isometry3<f64>,
    pub shape: Shape,
}

/// The collision geometry of a model, each link's shapes by link name (shared by the tables
/// and copies using the model).
pub(crate) type LinkShapes = HashMap<String, Vec<LinkShape>>;

/// A `[[model]]` table's colliders: its shapes and its settings.
#[derive(Debug, Clone)]
pub(crate) struct TableColliders {
    pub source: Collisions,
    pub shapes: Arc<LinkShapes>,
    pub friction: f64,
    pub restitution: f64,
    pub self_collision: bool,
}

/// Meshes read for colliders during one load, by file and scale: each hull built once.
#[derive(Default)]
pub(crate) struct HullCache {
    hulls: HashMap<(PathBuf, [u64; 3]), Shape>,
    /// Shapes by model (its address) and source: tables sharing a model share them.
    models: HashMap<(usize, u8), Arc<LinkShapes>>,
}

/// The colliders of `entry`'s model (`None` for `collisions = "none"`). `key` names the table
/// (`scene.toml: model[0]`), `label` the model. Errors name the URDF, the link and the element.
pub(crate) fn table_colliders(
    key: &str,
    entry: &ModelEntry,
    model: &Arc<Model>,
    label: &str,
    cache: &mut HullCache,
) -> anyhow::Result<Option<TableColliders>> {
    let source = entry.collisions();
    let set = match source {
        Collisions::None => return Ok(None),
        Collisions::Urdf => GeometrySource::Collision,
        Collisions::Visual => GeometrySource::Visual,
    };
    let context = || {
        format!(
            "{key}: collisions = \"{}\": model `{label}` ({})",
            source.name(),
            model.path.display()
        )
    };
    let model_key = (Arc::as_ptr(model) as usize, source as u8);
    let shapes = match cache.models.get(&model_key) {
        Some(shapes) => shapes.clone(),
        None => {
            let shapes = Arc::new(link_shapes(model, set, &mut cache.hulls).with_context(context)?);
            if shapes.values().all(Vec::is_empty) {
                let (element, other) = match source {
                    Collisions::Visual => ("<visual>", "\"urdf\" for its <collision> geometry"),
                    _ => ("<collision>", "\"visual\" for its visual geometry"),
                };
                bail!(
                    "{}: no link has {element} geometry: nothing would collide (use \
                     collisions = {other}, or \"none\")",
                    context()
                );
            }
            cache.models.insert(model_key, shapes.clone());
            shapes
        }
    };
    Ok(Some(TableColliders {
        source,
        shapes,
        friction: entry.friction.unwrap_or(DEFAULT_FRICTION),
        restitution: entry.restitution.unwrap_or(DEFAULT_RESTITUTION),
        self_collision: entry.self_collision.unwrap_or(false),
    }))
}

/// Every link's shapes of `set`, by link name.
fn link_shapes(
    model: &Model,
    set: GeometrySource,
    hulls: &mut HashMap<(PathBuf, [u64; 3]), Shape>,
) -> anyhow::Result<LinkShapes> {
    let mut out = LinkShapes::new();
    for link in &model.links {
        let mut shapes = Vec::new();
        for s in compose::shapes(link, set) {
            let at = || format!("link `{}`, {}", link.name, s.element);
            let shape = shape_of(&s.element, s.geometry, hulls).with_context(at)?;
            shapes.push(LinkShape {
                link_from_shape: *s.link_from_shape,
                shape,
            });
        }
        out.insert(link.name.clone(), shapes);
    }
    Ok(out)
}

/// A URDF geometry as a collider's shape. Errors say what is wrong (the caller names the link
/// and element).
pub(crate) fn shape_of(
    element: &str,
    geometry: &Geometry,
    hulls: &mut HashMap<(PathBuf, [u64; 3]), Shape>,
) -> anyhow::Result<Shape> {
    let positive = |what: &str, x: f64| -> anyhow::Result<()> {
        if !(x.is_finite() && x > 0.0) {
            bail!("{what} must be positive and finite (got {})", readable(x));
        }
        Ok(())
    };
    Ok(match geometry {
        Geometry::Box { size } => {
            for (axis, s) in ["x", "y", "z"].iter().zip(size.iter()) {
                positive(&format!("box size along {axis}"), *s)?;
            }
            Shape::Box {
                half_extents: size / 2.0,
            }
        }
        Geometry::Sphere { radius } => {
            positive("sphere radius", *radius)?;
            Shape::Sphere { radius: *radius }
        }
        Geometry::Cylinder { radius, length } => {
            positive("cylinder radius", *radius)?;
            positive("cylinder length", *length)?;
            Shape::Cylinder {
                radius: *radius,
                half_length: length / 2.0,
            }
        }
        Geometry::Capsule { radius, length } => {
            positive("capsule radius", *radius)?;
            if !(length.is_finite() && *length >= 0.0) {
                bail!(
                    "capsule length must be finite and >= 0 (got {})",
                    readable(*length)
                );
            }
            Shape::Capsule {
                radius: *radius,
                half_length: length / 2.0,
            }
        }
        Geometry::Mesh { uri, path, scale } => {
            if !scale.iter().all(|s| s.is_finite() && *s != 0.0) {
                bail!(
                    "mesh `{uri}`: scale [{}, {}, {}] must be finite and non-zero",
                    scale.x,
                    scale.y,
                    scale.z
                );
            }
            // A path refused by the confinement rule is `None` here (and stopped the load
            // before: `Model::check_meshes`): only allowed files are read.
            let Some(path) = path else {
                let error = match crate::model::package::uri_problem(uri) {
                    Some(reason) => GeometryError::MeshUri {
                        element: element.to_string(),
                        uri: uri.clone(),
                        reason,
                    },
                    None => GeometryError::MeshNotFound {
                        element: element.to_string(),
                        uri: uri.clone(),
                    },
                };
                let text = error.to_string();
                let text = text
                    .strip_prefix(&format!("{element}: "))
                    .unwrap_or(&text)
                    .to_string();
                bail!(text);
            };
            let key = (path.clone(), scale.map(f64::to_bits).into());
            if let Some(shape) = hulls.get(&key) {
                return Ok(shape.clone());
            }
            let mesh = crate::model::geometry::mesh_io::load_mesh(path)
                .with_context(|| format!("mesh `{uri}`"))?;
            let points: Vec<Vector3<f64>> = mesh
                .vertices
                .iter()
                .map(|v| v.component_mul(scale))
                .collect();
            let shape = convex_hull(&points).with_context(|| {
                format!(
                    "mesh `{uri}` ({}), scale [{}, {}, {}]: its convex hull (the collider a mesh \
                     becomes)",
                    path.display(),
                    scale.x,
                    scale.y,
                    scale.z
                )
            })?;
            hulls.insert(key, shape.clone());
            shape
        }
    })
}

/// The convex hull of `points` as a [`Shape::ConvexHull`] of the hull's vertices: an error for
/// fewer than 4 points, points all on a line or in a plane (relative to their spread:
/// [`COPLANAR_RELATIVE`]), non-finite points, or a hull parry3d-f64 cannot build.
pub(crate) fn convex_hull(points: &[Vector3<f64>]) -> anyhow::Result<Shape> {
    if let Some(p) = points.iter().find(|p| !p.iter().all(|x| x.is_finite())) {
        bail!(
            "a vertex is not finite ({}, {}, {})",
            readable(p.x),
            readable(p.y),
            readable(p.z)
        );
    }
    if points.len() < 4 {
        bail!(
            "{} vertices: a convex hull needs at least 4 points not in one plane",
            points.len()
        );
    }
    let p0 = points[0];
    let farthest = |f: &dyn Fn(&Vector3<f64>) -> f64| {
        points
            .iter()
            .map(|p| (f(p), *p))
            .fold((0.0_f64, p0), |a, b| if b.0 > a.0 { b } else { a })
    };
    let (d1, p1) = farthest(&|p| (p - p0).norm());
    let tolerance = COPLANAR_RELATIVE * d1;
    if d1 == 0.0 {
        bail!("all {} vertices are one point: no volume", points.len());
    }
    let e1 = (p1 - p0) / d1;
    let off_line = |p: &Vector3<f64>| {
        let d = p - p0;
        d - e1 * e1.dot(&d)
    };
    let (d2, p2) = farthest(&|p| off_line(p).norm());
    if d2 <= tolerance {
        bail!("all {} vertices lie on one line: no volume", points.len());
    }
    let n = e1.cross(&off_line(&p2)).normalize();
    let (d3, _) = farthest(&|p| n.dot(&(p - p0)).abs());
    if d3 <= tolerance {
        bail!(
            "all {} vertices lie in one plane: no volume (a flat mesh cannot be a collider; \
             give the part a thickness)",
            points.len()
        );
    }
    let pts: Vec<parry3d_f64::math::Vector> = points
        .iter()
        .map(|p| parry3d_f64::math::Vector::new(p.x, p.y, p.z))
        .collect();
    let (vertices, _) = parry3d_f64::transformation::try_convex_hull(&pts)
        .map_err(|e| anyhow::anyhow!("parry3d-f64 cannot build it: {e}"))?;
    let shape = Shape::ConvexHull {
        points: vertices
            .iter()
            .map(|v| Point3::new(v.x, v.y, v.z))
            .collect(),
    };
    if shape.to_parry().is_none() {
        bail!(
            "parry3d-f64 cannot build it from the {} hull vertices",
            vertices.len()
        );
    }
    Ok(shape)
}

/// What one copy's colliders left out: link names and why, for the note.
#[derive(Debug, Default)]
pub(crate) struct LeftOut {
    pub links: Vec<(String, &'static str)>,
}

/// Adds the colliders of one copy, whose link frames are `frames` of `world.layout.frames`,
/// as group `group`; returns what was left out (geometry no body carries) and how many
/// colliders were added.
pub(crate) fn attach(
    world: &mut World,
    frames: Range<usize>,
    table: &TableColliders,
    group: u32,
) -> (usize, LeftOut) {
    let mut left_out = LeftOut::default();
    let mut added = 0;
    let first_frame = frames.start;
    for f in frames {
        let link = &world.layout.frames[f].link;
        let Some(shapes) = table.shapes.get(link).filter(|s| !s.is_empty()) else {
            continue;
        };
        let attachment: Attachment = world.attachments[f];
        if attachment.body == Attachment::WORLD {
            // This copy's interior frames are the last ones pushed.
            let interior = world
                .interior_frames
                .iter()
                .rev()
                .take_while(|i| i.frame >= first_frame)
                .any(|i| i.frame == f);
            let why = if interior {
                "a massless link inside a compound joint: no body carries it"
            } else {
                "welded to the world (base = \"fixed\"): it does not move"
            };
            left_out.links.push((link.clone(), why));
            continue;
        }
        for s in shapes {
            world.contact.colliders.push(Collider {
                body: attachment.body,
                body_from_shape: attachment.body_from_link * s.link_from_shape,
                shape: s.shape.clone(),
                friction: table.friction,
                restitution: table.restitution,
                group,
                self_collision: table.self_collision,
            });
            added += 1;
        }
    }
    (added, left_out)
}

/// In links mode, the links with geometry that are no body (no mass), for the note.
pub(crate) fn massless_with_geometry(model: &Model, table: &TableColliders) -> Vec<String> {
    model
        .links
        .iter()
        .filter(|l| !l.has_mass() && table.shapes.get(&l.name).is_some_and(|s| !s.is_empty()))
        .map(|l| l.name.clone())
        .collect()
}

/// After a table's first copy: an error when none of its bodies got a collider (a model asking
/// for collisions must not silently get none), else a note naming the links whose geometry
/// was left out (no body carries it). `added` and `left_out` are [`attach`]'s.
#[allow(clippy::too_many_arguments)]
pub(crate) fn check_first_copy(
    key: &str,
    entry: &ModelEntry,
    model: &Model,
    label: &str,
    table: &TableColliders,
    added: usize,
    left_out: &LeftOut,
    world: &mut World,
) -> anyhow::Result<()> {
    let mut reasons: Vec<String> = Vec::new();
    if entry.bodies == BodiesMode::Links {
        for name in massless_with_geometry(model, table) {
            reasons.push(format!(
                "`{name}` (no mass: with bodies = \"links\" it is no body)"
            ));
        }
    }
    for (name, why) in &left_out.links {
        reasons.push(format!("`{name}` ({why})"));
    }
    let element = match table.source {
        Collisions::Visual => "<visual>",
        _ => "<collision>",
    };
    if added == 0 {
        bail!(
            "{key}: collisions = \"{}\": model `{label}` ({}): no body carries {element} \
             geometry, nothing would collide: link(s) {}",
            table.source.name(),
            model.path.display(),
            reasons.join(", ")
        );
    }
    if !reasons.is_empty() {
        world.notes.push(format!(
            "model `{label}`: the {element} geometry of link(s) {} is left out (nothing \
             collides with it)",
            reasons.join(", ")
        ));
    }
    Ok(())
}

/// The body pairs of one copy that never collide: in articulated mode each kept joint's parent
/// and child bodies (the mechanisms `mechanisms` of `world.mechanisms`), in links mode each URDF
/// joint's child link body and the body of its nearest ancestor link with mass (the copy's
/// frames `frames`). Rigid models are one body.
pub(crate) fn exclude_joint_pairs(
    world: &mut World,
    model: &Model,
    bodies: BodiesMode,
    frames: Range<usize>,
    mechanisms: Range<usize>,
) {
    match bodies {
        BodiesMode::Rigid => {}
        BodiesMode::Articulated => {
            for m in &world.mechanisms[mechanisms] {
                for j in &m.joints {
                    if let Some(parent) = j.parent {
                        let (a, b) = (m.first_body + parent, m.first_body + j.child);
                        world.contact.excluded_body_pairs.push((a.min(b), a.max(b)));
                    }
                }
            }
        }
        BodiesMode::Links => {
            let body_of: HashMap<&str, usize> = frames
                .clone()
                .map(|f| {
                    (
                        world.layout.frames[f].link.as_str(),
                        world.attachments[f].body,
                    )
                })
                .collect();
            let mut parent_of: Vec<Option<usize>> = vec![None; model.links.len()];
            for j in &model.joints {
                parent_of[j.child] = Some(j.parent);
            }
            let mut pairs = Vec::new();
            for (child, link) in model.links.iter().enumerate() {
                let Some(&b) = body_of.get(link.name.as_str()) else {
                    continue;
                };
                // Up through massless links (a loop guard: the URDF's tree has no cycle).
                let mut up = parent_of[child];
                let mut steps = 0;
                while let Some(p) = up {
                    if let Some(&a) = body_of.get(model.links[p].name.as_str()) {
                        pairs.push((a.min(b), a.max(b)));
                        break;
                    }
                    up = parent_of[p];
                    steps += 1;
                    if steps > model.links.len() {
                        break;
                    }
                }
            }
            world.contact.excluded_body_pairs.extend(pairs);
        }
    }
}

/// Sorts the colliders by body (stable: a body's colliders keep their URDF order) and the
/// excluded pairs, deduplicated: what [`ContactModel`] promises.
pub(crate) fn finish(contact: &mut ContactModel) {
    contact.colliders.sort_by_key(|c| c.body);
    contact.excluded_body_pairs.sort_unstable();
    contact.excluded_body_pairs.dedup();
    contact.colliders.shrink_to_fit();
    contact.excluded_body_pairs.shrink_to_fit();
}

/// Refuses a scene with contact for `verb` (`trade`, `stability --scene`, `bench --scene`):
/// their loops step the integrators directly, without the contact phase, so they would
/// measure a run without contact (docs/contact.md).
pub fn refuse_contact(
    scene: &super::Scene,
    world: &crate::world::World,
    verb: &str,
) -> anyhow::Result<()> {
    if world.contact.is_active() {
        anyhow::bail!(
            "{}: {verb} does not support contact yet ([ground] or colliding models); \
             time or measure it with tumble simulate (docs/contact.md)",
            scene.source.display()
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn parse(text: &str) -> anyhow::Result<Scene> {
        Scene::parse(text, Path::new("s.toml"))
    }

    fn ground(text: &str) -> Ground {
        let scene = parse(&format!("{text}\n[[model]]\nurdf = \"m.urdf\"\n")).unwrap();
        scene.ground().unwrap().expect("a ground")
    }

    fn error(text: &str) -> String {
        format!("{:#}", parse(text).unwrap_err())
    }

    const MODEL: &str = "[[model]]\nurdf = \"m.urdf\"\n";

    #[test]
    fn no_table_no_ground() {
        assert_eq!(parse(MODEL).unwrap().ground().unwrap(), None);
    }

    /// `height` is along −g/|g|: the normal is −g/|g|, the point height · normal.
    #[test]
    fn height_is_along_minus_gravity() {
        let g = ground("[ground]\nheight = 0.25\n");
        assert_eq!(g.normal.into_inner(), Vector3::z());
        assert_eq!(g.point, Vector3::new(0.0, 0.0, 0.25));
        assert_eq!((g.friction, g.restitution), (0.8, 0.0));
        // An empty table is a level ground through the origin.
        let g = ground("[ground]\n");
        assert_eq!(
            (g.normal.into_inner(), g.point),
            (Vector3::z(), Vector3::zeros())
        );
        // Gravity along −x with a 3-4-5 tilt: g = (−3, 0, −4), |g| = 5, n = (0.6, 0, 0.8).
        let g = ground("[sim]\ngravity = [-3.0, 0.0, -4.0]\n[ground]\nheight = 2.0\n");
        assert!((g.normal.into_inner() - Vector3::new(0.6, 0.0, 0.8)).norm() < 1e-15);
        assert!((g.point - Vector3::new(1.2, 0.0, 1.6)).norm() < 1e-15);
        assert!((g.height_of(&Vector3::new(0.0, 7.0, 0.0)) + 2.0).abs() < 1e-15);
    }

    #[test]
    fn normal_is_normalized_and_point_defaults_to_the_origin() {
        let g = ground("[ground]\nnormal = [0.0, 3.0, 4.0]\nfriction = 0.3\nrestitution = 0.5\n");
        assert_eq!(g.normal.into_inner(), Vector3::new(0.0, 0.6, 0.8));
        assert_eq!(g.point, Vector3::zeros());
        assert_eq!((g.friction, g.restitution), (0.3, 0.5));
        let g = ground("[ground]\nnormal = [1e-300, 0, 0]\npoint = [1, 2, 3]\n");
        assert_eq!(g.normal.into_inner(), Vector3::x());
        assert_eq!(g.point, Vector3::new(1.0, 2.0, 3.0));
        // Zero gravity is fine with a normal.
        let g = ground("[sim]\ngravity = [0, 0, 0]\n[ground]\nnormal = [0, 0, 2]\n");
        assert_eq!(g.normal.into_inner(), Vector3::z());
    }

    /// Each mistake is one message naming the file and the key.
    #[test]
    fn bad_grounds_name_the_key() {
        for (table, needle) in [
            (
                "friction = -0.1",
                "s.toml: ground.friction must be a finite number >= 0",
            ),
            (
                "friction = nan",
                "ground.friction must be a finite number >= 0",
            ),
            (
                "friction = inf",
                "ground.friction must be a finite number >= 0",
            ),
            (
                "restitution = 1.5",
                "s.toml: ground.restitution must be a number between 0 and 1",
            ),
            (
                "restitution = -0.5",
                "ground.restitution must be a number between 0 and 1",
            ),
            (
                "restitution = nan",
                "ground.restitution must be a number between 0 and 1",
            ),
            (
                "normal = [0, 0, 0]",
                "s.toml: ground.normal has zero length",
            ),
            (
                "normal = [0, nan, 1]",
                "ground.normal must hold three finite numbers",
            ),
            ("normal = [0, 1]", "invalid length 2"),
            (
                "normal = [0, 0, 1]\npoint = [0, inf, 0]",
                "ground.point must hold three finite",
            ),
            (
                "height = 0.0\nnormal = [0, 0, 1]",
                "ground: give either `height`",
            ),
            (
                "height = 1.0\npoint = [0, 0, 1]",
                "ground.point goes with `normal`",
            ),
            ("point = [0, 0, 1]", "ground.point goes with `normal`"),
            ("height = inf", "ground.height must be a finite number"),
            ("heigth = 0.0", "unknown field `heigth`"),
        ] {
            let e = error(&format!("[ground]\n{table}\n{MODEL}"));
            assert!(e.contains(needle), "{table}: {e}");
        }
        let e = error(&format!(
            "[sim]\ngravity = [0, 0, 0]\n[ground]\nheight = 0\n{MODEL}"
        ));
        assert!(
            e.contains("s.toml: ground.height is measured along −gravity, and sim.gravity is zero")
                && e.contains("`normal`"),
            "{e}"
        );
    }

    #[test]
    fn model_keys_default_and_refuse_bad_values() {
        let scene = parse(MODEL).unwrap();
        assert_eq!(scene.models[0].collisions(), Collisions::None);
        let scene = parse(&format!(
            "{MODEL}collisions = \"visual\"\nself_collision = true\nfriction = 0.2\n"
        ))
        .unwrap();
        let m = &scene.models[0];
        assert_eq!(m.collisions(), Collisions::Visual);
        assert_eq!(
            (m.self_collision, m.friction, m.restitution),
            (Some(true), Some(0.2), None)
        );
        for (keys, needle) in [
            (
                "collisions = \"mesh\"",
                "s.toml: model[0].collisions: unknown value \"mesh\" (expected one of: \"none\", \"urdf\", \"visual\")",
            ),
            (
                "collisions = \"urdf\"\nfriction = -1",
                "model[0].friction must be a finite number >= 0",
            ),
            (
                "collisions = \"urdf\"\nfriction = nan",
                "model[0].friction must be a finite number >= 0",
            ),
            (
                "collisions = \"urdf\"\nrestitution = 1.01",
                "model[0].restitution must be a number between 0 and 1",
            ),
            (
                "friction = 0.5",
                "model[0].friction applies to a model that collides",
            ),
            (
                "collisions = \"none\"\nself_collision = true",
                "model[0].self_collision applies to a model that collides",
            ),
            (
                "restitution = 0.5",
                "model[0].restitution applies to a model that collides",
            ),
            ("collisions = 1", "invalid type"),
        ] {
            let e = error(&format!("{MODEL}{keys}\n"));
            assert!(e.contains(needle), "{keys}: {e}");
        }
    }

    /// The new keys stay out of the recorded settings unless given (recordings of scenes
    /// without contact are unchanged), and are recorded when given.
    #[test]
    fn settings_json_holds_the_keys_only_when_given() {
        let plain = parse(MODEL).unwrap().metadata()["settings_json"].clone();
        for key in [
            "ground",
            "collisions",
            "friction",
            "restitution",
            "self_collision",
        ] {
            assert!(!plain.contains(key), "{plain}");
        }
        let contact = parse(&format!(
            "[ground]\nheight = 0.5\n{MODEL}collisions = \"urdf\"\nfriction = 0.3\n"
        ))
        .unwrap()
        .metadata()["settings_json"]
            .clone();
        for key in [
            "\"ground\":{\"height\":0.5}",
            "\"collisions\":\"urdf\"",
            "\"friction\":0.3",
        ] {
            assert!(contact.contains(key), "{key} not in {contact}");
        }
    }

    fn no_cache() -> HashMap<(PathBuf, [u64; 3]), Shape> {
        HashMap::new()
    }

    #[test]
    fn primitives_become_shapes_with_half_sizes() {
        let shape = |g: Geometry| shape_of("collision #0", &g, &mut no_cache());
        assert_eq!(
            shape(Geometry::Box {
                size: Vector3::new(0.2, 0.4, 0.6)
            })
            .unwrap(),
            Shape::Box {
                half_extents: Vector3::new(0.1, 0.2, 0.3)
            }
        );
        assert_eq!(
            shape(Geometry::Cylinder {
                radius: 0.1,
                length: 0.5
            })
            .unwrap(),
            Shape::Cylinder {
                radius: 0.1,
                half_length: 0.25
            }
        );
        assert_eq!(
            shape(Geometry::Capsule {
                radius: 0.1,
                length: 0.0
            })
            .unwrap(),
            Shape::Capsule {
                radius: 0.1,
                half_length: 0.0
            }
        );
        assert_eq!(
            shape(Geometry::Sphere { radius: 0.3 }).unwrap(),
            Shape::Sphere { radius: 0.3 }
        );
        for (g, needle) in [
            (
                Geometry::Box {
                    size: Vector3::new(0.2, 0.0, 0.6),
                },
                "box size along y must be positive and finite (got 0)",
            ),
            (
                Geometry::Box {
                    size: Vector3::new(0.2, 0.1, f64::NAN),
                },
                "box size along z must be positive and finite",
            ),
            (
                Geometry::Sphere { radius: -1.0 },
                "sphere radius must be positive",
            ),
            (
                Geometry::Cylinder {
                    radius: 0.1,
                    length: 0.0,
                },
                "cylinder length must be positive",
            ),
            (
                Geometry::Capsule {
                    radius: 0.1,
                    length: -0.1,
                },
                "capsule length must be finite and >= 0",
            ),
            (
                Geometry::Mesh {
                    uri: "m.stl".into(),
                    path: Some("m.stl".into()),
                    scale: Vector3::new(1.0, 0.0, 1.0),
                },
                "mesh `m.stl`: scale [1, 0, 1] must be finite and non-zero",
            ),
            (
                Geometry::Mesh {
                    uri: "gone.stl".into(),
                    path: None,
                    scale: Vector3::repeat(1.0),
                },
                "mesh `gone.stl` not found",
            ),
        ] {
            let e = format!("{:#}", shape(g).unwrap_err());
            assert!(e.contains(needle), "{e}");
        }
    }

    /// The hull keeps the extreme points only; degenerate sets are refused.
    #[test]
    fn convex_hulls_of_points() {
        let mut points: Vec<Vector3<f64>> = (0..8)
            .map(|k| {
                Vector3::new(
                    if k & 1 == 0 { -1.0 } else { 1.0 },
                    if k & 2 == 0 { -2.0 } else { 2.0 },
                    if k & 4 == 0 { -3.0 } else { 3.0 },
                )
            })
            .collect();
        points.push(Vector3::new(0.1, 0.2, 0.3));
        points.push(Vector3::new(0.0, 2.0, 0.0));
        let Shape::ConvexHull { points: hull } = convex_hull(&points).unwrap() else {
            panic!("a hull")
        };
        assert_eq!(hull.len(), 8, "{hull:?}");
        for p in hull.iter() {
            assert_eq!((p.x.abs(), p.y.abs(), p.z.abs()), (1.0, 2.0, 3.0));
        }
        let tetra = [Vector3::zeros(), Vector3::x(), Vector3::y(), Vector3::z()];
        assert!(convex_hull(&tetra).is_ok());
        for (points, needle) in [
            (
                tetra[..3].to_vec(),
                "3 vertices: a convex hull needs at least 4 points",
            ),
            (vec![Vector3::x(); 5], "all 5 vertices are one point"),
            (
                (0..5)
                    .map(|k| Vector3::new(k as f64, 2.0 * k as f64, 0.0))
                    .collect(),
                "all 5 vertices lie on one line",
            ),
            (
                vec![
                    Vector3::zeros(),
                    Vector3::x(),
                    Vector3::y(),
                    Vector3::new(1.0, 1.0, 1e-12),
                ],
                "all 4 vertices lie in one plane",
            ),
            (
                vec![
                    Vector3::zeros(),
                    Vector3::x(),
                    Vector3::y(),
                    Vector3::new(0.0, 0.0, f64::NAN),
                ],
                "a vertex is not finite",
            ),
        ] {
            let e = convex_hull(&points).unwrap_err().to_string();
            assert!(e.contains(needle), "{e}");
        }
    }

    /// A mesh file's vertices, scaled, make the hull: the interior vertex left out.
    #[test]
    fn a_mesh_becomes_the_hull_of_its_scaled_vertices() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("tetra.obj");
        // A tetrahedron split at an interior point (0.1, 0.1, 0.1) of its base's inside.
        std::fs::write(
            &path,
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 0.1 0.1 0.1\n\
             f 1 3 2\nf 1 2 4\nf 2 3 5\nf 3 4 5\nf 4 2 5\nf 1 4 3\n",
        )
        .unwrap();
        let mut cache = no_cache();
        let geometry = Geometry::Mesh {
            uri: "tetra.obj".into(),
            path: Some(path.clone()),
            scale: Vector3::new(2.0, -3.0, 0.5),
        };
        let shape = shape_of("collision #0", &geometry, &mut cache).unwrap();
        let Shape::ConvexHull { points } = &shape else {
            panic!("{shape:?}")
        };
        let mut got: Vec<[f64; 3]> = points.iter().map(|p| [p.x, p.y, p.z]).collect();
        got.sort_by(|a, b| a.partial_cmp(b).unwrap());
        assert_eq!(
            got,
            vec![
                [0.0, -3.0, 0.0],
                [0.0, 0.0, 0.0],
                [0.0, 0.0, 0.5],
                [2.0, 0.0, 0.0]
            ]
        );
        assert!(shape.to_parry().is_some());
        // Read once: the cached hull is returned for the same file and scale.
        std::fs::remove_file(&path).unwrap();
        assert_eq!(
            shape_of("collision #1", &geometry, &mut cache).unwrap(),
            shape
        );
    }
}
