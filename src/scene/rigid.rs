//! `bodies = "rigid"`: the whole model, locked at its joints, as one rigid body; and the checks
//! of the parts every composite mode (rigid, articulated) builds from.

use super::placement;
use crate::model::{MassProperties, Model};
use crate::record::{BodyLayout, FrameLayout};
use crate::sim::BodyInit;
use crate::world::{Attachment, World};
use anyhow::bail;
use nalgebra::{Isometry3, Translation3};
use std::collections::HashSet;

/// Below this fraction of a model's largest principal moment of inertia, a part's principal
/// moment is zero to round-off ([`check_rigid_parts`]).
pub const PART_ROUND_OFF: f64 = 1e-12;

/// The parts of a `bodies = "rigid"` model: each link with an `<inertial>` and a non-zero mass
/// must have finite values, a positive mass and a positive *semi*-definite inertia (a point mass
/// or a rod is a fine part of a composite: real robots have sensor links with mass and zero
/// inertia); the composite itself is then validated in full by [`add_rigid_model`].
///
/// Semi-definiteness is judged to round-off of the model's scale: a principal moment counts as
/// zero when its magnitude is at most [`PART_ROUND_OFF`] times the model's largest principal
/// moment (or 1e-9 times the link's own largest inertia entry). A link written with moments of
/// 1e-35 kg m² (zero to round-off: iCub's `head`, -2.4e-35, 0, 2.4e-35) is a point mass, not a
/// defect. A moment below that is refused, and the message names the opt-in that accepts it
/// (`allow_non_physical_inertia`: the composite is still validated in full).
pub(super) fn check_rigid_parts(
    model: &Model,
    allow_non_physical_inertia: bool,
) -> Result<(), crate::model::urdf::ModelError> {
    let model_scale = model
        .links
        .iter()
        .filter_map(|l| l.inertial.as_ref())
        .filter(|mp| mp.mass != 0.0 && mp.inertia.iter().all(|x| x.is_finite()))
        .map(|mp| mp.principal_moments().amax())
        .fold(0.0, f64::max);
    for link in &model.links {
        let Some(mp) = &link.inertial else { continue };
        if mp.mass == 0.0 {
            continue;
        }
        let finite = mp.mass.is_finite()
            && mp.com.iter().all(|x| x.is_finite())
            && mp.inertia.iter().all(|x| x.is_finite());
        let rule = if !finite {
            Some("mass, centre of mass or inertia not finite".to_string())
        } else if mp.mass < 0.0 {
            Some(format!("mass is negative: {} kg", mp.mass))
        } else {
            let moments = mp.principal_moments();
            let tolerance = (1e-9 * mp.inertia.amax()).max(PART_ROUND_OFF * model_scale);
            // Issue 32: the opt-in alone runs the file only when the body the link is merged
            // into (fixed joints) comes out positive definite, as tiago's antennas do on its
            // base; romeo_laas_small's `body` (-0.021 kg m^2) stays negative and is refused
            // again as a body, so the message names the key that always replaces the values.
            (!allow_non_physical_inertia && moments.min() < -tolerance).then(|| {
                format!(
                    "inertia is not positive semi-definite: principal moments {}, {}, {} kg m^2 \
                     (a moment below -{tolerance:e} kg m^2, {PART_ROUND_OFF:e} of the model's \
                     largest principal moment, is not round-off); to simulate it anyway set \
                     allow_non_physical_inertia = true on its [[model]] (or pass \
                     --allow-non-physical-inertia), which runs it if the body it is part of \
                     comes out positive definite, or take its mass properties from its \
                     geometry: `links = {{ {} = {{ inertia = \"geometry\" }} }}`",
                    moments.x, moments.y, moments.z, link.name
                )
            })
        };
        if let Some(rule) = rule {
            return Err(crate::model::urdf::ModelError::NotSimulable {
                path: model.path.clone(),
                link: link.name.clone(),
                rule,
            });
        }
    }
    Ok(())
}

/// The whole model, locked at the entry's `joints`, as one rigid body (`bodies = "rigid"`).
///
/// The composite, in the model (root link) frame, of the links with positive mass, link `i` with
/// mass `m_i`, centre of mass `com_i` and inertia `I_i` (about `com_i`, link axes), placed by
/// forward kinematics at `model_from_link_i = (R_i, p_i)`:
///
/// ```text
/// m   = Σ m_i
/// c_i = p_i + R_i com_i
/// c   = Σ m_i c_i / m
/// I   = Σ [ R_i I_i R_iᵀ + m_i (|d_i|² E − d_i d_iᵀ) ],   d_i = c_i − c   (about c, model axes)
/// ```
///
/// ([`MassProperties::transformed`] then [`MassProperties::combine`], which sums the offsets
/// from a reference point near the parts.) Its principal frame `model_from_principal = (c, Q)`,
/// `I = Q diag(moments) Qᵀ`, is the body frame:
///
/// ```text
/// world_from_body = world_from_model · model_from_principal
/// body_from_link  = model_from_principal⁻¹ · model_from_link      (every link, massless too)
/// ```
///
/// Recording: every link frame is recorded (frame ids `link`, or `name/link` with a `name`, as
/// in links mode, so recordings of the two modes line up), all riding on the one body. The
/// body is named after the model: the entry's `name`, else the URDF `<robot name>`; its
/// [`BodyLayout`] refers to the root link frame (= the model frame), so `link_from_principal`
/// is `model_from_principal`. The body gets the entry's `linvel` (of the composite centre of
/// mass) and `angvel`.
///
/// Errors (the caller adds the scene file and model index): no link with positive mass; a
/// composite that is not a valid rigid body (e.g. a total mass or inertia overflowing to
/// infinity), naming the model and the broken rules; a link frame whose pose is not finite; a
/// body name already used by an earlier model.
pub(super) fn add_rigid_model(
    world: &mut World,
    model: &Model,
    prefix: Option<&str>,
    label: &str,
    place: &placement::Placement,
    allow_non_physical_inertia: bool,
    body_names: &mut HashSet<String>,
) -> anyhow::Result<()> {
    let label = label.to_string();
    let composite = rigid_composite(model, &label, allow_non_physical_inertia)?;
    if let Some(link) = model
        .links
        .iter()
        .find(|l| !isometry_is_finite(&l.model_from_link))
    {
        bail!(
            "bodies = \"rigid\": model `{label}` ({}): link `{}` has a non-finite pose",
            model.path.display(),
            link.name
        );
    }
    if !body_names.insert(label.clone()) {
        bail!(
            "bodies = \"rigid\": body name {label:?} (the model's) is used by an earlier model; \
             give the model a different `name`"
        );
    }
    let (moments, model_from_principal_rot) = composite.principal();
    let model_from_principal =
        Isometry3::from_parts(Translation3::from(composite.com), model_from_principal_rot);
    let principal_from_model = model_from_principal.inverse();
    let body = world.bodies.len();
    world.bodies.push(BodyInit {
        mass: composite.mass,
        principal_moments: moments,
        world_from_body: place.world_from_model * model_from_principal,
        linvel_world: place.linvel_world,
        angvel_world: place.angvel_world,
    });
    let first_frame = world.layout.frames.len();
    for link in &model.links {
        std::sync::Arc::make_mut(&mut world.attachments).push(Attachment {
            body,
            body_from_link: principal_from_model * link.model_from_link,
        });
        world.layout.frames.push(FrameLayout {
            frame_id: match prefix {
                Some(prefix) => format!("{prefix}/{}", link.name),
                None => link.name.clone(),
            },
            model: label.clone(),
            link: link.name.clone(),
            visuals: link.visuals.clone(),
        });
    }
    world.layout.bodies.push(BodyLayout {
        name: label,
        frame: first_frame + model.root,
        mass: composite.mass,
        link_from_principal: model_from_principal,
        principal_moments: moments,
    });
    Ok(())
}

/// The composite mass properties of `model`'s links with positive mass, in the model frame (see
/// [`add_rigid_model`] for the formulas), checked to be a valid rigid body
/// ([`MassProperties::validate_with`], the triangle rule skipped with `allow_non_physical`).
/// `label` names the model in errors.
fn rigid_composite(
    model: &Model,
    label: &str,
    allow_non_physical: bool,
) -> anyhow::Result<MassProperties> {
    let parts: Vec<MassProperties> = model
        .links
        .iter()
        .filter_map(|l| {
            let mp = l.inertial.as_ref().filter(|mp| mp.mass > 0.0)?;
            Some(mp.transformed(&l.model_from_link))
        })
        .collect();
    if parts.is_empty() {
        bail!(
            "bodies = \"rigid\": model `{label}` ({}) has no link with positive mass: \
             nothing to simulate ({})",
            model.path.display(),
            crate::model::urdf::MASSLESS_REMEDY
        );
    }
    let invalid = |rules: &str| {
        anyhow::anyhow!(
            "bodies = \"rigid\": the composite of model `{label}` ({}) is not a valid rigid \
             body: {rules}",
            model.path.display()
        )
    };
    let Some(composite) = MassProperties::combine(&parts) else {
        let total: f64 = parts.iter().map(|p| p.mass).sum();
        return Err(invalid(&format!(
            "total mass is not a positive finite number ({total} kg)"
        )));
    };
    let rules = composite.validate_with(allow_non_physical);
    if !rules.is_empty() {
        return Err(invalid(&rules.join("; ")));
    }
    Ok(composite)
}

fn isometry_is_finite(p: &Isometry3<f64>) -> bool {
    p.translation.vector.iter().all(|x| x.is_finite())
        && p.rotation.coords.iter().all(|x| x.is_finite())
}
