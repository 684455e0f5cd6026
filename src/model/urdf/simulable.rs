//! What is asked of a loaded [`Model`]: a link by name, whether any link has a problem,
//! whether the model can be simulated ([`Model::check_simulable`]), and its total mass
//! properties.

use super::ModelError;
use super::links::{NON_FINITE_POSE, pose_is_finite};
use crate::model::{Link, MassProperties, Model};

impl Model {
    /// The model with its links placed at `joint_positions` instead of the configuration it was
    /// loaded at (joints not named at 0): each `model_from_link` by forward kinematics
    /// ([`crate::model::kinematics::forward_kinematics`], the same as loading with
    /// `joint_positions`); everything else (mass properties, geometry) is the same. A dataset
    /// run's drawn joints place a model loaded once.
    pub fn at_joint_positions(
        &self,
        joint_positions: &std::collections::HashMap<String, f64>,
    ) -> Result<Model, crate::model::kinematics::KinematicsError> {
        let names: Vec<String> = self.links.iter().map(|l| l.name.clone()).collect();
        let poses =
            crate::model::kinematics::forward_kinematics(&names, &self.joints, joint_positions)?;
        let mut model = self.clone();
        for (link, pose) in model.links.iter_mut().zip(poses) {
            link.model_from_link = pose;
        }
        Ok(model)
    }

    /// Index of the link named `name`.
    pub fn link_index(&self, name: &str) -> Option<usize> {
        self.links.iter().position(|l| l.name == name)
    }

    /// Whether any link has a problem (validation finding, unresolved mesh, bad visual).
    pub fn has_problems(&self) -> bool {
        self.links.iter().any(|l| !l.problems.is_empty())
    }

    /// Errors, naming the file, link and rule, when a link that should become a body cannot:
    /// a link with an `<inertial>` and a mass other than 0 whose mass properties break a rule of
    /// [`MassProperties::validate`] (negative or NaN mass, non-finite values, not positive
    /// definite, triangle inequality) or whose pose is not finite; or when no link has a
    /// positive mass at all. Links without `<inertial>` or with mass exactly 0 are frames, not
    /// bodies, and are skipped. Visual problems (unresolved meshes) do not block simulation.
    /// `allow_non_physical_inertia` waives the triangle-inequality rule only (the user's opt-in,
    /// `allow_non_physical_inertia = true` on a scene's `[[model]]`); when that rule is what
    /// fails, the error says how to opt in.
    pub fn check_simulable(&self, allow_non_physical_inertia: bool) -> Result<(), ModelError> {
        for link in &self.links {
            let Some(mp) = &link.inertial else { continue };
            if mp.mass == 0.0 {
                continue;
            }
            let mut rules = mp.validate_with(allow_non_physical_inertia);
            if !allow_non_physical_inertia && rules.len() == 1 && mp.breaks_triangle_inequality() {
                rules[0].push_str(
                    "; to simulate it anyway set allow_non_physical_inertia = true on its [[model]] \
                     (or pass --allow-non-physical-inertia)",
                );
            }
            if !pose_is_finite(&link.model_from_link) {
                rules.push(NON_FINITE_POSE.to_string());
            }
            if !rules.is_empty() {
                return Err(ModelError::NotSimulable {
                    path: self.path.clone(),
                    link: link.name.clone(),
                    rule: rules.join("; "),
                });
            }
        }
        if !self.links.iter().any(Link::has_mass) {
            return Err(ModelError::NothingToSimulate {
                path: self.path.clone(),
            });
        }
        Ok(())
    }

    /// The whole model as one rigid body in the model (root link) frame: the sum of the links
    /// with a positive mass ([`Link::has_mass`]), each moved by its `model_from_link`. Inertia
    /// about the total centre of mass, model axes. `None` when no link has mass.
    pub fn total_mass_properties(&self) -> Option<MassProperties> {
        let parts: Vec<MassProperties> = self
            .links
            .iter()
            .filter(|l| l.has_mass())
            .filter_map(|l| Some(l.inertial?.transformed(&l.model_from_link)))
            .collect();
        MassProperties::combine(&parts)
    }
}
