//! One module per command verb; each exposes its clap `Args` struct and a `run` function.
//! `main.rs` is the only place that turns results into exit codes.

pub mod bench;
pub mod inspect;
pub mod simulate;
pub mod trade;

use nalgebra::Vector3;

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
