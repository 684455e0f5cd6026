//! `tumble inspect MODEL.urdf`: every link's mass properties, where they came from, the problems
//! found, and the whole model's mass, centre of mass and inertia.
//!
//! `--inertia`, `--density`, `--geometry` apply an inertia policy first ([`policy::apply`]) and
//! show per link where its values came from and what was repaired; `--compare` prints the URDF's
//! values and the geometry's side by side with their differences ([`compare`]).
//!
//! Exit codes (set in `main`): 0 no link has a problem, 1 some link has one, 2 an error. Problems
//! describe the values in use: the findings about URDF values a policy replaced move to the
//! link's notes, so `--inertia auto` exits 0 when it could repair every invalid link. Geometry
//! that cannot give mass properties under `--inertia geometry` is an error (exit 2), as it is for
//! `simulate`; under `auto` and `--compare` it is reported per link.
//!
//! # `--json` output
//!
//! One JSON object, SI units (kg, m, kg m²), model frame = root link frame. Stable keys:
//!
//! ```text
//! {
//!   "file": "models/arm.urdf",            // the URDF path as given
//!   "model": "arm",                       // <robot name>
//!   "root": "base",                       // root link name
//!   "ok": true,                           // no link has a problem (exit code 0)
//!   "warnings": ["FILE: ELEMENT: MESSAGE"],  // oddities loaded leniently (docs/urdf.md); []
//!                                         //   for a file URDF defines fully; also on stderr
//!   "mass_settings": {"inertia": "urdf" | "geometry" | "auto", "density": 1000.0,
//!                     "geometry": "collision" | "visual"},   // the flags, defaults filled in
//!   "links": [                            // URDF order
//!     {
//!       "name": "forearm",
//!       "source": "urdf" | "missing" | "geometry" | "repaired",
//!                                         // "missing": no <inertial>; "geometry": computed
//!                                         //   because --inertia geometry; "repaired": --inertia
//!                                         //   auto replaced missing or invalid values. A link
//!                                         //   without values (a massless frame) reports mass,
//!                                         //   com, inertia and principal moments as zeros
//!       "mass": 1.0,
//!       "com": [x, y, z],                 // centre of mass, link frame
//!       "inertia": [[..], [..], [..]],    // about the com, link axes (inertial rpy applied)
//!       "principal_moments": [a, b, c],   // ascending
//!       "model_from_link": {"translation": [x, y, z], "rotation_xyzw": [x, y, z, w]},
//!                                         // link pose at the zero joint configuration
//!       "problems": ["..."],              // rules broken by the values in use, in words
//!       "notes": ["..."],                 // what the inertia policy did and why; [] if nothing
//!       "geometry_used": {"set": "collision" | "visual", "fallback": false, "shapes": 2,
//!                         "density": 1000.0} | null,   // what the values were computed from
//!       // with --compare only:
//!       "urdf": {"mass", "com", "inertia", "principal_moments"} | null,  // the <inertial>
//!       "geometry": {"mass", "com", "inertia", "principal_moments", "set", "fallback",
//!                    "shapes", "density"} | null,     // null when geometry_error is set
//!       "geometry_error": "..." | null,
//!       "difference": {"mass_relative", "com_distance", "principal_moments_relative": [3],
//!                      "inertia_relative", "density_matching_urdf_mass" (null when the
//!                      URDF mass is not positive)} | null
//!                                         // see `compare`; null unless both sides exist
//!     }
//!   ],
//!   "total_mass": 4.8,                    // sum over links with positive mass (0 if none)
//!   "com": [x, y, z] | null,              // model frame; null when total_mass is 0
//!   "inertia_about_com": [[..],[..],[..]] | null,   // about "com", model axes
//!   "principal_moments": [a, b, c] | null,
//!   "joints": [                           // URDF order
//!     {
//!       "name": "elbow",
//!       "type": "revolute" | "continuous" | "prismatic" | "fixed" | "floating" | "planar" | "spherical",
//!       "parent": "upper_arm", "child": "forearm",   // link names
//!       "axis": [x, y, z],                // the <axis> as written, joint frame
//!       "origin": {"translation": [..], "rotation_xyzw": [..]},   // joint frame in the parent link
//!       "lower": -1.57 | null, "upper": 1.57 | null,   // <limit lower upper> when upper > lower
//!                                         //   (revolute, prismatic), else null
//!       "effort": 12.0, "velocity": 3.0,  // <limit effort velocity>, 0 when absent
//!       "damping": 0.1, "friction": 0.05, // <dynamics>, 0 when absent
//!       "mimic": {"joint", "multiplier", "offset"} | null
//!     }
//!   ],
//!   "meshes": [                           // every <mesh>, visual and collision, file order
//!     {
//!       "link": "forearm",
//!       "element": "visual #0",           // as in the link's problems
//!       "uri": "package://arm/meshes/forearm.stl",   // as the URDF writes it
//!       "path": "/ws/arm/meshes/forearm.stl" | null, // the file it resolved to, as found
//!       "real_path": "/ws/arm/meshes/forearm.stl" | null,  // links resolved
//!       "status": "allowed" | "refused" | "unresolved",
//!       "detail": "..."                   // allowed: the folder allowing it ("the URDF's
//!                                         //   folder /ws/arm/urdf"); refused, unresolved: why
//!     }
//!   ]
//! }
//! ```
//!
//! Meshes are read only inside the URDF's folder (its parent for a folder named `urdf`, or the
//! ROS package holding it), the `--package-path` folders, `ROS_PACKAGE_PATH` and `--allow-mesh-path` folders, links resolved
//! ([`crate::model::confine`]). A mesh elsewhere is refused: a problem of its link (exit 1),
//! listed under "meshes" with its resolved and real paths.
//!
//! Non-finite numbers (a NaN mass in the URDF) are written as `null`, as JSON has no NaN.

pub mod compare;

use crate::model::confine::{MeshAccess, MeshStatus, MeshUse};
use crate::model::geometry::GeometryUsed;
use crate::model::kinematics::{Joint, JointKind};
use crate::model::policy::{self, GeometrySource, InertiaPolicy, ModelMassSettings};
use crate::model::{InertiaSource, Link, MassProperties, Model, urdf};
use compare::Comparison;
use nalgebra::{Isometry3, Matrix3, Vector3};
use serde_json::{Value, json};
use std::fmt::Write;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct InspectArgs {
    /// The URDF file.
    pub model: PathBuf,
    /// Print one JSON object instead of tables.
    #[arg(long)]
    pub json: bool,
    /// Folder searched first for `package://` meshes (repeatable); then ROS_PACKAGE_PATH and the
    /// URDF's parent folders.
    #[arg(long = "package-path")]
    pub package_paths: Vec<PathBuf>,
    /// Also read mesh files from DIR (repeatable). By default a mesh is read only when its real
    /// path (links resolved) is inside the URDF's folder (its parent for a folder named urdf, or
    /// the ROS package holding it), a package path or ROS_PACKAGE_PATH; any other is refused (a
    /// problem of its link).
    #[arg(long = "allow-mesh-path", value_name = "DIR")]
    pub allow_mesh_paths: Vec<PathBuf>,
    /// --inertia, --density, --geometry: the inertia policy applied before reporting.
    #[command(flatten)]
    pub mass: super::MassArgs,
    /// Print each link's URDF values and the values its geometry gives side by side (mass,
    /// centre of mass, principal moments, relative differences).
    #[arg(long)]
    pub compare: bool,
    /// Refuse the oddities urdfdom loads (a misplaced XML declaration, unknown geometry,
    /// repeated elements, a 4-number mesh scale, a mimic of a missing joint) instead of loading
    /// them with a warning (docs/urdf.md).
    #[arg(long)]
    pub strict: bool,
}

/// What the report includes beyond the model itself.
#[derive(Debug, Clone, Default)]
pub struct ReportOptions {
    /// The mass settings the model was loaded with (for the header, and the density and
    /// geometry preference of `compare`).
    pub settings: ModelMassSettings,
    /// Add the URDF-versus-geometry comparison per link.
    pub compare: bool,
}

/// Prints the report; `Ok(true)` when no link has a problem, `Ok(false)` otherwise, `Err` when
/// the URDF cannot be loaded.
pub fn run(args: &InspectArgs) -> anyhow::Result<bool> {
    // ModelError and PolicyError already name the file (and link, rule): no extra context.
    let access = MeshAccess {
        allowed: args
            .allow_mesh_paths
            .iter()
            .map(std::path::absolute)
            .collect::<std::io::Result<_>>()?,
        scene_folder: None,
    };
    let mut model = urdf::load(
        &args.model,
        &urdf::LoadOptions {
            package_paths: args.package_paths.clone(),
            strictness: urdf::Strictness::from_strict(args.strict),
            mesh_access: access,
            ..Default::default()
        },
    )?;
    for warning in &model.warnings {
        eprintln!("warning: {warning}");
    }
    let options = ReportOptions {
        settings: ModelMassSettings {
            model: args.mass.settings(),
            links: Default::default(),
        },
        compare: args.compare,
    };
    if let Err(e) = policy::apply(&mut model, &options.settings) {
        // A refused mesh reads as not found to the policy: say why.
        return Err(match model.check_meshes() {
            Err(refused) => anyhow::Error::new(e).context(refused.to_string()),
            Ok(()) => e.into(),
        });
    }
    if args.json {
        let text = serde_json::to_string_pretty(&report_with(&model, &options))?;
        println!("{text}");
    } else {
        print!("{}", render_text_with(&model, &options));
    }
    Ok(!model.has_problems())
}

fn vec3(v: &Vector3<f64>) -> Value {
    json!([v.x, v.y, v.z])
}

fn mat3(m: &Matrix3<f64>) -> Value {
    json!([
        [m[(0, 0)], m[(0, 1)], m[(0, 2)]],
        [m[(1, 0)], m[(1, 1)], m[(1, 2)]],
        [m[(2, 0)], m[(2, 1)], m[(2, 2)]],
    ])
}

fn pose(p: &Isometry3<f64>) -> Value {
    let q = p.rotation.coords;
    json!({
        "translation": vec3(&p.translation.vector),
        "rotation_xyzw": [q.x, q.y, q.z, q.w],
    })
}

/// What a link reports: its mass properties, or zeros for a link without `<inertial>`.
fn link_mass_properties(link: &Link) -> MassProperties {
    link.inertial
        .unwrap_or_else(|| MassProperties::point(0.0, Vector3::zeros()))
}

fn source_name(source: InertiaSource) -> &'static str {
    match source {
        InertiaSource::Urdf => "urdf",
        InertiaSource::Missing => "missing",
        InertiaSource::Geometry => "geometry",
        InertiaSource::Repaired => "repaired",
    }
}

fn set_name(set: GeometrySource) -> &'static str {
    match set {
        GeometrySource::Collision => "collision",
        GeometrySource::Visual => "visual",
    }
}

fn policy_name(policy: InertiaPolicy) -> &'static str {
    match policy {
        InertiaPolicy::Urdf => "urdf",
        InertiaPolicy::Geometry => "geometry",
        InertiaPolicy::Auto => "auto",
    }
}

fn mass_properties_json(mp: &MassProperties) -> serde_json::Map<String, Value> {
    let Value::Object(map) = json!({
        "mass": mp.mass,
        "com": vec3(&mp.com),
        "inertia": mat3(&mp.inertia),
        "principal_moments": vec3(&mp.principal_moments()),
    }) else {
        unreachable!("json! of an object literal is an object")
    };
    map
}

fn geometry_used_json(used: &GeometryUsed) -> serde_json::Map<String, Value> {
    let Value::Object(map) = json!({
        "set": set_name(used.set),
        "fallback": used.fallback,
        "shapes": used.shapes,
        "density": used.density_kg_per_m3,
    }) else {
        unreachable!("json! of an object literal is an object")
    };
    map
}

/// The `--compare` keys of one link: `urdf`, `geometry`, `geometry_error`, `difference`.
fn comparison_json(c: &Comparison) -> serde_json::Map<String, Value> {
    let mut map = serde_json::Map::new();
    map.insert(
        "urdf".into(),
        c.urdf
            .as_ref()
            .map_or(Value::Null, |mp| mass_properties_json(mp).into()),
    );
    let (geometry, error) = match &c.geometry {
        Ok(g) => {
            let mut m = mass_properties_json(&g.mass_properties);
            m.extend(geometry_used_json(&g.used));
            (Value::Object(m), Value::Null)
        }
        Err(e) => (Value::Null, Value::String(e.clone())),
    };
    map.insert("geometry".into(), geometry);
    map.insert("geometry_error".into(), error);
    map.insert(
        "difference".into(),
        c.difference().map_or(Value::Null, |d| {
            json!({
                "mass_relative": d.mass_relative,
                "com_distance": d.com_distance_m,
                "principal_moments_relative": vec3(&d.principal_moments_relative),
                "inertia_relative": d.inertia_relative,
                "density_matching_urdf_mass": d.density_matching_urdf_mass_kg_per_m3,
            })
        }),
    );
    map
}

/// The `--json` document of a model loaded with the default settings and no comparison.
pub fn report(model: &Model) -> Value {
    report_with(model, &ReportOptions::default())
}

/// The `--json` document (structure in the module documentation).
pub fn report_with(model: &Model, options: &ReportOptions) -> Value {
    let links: Vec<Value> = model
        .links
        .iter()
        .map(|link| {
            let mp = link_mass_properties(link);
            let moments = if link.inertial.is_some() {
                mp.principal_moments()
            } else {
                Vector3::zeros()
            };
            let mut value = json!({
                "name": link.name,
                "source": source_name(link.source),
                "mass": mp.mass,
                "com": vec3(&mp.com),
                "inertia": mat3(&mp.inertia),
                "principal_moments": vec3(&moments),
                "model_from_link": pose(&link.model_from_link),
                "problems": link.problems,
                "notes": link.notes,
                "geometry_used": link.geometry_used.as_ref().map(geometry_used_json),
            });
            if options.compare
                && let Value::Object(map) = &mut value
            {
                let settings = options.settings.for_link(&link.name);
                map.extend(comparison_json(&Comparison::of(link, &settings)));
            }
            value
        })
        .collect();
    let total = model.total_mass_properties();
    let settings = options.settings.model.resolved();
    json!({
        "file": model.path.display().to_string(),
        "model": model.name,
        "root": model.links.get(model.root).map(|l| l.name.as_str()),
        "ok": !model.has_problems(),
        "warnings": model.warnings.iter().map(ToString::to_string).collect::<Vec<_>>(),
        "mass_settings": {
            "inertia": policy_name(settings.inertia),
            "density": settings.density,
            "geometry": set_name(settings.geometry),
        },
        "links": links,
        "total_mass": total.map_or(0.0, |t| t.mass),
        "com": total.map(|t| vec3(&t.com)),
        "inertia_about_com": total.map(|t| mat3(&t.inertia)),
        "principal_moments": total.map(|t| vec3(&t.principal_moments())),
        "joints": model.joints.iter().map(|j| joint_json(model, j)).collect::<Vec<_>>(),
        "meshes": model.meshes.iter().map(mesh_json).collect::<Vec<_>>(),
    })
}

/// A link's name by index (`?` if out of range, which a loaded model never has).
fn link_name(model: &Model, index: usize) -> &str {
    model.links.get(index).map_or("?", |l| l.name.as_str())
}

fn joint_json(model: &Model, joint: &Joint) -> Value {
    json!({
        "name": joint.name,
        "type": joint.kind.as_str(),
        "parent": link_name(model, joint.parent),
        "child": link_name(model, joint.child),
        "axis": vec3(&joint.axis),
        "origin": pose(&joint.parent_from_joint),
        "lower": joint.limits.map(|l| l[0]),
        "upper": joint.limits.map(|l| l[1]),
        "effort": joint.effort_limit,
        "velocity": joint.velocity_limit,
        "damping": joint.damping,
        "friction": joint.friction,
        "mimic": joint.mimic.as_ref().map(|m| json!({
            "joint": m.joint,
            "multiplier": m.multiplier,
            "offset": m.offset,
        })),
    })
}

/// The "joints" section of the text report: one line per joint, URDF order.
fn render_joints(out: &mut String, model: &Model) {
    if model.joints.is_empty() {
        return;
    }
    let moving = model
        .joints
        .iter()
        .filter(|j| j.kind != JointKind::Fixed)
        .count();
    let _ = writeln!(out);
    let _ = writeln!(out, "joints ({}, {moving} moving)", model.joints.len());
    for j in &model.joints {
        let mut line = format!(
            "  joint `{}` {}: `{}` -> `{}`",
            j.name,
            j.kind.as_str(),
            link_name(model, j.parent),
            link_name(model, j.child)
        );
        if j.kind != JointKind::Fixed {
            let limits = match j.limits {
                Some([lower, upper]) => format!("lower {} upper {}", num(lower), num(upper)),
                None => "none".into(),
            };
            let _ = write!(
                line,
                ", axis [{}], limits {limits}, effort {}, velocity {}, damping {}, friction {}",
                numbers(j.axis.as_slice()),
                num(j.effort_limit),
                num(j.velocity_limit),
                num(j.damping),
                num(j.friction)
            );
        }
        if let Some(m) = &j.mimic {
            let _ = write!(
                line,
                ", mimics `{}` (multiplier {}, offset {})",
                m.joint,
                num(m.multiplier),
                num(m.offset)
            );
        }
        let _ = writeln!(out, "{line}");
    }
}

/// A mesh's status as the JSON's `status` and `detail`.
fn mesh_status(mesh: &MeshUse) -> (&'static str, String) {
    match &mesh.status {
        MeshStatus::Allowed { root } => ("allowed", format!("inside {root}")),
        MeshStatus::Refused(why) => ("refused", why.reason()),
        MeshStatus::Unresolved(why) => ("unresolved", why.clone()),
    }
}

fn mesh_json(mesh: &MeshUse) -> Value {
    let (status, detail) = mesh_status(mesh);
    json!({
        "link": mesh.link,
        "element": mesh.element,
        "uri": mesh.uri,
        "path": mesh.path.as_ref().map(|p| p.display().to_string()),
        "real_path": mesh.real_path.as_ref().map(|p| p.display().to_string()),
        "status": status,
        "detail": detail,
    })
}

/// The "meshes" section of the text report: one line per `<mesh>`, with the file it resolved
/// to, its real path when links make it another, and whether it is read.
fn render_meshes(out: &mut String, meshes: &[MeshUse]) {
    if meshes.is_empty() {
        return;
    }
    let refused = meshes.iter().filter(|m| m.refusal().is_some()).count();
    let _ = writeln!(out);
    let _ = writeln!(out, "meshes ({}, {refused} refused)", meshes.len());
    for m in meshes {
        let (status, detail) = mesh_status(m);
        let path = match (&m.path, &m.real_path) {
            (Some(p), Some(real)) if p != real => {
                format!(" -> {} (real path {})", p.display(), real.display())
            }
            (Some(p), _) => format!(" -> {}", p.display()),
            (None, _) => String::new(),
        };
        let detail = match m.status {
            MeshStatus::Refused(_) => format!("REFUSED: {detail}"),
            _ => format!("{status}, {detail}"),
        };
        let _ = writeln!(
            out,
            "  link `{}` {} `{}`{path}: {detail}",
            m.link, m.element, m.uri
        );
    }
}

/// A number with 6 significant digits, fixed notation for ordinary magnitudes, scientific
/// otherwise; exact zero as `0`.
fn num(x: f64) -> String {
    if x == 0.0 {
        return "0".into();
    }
    if !x.is_finite() {
        return x.to_string();
    }
    let magnitude = x.abs().log10().floor() as i32;
    if (-3..6).contains(&magnitude) {
        let decimals = (5 - magnitude).max(0) as usize;
        format!("{x:.decimals$}")
    } else {
        format!("{x:.5e}")
    }
}

fn row(values: &[f64]) -> String {
    let cells: Vec<String> = values.iter().map(|&x| format!(" {:>12}", num(x))).collect();
    format!("[{} ]", cells.join(""))
}

fn matrix_rows(out: &mut String, label: &str, m: &Matrix3<f64>, unit: &str) {
    for r in 0..3 {
        let head = if r == 0 { label } else { "" };
        let tail = if r == 0 { unit } else { "" };
        let _ = writeln!(
            out,
            "  {head:<18}{} {tail}",
            row(&[m[(r, 0)], m[(r, 1)], m[(r, 2)]])
        );
    }
}

/// Where a link's values came from, in words (the text after its name).
fn source_text(link: &Link) -> String {
    let used = link.geometry_used.as_ref().map(GeometryUsed::describe);
    match (link.source, used) {
        (InertiaSource::Urdf, _) => "from <inertial>".into(),
        (InertiaSource::Missing, _) => "no <inertial>: massless frame, zeros shown".into(),
        (InertiaSource::Geometry, Some(used)) => format!("from geometry: {used}"),
        (InertiaSource::Geometry, None) => "no geometry: massless frame, zeros shown".into(),
        (InertiaSource::Repaired, Some(used)) => format!("repaired from geometry: {used}"),
        (InertiaSource::Repaired, None) => "repaired".into(),
    }
}

/// `x` as a signed percentage, 3 significant digits.
fn percent(x: f64) -> String {
    let p = 100.0 * x;
    if !p.is_finite() {
        format!("{p} %")
    } else if p.abs() < 1e3 {
        format!("{p:+.3} %")
    } else {
        format!("{p:+.2e} %")
    }
}

fn numbers(values: &[f64]) -> String {
    values.iter().map(|&x| num(x)).collect::<Vec<_>>().join(" ")
}

/// Width of the URDF and geometry columns of the comparison.
const COMPARE_COLUMN: usize = 40;

/// The `--compare` lines of one link.
fn render_comparison(out: &mut String, c: &Comparison) {
    let w = COMPARE_COLUMN;
    let urdf = c.urdf.as_ref();
    let geometry = c.geometry.as_ref().ok().map(|g| &g.mass_properties);
    let cell = |mp: Option<&MassProperties>, f: &dyn Fn(&MassProperties) -> String| {
        mp.map_or_else(|| "-".to_string(), f)
    };
    let diff = c.difference();
    let _ = writeln!(
        out,
        "  {:<18}{:<w$}  {:<w$}  URDF vs geometry",
        "compare",
        if urdf.is_some() {
            "URDF <inertial>"
        } else {
            "URDF: no <inertial>"
        },
        if geometry.is_some() {
            "geometry"
        } else {
            "geometry: unavailable"
        },
    );
    let mass = |mp: &MassProperties| format!("{} kg", num(mp.mass));
    let com = |mp: &MassProperties| format!("{} m", numbers(mp.com.as_slice()));
    let moments =
        |mp: &MassProperties| format!("{} kg m^2", numbers(mp.principal_moments().as_slice()));
    let mut line = |label: &str, f: &dyn Fn(&MassProperties) -> String, difference: String| {
        let text = format!(
            "    {label:<16}{:<w$}  {:<w$}  {difference}",
            cell(urdf, f),
            cell(geometry, f)
        );
        let _ = writeln!(out, "{}", text.trim_end());
    };
    line(
        "mass",
        &mass,
        diff.map_or(String::new(), |d| percent(d.mass_relative)),
    );
    line(
        "com",
        &com,
        diff.map_or(String::new(), |d| {
            format!("{} m apart", num(d.com_distance_m))
        }),
    );
    line(
        "moments",
        &moments,
        diff.map_or(String::new(), |d| {
            let p = d.principal_moments_relative;
            format!("{} {} {}", percent(p.x), percent(p.y), percent(p.z))
        }),
    );
    if let Some(d) = diff {
        let density = d
            .density_matching_urdf_mass_kg_per_m3
            .map_or(String::new(), |rho| {
                format!("; the masses agree at {} kg/m^3", num(rho))
            });
        let _ = writeln!(
            out,
            "    {:<16}tensors differ by {} (Frobenius, relative to the geometry's){density}",
            "inertia",
            percent(d.inertia_relative).trim_start_matches('+'),
        );
    }
    match &c.geometry {
        Ok(g) => {
            let _ = writeln!(out, "    {:<16}{}", "geometry", g.used.describe());
        }
        Err(e) => {
            let _ = writeln!(out, "    {:<16}unavailable: {e}", "geometry");
        }
    }
}

/// The human-readable report of a model loaded with the default settings, no comparison.
pub fn render_text(model: &Model) -> String {
    render_text_with(model, &ReportOptions::default())
}

/// The human-readable report `inspect` prints.
pub fn render_text_with(model: &Model, options: &ReportOptions) -> String {
    let mut out = String::new();
    let root = model.links.get(model.root).map_or("?", |l| l.name.as_str());
    let _ = writeln!(
        out,
        "model `{}` ({}): {} links, root `{root}` (model frame = root link frame, SI units)",
        model.name,
        model.path.display(),
        model.links.len()
    );
    let settings = options.settings.model.resolved();
    let _ = writeln!(
        out,
        "mass settings: inertia {}, density {} kg/m^3, geometry {} (used by geometry, auto and \
         --compare)",
        policy_name(settings.inertia),
        settings.density,
        set_name(settings.geometry)
    );
    for link in &model.links {
        let _ = writeln!(out);
        let _ = writeln!(out, "link `{}` ({})", link.name, source_text(link));
        let mp = link_mass_properties(link);
        let moments = if link.inertial.is_some() {
            mp.principal_moments()
        } else {
            Vector3::zeros()
        };
        let t = link.model_from_link.translation.vector;
        let _ = writeln!(
            out,
            "  {:<18}{} m, rotation xyzw {}",
            "origin in model",
            row(&[t.x, t.y, t.z]),
            row(link.model_from_link.rotation.coords.as_slice())
        );
        let _ = writeln!(out, "  {:<18}{} kg", "mass", num(mp.mass));
        let _ = writeln!(
            out,
            "  {:<18}{} m (link frame)",
            "com",
            row(&[mp.com.x, mp.com.y, mp.com.z])
        );
        matrix_rows(
            &mut out,
            "inertia about com",
            &mp.inertia,
            "kg m^2 (link axes)",
        );
        let _ = writeln!(
            out,
            "  {:<18}{} kg m^2",
            "principal moments",
            row(&[moments.x, moments.y, moments.z])
        );
        for (k, note) in link.notes.iter().enumerate() {
            let head = if k == 0 { "notes" } else { "" };
            let _ = writeln!(out, "  {head:<18}- {note}");
        }
        if link.problems.is_empty() {
            let _ = writeln!(out, "  {:<18}none", "problems");
        } else {
            for (k, p) in link.problems.iter().enumerate() {
                let head = if k == 0 { "problems" } else { "" };
                let _ = writeln!(out, "  {head:<18}- {p}");
            }
        }
        if options.compare {
            let settings = options.settings.for_link(&link.name);
            render_comparison(&mut out, &Comparison::of(link, &settings));
        }
    }
    render_joints(&mut out, model);
    render_meshes(&mut out, &model.meshes);
    let _ = writeln!(out);
    match model.total_mass_properties() {
        Some(total) => {
            let _ = writeln!(
                out,
                "total (links with positive mass, model frame, zero joint configuration)"
            );
            let _ = writeln!(out, "  {:<18}{} kg", "mass", num(total.mass));
            let _ = writeln!(
                out,
                "  {:<18}{} m",
                "com",
                row(&[total.com.x, total.com.y, total.com.z])
            );
            matrix_rows(&mut out, "inertia about com", &total.inertia, "kg m^2");
            let m = total.principal_moments();
            let _ = writeln!(
                out,
                "  {:<18}{} kg m^2",
                "principal moments",
                row(&[m.x, m.y, m.z])
            );
        }
        None => {
            let _ = writeln!(
                out,
                "total: no link has a positive mass (nothing to simulate)"
            );
        }
    }
    let with_problems = model
        .links
        .iter()
        .filter(|l| !l.problems.is_empty())
        .count();
    let _ = writeln!(
        out,
        "{}",
        if with_problems == 0 {
            "no problems found".to_string()
        } else {
            format!("{with_problems} link(s) with problems")
        }
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_readable() {
        assert_eq!(num(0.0), "0");
        assert_eq!(num(6.0), "6.00000");
        assert_eq!(num(0.065), "0.0650000");
        assert_eq!(num(4.491666666666667e-5), "4.49167e-5");
        assert_eq!(num(-1234.5), "-1234.50");
        assert_eq!(num(f64::NAN), "NaN");
    }
}
