//! `bodies = "links"`: one free body per link with positive mass.

use super::placement;
use crate::model::Model;
use crate::record::{BodyLayout, FrameLayout};
use crate::sim::BodyInit;
use crate::world::{Attachment, World};
use nalgebra::{Isometry3, Translation3};

/// One free body per link with positive mass, the model placed at `place`; frame ids
/// `<prefix>/<link>` (or `<link>`), the model labelled `label`.
pub(super) fn add_links_model(
    world: &mut World,
    model: &Model,
    prefix: Option<&str>,
    label: &str,
    place: &placement::Placement,
) {
    let world_from_model = place.world_from_model;
    let model_label = label.to_string();
    for link in &model.links {
        let Some(mp) = link.inertial.as_ref().filter(|mp| mp.mass > 0.0) else {
            continue;
        };
        let (moments, link_from_principal_rot) = mp.principal();
        let link_from_principal =
            Isometry3::from_parts(Translation3::from(mp.com), link_from_principal_rot);
        // `world_from_model · (model_from_link · link_from_principal)`: the body's pose in the
        // model frame, then the copy's placement, as the rigid and articulated modes compose
        // it (and as a dataset run placed a model built at the origin).
        let world_from_body = world_from_model * (link.model_from_link * link_from_principal);
        let frame_id = match prefix {
            Some(prefix) => format!("{prefix}/{}", link.name),
            None => link.name.clone(),
        };
        let body = world.bodies.len();
        let frame = world.layout.frames.len();
        world.bodies.push(BodyInit {
            mass: mp.mass,
            principal_moments: moments,
            world_from_body,
            linvel_world: place.linvel_world,
            angvel_world: place.angvel_world,
        });
        std::sync::Arc::make_mut(&mut world.attachments).push(Attachment {
            body,
            body_from_link: link_from_principal.inverse(),
        });
        world.layout.frames.push(FrameLayout {
            frame_id: frame_id.clone(),
            model: model_label.clone(),
            link: link.name.clone(),
            visuals: link.visuals.clone(),
        });
        world.layout.bodies.push(BodyLayout {
            name: frame_id,
            frame,
            mass: mp.mass,
            link_from_principal,
            principal_moments: moments,
        });
    }
}
