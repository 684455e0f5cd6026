//! Mass properties of the URDF primitives in closed form, about each primitive's centre, in the
//! primitive's own frame (the frame its `<origin>` places in the link), at uniform density.
//!
//! Every primitive is symmetric about its centre, so the centre of mass is the frame origin and
//! the inertia tensor is diagonal in the primitive's axes. URDF cylinders and capsules have
//! their axis along z. `mass = volume × density`.
//!
//! | shape | volume | `Ixx` | `Iyy` | `Izz` |
//! |---|---|---|---|---|
//! | box `a × b × c` (full sides) | `abc` | `m(b²+c²)/12` | `m(a²+c²)/12` | `m(a²+b²)/12` |
//! | cylinder radius `r`, length `L` | `π r² L` | `m(3r²+L²)/12` | same | `m r²/2` |
//! | sphere radius `r` | `4/3 π r³` | `2/5 m r²` | same | same |
//! | capsule (see [`capsule`]) | `π r² L + 4/3 π r³` | see [`capsule`] | same | see [`capsule`] |
//!
//! Dimensions are checked here too (finite, positive; a capsule's straight length may be 0):
//! a shape without volume has no centre of mass, so it is an error, not a zero.

use crate::model::MassProperties;
use nalgebra::{Matrix3, Vector3};
use std::f64::consts::PI;

/// Why a primitive has no mass properties (its dimensions), in words.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct DimensionError(pub String);

fn positive(what: &str, x: f64) -> Result<(), DimensionError> {
    if x.is_finite() && x > 0.0 {
        Ok(())
    } else {
        Err(DimensionError(format!(
            "{what} {x} must be positive and finite"
        )))
    }
}

fn diagonal(mass_kg: f64, moments: [f64; 3]) -> MassProperties {
    MassProperties::new(
        mass_kg,
        Vector3::zeros(),
        Matrix3::from_diagonal(&Vector3::from(moments)),
    )
}

/// Solid box with full side lengths `size = (a, b, c)` along x, y, z:
///
/// ```text
/// m = ρ a b c,   I = m/12 · diag(b² + c², a² + c², a² + b²)
/// ```
pub fn cuboid(
    size_m: &Vector3<f64>,
    density_kg_per_m3: f64,
) -> Result<MassProperties, DimensionError> {
    for (axis, s) in ["x", "y", "z"].iter().zip(size_m.iter()) {
        positive(&format!("box size along {axis}"), *s)?;
    }
    let (a2, b2, c2) = (size_m.x.powi(2), size_m.y.powi(2), size_m.z.powi(2));
    let m = density_kg_per_m3 * size_m.x * size_m.y * size_m.z;
    Ok(diagonal(
        m,
        [
            m * (b2 + c2) / 12.0,
            m * (a2 + c2) / 12.0,
            m * (a2 + b2) / 12.0,
        ],
    ))
}

/// Solid cylinder of radius `r` and length `L`, axis along z, centred:
///
/// ```text
/// m = ρ π r² L,   Ixx = Iyy = m (3 r² + L²) / 12,   Izz = m r² / 2
/// ```
pub fn cylinder(
    radius_m: f64,
    length_m: f64,
    density_kg_per_m3: f64,
) -> Result<MassProperties, DimensionError> {
    positive("cylinder radius", radius_m)?;
    positive("cylinder length", length_m)?;
    let r2 = radius_m * radius_m;
    let m = density_kg_per_m3 * PI * r2 * length_m;
    let transverse = m * (3.0 * r2 + length_m * length_m) / 12.0;
    Ok(diagonal(m, [transverse, transverse, m * r2 / 2.0]))
}

/// Solid sphere of radius `r`:
///
/// ```text
/// m = ρ 4/3 π r³,   I = 2/5 m r² · E
/// ```
pub fn sphere(radius_m: f64, density_kg_per_m3: f64) -> Result<MassProperties, DimensionError> {
    positive("sphere radius", radius_m)?;
    let m = density_kg_per_m3 * 4.0 / 3.0 * PI * radius_m.powi(3);
    let i = 0.4 * m * radius_m * radius_m;
    Ok(diagonal(m, [i, i, i]))
}

/// URDF 1.1 capsule: a cylinder of radius `r` and length `L` (the straight part only) along z,
/// closed by two hemispheres of radius `r`; centred, total length `L + 2r`.
///
/// Parts: the cylinder `m_c = ρ π r² L` and two hemispheres `m_h = ρ 2/3 π r³` each, so
/// `m = m_c + 2 m_h`.
///
/// About z every part is centred on the axis, and a hemisphere is half a sphere:
///
/// ```text
/// Izz = m_c r²/2 + 2 · (2/5 m_h r²)
/// ```
///
/// About x (and y): a hemisphere's moment about a diameter of its flat face is that of the
/// sphere, `2/5 m_h r²`; its centre of mass lies `3r/8` from the face, so about its own centre
/// of mass (parallel axis) it is `(2/5 − 9/64) m_h r² = 83/320 m_h r²`. Its centre of mass is
/// `d = L/2 + 3r/8` from the capsule's centre, so (parallel axis again)
///
/// ```text
/// Ixx = Iyy = m_c (3 r² + L²)/12 + 2 m_h (83/320 r² + (L/2 + 3r/8)²)
///           = m_c (3 r² + L²)/12 + 2 m_h (2/5 r² + L²/4 + 3 L r/8)
/// ```
///
/// With `L = 0` this is a sphere (`Ixx = 2/5 m r²`), which the tests check.
pub fn capsule(
    radius_m: f64,
    length_m: f64,
    density_kg_per_m3: f64,
) -> Result<MassProperties, DimensionError> {
    positive("capsule radius", radius_m)?;
    if !(length_m.is_finite() && length_m >= 0.0) {
        return Err(DimensionError(format!(
            "capsule length {length_m} must be finite and >= 0"
        )));
    }
    let (r, l) = (radius_m, length_m);
    let r2 = r * r;
    let m_cylinder = density_kg_per_m3 * PI * r2 * l;
    let m_hemisphere = density_kg_per_m3 * 2.0 / 3.0 * PI * r2 * r;
    let izz = m_cylinder * r2 / 2.0 + 2.0 * 0.4 * m_hemisphere * r2;
    let ixx = m_cylinder * (3.0 * r2 + l * l) / 12.0
        + 2.0 * m_hemisphere * (0.4 * r2 + l * l / 4.0 + 3.0 * l * r / 8.0);
    Ok(diagonal(m_cylinder + 2.0 * m_hemisphere, [ixx, ixx, izz]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_cube_of_water() {
        let mp = cuboid(&Vector3::repeat(1.0), 1000.0).unwrap();
        assert_eq!(mp.mass, 1000.0);
        assert_eq!(mp.inertia, Matrix3::identity() * (1000.0 * 2.0 / 12.0));
    }

    #[test]
    fn bad_dimensions_are_errors() {
        assert!(cuboid(&Vector3::new(1.0, 0.0, 1.0), 1.0).is_err());
        assert!(cylinder(1.0, f64::NAN, 1.0).is_err());
        assert!(sphere(-1.0, 1.0).is_err());
        assert!(capsule(0.0, 1.0, 1.0).is_err());
        assert!(capsule(1.0, -1.0, 1.0).is_err());
        assert!(capsule(1.0, 0.0, 1.0).is_ok());
    }
}
