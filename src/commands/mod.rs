//! One module per command verb; each exposes its clap `Args` struct and a `run` function.
//! `main.rs` is the only place that turns results into exit codes.

pub mod bench;
pub mod inspect;
pub mod simulate;
pub mod stability;
pub mod survey;
pub mod trade;

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
