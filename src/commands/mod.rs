//! One module per command verb; each exposes its clap `Args` struct and a `run` function.
//! `main.rs` is the only place that turns results into exit codes.

pub mod bench;
pub mod convert;
pub mod dataset;
pub mod diff;
pub mod info;
pub mod inspect;
pub mod simulate;
pub mod stability;
pub mod survey;
pub mod trade;

use crate::model::policy::{GeometrySource, InertiaPolicy, MassSettings};
use crate::sim::IntegratorKind;
use nalgebra::Vector3;

/// Integrator names from the command line; empty means all of [`IntegratorKind::ALL`]. An
/// unknown name is an error that lists the known ones.
pub fn parse_integrators(names: &[String]) -> anyhow::Result<Vec<IntegratorKind>> {
    if names.is_empty() {
        return Ok(IntegratorKind::ALL.to_vec());
    }
    names
        .iter()
        .map(|name| {
            IntegratorKind::from_name(name).ok_or_else(|| {
                let known: Vec<_> = IntegratorKind::ALL.iter().map(|k| k.name()).collect();
                anyhow::anyhow!(
                    "--integrators: unknown integrator {name:?} (expected one of: {})",
                    known.join(", ")
                )
            })
        })
        .collect()
}

/// Parses `x,y,z` into three finite numbers (clap value parser).
pub fn parse_vec3(s: &str) -> Result<[f64; 3], String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return Err(format!(
            "expected three comma-separated numbers x,y,z, got {s:?}"
        ));
    }
    let mut v = [0.0; 3];
    for (slot, p) in v.iter_mut().zip(&parts) {
        *slot = p.parse::<f64>().map_err(|e| format!("{p:?}: {e}"))?;
        if !slot.is_finite() {
            return Err(format!("{p:?} is not a finite number"));
        }
    }
    Ok(v)
}

/// Formats a vector for terminal output.
pub fn fmt_vec3(v: &Vector3<f64>) -> String {
    format!("[{:.6}, {:.6}, {:.6}]", v.x, v.y, v.z)
}

/// `--inertia`, `--density`, `--geometry`: the mass settings flags shared by `simulate` and
/// `inspect` (see [`crate::model::policy`]). Unset flags leave the scene's `[mass]` (or the
/// defaults: urdf, 1000 kg/m^3, collision) as they are.
#[derive(clap::Args, Debug, Clone, Default, PartialEq)]
pub struct MassArgs {
    /// Where link mass properties come from: urdf (the file's inertial values), geometry (computed
    /// from the link's shapes at --density), auto (the URDF's where present and valid, the
    /// geometry's where missing or invalid). Overrides the scene's [mass] inertia.
    #[arg(long, value_name = "urdf|geometry|auto", value_parser = parse_inertia_policy)]
    pub inertia: Option<InertiaPolicy>,
    /// Uniform density for geometry-derived mass properties, kg/m^3 (default 1000). Overrides
    /// the scene's [mass] density.
    #[arg(long, value_name = "KG_PER_M3", value_parser = parse_density)]
    pub density: Option<f64>,
    /// Which shapes geometry-derived mass properties use: collision (visual when a link has
    /// none) or visual (collision when a link has none). Overrides the scene's [mass] geometry.
    #[arg(long, value_name = "collision|visual", value_parser = parse_geometry_source)]
    pub geometry: Option<GeometrySource>,
}

impl MassArgs {
    /// As mass settings (`None` where a flag is unset).
    pub fn settings(&self) -> MassSettings {
        MassSettings {
            inertia: self.inertia,
            density: self.density,
            geometry: self.geometry,
        }
    }
}

/// `urdf | geometry | auto` (clap value parser).
pub fn parse_inertia_policy(s: &str) -> Result<InertiaPolicy, String> {
    match s {
        "urdf" => Ok(InertiaPolicy::Urdf),
        "geometry" => Ok(InertiaPolicy::Geometry),
        "auto" => Ok(InertiaPolicy::Auto),
        _ => Err(format!("expected urdf, geometry or auto, got {s:?}")),
    }
}

/// `collision | visual` (clap value parser).
pub fn parse_geometry_source(s: &str) -> Result<GeometrySource, String> {
    match s {
        "collision" => Ok(GeometrySource::Collision),
        "visual" => Ok(GeometrySource::Visual),
        _ => Err(format!("expected collision or visual, got {s:?}")),
    }
}

/// A density in kg/m^3: a positive finite number (clap value parser).
pub fn parse_density(s: &str) -> Result<f64, String> {
    let v: f64 = s.trim().parse().map_err(|e| format!("{s:?}: {e}"))?;
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(format!(
            "must be a positive finite number of kg/m^3, got {s}"
        ))
    }
}
