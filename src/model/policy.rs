//! Where a link's mass properties come from: the URDF's `<inertial>`, the link's geometry, or
//! the URDF where it is present and valid and the geometry otherwise (issue 5).
//!
//! Settings are given at three levels; the more specific wins: per link
//! (`[[model]] links.<name> = { ... }`), per model (`[[model]] inertia/density/geometry`), and
//! the scene's defaults (`[mass]` table, which the command-line flags `--inertia`, `--density`,
//! `--geometry` override).
//!
//! What each policy does to a link is documented on [`apply`]; where geometry-derived values
//! come from on [`geometry::compose`].

use super::geometry::{self, GeometryError, LinkGeometryMass};
use super::{InertiaSource, Link, Model};
use std::collections::BTreeMap;
use std::path::PathBuf;

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

/// Why the inertia policy cannot be applied to a model. Every message starts with the URDF
/// file and names the link.
#[derive(Debug, thiserror::Error)]
pub enum PolicyError {
    #[error(
        "{}: links.{link}: the model `{model}` has no link `{link}` (its links: {}){}",
        .path.display(),
        list_names(.known),
        crate::message::did_you_mean(.link, .known.iter().map(String::as_str))
    )]
    UnknownLink {
        path: PathBuf,
        model: String,
        link: String,
        known: Vec<String>,
    },
    #[error(
        "{}: link `{link}`: density {density_kg_per_m3} kg/m^3 must be positive and finite",
        .path.display()
    )]
    Density {
        path: PathBuf,
        link: String,
        density_kg_per_m3: f64,
    },
    #[error(
        "{}: link `{link}`: inertia = \"geometry\": cannot compute mass properties from its \
         geometry: {reason}",
        .path.display()
    )]
    Geometry {
        path: PathBuf,
        link: String,
        reason: Box<GeometryError>,
    },
}

/// At most 20 names, back-quoted, then how many more.
fn list_names(names: &[String]) -> String {
    const SHOWN: usize = 20;
    let mut text: Vec<String> = names.iter().take(SHOWN).map(|n| format!("`{n}`")).collect();
    if names.len() > SHOWN {
        text.push(format!("and {} more", names.len() - SHOWN));
    }
    text.join(", ")
}

/// Applies the policy to every link of a freshly loaded `model` in place (`inertial`, `source`,
/// `problems`, `geometry_used`, `notes`), link by link with [`ModelMassSettings::for_link`]:
///
/// - `urdf`: nothing changes. A missing `<inertial>` stays a massless frame; invalid values stay
///   invalid, and [`Model::check_simulable`] refuses them.
/// - `geometry`: the values computed from the link's geometry
///   ([`geometry::link_mass_properties`]: collision shapes, visual ones as the fallback, or the
///   reverse with `geometry = "visual"`) replace the URDF's, [`InertiaSource::Geometry`]. A
///   link with no geometry at all (a frame such as `tool0`) becomes a massless frame (with
///   `inertial: None` and a note), whatever mass the URDF gave it: the geometry says there is
///   nothing there. Geometry that exists but cannot give mass properties (an unresolved or
///   unreadable mesh, a zero dimension) is an error naming the file, link and element.
/// - `auto`: the URDF's values where present and valid ([`super::MassProperties::validate`]: a zero
///   mass, a triangle-inequality violation and every other rule count as invalid), kept
///   unchanged and silently; where missing or invalid, the geometry's values,
///   [`InertiaSource::Repaired`]. When the geometry cannot give them either, the link stays as
///   the URDF had it (so the usual rules apply: missing = massless, invalid = refused by
///   [`Model::check_simulable`]) and a note says why it was not repaired.
///
/// Findings of [`super::MassProperties::validate`] about URDF values that were replaced leave
/// `problems` (they no longer describe the values in use) and are repeated in `notes`; the new
/// values are validated in turn. Visual problems stay.
///
/// Errors: a `links` key naming no link of the model; a density that is not a positive finite
/// number where geometry is used; under `geometry`, unusable geometry.
pub fn apply(model: &mut Model, settings: &ModelMassSettings) -> Result<(), PolicyError> {
    // The meshes read for one model's mass properties count against one cap (or the scene's,
    // when a scene is being built): a URDF naming one big file on many links reads it per link.
    let _triangles = super::geometry::mesh_io::TriangleBudget::open();
    for name in settings.links.keys() {
        if model.link_index(name).is_none() {
            return Err(PolicyError::UnknownLink {
                path: model.path.clone(),
                model: model.name.clone(),
                link: name.clone(),
                known: model.links.iter().map(|l| l.name.clone()).collect(),
            });
        }
    }
    for link in &mut model.links {
        let resolved = settings.for_link(&link.name);
        if resolved.inertia == InertiaPolicy::Urdf {
            continue;
        }
        if !(resolved.density.is_finite() && resolved.density > 0.0) {
            return Err(PolicyError::Density {
                path: model.path.clone(),
                link: link.name.clone(),
                density_kg_per_m3: resolved.density,
            });
        }
        match resolved.inertia {
            InertiaPolicy::Urdf => {}
            InertiaPolicy::Geometry => {
                from_geometry(link, &resolved).map_err(|reason| PolicyError::Geometry {
                    path: model.path.clone(),
                    link: link.name.clone(),
                    reason: Box::new(reason),
                })?
            }
            InertiaPolicy::Auto => repair(link, &resolved),
        }
    }
    Ok(())
}

/// `inertia = "geometry"` on one link.
fn from_geometry(link: &mut Link, settings: &ResolvedMass) -> Result<(), GeometryError> {
    let ignored = match &link.urdf_inertial {
        None => String::new(),
        Some(mp) => match mp.validate() {
            findings if findings.is_empty() => {
                format!(" (the URDF's <inertial>, {} kg, is not used)", mp.mass)
            }
            findings => format!(
                " (the URDF's <inertial> is not used; it was invalid: {})",
                findings.join("; ")
            ),
        },
    };
    match geometry::link_mass_properties(link, settings.geometry, settings.density) {
        Ok(computed) => {
            let note = format!(
                "inertia = geometry: computed from {}{ignored}",
                computed.used.describe()
            );
            replace(link, Some(&computed), InertiaSource::Geometry, note);
            Ok(())
        }
        Err(GeometryError::NoGeometry) => {
            let note = format!(
                "inertia = geometry: no <collision> or <visual> geometry, so a massless frame{ignored}"
            );
            replace(link, None, InertiaSource::Geometry, note);
            Ok(())
        }
        Err(e) => Err(e),
    }
}

/// `inertia = "auto"` on one link.
fn repair(link: &mut Link, settings: &ResolvedMass) {
    let why = match &link.urdf_inertial {
        None => "no <inertial>".to_string(),
        Some(mp) => {
            let findings = mp.validate();
            if findings.is_empty() {
                return;
            }
            format!("invalid <inertial> ({})", findings.join("; "))
        }
    };
    match geometry::link_mass_properties(link, settings.geometry, settings.density) {
        Ok(computed) => {
            let note = format!(
                "{why}: replaced by values computed from {}",
                computed.used.describe()
            );
            replace(link, Some(&computed), InertiaSource::Repaired, note);
        }
        Err(GeometryError::NoGeometry) if link.urdf_inertial.is_none() => link
            .notes
            .push("no <inertial> and no geometry: a massless frame".into()),
        Err(e) => link.notes.push(format!("{why}: not repaired: {e}")),
    }
}

/// Puts `computed` (or nothing: a massless frame) in place of the URDF's values.
fn replace(
    link: &mut Link,
    computed: Option<&LinkGeometryMass>,
    source: InertiaSource,
    note: String,
) {
    let urdf_findings = link
        .urdf_inertial
        .map(|mp| mp.validate())
        .unwrap_or_default();
    link.problems.retain(|p| !urdf_findings.contains(p));
    if let Some(computed) = computed {
        link.problems.extend(computed.mass_properties.validate());
    }
    link.inertial = computed.map(|c| c.mass_properties);
    link.geometry_used = computed.map(|c| c.used);
    link.source = source;
    link.notes.push(note);
}
