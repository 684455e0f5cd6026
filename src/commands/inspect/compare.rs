//! `inspect --compare`: a link's URDF values beside the values its geometry gives, and how far
//! apart they are.
//!
//! Differences (URDF against geometry; the geometry's values are the reference because they
//! always exist and are valid when computed):
//!
//! ```text
//! mass_relative              = (m_urdf − m_geom) / m_geom
//! com_distance               = |c_urdf − c_geom|                  m, link frame
//! principal_moments_relative = (λk_urdf − λk_geom) / λk_geom      ascending, paired by rank
//! inertia_relative           = ‖I_urdf − I_geom‖_F / ‖I_geom‖_F   about each com, link axes
//!                                                                 (sees turned axes too)
//! density_matching_urdf_mass = ρ m_urdf / m_geom                  kg/m^3 at which the masses
//!                                                                 agree; none unless m_urdf > 0
//! ```
//!
//! The geometry's mass scales with the density, which is a guess; the centre of mass and the
//! ratios of the moments do not depend on it.

use crate::model::geometry::{self, LinkGeometryMass};
use crate::model::policy::ResolvedMass;
use crate::model::{Link, MassProperties};
use nalgebra::Vector3;

/// The URDF's values and the geometry's for one link.
#[derive(Debug, Clone)]
pub struct Comparison {
    /// The URDF's `<inertial>` as written; `None` when absent.
    pub urdf: Option<MassProperties>,
    /// The geometry's values at the link's density and geometry preference, or why there are
    /// none (in words).
    pub geometry: Result<LinkGeometryMass, String>,
}

/// How far the URDF's values are from the geometry's (definitions in the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Difference {
    pub mass_relative: f64,
    pub com_distance_m: f64,
    pub principal_moments_relative: Vector3<f64>,
    pub inertia_relative: f64,
    pub density_matching_urdf_mass_kg_per_m3: Option<f64>,
}

impl Comparison {
    /// Computes the geometry's values of `link` with its resolved `settings` (density, geometry
    /// preference; the inertia policy does not matter here).
    pub fn of(link: &Link, settings: &ResolvedMass) -> Self {
        Self {
            urdf: link.urdf_inertial,
            geometry: geometry::link_mass_properties(link, settings.geometry, settings.density)
                .map_err(|e| e.to_string()),
        }
    }

    /// `None` unless both values exist.
    pub fn difference(&self) -> Option<Difference> {
        let urdf = self.urdf.as_ref()?;
        let computed = self.geometry.as_ref().ok()?;
        let geom = &computed.mass_properties;
        let moments_urdf = urdf.principal_moments();
        let moments_geom = geom.principal_moments();
        Some(Difference {
            mass_relative: (urdf.mass - geom.mass) / geom.mass,
            com_distance_m: (urdf.com - geom.com).norm(),
            principal_moments_relative: (moments_urdf - moments_geom).component_div(&moments_geom),
            inertia_relative: (urdf.inertia - geom.inertia).norm() / geom.inertia.norm(),
            density_matching_urdf_mass_kg_per_m3: (urdf.mass > 0.0)
                .then(|| computed.used.density_kg_per_m3 * urdf.mass / geom.mass),
        })
    }
}
