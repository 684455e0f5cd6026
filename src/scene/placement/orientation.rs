//! How a root link frame's orientation is given, in a scene's `[[model]]` and in a dataset's
//! `[vary]`: one parser for both, and the draw.
//!
//! ```toml
//! rpy = [r, p, y]                         # a value (R = Rz Ry Rx), read by serde
//! rpy = { normal = { mean = ..., std = ... } }   # roll, pitch, yaw drawn from a distribution
//! orientation = "uniform"                 # uniformly distributed over SO(3) (Shoemake)
//! orientation = [x, y, z, w]              # a unit quaternion (normalised when read)
//! ```

use super::distribution::Dist;
use super::rng::Rng;
use crate::model::kinematics::rotation_from_rpy;
use anyhow::{Context, bail};
use nalgebra::{Quaternion, UnitQuaternion};

/// How the root link frame's orientation is given.
#[derive(Debug, Clone, Default, PartialEq)]
pub enum Orientation {
    /// The entry's (or the template's) `rpy` value.
    #[default]
    Rpy,
    /// `orientation = [x, y, z, w]`: a unit quaternion (normalised when read).
    Quaternion([f64; 4]),
    /// `orientation = "uniform"`: uniformly distributed over SO(3) (Shoemake's method).
    Uniform,
    /// `rpy = { ... }`: roll, pitch, yaw (rad) from a distribution, `R = Rz Ry Rx`.
    RpyDrawn(Dist),
}

impl Orientation {
    /// Whether the orientation is drawn (from the `orientation` or the `rpy` stream).
    pub fn is_drawn(&self) -> bool {
        matches!(self, Orientation::Uniform | Orientation::RpyDrawn(_))
    }

    /// Parses `orientation` and a distribution-valued `rpy` (an `rpy` value is the caller's:
    /// pass `rpy_dist = None` for it, and `rpy_given` whether one was written). `prefix` names
    /// the table in errors (`file: model[0]`, `spec.toml: vary`).
    pub fn parse(
        prefix: &str,
        orientation: Option<&toml::Value>,
        rpy_dist: Option<&toml::Value>,
        rpy_given: bool,
    ) -> anyhow::Result<Self> {
        match (orientation, rpy_dist) {
            (Some(_), _) if rpy_given || rpy_dist.is_some() => {
                bail!("{prefix}.orientation: give orientation or rpy, not both")
            }
            (Some(value), None) => match value {
                toml::Value::String(s) if s == "uniform" => Ok(Orientation::Uniform),
                toml::Value::Array(a) => Ok(Orientation::Quaternion(unit_quaternion(
                    &format!("{prefix}.orientation"),
                    a,
                )?)),
                _ => bail!(
                    "{prefix}.orientation: expected \"uniform\" (a uniformly random rotation) or a \
                     unit quaternion [x, y, z, w] (got {value}); for other distributions use \
                     rpy = {{ ... }}"
                ),
            },
            (None, Some(value)) => Ok(Orientation::RpyDrawn(Dist::parse(
                &format!("{prefix}.rpy"),
                value,
                3,
            )?)),
            _ => Ok(Orientation::Rpy),
        }
    }

    /// The rotation: drawn from the `orientation` (uniform) or `rpy` stream of `seed` (a run's
    /// or a copy's [`super::rng::run_seed`]), else the quaternion, else `R(rpy)`.
    pub fn rotation(&self, seed: u64, rpy: [f64; 3]) -> UnitQuaternion<f64> {
        match self {
            Orientation::Rpy => rotation_from_rpy(rpy),
            Orientation::Quaternion([x, y, z, w]) => {
                UnitQuaternion::new_unchecked(Quaternion::new(*w, *x, *y, *z))
            }
            Orientation::Uniform => {
                let [x, y, z, w] = Rng::for_key(seed, "orientation").unit_quaternion_xyzw();
                UnitQuaternion::new_normalize(Quaternion::new(w, x, y, z))
            }
            Orientation::RpyDrawn(d) => {
                let r = d.sample(&mut Rng::for_key(seed, "rpy"));
                rotation_from_rpy([r[0], r[1], r[2]])
            }
        }
    }
}

/// `[x, y, z, w]`, finite, of norm 1 within 1e-6 (then normalised).
fn unit_quaternion(key: &str, items: &[toml::Value]) -> anyhow::Result<[f64; 4]> {
    let values: Option<Vec<f64>> = items
        .iter()
        .map(|v| match v {
            toml::Value::Float(x) => Some(*x),
            toml::Value::Integer(i) => Some(*i as f64),
            _ => None,
        })
        .collect();
    let q = values
        .filter(|v| v.len() == 4 && v.iter().all(|x| x.is_finite()))
        .with_context(|| format!("{key}: expected [x, y, z, w], four finite numbers"))?;
    let norm = q.iter().map(|x| x * x).sum::<f64>().sqrt();
    if (norm - 1.0).abs() > 1e-6 {
        bail!(
            "{key}: the quaternion [x, y, z, w] must have norm 1 (got {})",
            crate::budget::readable(norm)
        );
    }
    Ok([q[0] / norm, q[1] / norm, q[2] / norm, q[3] / norm])
}
