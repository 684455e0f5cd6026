//! `[[model.load]]`: a force and a torque on a link of a model of any body mode (issue 30).
//!
//! ```toml
//! [[model.load]]
//! link = "box"                 # a URDF link of the model
//! force = [0.0, 0.0, 5.0]      # N, at the link frame's origin (default [0, 0, 0])
//! torque = [0.0, 0.0, 0.1]     # N m (default [0, 0, 0])
//! frame = "world"              # "world" (default) or "link": the components' axes
//! ```
//!
//! Each component is a signal ([`super::signal`]): a number, a sine, or a CSV table whose
//! column is named after the component: `force_x`, `force_y`, `force_z`, `torque_x`,
//! `torque_y`, `torque_z` (with `time`). A recorded log is for actuators only.
//!
//! The load acts on the body the link rides on: its own body (`bodies = "links"`, where a link
//! without mass is no body and is refused), the model's one body (`rigid`), or its group's body
//! (`articulated`, where a link welded to the world by `base = "fixed"` or inside a compound
//! joint is refused: nothing moves it). The link frame's pose in that body
//! ([`crate::world::Attachment`]) gives the point and the axes; every copy of the model gets
//! its own load.

use super::signal;
use super::{BodiesMode, ModelEntry};
use crate::model::Model;
use crate::sim::loads::{BodyLoad, LoadFrame};
use crate::sim::signal::Signal;
use crate::world::{Attachment, World};
use anyhow::bail;
use std::ops::Range;
use std::path::Path;

/// The CSV columns of the components, in order.
const FORCE_COLUMNS: [&str; 3] = ["force_x", "force_y", "force_z"];
const TORQUE_COLUMNS: [&str; 3] = ["torque_x", "torque_y", "torque_z"];

/// One `[[model.load]]` table, checked, its signals not read yet.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct LoadSpec {
    /// Its index among the model's load tables (errors say `load[index]`).
    pub index: usize,
    pub link: String,
    force: [toml::Value; 3],
    torque: [toml::Value; 3],
    frame: LoadFrame,
}

/// A load with its signals read, on the link `link` (index into `Model::links`).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct LinkLoad {
    pub index: usize,
    pub link: String,
    pub force: [Signal; 3],
    pub torque: [Signal; 3],
    pub frame: LoadFrame,
}

/// The load tables of `entry`, checked; `key` names the model (`scene.toml: model[0]`).
pub(crate) fn read_all(key: &str, entry: &ModelEntry) -> anyhow::Result<Vec<LoadSpec>> {
    entry
        .loads
        .iter()
        .enumerate()
        .map(|(k, table)| read(&format!("{key}: load[{k}]"), k, table))
        .collect()
}

fn read(key: &str, index: usize, table: &toml::Table) -> anyhow::Result<LoadSpec> {
    const KEYS: [&str; 4] = ["link", "force", "torque", "frame"];
    if let Some(other) = table.keys().find(|k| !KEYS.contains(&k.as_str())) {
        bail!(
            "{key}.{other}: unknown key (a load takes: {})",
            KEYS.join(", ")
        );
    }
    let link = match table.get("link") {
        Some(toml::Value::String(s)) => s.clone(),
        Some(v) => bail!("{key}.link: expected a link name (got {v})"),
        None => bail!("{key}.link: missing (the URDF link the load acts on)"),
    };
    let frame = match table.get("frame") {
        None => LoadFrame::World,
        Some(toml::Value::String(s)) if s == "world" => LoadFrame::World,
        Some(toml::Value::String(s)) if s == "link" => LoadFrame::Link,
        Some(v) => bail!("{key}.frame: expected \"world\" or \"link\" (got {v})"),
    };
    if !table.contains_key("force") && !table.contains_key("torque") {
        bail!("{key}: a load needs a force, a torque or both");
    }
    let vector = |name: &str| -> anyhow::Result<[toml::Value; 3]> {
        let Some(value) = table.get(name) else {
            return Ok([0, 1, 2].map(|_| toml::Value::Float(0.0)));
        };
        let toml::Value::Array(items) = value else {
            bail!(
                "{key}.{name}: expected 3 components [x, y, z], each a number or a signal \
                 (got {value})"
            );
        };
        let Ok(three) = <[toml::Value; 3]>::try_from(items.clone()) else {
            bail!(
                "{key}.{name}: expected 3 components [x, y, z] (got {})",
                items.len()
            );
        };
        Ok(three)
    };
    Ok(LoadSpec {
        index,
        link,
        force: vector("force")?,
        torque: vector("torque")?,
        frame,
    })
}

/// The loads of `entry` with their signals read (relative paths against `base_dir`), each
/// link checked against `model` (`label` its name in messages).
pub(crate) fn resolve_all(
    key: &str,
    entry: &ModelEntry,
    model: &Model,
    label: &str,
    base_dir: &Path,
) -> anyhow::Result<Vec<LinkLoad>> {
    let mut out = Vec::new();
    for spec in read_all(key, entry)? {
        let at = format!("{key}: load[{}]", spec.index);
        if !model.links.iter().any(|l| l.name == spec.link) {
            let names: Vec<&str> = model
                .links
                .iter()
                .map(|l| l.name.as_str())
                .take(40)
                .collect();
            bail!(
                "{at}.link: no link `{}` in model `{label}` ({}; its links: {}){}",
                spec.link,
                entry.urdf.display(),
                names.join(", "),
                crate::message::did_you_mean(
                    &spec.link,
                    model.links.iter().map(|l| l.name.as_str())
                )
            );
        }
        let read = |name: &str, values: &[toml::Value; 3], columns: [&str; 3]| {
            let mut signals = [0, 1, 2].map(|_| Signal::Constant(0.0));
            for (c, (value, column)) in values.iter().zip(columns).enumerate() {
                signals[c] =
                    signal::parse(&format!("{at}.{name}[{c}]"), value, base_dir, column, None)?;
            }
            anyhow::Ok(signals)
        };
        out.push(LinkLoad {
            index: spec.index,
            force: read("force", &spec.force, FORCE_COLUMNS)?,
            torque: read("torque", &spec.torque, TORQUE_COLUMNS)?,
            link: spec.link,
            frame: spec.frame,
        });
    }
    Ok(out)
}

/// Adds `loads` to the world for the copy whose link frames are `frames` of
/// `world.layout.frames`: each on the body its link rides on (see the module doc). Errors
/// (the caller adds the scene file and model) name the load and the link.
pub(crate) fn attach(
    world: &mut World,
    frames: Range<usize>,
    loads: &[LinkLoad],
    entry: &ModelEntry,
    label: &str,
) -> anyhow::Result<()> {
    for load in loads {
        let at = format!("load[{}].link", load.index);
        let found = frames
            .clone()
            .find(|&f| world.layout.frames[f].link == load.link);
        let Some(frame) = found else {
            // Every link of a rigid or articulated model is recorded: only a link without mass
            // in links mode has no frame.
            let why = match entry.bodies {
                BodiesMode::Links => "has no mass: with bodies = \"links\" it is no body",
                _ => "is not recorded",
            };
            bail!(
                "{at}: link `{}` of model `{label}` {why} (nothing for the load to act on)",
                load.link
            );
        };
        let attachment: Attachment = world.attachments[frame];
        if attachment.body == Attachment::WORLD {
            let why = if world.interior_frames.iter().any(|i| i.frame == frame) {
                "is a massless link inside a compound joint: no body carries it"
            } else {
                "is welded to the world (base = \"fixed\"): it does not move"
            };
            bail!(
                "{at}: link `{}` of model `{label}` {why} (nothing for the load to act on)",
                load.link
            );
        }
        world.body_loads.push(BodyLoad {
            body: attachment.body,
            point_body: attachment.body_from_link.translation.vector,
            body_from_link: attachment.body_from_link.rotation,
            force: load.force.clone(),
            torque: load.torque.clone(),
            frame: load.frame,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entry(tables: &[&str]) -> ModelEntry {
        let mut e = ModelEntry::at("m.urdf".into(), [0.0; 3]);
        e.loads = tables.iter().map(|t| toml::from_str(t).unwrap()).collect();
        e
    }

    #[test]
    fn loads_are_read_with_their_defaults() {
        let specs = read_all(
            "k",
            &entry(&[
                "link = \"a\"\nforce = [1, 2.5, { sine = { amplitude = 1, frequency_hz = 2 } }]",
                "link = \"b\"\ntorque = [0, 0, 1]\nframe = \"link\"",
            ]),
        )
        .unwrap();
        assert_eq!(specs[0].frame, LoadFrame::World);
        assert_eq!(specs[0].force[1], toml::Value::Float(2.5));
        assert_eq!(specs[0].torque, [0, 1, 2].map(|_| toml::Value::Float(0.0)));
        assert_eq!((specs[1].index, specs[1].frame), (1, LoadFrame::Link));
    }

    /// Each mistake is one message naming the load's key.
    #[test]
    fn bad_tables_name_the_key() {
        for (text, needle) in [
            ("force = [0, 0, 1]", "k: load[0].link: missing"),
            (
                "link = \"a\"",
                "load[0]: a load needs a force, a torque or both",
            ),
            (
                "link = \"a\"\nforce = [0, 1]",
                "load[0].force: expected 3 components [x, y, z] (got 2)",
            ),
            (
                "link = \"a\"\ntorque = 3",
                "load[0].torque: expected 3 components",
            ),
            (
                "link = \"a\"\nforce = [0, 0, 1]\nframe = \"body\"",
                "load[0].frame: expected \"world\" or \"link\"",
            ),
            (
                "link = \"a\"\nforce = [0, 0, 1]\npoint = [0, 0, 0]",
                "load[0].point: unknown key",
            ),
        ] {
            let e = read_all("k", &entry(&[text])).unwrap_err().to_string();
            assert!(e.contains(needle), "{text}: {e}");
        }
    }
}
