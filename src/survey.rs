//! A survey of URDF corpora: which files load, and how healthy their links' inertial data are.
//!
//! Every `*.urdf` under the given folders is loaded as `tumble simulate` would (`package://`
//! resolved through the given search folders and the file's parent folders); files that fail
//! keep their one-line error. Each loaded link falls in exactly one [`LinkClass`], from its
//! `<inertial>` as written: missing, zero mass, invalid (a rule of
//! [`crate::model::MassProperties::validate`] other than zero mass), light (valid, under 1 g),
//! or valid. Then the `auto` policy ([`crate::model::policy`], density 1000 kg/m^3, collision
//! geometry first) is applied to a copy: `repaired` counts the links whose missing or invalid
//! values it replaced by geometry-derived ones, `still_invalid` the links with a non-zero mass
//! that still break a rule afterwards (no usable geometry).
//!
//! Files load leniently unless `strict` (see [`urdf::Strictness`]): each oddity the loader
//! accepted is one line of the file's `warnings`.

use crate::model::policy::{self, InertiaPolicy, MassSettings, ModelMassSettings};
use crate::model::{InertiaSource, MassProperties, Model, urdf};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Mass below which a valid link is counted as `light`, kg.
pub const LIGHT_MASS_KG: f64 = 1e-3;

/// The class of one link's inertial data, as written in the URDF.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum LinkClass {
    /// No `<inertial>`: a massless frame.
    Missing,
    /// `<mass value="0"/>`.
    ZeroMass,
    /// Negative, NaN or infinite values, not positive definite, or the triangle inequality broken.
    Invalid,
    /// Valid, mass under [`LIGHT_MASS_KG`] (often a placeholder).
    Light,
    Valid,
}

impl LinkClass {
    pub const ALL: [LinkClass; 5] = [
        LinkClass::Missing,
        LinkClass::ZeroMass,
        LinkClass::Invalid,
        LinkClass::Light,
        LinkClass::Valid,
    ];

    /// Classifies `<inertial>` data (`None` = element missing).
    pub fn of(inertial: Option<&MassProperties>) -> Self {
        match inertial {
            None => LinkClass::Missing,
            Some(mp) if mp.mass == 0.0 => LinkClass::ZeroMass,
            Some(mp) if !mp.validate().is_empty() => LinkClass::Invalid,
            Some(mp) if mp.mass < LIGHT_MASS_KG => LinkClass::Light,
            Some(_) => LinkClass::Valid,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            LinkClass::Missing => "missing",
            LinkClass::ZeroMass => "zero_mass",
            LinkClass::Invalid => "invalid",
            LinkClass::Light => "light",
            LinkClass::Valid => "valid",
        }
    }
}

/// What one URDF file gave.
#[derive(Debug, Clone, serde::Serialize)]
pub struct FileReport {
    pub path: PathBuf,
    /// The one-line error when the file did not load.
    pub error: Option<String>,
    /// One line per oddity the loader accepted (`FILE: ELEMENT: MESSAGE`; docs/urdf.md).
    pub warnings: Vec<String>,
    /// Links per class (empty when the file did not load).
    pub links: BTreeMap<LinkClass, usize>,
    /// Links breaking the triangle inequality (a subset of `invalid`).
    pub triangle_violations: usize,
    /// Links the `auto` policy repaired from geometry.
    pub repaired: usize,
    /// Links with a non-zero mass still invalid under `auto`.
    pub still_invalid: usize,
    /// One line per mesh refused because it is outside the folders meshes are read from
    /// (`FILE: link `L`: ELEMENT: mesh `URI`: WHY`; [`crate::model::confine`]).
    pub refused_meshes: Vec<String>,
}

/// Totals over the files under one root.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct Summary {
    pub root: PathBuf,
    pub files: usize,
    pub loaded: usize,
    pub failed: usize,
    /// Warnings over the loaded files.
    pub warnings: usize,
    /// Loaded files with at least one warning.
    pub files_with_warnings: usize,
    pub links: usize,
    pub by_class: BTreeMap<LinkClass, usize>,
    pub triangle_violations: usize,
    pub repaired: usize,
    pub still_invalid: usize,
}

/// Every `*.urdf` under `root` (or `root` itself when it is a file), sorted.
pub fn urdf_files(root: &Path) -> Vec<PathBuf> {
    if root.is_file() {
        return vec![root.to_path_buf()];
    }
    let mut out = Vec::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for entry in entries.flatten() {
            let path = entry.path();
            if path.is_dir() {
                stack.push(path);
            } else if path
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("urdf"))
            {
                out.push(path);
            }
        }
    }
    out.sort();
    out
}

/// Loads one file (leniently) and classifies its links.
pub fn survey_file(path: &Path, package_paths: &[PathBuf]) -> FileReport {
    survey_file_with(
        path,
        package_paths,
        urdf::Strictness::Lenient,
        &Default::default(),
    )
}

/// [`survey_file`], choosing whether oddities load with warnings or fail the file, and where
/// else meshes may be read from ([`crate::model::confine`]).
pub fn survey_file_with(
    path: &Path,
    package_paths: &[PathBuf],
    strictness: urdf::Strictness,
    access: &crate::model::confine::MeshAccess,
) -> FileReport {
    let options = urdf::LoadOptions {
        package_paths: package_paths.to_vec(),
        strictness,
        mesh_access: access.clone(),
        ..Default::default()
    };
    match urdf::load(path, &options) {
        Ok(model) => classify(path, &model),
        Err(e) => FileReport {
            path: path.to_path_buf(),
            error: Some(e.to_string()),
            warnings: Vec::new(),
            links: BTreeMap::new(),
            triangle_violations: 0,
            repaired: 0,
            still_invalid: 0,
            refused_meshes: Vec::new(),
        },
    }
}

fn classify(path: &Path, model: &Model) -> FileReport {
    let mut links = BTreeMap::new();
    let mut triangle_violations = 0;
    for link in &model.links {
        let class = LinkClass::of(link.inertial.as_ref());
        *links.entry(class).or_insert(0) += 1;
        if class == LinkClass::Invalid
            && link
                .inertial
                .as_ref()
                .is_some_and(|mp| mp.mass > 0.0 && mp.breaks_triangle_inequality())
        {
            triangle_violations += 1;
        }
    }
    let mut auto = model.clone();
    let settings = ModelMassSettings {
        model: MassSettings {
            inertia: Some(InertiaPolicy::Auto),
            ..Default::default()
        },
        ..Default::default()
    };
    let (repaired, still_invalid) = match policy::apply(&mut auto, &settings) {
        Ok(()) => (
            auto.links
                .iter()
                .filter(|l| l.source == InertiaSource::Repaired)
                .count(),
            auto.links
                .iter()
                .filter_map(|l| l.inertial.as_ref())
                .filter(|mp| mp.mass != 0.0 && !mp.validate().is_empty())
                .count(),
        ),
        Err(_) => (0, links.get(&LinkClass::Invalid).copied().unwrap_or(0)),
    };
    FileReport {
        path: path.to_path_buf(),
        error: None,
        warnings: model.warnings.iter().map(ToString::to_string).collect(),
        links,
        triangle_violations,
        repaired,
        still_invalid,
        refused_meshes: model
            .meshes
            .iter()
            .filter(|m| m.refusal().is_some())
            .map(|m| {
                crate::model::confine::MeshRefused {
                    file: path.to_path_buf(),
                    mesh: m.clone(),
                    more: 0,
                }
                .to_string()
            })
            .collect(),
    }
}

/// Sums file reports into one summary for `root`.
pub fn summarize(root: &Path, files: &[FileReport]) -> Summary {
    let mut s = Summary {
        root: root.to_path_buf(),
        files: files.len(),
        ..Default::default()
    };
    for f in files {
        if f.error.is_some() {
            s.failed += 1;
            continue;
        }
        s.loaded += 1;
        s.warnings += f.warnings.len();
        s.files_with_warnings += usize::from(!f.warnings.is_empty());
        for (&class, &n) in &f.links {
            *s.by_class.entry(class).or_insert(0) += n;
            s.links += n;
        }
        s.triangle_violations += f.triangle_violations;
        s.repaired += f.repaired;
        s.still_invalid += f.still_invalid;
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix3, Vector3};

    fn mp(mass: f64, moments: [f64; 3]) -> MassProperties {
        MassProperties::new(
            mass,
            Vector3::zeros(),
            Matrix3::from_diagonal(&Vector3::from(moments)),
        )
    }

    #[test]
    fn classes_follow_the_validation_rules() {
        assert_eq!(LinkClass::of(None), LinkClass::Missing);
        assert_eq!(LinkClass::of(Some(&mp(0.0, [0.0; 3]))), LinkClass::ZeroMass);
        assert_eq!(LinkClass::of(Some(&mp(-1.0, [1.0; 3]))), LinkClass::Invalid);
        // pybullet's placeholder: izz = 0, not positive definite.
        assert_eq!(
            LinkClass::of(Some(&mp(0.1, [1.0, 1.0, 0.0]))),
            LinkClass::Invalid
        );
        // Hairer-Lubich-Wanner moments break the triangle inequality.
        assert_eq!(
            LinkClass::of(Some(&mp(1.0, [2.0, 1.0, 2.0 / 3.0]))),
            LinkClass::Invalid
        );
        assert_eq!(LinkClass::of(Some(&mp(1e-4, [1e-9; 3]))), LinkClass::Light);
        assert_eq!(
            LinkClass::of(Some(&mp(1.0, [1.0, 1.0, 1.5]))),
            LinkClass::Valid
        );
    }
}
