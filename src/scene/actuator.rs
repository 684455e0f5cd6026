//! `[[model.actuator]]`: one actuator on a joint of a `bodies = "articulated"` model (issue 30).
//!
//! ```toml
//! [[model.actuator]]
//! joint = "elbow"
//! kind = "motor"          # effort = u(t): the joint torque (N m) or force (N)
//! effort = 0.5            # a signal (crate::scene::signal)
//!
//! [[model.actuator]]
//! joint = "shoulder"
//! kind = "position"       # PD servo: effort = kp (r(t) - q) - kd qdot
//! target = { sine = { amplitude = 0.5, frequency_hz = 0.5 } }
//! kp = 80.0               # N m/rad (N/m), required, >= 0
//! kd = 4.0                # N m s/rad (N s/m), >= 0 (default 0)
//!
//! [[model.actuator]]
//! joint = "wrist"
//! kind = "velocity"       # effort = kd (w(t) - qdot)
//! target = 1.0
//! kd = 2.0                # required, >= 0
//! effort_limit = 3.0      # |effort| <= 3 (default: the URDF's <limit effort> when positive; 0: none)
//! ```
//!
//! Read in two steps: [`read_all`] checks the tables' keys and values when the scene is parsed
//! (nothing but the scene needed); [`resolve_all`] checks the joints against the URDF and reads
//! the signals (tables, logs) once per `[[model]]` when its model is loaded. Which joints move
//! (not locked, not inside a compound joint) is known only when the mechanism is built
//! ([`super::drives`]).

use super::joint_states::Quantity;
use super::signal;
use super::signal_log::Pick;
use super::{BodiesMode, ModelEntry};
use crate::model::Model;
use crate::model::kinematics::JointKind;
use crate::sim::mechanism::{Actuator, ActuatorKind};
use anyhow::bail;
use std::path::Path;

/// An actuator's law as written, signals not read yet.
#[derive(Debug, Clone, PartialEq)]
enum Law {
    Motor {
        effort: toml::Value,
    },
    Position {
        target: toml::Value,
        kp: f64,
        kd: f64,
    },
    Velocity {
        target: toml::Value,
        kd: f64,
    },
}

/// One `[[model.actuator]]` table, checked.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ActuatorSpec {
    /// Its index among the model's actuator tables (errors say `actuator[index]`).
    pub index: usize,
    pub joint: String,
    law: Law,
    /// `effort_limit` as written: `None` takes the URDF's, `Some(0)` means none.
    effort_limit: Option<f64>,
}

/// An actuator with its signals read, for the joint `joint`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ResolvedActuator {
    pub index: usize,
    pub joint: String,
    pub actuator: Actuator,
}

const KINDS: &str = "\"motor\", \"position\" or \"velocity\"";

/// The actuator tables of `entry`, checked; `key` names the model (`scene.toml: model[0]`).
/// Refused: actuators on a model that is not articulated, two on one joint, and every bad
/// key or value of a table ([`read`]).
pub(crate) fn read_all(key: &str, entry: &ModelEntry) -> anyhow::Result<Vec<ActuatorSpec>> {
    if !entry.actuators.is_empty() && entry.bodies != BodiesMode::Articulated {
        let mode = match entry.bodies {
            BodiesMode::Links => "links",
            _ => "rigid",
        };
        bail!(
            "{key}: actuator[0]: actuators drive the joints of bodies = \"articulated\" models \
             only (this model has bodies = \"{mode}\", whose joints do not move)"
        );
    }
    let mut specs: Vec<ActuatorSpec> = Vec::with_capacity(entry.actuators.len());
    for (k, table) in entry.actuators.iter().enumerate() {
        let spec = read(&format!("{key}: actuator[{k}]"), k, table)?;
        if let Some(first) = specs.iter().find(|s| s.joint == spec.joint) {
            bail!(
                "{key}: actuator[{k}].joint: joint `{}` already has an actuator (actuator[{}]); \
                 one actuator per joint",
                spec.joint,
                first.index
            );
        }
        specs.push(spec);
    }
    Ok(specs)
}

/// A finite number `>= 0` (kp, kd, effort_limit).
fn gain(key: &str, value: &toml::Value) -> anyhow::Result<f64> {
    let x = match value {
        toml::Value::Float(x) => *x,
        toml::Value::Integer(i) => *i as f64,
        _ => bail!("{key}: expected a number (got {value})"),
    };
    if !(x.is_finite() && x >= 0.0) {
        bail!("{key}: must be a finite number >= 0 (got {x})");
    }
    Ok(x)
}

/// One table; `key` is `scene.toml: model[0]: actuator[k]`.
fn read(key: &str, index: usize, table: &toml::Table) -> anyhow::Result<ActuatorSpec> {
    let text = |name: &str| -> anyhow::Result<&str> {
        match table.get(name) {
            Some(toml::Value::String(s)) => Ok(s),
            Some(v) => bail!("{key}.{name}: expected a string (got {v})"),
            None => bail!("{key}.{name}: missing"),
        }
    };
    let joint = text("joint")?.to_string();
    let kind = text("kind")?;
    // The keys each kind takes, besides joint, kind and effort_limit.
    let own: &[&str] = match kind {
        "motor" => &["effort"],
        "position" => &["target", "kp", "kd"],
        "velocity" => &["target", "kd"],
        other => bail!("{key}.kind: unknown kind {other:?} (expected {KINDS})"),
    };
    for name in table.keys() {
        if ["joint", "kind", "effort_limit"].contains(&name.as_str()) || own.contains(&&**name) {
            continue;
        }
        let known = ["effort", "target", "kp", "kd"].contains(&name.as_str());
        if known {
            bail!(
                "{key}.{name}: a {kind} actuator takes no `{name}` (it takes: {})",
                own.join(", ")
            );
        }
        bail!(
            "{key}.{name}: unknown key (an actuator takes: joint, kind, effort, target, kp, kd, \
             effort_limit)"
        );
    }
    let signal = |name: &str| -> anyhow::Result<toml::Value> {
        match table.get(name) {
            Some(v) => Ok(v.clone()),
            None => bail!("{key}.{name}: missing (a {kind} actuator needs it)"),
        }
    };
    let gain_of = |name: &str, default: Option<f64>| -> anyhow::Result<f64> {
        match (table.get(name), default) {
            (Some(v), _) => gain(&format!("{key}.{name}"), v),
            (None, Some(d)) => Ok(d),
            (None, None) => bail!("{key}.{name}: missing (a {kind} actuator needs it)"),
        }
    };
    let law = match kind {
        "motor" => Law::Motor {
            effort: signal("effort")?,
        },
        "position" => Law::Position {
            target: signal("target")?,
            kp: gain_of("kp", None)?,
            kd: gain_of("kd", Some(0.0))?,
        },
        _ => Law::Velocity {
            target: signal("target")?,
            kd: gain_of("kd", None)?,
        },
    };
    let effort_limit = table
        .get("effort_limit")
        .map(|v| gain(&format!("{key}.effort_limit"), v))
        .transpose()?;
    Ok(ActuatorSpec {
        index,
        joint,
        law,
        effort_limit,
    })
}

/// The actuators of `entry` ready for its mechanism: each joint checked against `model` (it
/// exists, is not fixed, is no mimic follower), each signal read (relative paths against
/// `base_dir`), each effort limit chosen ([`effort_limit`]). `key` names the model, `label` is
/// its name in messages.
pub(crate) fn resolve_all(
    key: &str,
    entry: &ModelEntry,
    model: &Model,
    label: &str,
    base_dir: &Path,
) -> anyhow::Result<Vec<ResolvedActuator>> {
    let mut out = Vec::new();
    for spec in read_all(key, entry)? {
        let k = spec.index;
        let at = format!("{key}: actuator[{k}]");
        let Some(joint) = model.joints.iter().find(|j| j.name == spec.joint) else {
            let names: Vec<&str> = model
                .joints
                .iter()
                .map(|j| j.name.as_str())
                .take(40)
                .collect();
            bail!(
                "{at}.joint: no joint `{}` in model `{label}` ({}; its joints: {}){}",
                spec.joint,
                entry.urdf.display(),
                if names.is_empty() {
                    "none".to_string()
                } else {
                    names.join(", ")
                },
                crate::message::did_you_mean(
                    &spec.joint,
                    model.joints.iter().map(|j| j.name.as_str())
                )
            );
        };
        if joint.kind == JointKind::Fixed {
            bail!(
                "{at}.joint: joint `{}` of model `{label}` is fixed: it does not move",
                joint.name
            );
        }
        if let Some(m) = &joint.mimic {
            bail!(
                "{at}.joint: joint `{}` of model `{label}` mimics `{}`: its motion follows that \
                 joint's (drive `{}` instead)",
                joint.name,
                m.joint,
                m.joint
            );
        }
        let read = |name: &str, value: &toml::Value, quantity: Quantity| {
            signal::parse(
                &format!("{at}.{name}"),
                value,
                base_dir,
                &spec.joint,
                Some(Pick {
                    joint: &spec.joint,
                    quantity,
                }),
            )
        };
        let kind = match &spec.law {
            Law::Motor { effort } => ActuatorKind::Motor {
                effort: read("effort", effort, Quantity::Effort)?,
            },
            Law::Position { target, kp, kd } => ActuatorKind::Position {
                target: read("target", target, Quantity::Position)?,
                kp: *kp,
                kd: *kd,
            },
            Law::Velocity { target, kd } => ActuatorKind::Velocity {
                target: read("target", target, Quantity::Velocity)?,
                kd: *kd,
            },
        };
        let effort_limit = effort_limit(&at, spec.effort_limit, joint, label)?;
        out.push(ResolvedActuator {
            index: k,
            joint: spec.joint,
            actuator: Actuator { kind, effort_limit },
        });
    }
    Ok(out)
}

/// The clamp of an actuator: `effort_limit` when given (`0`: none), else the URDF's `<limit
/// effort>` when positive and finite (`0`, absent or `inf`: none). A negative or NaN URDF
/// effort is refused unless `effort_limit` overrides it.
fn effort_limit(
    at: &str,
    given: Option<f64>,
    joint: &crate::model::kinematics::Joint,
    label: &str,
) -> anyhow::Result<Option<f64>> {
    if let Some(limit) = given {
        return Ok((limit > 0.0).then_some(limit));
    }
    let urdf = joint.effort_limit;
    if urdf.is_nan() || urdf < 0.0 {
        bail!(
            "{at}: joint `{}` of model `{label}` has <limit effort=\"{urdf}\">, which is no \
             limit (it must be >= 0); give the actuator an effort_limit (0: none)",
            joint.name
        );
    }
    Ok((urdf > 0.0 && urdf.is_finite()).then_some(urdf))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(text: &str) -> toml::Table {
        toml::from_str(text).unwrap()
    }

    fn entry(tables: &[&str]) -> ModelEntry {
        let mut e = ModelEntry::at("m.urdf".into(), [0.0; 3]);
        e.bodies = BodiesMode::Articulated;
        e.actuators = tables.iter().map(|t| table(t)).collect();
        e
    }

    #[test]
    fn the_three_kinds_are_read_with_their_defaults() {
        let specs = read_all(
            "k",
            &entry(&[
                "joint = \"a\"\nkind = \"motor\"\neffort = 0.5",
                "joint = \"b\"\nkind = \"position\"\ntarget = 1\nkp = 80",
                "joint = \"c\"\nkind = \"velocity\"\ntarget = 1\nkd = 2\neffort_limit = 0",
            ]),
        )
        .unwrap();
        assert_eq!(
            specs[0].law,
            Law::Motor {
                effort: toml::Value::Float(0.5)
            }
        );
        assert_eq!(
            specs[1].law,
            Law::Position {
                target: toml::Value::Integer(1),
                kp: 80.0,
                kd: 0.0
            }
        );
        assert_eq!(specs[1].effort_limit, None);
        assert_eq!(specs[2].effort_limit, Some(0.0));
        assert_eq!(specs[2].index, 2);
    }

    /// Each mistake is one message naming the actuator's key.
    #[test]
    fn bad_tables_name_the_key() {
        for (text, needle) in [
            (
                "kind = \"motor\"\neffort = 1",
                "k: actuator[0].joint: missing",
            ),
            (
                "joint = 3\nkind = \"motor\"",
                "actuator[0].joint: expected a string",
            ),
            (
                "joint = \"a\"\nkind = \"torque\"",
                "actuator[0].kind: unknown kind \"torque\"",
            ),
            (
                "joint = \"a\"\nkind = \"motor\"",
                "actuator[0].effort: missing",
            ),
            (
                "joint = \"a\"\nkind = \"position\"\ntarget = 1",
                "actuator[0].kp: missing",
            ),
            (
                "joint = \"a\"\nkind = \"velocity\"\ntarget = 1",
                "actuator[0].kd: missing",
            ),
            (
                "joint = \"a\"\nkind = \"position\"\ntarget = 1\nkp = -1",
                "actuator[0].kp: must be a finite number >= 0 (got -1)",
            ),
            (
                "joint = \"a\"\nkind = \"position\"\ntarget = 1\nkp = 1\nkd = nan",
                "actuator[0].kd: must be a finite number >= 0",
            ),
            (
                "joint = \"a\"\nkind = \"velocity\"\ntarget = 1\nkd = 1\nkp = 3",
                "actuator[0].kp: a velocity actuator takes no `kp`",
            ),
            (
                "joint = \"a\"\nkind = \"motor\"\neffort = 1\ntarget = 3",
                "actuator[0].target: a motor actuator takes no `target`",
            ),
            (
                "joint = \"a\"\nkind = \"motor\"\neffort = 1\ngain = 3",
                "actuator[0].gain: unknown key",
            ),
            (
                "joint = \"a\"\nkind = \"motor\"\neffort = 1\neffort_limit = -2",
                "actuator[0].effort_limit: must be a finite number >= 0",
            ),
        ] {
            let e = read_all("k", &entry(&[text])).unwrap_err().to_string();
            assert!(e.contains(needle), "{text}: {e}");
        }
        let two = entry(&[
            "joint = \"a\"\nkind = \"motor\"\neffort = 1",
            "joint = \"a\"\nkind = \"motor\"\neffort = 2",
        ]);
        let e = read_all("k", &two).unwrap_err().to_string();
        assert!(
            e.contains("actuator[1].joint: joint `a` already has an actuator (actuator[0])"),
            "{e}"
        );
        let mut links = entry(&["joint = \"a\"\nkind = \"motor\"\neffort = 1"]);
        links.bodies = BodiesMode::Rigid;
        let e = read_all("k", &links).unwrap_err().to_string();
        assert!(e.contains("bodies = \"rigid\""), "{e}");
    }

    fn joint(effort_limit: f64) -> crate::model::kinematics::Joint {
        crate::model::kinematics::Joint {
            name: "j".into(),
            kind: JointKind::Revolute,
            parent: 0,
            child: 1,
            parent_from_joint: nalgebra::Isometry3::identity(),
            axis: nalgebra::Vector3::z(),
            mimic: None,
            limits: None,
            damping: 0.0,
            friction: 0.0,
            effort_limit,
            velocity_limit: 0.0,
        }
    }

    /// The URDF's effort when positive and finite, the override first, `0` none.
    #[test]
    fn the_effort_limit_comes_from_the_urdf_unless_overridden() {
        assert_eq!(
            effort_limit("k", None, &joint(12.0), "m").unwrap(),
            Some(12.0)
        );
        assert_eq!(effort_limit("k", None, &joint(0.0), "m").unwrap(), None);
        assert_eq!(
            effort_limit("k", None, &joint(f64::INFINITY), "m").unwrap(),
            None
        );
        assert_eq!(
            effort_limit("k", Some(3.0), &joint(12.0), "m").unwrap(),
            Some(3.0)
        );
        assert_eq!(
            effort_limit("k", Some(0.0), &joint(12.0), "m").unwrap(),
            None
        );
        assert_eq!(
            effort_limit("k", Some(2.0), &joint(-1.0), "m").unwrap(),
            Some(2.0)
        );
        let e = effort_limit("k", None, &joint(-1.0), "m").unwrap_err();
        assert!(e.to_string().contains("<limit effort=\"-1\">"), "{e}");
        assert!(effort_limit("k", None, &joint(f64::NAN), "m").is_err());
    }
}
