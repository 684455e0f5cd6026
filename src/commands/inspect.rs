//! `tumble inspect MODEL.urdf`: every link's mass properties, the problems found, and the whole
//! model's mass, centre of mass and inertia.
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
//!   "links": [                            // URDF order
//!     {
//!       "name": "forearm",
//!       "source": "urdf" | "missing",     // "missing": no <inertial>; mass, com, inertia and
//!                                         //   principal moments are then reported as zeros
//!       "mass": 1.0,
//!       "com": [x, y, z],                 // centre of mass, link frame
//!       "inertia": [[..], [..], [..]],    // about the com, link axes (inertial rpy applied)
//!       "principal_moments": [a, b, c],   // ascending
//!       "model_from_link": {"translation": [x, y, z], "rotation_xyzw": [x, y, z, w]},
//!                                         // link pose at the zero joint configuration
//!       "problems": ["..."]               // rules broken, in words; [] when fine
//!     }
//!   ],
//!   "total_mass": 4.8,                    // sum over links with positive mass (0 if none)
//!   "com": [x, y, z] | null,              // model frame; null when total_mass is 0
//!   "inertia_about_com": [[..],[..],[..]] | null,   // about "com", model axes
//!   "principal_moments": [a, b, c] | null
//! }
//! ```
//!
//! Non-finite numbers (a NaN mass in the URDF) are written as `null`, as JSON has no NaN.

use crate::model::{InertiaSource, Link, MassProperties, Model, urdf};
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
}

/// Prints the report; `Ok(true)` when no link has a problem, `Ok(false)` otherwise, `Err` when
/// the URDF cannot be loaded.
pub fn run(args: &InspectArgs) -> anyhow::Result<bool> {
    // ModelError already names the file (and link, rule): no extra context.
    let model = urdf::load(&args.model, &args.package_paths)?;
    if args.json {
        let text = serde_json::to_string_pretty(&report(&model))?;
        println!("{text}");
    } else {
        print!("{}", render_text(&model));
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

/// The `--json` document (structure in the module documentation).
pub fn report(model: &Model) -> Value {
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
            json!({
                "name": link.name,
                "source": match link.source {
                    InertiaSource::Urdf => "urdf",
                    InertiaSource::Missing => "missing",
                },
                "mass": mp.mass,
                "com": vec3(&mp.com),
                "inertia": mat3(&mp.inertia),
                "principal_moments": vec3(&moments),
                "model_from_link": pose(&link.model_from_link),
                "problems": link.problems,
            })
        })
        .collect();
    let total = model.total_mass_properties();
    json!({
        "file": model.path.display().to_string(),
        "model": model.name,
        "root": model.links.get(model.root).map(|l| l.name.as_str()),
        "ok": !model.has_problems(),
        "links": links,
        "total_mass": total.map_or(0.0, |t| t.mass),
        "com": total.map(|t| vec3(&t.com)),
        "inertia_about_com": total.map(|t| mat3(&t.inertia)),
        "principal_moments": total.map(|t| vec3(&t.principal_moments())),
    })
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

/// The human-readable report `inspect` prints.
pub fn render_text(model: &Model) -> String {
    let mut out = String::new();
    let root = model.links.get(model.root).map_or("?", |l| l.name.as_str());
    let _ = writeln!(
        out,
        "model `{}` ({}): {} links, root `{root}` (model frame = root link frame, SI units)",
        model.name,
        model.path.display(),
        model.links.len()
    );
    for link in &model.links {
        let _ = writeln!(out);
        let source = match link.source {
            InertiaSource::Urdf => "from <inertial>",
            InertiaSource::Missing => "no <inertial>: massless frame, zeros shown",
        };
        let _ = writeln!(out, "link `{}` ({source})", link.name);
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
        if link.problems.is_empty() {
            let _ = writeln!(out, "  {:<18}none", "problems");
        } else {
            for (k, p) in link.problems.iter().enumerate() {
                let head = if k == 0 { "problems" } else { "" };
                let _ = writeln!(out, "  {head:<18}- {p}");
            }
        }
    }
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
