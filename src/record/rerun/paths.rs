//! Where things go in a Rerun recording: the entity paths (the table in [`super`]), the names
//! of the two timelines and of the energy series, the entities of each frame and body
//! ([`FrameTrack`], [`BodyTrack`]), and the recording's deterministic ids.

use crate::record::RecordingLayout;
use rerun::{EntityPath, EntityPathPart};

/// Name of the duration timeline (integer nanoseconds of simulated time).
pub const SIM_TIME_TIMELINE: &str = "sim_time";
/// Name of the sequence timeline (integrator step index).
pub const STEP_TIMELINE: &str = "step";
/// Series names of the energy plots, in the order of the values.
pub const ENERGY_SERIES: [&str; 3] = ["kinetic", "potential", "total"];

/// Entity of visual `index` of a link: `/<model>/visual_geometries/<link>/<name or visual_<index>>`.
pub fn visual_entity_path(model: &str, link: &str, index: usize, name: Option<&str>) -> EntityPath {
    let leaf = match name {
        Some(name) if !name.is_empty() => name.to_owned(),
        _ => format!("visual_{index}"),
    };
    entity(&[model, "visual_geometries", link, &leaf])
}

/// Entity of a body's inertia ellipsoid: `/<model>/inertia/<link>`.
pub fn inertia_entity_path(model: &str, link: &str) -> EntityPath {
    entity(&[model, "inertia", link])
}

/// Entity holding the `world -> frame_id` transforms of a link: `/<model>/world_from_link/<link>`.
pub fn transform_entity_path(model: &str, link: &str) -> EntityPath {
    entity(&[model, "world_from_link", link])
}

/// Entity of a body's energy plot: `/plots/energy/<body split at '/'>`.
pub fn energy_entity_path(body: &str) -> EntityPath {
    plot_path("energy", body)
}

/// Entity of a body's angular momentum plot: `/plots/angular_momentum/<body split at '/'>`.
pub fn angular_momentum_entity_path(body: &str) -> EntityPath {
    plot_path("angular_momentum", body)
}

/// Entity of the whole scene's energy plot: `/plots/scene/energy`.
pub fn scene_energy_entity_path() -> EntityPath {
    entity(&["plots", "scene", "energy"])
}

/// Entity of the scene's relative energy change `(E − E₀)/|E₀|` (`E₀` the first recorded
/// total; divided by 1 J instead when `E₀ = 0`): `/plots/scene/energy_change`.
pub fn scene_energy_change_entity_path() -> EntityPath {
    entity(&["plots", "scene", "energy_change"])
}

/// Entity of the largest relative angular momentum change over the bodies,
/// `max_i |L_i − L_i0| / |L_i0|` (about each body's centre of mass, world; divided by
/// 1 kg m²/s instead where `L_i0 = 0`): `/plots/scene/angular_momentum_change`.
pub fn scene_angmom_change_entity_path() -> EntityPath {
    entity(&["plots", "scene", "angular_momentum_change"])
}

/// `parts`, then `name` split at `/` (one path part each, empty parts dropped): the entity of a
/// named series such as a joint's (`/plots/joints/position/<joint>`).
pub(super) fn named_path(parts: &[&str], name: &str) -> EntityPath {
    let mut p: Vec<EntityPathPart> = parts.iter().map(|s| EntityPathPart::new(*s)).collect();
    p.extend(
        name.split('/')
            .filter(|s| !s.is_empty())
            .map(EntityPathPart::new),
    );
    EntityPath::new(p)
}

pub(super) fn entity(parts: &[&str]) -> EntityPath {
    EntityPath::new(parts.iter().map(|p| EntityPathPart::new(*p)).collect())
}

fn plot_path(kind: &str, body: &str) -> EntityPath {
    let mut parts = vec![EntityPathPart::new("plots"), EntityPathPart::new(kind)];
    parts.extend(
        body.split('/')
            .filter(|p| !p.is_empty())
            .map(EntityPathPart::new),
    );
    EntityPath::new(parts)
}

/// Application id accepted by Rerun: ASCII letters, digits, `_ - space [ ] :`, at most 180 chars.
pub(super) fn application_id(name: &str) -> String {
    let id: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "_- []:".contains(c) {
                c
            } else {
                '_'
            }
        })
        .take(180)
        .collect();
    if id.trim().is_empty() {
        "tumble".to_owned()
    } else {
        id
    }
}

/// Deterministic recording id: the app id and a 64-bit FNV-1a hash of name and metadata.
pub(super) fn recording_id(layout: &RecordingLayout) -> String {
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |bytes: &[u8]| {
        for &b in bytes.iter().chain(&[0xff]) {
            hash ^= u64::from(b);
            hash = hash.wrapping_mul(0x0100_0000_01b3);
        }
    };
    eat(layout.name.as_bytes());
    for (key, value) in &layout.metadata {
        eat(key.as_bytes());
        eat(value.as_bytes());
    }
    format!("{}-{hash:016x}", application_id(&layout.name))
}

/// The 64-bit seed of the blueprint's UUIDs: an FNV-1a hash of the recording id.
pub(super) fn recording_seed(info: &rerun::external::re_log_types::StoreInfo) -> u64 {
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    for b in info.store_id.recording_id().as_str().bytes() {
        hash ^= u64::from(b);
        hash = hash.wrapping_mul(0x0100_0000_01b3);
    }
    hash
}

/// Per link frame: where its transforms go.
pub(super) struct FrameTrack {
    pub(super) entity: EntityPath,
    pub(super) frame_id: String,
}

/// Per body: where its plots go.
pub(super) struct BodyTrack {
    pub(super) energy: EntityPath,
    pub(super) angular_momentum: EntityPath,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entity_paths_follow_the_urdf_importer_and_document() {
        assert_eq!(
            visual_entity_path("robot", "base_link", 0, Some("shell")).to_string(),
            "/robot/visual_geometries/base_link/shell"
        );
        assert_eq!(
            visual_entity_path("robot", "base_link", 2, None).to_string(),
            "/robot/visual_geometries/base_link/visual_2"
        );
        assert_eq!(
            visual_entity_path("robot", "base_link", 1, Some("")).to_string(),
            "/robot/visual_geometries/base_link/visual_1"
        );
        assert_eq!(
            inertia_entity_path("arm", "link1").to_string(),
            "/arm/inertia/link1"
        );
        assert_eq!(
            transform_entity_path("arm", "link1").to_string(),
            "/arm/world_from_link/link1"
        );
        assert_eq!(
            energy_entity_path("arm/link1").to_string(),
            "/plots/energy/arm/link1"
        );
        assert_eq!(
            angular_momentum_entity_path("box").to_string(),
            "/plots/angular_momentum/box"
        );
        assert_eq!(
            scene_energy_entity_path().to_string(),
            "/plots/scene/energy"
        );
        // A name with a slash stays one part (escaped), as in Rerun's URDF importer.
        let odd = visual_entity_path("my robot", "a/b", 0, None);
        assert_eq!(odd.len(), 4);
        assert_eq!(odd.as_slice()[2].unescaped_str(), "a/b");
    }

    #[test]
    fn ids_are_valid_and_deterministic() {
        assert_eq!(application_id("two.boxes/v1"), "two_boxes_v1");
        assert_eq!(application_id(""), "tumble");
        let mut layout = RecordingLayout {
            name: "scene".into(),
            ..Default::default()
        };
        let a = recording_id(&layout);
        assert_eq!(a, recording_id(&layout.clone()));
        assert!(a.starts_with("scene-"));
        layout.metadata.insert("dt".into(), "0.001".into());
        assert_ne!(a, recording_id(&layout));
    }
}
