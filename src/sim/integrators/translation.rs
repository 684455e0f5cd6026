//! Translation of the centre of mass in uniform gravity, from the discrete Lagrangian
//! `L_d = h m/2 |(c1 - c0)/h|^2 - h V_d(c0, c1)` with `V(c) = -m g·c`.
//!
//! With the discrete Legendre transform `p_k = m v_k`, the discrete Euler-Lagrange equations give
//! `c_{k+1} = c_k + h v_k + α h^2 g`, `v_{k+1} = v_k + h g`, where
//! - symmetric (trapezoid) potential `V_d = (V(c0) + V(c1))/2`: `α = 1/2` (Störmer-Verlet),
//!   exact for uniform gravity;
//! - end-point potential `V_d = V(c1)` (the seed's choice): `α = 0`, so every position lags the
//!   parabola by `t h g / 2` (0.049 m after 1 s at h = 0.01 s).

use crate::sim::loads::Loads;
use nalgebra::Vector3;

/// Quadrature of the potential in the discrete Lagrangian.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Potential {
    /// `h (V(c0) + V(c1)) / 2`: Störmer-Verlet, exact parabola. The default.
    #[default]
    Symmetric,
    /// `h V(c1)`: the seed's scheme; O(h) position offset `t h g / 2`.
    EndPoint,
}

impl Potential {
    pub fn name(self) -> &'static str {
        match self {
            Potential::Symmetric => "symmetric",
            Potential::EndPoint => "end-point",
        }
    }

    /// The coefficient `α` of `h^2 g` in the position update.
    pub fn alpha(self) -> f64 {
        match self {
            Potential::Symmetric => 0.5,
            Potential::EndPoint => 0.0,
        }
    }
}

/// Advances every centre of mass one step.
pub fn step_translation(
    com_world: &mut [Vector3<f64>],
    linvel_world: &mut [Vector3<f64>],
    dt_secs: f64,
    loads: &Loads,
    potential: Potential,
) {
    let dc_gravity = loads.gravity() * (potential.alpha() * dt_secs * dt_secs);
    let dv = loads.gravity() * dt_secs;
    for (c, v) in com_world.iter_mut().zip(linvel_world.iter_mut()) {
        *c += *v * dt_secs + dc_gravity;
        *v += dv;
    }
}
