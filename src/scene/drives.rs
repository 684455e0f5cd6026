//! What drives an articulated model's joint coordinates ([`JointDrive`]): its actuators
//! ([`super::actuator`]) and the URDF's `<dynamics damping>`.
//!
//! - Damping `b` acts on every moving joint (a coordinate of the mechanism) whose URDF gives
//!   `b > 0`, mimic followers included (the mimic row carries the follower's damping to its
//!   leader), unless the model says `joint_damping = false`. It must be a finite number
//!   `>= 0`. Fixed and locked joints do not move: their damping does nothing and is left out.
//!   A stage of a compound joint (two or three revolutes through a massless link) is a
//!   coordinate like any other: its damping and actuator act on its angle.
//! - An actuator needs a moving joint: one locked (`locked_joints`, or because no mass hangs
//!   from it) is refused, naming the reason.
//!
//! One drive per coordinate, sorted by coordinate, as `MechanismModel::validate` requires.
//!
//! The joints' limits and friction ([`stops`]) are built here too: `<limit lower upper>` and
//! `<dynamics friction>`, unless `joint_limits = false` / `joint_friction = false`.

use super::ModelEntry;
use super::actuator::ResolvedActuator;
use crate::model::Model;
use crate::sim::mechanism::rows::MAX_ROWS;
use crate::sim::mechanism::{Coordinate, CoordinateKind, JointDrive, JointStop, MechanismModel};
use anyhow::bail;
use std::collections::{BTreeMap, BTreeSet};

/// Why a joint an actuator names is not among the mechanism's coordinates.
pub(super) struct Merged<'a> {
    /// `locked_joints`.
    pub locked: &'a BTreeSet<String>,
    /// Joints locked because no mass hangs from them.
    pub massless: &'a [String],
}

/// The drives of a mechanism over `coordinates` (see the module doc); `label` names the model
/// in messages. Errors name the actuator's key or `joint_damping`.
pub(super) fn drives(
    model: &Model,
    entry: &ModelEntry,
    label: &str,
    coordinates: &[Coordinate],
    actuators: &[ResolvedActuator],
    merged: &Merged<'_>,
) -> anyhow::Result<Vec<JointDrive>> {
    let coordinate_of = |name: &str| coordinates.iter().position(|c| c.name == name);
    let mut drives: BTreeMap<usize, JointDrive> = BTreeMap::new();
    if entry.joint_damping != Some(false) {
        for (k, c) in coordinates.iter().enumerate() {
            let Some(joint) = model.joints.iter().find(|j| j.name == c.name) else {
                continue;
            };
            let b = joint.damping;
            if b == 0.0 {
                continue;
            }
            if !(b.is_finite() && b > 0.0) {
                bail!(
                    "joint_damping: joint `{}` of model `{label}` has <dynamics damping=\"{b}\"> \
                     ({}): damping must be a finite number >= 0 (or set joint_damping = false \
                     to leave the URDF's damping out)",
                    c.name,
                    entry.urdf.display()
                );
            }
            drives.insert(
                k,
                JointDrive {
                    coordinate: k,
                    actuator: None,
                    damping: b,
                },
            );
        }
    }
    for a in actuators {
        let at = format!("actuator[{}].joint", a.index);
        let Some(k) = coordinate_of(&a.joint) else {
            let why = if merged.locked.contains(&a.joint) {
                "locked (locked_joints)"
            } else if merged.massless.contains(&a.joint) {
                "locked (no mass hangs from it)"
            } else {
                "merged into a body (it does not move)"
            };
            bail!(
                "{at}: joint `{}` of model `{label}` is {why}: nothing for the actuator to drive",
                a.joint
            );
        };
        drives
            .entry(k)
            .or_insert(JointDrive {
                coordinate: k,
                actuator: None,
                damping: 0.0,
            })
            .actuator = Some(a.actuator.clone());
    }
    Ok(drives.into_values().collect())
}

/// The limits and friction of a mechanism's coordinates ([`JointStop`]): the URDF's
/// `<limit lower upper>` of a revolute or prismatic joint (unless `joint_limits = false`) and its
/// `<dynamics friction>` (unless `joint_friction = false`; a finite number `>= 0`, else an error
/// naming the joint, the file and the key). A mimic follower takes none (its leader's stop moves
/// it; a second row on the pair would make the step singular). A stop that finds no room left
/// in its joint's block (a compound joint whose stages are driven) is left out with a note in
/// `notes`. Sorted by coordinate, as `MechanismModel::validate` requires.
pub(super) fn stops(
    model: &Model,
    entry: &ModelEntry,
    label: &str,
    shared: &MechanismModel,
    notes: &mut Vec<String>,
) -> anyhow::Result<Vec<JointStop>> {
    let mut used: Vec<usize> = shared.joints.iter().map(|j| j.rows.count()).collect();
    for d in &shared.drives {
        used[shared.coordinates[d.coordinate].joint] += 1;
    }
    let mut stops = Vec::new();
    for (k, c) in shared.coordinates.iter().enumerate() {
        let Some(joint) = model.joints.iter().find(|j| j.name == c.name) else {
            continue;
        };
        let friction = if entry.joint_friction == Some(false) {
            0.0
        } else {
            joint.friction
        };
        if !(friction.is_finite() && friction >= 0.0) {
            bail!(
                "joint_friction: joint `{}` of model `{label}` has <dynamics friction=\"{friction}\"> \
                 ({}): friction must be a finite number >= 0 (or set joint_friction = false to \
                 leave the URDF's friction out)",
                c.name,
                entry.urdf.display()
            );
        }
        let limits = if entry.joint_limits == Some(false) {
            None
        } else {
            c.limits
        };
        if (limits.is_none() && friction == 0.0) || shared.mimics.iter().any(|m| m.follower == k) {
            continue;
        }
        if matches!(c.kind, CoordinateKind::Compound { .. }) {
            // A stage of revolutes through one point (a ball joint): its stop rows made the
            // step's Newton solve fail at the limit (example-robot-data's human.urdf, fixed
            // base, at 0.451 s at any dt): left out until that is understood.
            notes.push(format!(
                "model `{label}`: joint `{}` is a stage of a compound joint (revolutes through \
                 one point): its limit and friction are not enforced (docs/mechanisms.md)",
                c.name
            ));
            continue;
        }
        if used[c.joint] >= MAX_ROWS {
            notes.push(format!(
                "model `{label}`: joint `{}` is a driven stage of a compound joint: its limit \
                 and friction are left out (no room in the joint's rows)",
                c.name
            ));
            continue;
        }
        used[c.joint] += 1;
        stops.push(JointStop {
            coordinate: k,
            limits,
            friction,
        });
    }
    Ok(stops)
}
