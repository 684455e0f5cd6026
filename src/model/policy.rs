//! Where a link's mass properties come from: the URDF's `<inertial>`, the link's geometry, or
//! the URDF where it is present and valid and the geometry otherwise (issue 5).
//!
//! Settings are given at three levels; the more specific wins: per link
//! (`[[model]] links.<name> = { ... }`), per model (`[[model]] inertia/density/geometry`), and
//! the scene's defaults (`[mass]` table, which the command-line flags `--inertia`, `--density`,
//! `--geometry` override).

use super::Model;
use std::collections::BTreeMap;

/// `inertia = "urdf" | "geometry" | "auto"`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum InertiaPolicy {
    /// The URDF's values; a missing `<inertial>` is a massless frame, an invalid one an error.
    #[default]
    Urdf,
    /// Computed from the link's geometry at the density, whatever the URDF says.
    Geometry,
    /// The URDF's values where present and valid, the geometry's where missing or invalid.
    Auto,
}

/// Which geometry of a link mass properties are computed from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum GeometrySource {
    /// `<collision>` elements; the `<visual>` ones when the link has no collision geometry.
    #[default]
    Collision,
    /// `<visual>` elements; the `<collision>` ones when the link has no visual geometry.
    Visual,
}

/// Default density, kg/m^3 (water).
pub const DEFAULT_DENSITY: f64 = 1000.0;

/// Mass settings at one level; `None` = inherit from the level above.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MassSettings {
    #[serde(default)]
    pub inertia: Option<InertiaPolicy>,
    /// kg/m^3, finite and > 0.
    #[serde(default)]
    pub density: Option<f64>,
    #[serde(default)]
    pub geometry: Option<GeometrySource>,
}

impl MassSettings {
    /// `self` refined by the more specific `other` (its `Some` values win).
    pub fn refined(&self, other: &MassSettings) -> MassSettings {
        MassSettings {
            inertia: other.inertia.or(self.inertia),
            density: other.density.or(self.density),
            geometry: other.geometry.or(self.geometry),
        }
    }

    /// With every unset value at its default.
    pub fn resolved(&self) -> ResolvedMass {
        ResolvedMass {
            inertia: self.inertia.unwrap_or_default(),
            density: self.density.unwrap_or(DEFAULT_DENSITY),
            geometry: self.geometry.unwrap_or_default(),
        }
    }
}

/// Mass settings with every value decided.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ResolvedMass {
    pub inertia: InertiaPolicy,
    pub density: f64,
    pub geometry: GeometrySource,
}

/// The settings of every link of one model: the model-level ones refined per link.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ModelMassSettings {
    pub model: MassSettings,
    pub links: BTreeMap<String, MassSettings>,
}

impl ModelMassSettings {
    /// The resolved settings of link `name`.
    pub fn for_link(&self, name: &str) -> ResolvedMass {
        match self.links.get(name) {
            Some(link) => self.model.refined(link).resolved(),
            None => self.model.resolved(),
        }
    }
}

/// Applies the policy to every link of `model` in place: replaces `inertial`, `source` and
/// `problems` as the policy says. Errors name the file, the link and the reason (e.g. a link
/// whose geometry cannot give mass properties under `inertia = "geometry"`).
///
/// SKELETON: today only `urdf` is implemented (nothing changes); issue 5 fills in the rest.
pub fn apply(model: &mut Model, settings: &ModelMassSettings) -> anyhow::Result<()> {
    for link in &model.links {
        let resolved = settings.for_link(&link.name);
        if resolved.inertia != InertiaPolicy::Urdf {
            anyhow::bail!(
                "{}: link {:?}: inertia = {:?} is not implemented yet",
                model.path.display(),
                link.name,
                resolved.inertia
            );
        }
    }
    Ok(())
}
