//! Volume, centroid and second moments of the solid a closed triangle mesh bounds.
//!
//! By the divergence theorem a volume integral over the solid is a sum over the boundary
//! triangles; for polynomial integrands it reduces to a sum over the tetrahedra `(p, a, b, c)`
//! joining a reference point `p` to each triangle, taken with the sign of their orientation
//! (Mirtich, "Fast and Accurate Computation of Polyhedral Mass Properties", J. Graphics Tools
//! 1(2), 1996; Eberly, "Polyhedral Mass Properties (Revisited)", Geometric Tools, 2002/2009).
//! With `a, b, c` the triangle's vertices relative to `p` and `s = a + b + c`, over one such
//! tetrahedron `T` (Tonon, "Explicit Exact Formulas for the 3-D Tetrahedron Inertia Tensor in
//! Terms of its Vertex Coordinates", J. Math. Stat. 1(1), 2004, for the same moments written
//! out per coordinate):
//!
//! ```text
//! ∫_T dV     = V_t = a · (b × c) / 6
//! ∫_T x dV   = V_t s / 4
//! ∫_T x xᵀ dV = V_t / 20 (a aᵀ + b bᵀ + c cᵀ + s sᵀ)
//! ```
//!
//! Summed over the triangles: the volume `V`, the first moment, and the covariance `C_p` about
//! `p`. Then the centroid `c = first / V` and the covariance about the centroid
//! `C = C_p − V c cᵀ`; the inertia per unit density is `tr(C) E − C`.
//!
//! # Round-off
//! `p` is the centre of the bounding box of the used vertices: coordinates are subtracted once,
//! exactly or to one rounding, and every product is of mesh-sized numbers. Integrating about a
//! far origin instead (a mesh at distance `d`, size `L`) makes `C_p` of order `V d²` and the
//! shift `C_p − V c cᵀ` cancels `(d/L)²` of the digits: 2e-4 relative at 1 km for a centimetre
//! part (`tests/model/mesh.rs` measures both).

use super::topology::is_kept;
use super::{MeshError, TriangleMesh};
use crate::model::MassProperties;
use nalgebra::{Matrix3, Vector3};

/// A volume `|V| ≤ DEGENERATE_VOLUME_RATIO · R³` (`R` half the diagonal of the bounding box)
/// is zero to round-off: the mesh is flat, scaled by zero, or collapsed. Each tetrahedron's
/// volume carries a rounding error of about `eps R³` (eps = 2.2e-16); a million of them add up
/// to about `1e3 eps R³ = 2.2e-13 R³` (random walk), so `1e-11 R³` sits well above the noise of
/// any real mesh and well below a real solid's volume (a 0.2 mm cube in a 2 m bounding box).
pub const DEGENERATE_VOLUME_RATIO: f64 = 1e-11;

/// Volume, centroid and second moments of a solid of unit density.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VolumeProperties {
    /// Volume, m^3 (signed: negative for an inside-out mesh when integrated unchecked).
    pub volume_m3: f64,
    /// Centroid (centre of mass at uniform density), m, in the mesh frame.
    pub centroid: Vector3<f64>,
    /// Covariance about the centroid, `∫ (x − c)(x − c)ᵀ dV`, m^5.
    pub covariance_m5: Matrix3<f64>,
    /// Round-off bound on the volume, `DEGENERATE_VOLUME_RATIO · R³`, m^3.
    pub degenerate_limit_m3: f64,
}

impl VolumeProperties {
    /// Inertia about the centroid at unit density, `tr(C) E − C`, m^5 (kg m² per kg/m^3).
    pub fn inertia_unit_density(&self) -> Matrix3<f64> {
        Matrix3::identity() * self.covariance_m5.trace() - self.covariance_m5
    }

    /// Mass properties at `density` (kg/m^3): `m = ρ V`, `com = c`, `I = ρ (tr(C) E − C)`.
    pub fn mass_properties(&self, density: f64) -> MassProperties {
        MassProperties::new(
            density * self.volume_m3,
            self.centroid,
            self.inertia_unit_density() * density,
        )
    }

    /// `Err` when the volume is zero to round-off ([`MeshError::Degenerate`]) or negative
    /// ([`MeshError::InsideOut`]).
    pub fn checked(self) -> Result<Self, MeshError> {
        if self.volume_m3.is_nan() || self.volume_m3.abs() <= self.degenerate_limit_m3 {
            Err(MeshError::Degenerate {
                volume_m3: self.volume_m3,
                limit_m3: self.degenerate_limit_m3,
            })
        } else if self.volume_m3 < 0.0 {
            Err(MeshError::InsideOut {
                volume_m3: self.volume_m3,
            })
        } else {
            Ok(self)
        }
    }
}

/// Centre of the bounding box of the vertices the kept triangles use, and half its diagonal.
/// `None` when no triangle is kept.
fn reference_point(mesh: &TriangleMesh) -> Option<(Vector3<f64>, f64)> {
    let n = mesh.vertices.len();
    let mut lo = Vector3::repeat(f64::INFINITY);
    let mut hi = Vector3::repeat(f64::NEG_INFINITY);
    let mut any = false;
    for t in mesh.triangles.iter().filter(|t| is_kept(t, n)) {
        for &i in t {
            let v = &mesh.vertices[i as usize];
            lo = lo.inf(v);
            hi = hi.sup(v);
            any = true;
        }
    }
    any.then(|| ((lo + hi) * 0.5, (hi - lo).norm() * 0.5))
}

impl TriangleMesh {
    /// Volume properties integrated without any check (see the module documentation of
    /// `mesh`): meaningful only for a closed, consistently oriented mesh; negative volume for
    /// an inside-out one. Triangles out of range or repeating an index are skipped. Prefer
    /// [`TriangleMesh::volume_properties`].
    pub fn signed_volume_properties(&self) -> VolumeProperties {
        integrate(self)
    }
}

/// See [`TriangleMesh::signed_volume_properties`].
pub(super) fn integrate(mesh: &TriangleMesh) -> VolumeProperties {
    let Some((p, half_diagonal)) = reference_point(mesh) else {
        return VolumeProperties {
            volume_m3: 0.0,
            centroid: Vector3::zeros(),
            covariance_m5: Matrix3::zeros(),
            degenerate_limit_m3: 0.0,
        };
    };
    let n = mesh.vertices.len();
    // Sums of 6 V_t, 6 V_t s (= 24 × first moment) and 6 V_t (a aᵀ + b bᵀ + c cᵀ + s sᵀ)
    // (= 120 × covariance): the constant factors are applied once at the end.
    let mut volume6 = 0.0;
    let mut first24 = Vector3::zeros();
    let mut covariance120 = Matrix3::zeros();
    for t in mesh.triangles.iter().filter(|t| is_kept(t, n)) {
        let a = mesh.vertices[t[0] as usize] - p;
        let b = mesh.vertices[t[1] as usize] - p;
        let c = mesh.vertices[t[2] as usize] - p;
        let v6 = a.dot(&b.cross(&c));
        let s = a + b + c;
        volume6 += v6;
        first24 += s * v6;
        covariance120 +=
            (a * a.transpose() + b * b.transpose() + c * c.transpose() + s * s.transpose()) * v6;
    }
    let volume = volume6 / 6.0;
    let centroid_from_p = if volume6 != 0.0 {
        first24 / (4.0 * volume6)
    } else {
        Vector3::zeros()
    };
    let covariance_p = covariance120 / 120.0;
    let covariance = covariance_p - centroid_from_p * centroid_from_p.transpose() * volume;
    VolumeProperties {
        volume_m3: volume,
        centroid: p + centroid_from_p,
        // Symmetric by construction up to the last bit; make it exactly so.
        covariance_m5: (covariance + covariance.transpose()) * 0.5,
        degenerate_limit_m3: DEGENERATE_VOLUME_RATIO * half_diagonal.powi(3),
    }
}
