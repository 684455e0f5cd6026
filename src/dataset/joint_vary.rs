//! The `[vary]` keys over a robot's joints (issue 32): initial joint positions and velocities,
//! and the actuators' signals, drawn for every moving joint at once or joint by joint.
//!
//! ```toml
//! [vary]
//! joints = { uniform = [-0.5, 0.5] }                 # every moving joint, each its own draw (rad or m)
//! joints = { shoulder = { uniform = [-1, 1] }, elbow = { normal = { mean = 0, std = 0.2 } } }
//! joint_velocities = { normal = { mean = 0, std = 0.5 } }    # rad/s or m/s, same two forms
//! actuators = { uniform = [-0.5, 0.5] }              # every actuator of the template: a constant signal
//! actuators = { smooth = { amplitude = 0.8, cutoff_hz = 1.5 } }   # random smooth, per run and joint
//! actuators = { shoulder = { smooth = { amplitude = 1, cutoff_hz = 2 } }, elbow = { choice = [0, 0.5] } }
//! ```
//!
//! A table whose one key names a distribution (`uniform`, `log_uniform`, `normal`, `choice`, and
//! `smooth` for actuators) applies to every joint; otherwise its keys are joint names (the URDF's,
//! without the model's `name/` prefix). "Every moving joint" is every joint of the model that
//! moves in the articulated model (not fixed, not locked, not merged, not a mimic follower);
//! "every actuator" every `[[scene.model.actuator]]` of the template. A drawn value replaces the
//! template's: `joints` the `[[scene.model]] joints` entry, `actuators` the actuator's signal
//! (a position or velocity servo's `target`, a motor's `effort`), in the target's units. A
//! `smooth` draw without `offset` varies about the template's signal when it is a constant (a
//! servo's standing pose), about 0 otherwise.
//!
//! Each joint draws from its own stream, `Rng::for_key(run seed, "<key>.<joint>")`, so adding a
//! joint or a key leaves the other values alone. A smooth signal is seeded by that stream's first
//! number ([`crate::scene::signal::smooth`]).
//!
//! A drawn position outside the joint's URDF range is clamped into it when the model's joint
//! limits are on (`joint_limits`, default true): a run never starts with a joint past its stop.
//! The values used are the `joints` table's step-0 rows (position, velocity) and its `target` /
//! `effort` columns.

use crate::message::did_you_mean;
use crate::scene::placement::{Dist, Rng};
use crate::scene::signal::{SmoothParams, smooth};
use crate::sim::signal::Signal;
use anyhow::bail;
use std::collections::BTreeMap;

/// A draw for every joint, or one per named joint.
#[derive(Debug, Clone, PartialEq)]
pub enum PerJoint<T> {
    Every(T),
    Each(BTreeMap<String, T>),
}

impl<T> PerJoint<T> {
    /// The draw for joint `name` among the joints it covers.
    pub fn for_joint(&self, name: &str) -> Option<&T> {
        match self {
            PerJoint::Every(d) => Some(d),
            PerJoint::Each(m) => m.get(name),
        }
    }

    /// Checks that every named joint is in `known` (what `what` lists); `key` names the
    /// `[vary]` key in the message.
    pub fn check_names(&self, key: &str, known: &[String], what: &str) -> anyhow::Result<()> {
        if let PerJoint::Each(m) = self {
            for name in m.keys() {
                if !known.iter().any(|k| k == name) {
                    bail!(
                        "{key}.{name}: not {what} ({}){}",
                        if known.is_empty() {
                            "there is none".to_string()
                        } else {
                            known.join(", ")
                        },
                        did_you_mean(name, known.iter().map(String::as_str))
                    );
                }
            }
        }
        Ok(())
    }
}

/// How an actuator's signal is drawn per run.
#[derive(Debug, Clone, PartialEq)]
pub enum SignalDraw {
    /// A constant drawn from the distribution.
    Constant(Dist),
    /// A random smooth signal ([`smooth`]) seeded per run and joint; `offset_given` is false
    /// when the spec left `offset` out: the template's constant signal is then the offset.
    Smooth {
        params: SmoothParams,
        offset_given: bool,
    },
}

impl SignalDraw {
    fn parse(key: &str, value: &toml::Value) -> anyhow::Result<Self> {
        if let Some(fields) = value.get("smooth") {
            let single = value.as_table().is_some_and(|t| t.len() == 1);
            let Some(fields) = fields.as_table().filter(|_| single) else {
                bail!("{key}: expected {{ smooth = {{ amplitude, cutoff_hz, offset }} }}");
            };
            return Ok(SignalDraw::Smooth {
                params: SmoothParams::parse(&format!("{key}.smooth"), fields, false)?,
                offset_given: fields.contains_key("offset"),
            });
        }
        Ok(SignalDraw::Constant(Dist::parse(key, value, 1)?))
    }

    /// One run's signal; `template` is the template's signal on the joint when it is a
    /// constant (the offset of a smooth signal that gives none).
    fn draw(&self, rng: &mut Rng, template: Option<f64>) -> Signal {
        match self {
            SignalDraw::Constant(d) => Signal::Constant(d.sample(rng)[0]),
            SignalDraw::Smooth {
                params,
                offset_given,
            } => {
                let mut p = *params;
                if !offset_given {
                    p.offset = template.unwrap_or(0.0);
                }
                smooth(&p, rng.next_u64())
            }
        }
    }
}

/// The names that make a table a draw for every joint rather than a table of joints.
const EVERY_KEYS: &[&str] = &["uniform", "log_uniform", "normal", "choice", "smooth"];

fn parse_per_joint<T>(
    key: &str,
    value: &toml::Value,
    parse: impl Fn(&str, &toml::Value) -> anyhow::Result<T>,
) -> anyhow::Result<PerJoint<T>> {
    let Some(table) = value.as_table() else {
        bail!(
            "{key}: expected a distribution for every joint ({{ uniform = [lo, hi] }}) or a table \
             of joints ({{ shoulder = {{ uniform = [lo, hi] }}, ... }})"
        );
    };
    if table.len() == 1 && table.keys().all(|k| EVERY_KEYS.contains(&k.as_str())) {
        return Ok(PerJoint::Every(parse(key, value)?));
    }
    if table.is_empty() {
        bail!("{key}: empty table (give a distribution or joints)");
    }
    let mut each = BTreeMap::new();
    for (name, v) in table {
        each.insert(name.clone(), parse(&format!("{key}.{name}"), v)?);
    }
    Ok(PerJoint::Each(each))
}

/// `vary.joints`, `vary.joint_velocities`, `vary.actuators` as parsed.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct JointVary {
    pub positions: Option<PerJoint<Dist>>,
    pub velocities: Option<PerJoint<Dist>>,
    pub actuators: Option<PerJoint<SignalDraw>>,
}

impl JointVary {
    /// Reads the three keys of `table` (`prefix` is `spec.toml: vary`). A `smooth` signal is
    /// refused for `joints` and `joint_velocities` (they are initial values).
    pub fn parse(prefix: &str, table: &toml::Table) -> anyhow::Result<Self> {
        let dist = |key: &str, v: &toml::Value| -> anyhow::Result<Dist> {
            if v.get("smooth").is_some() {
                bail!(
                    "{key}: a smooth signal drives actuators (vary.actuators); initial values take a distribution"
                );
            }
            Dist::parse(key, v, 1)
        };
        let key = |name: &str| format!("{prefix}.{name}");
        Ok(Self {
            positions: table
                .get("joints")
                .map(|v| parse_per_joint(&key("joints"), v, dist))
                .transpose()?,
            velocities: table
                .get("joint_velocities")
                .map(|v| parse_per_joint(&key("joint_velocities"), v, dist))
                .transpose()?,
            actuators: table
                .get("actuators")
                .map(|v| parse_per_joint(&key("actuators"), v, SignalDraw::parse))
                .transpose()?,
        })
    }

    pub fn is_empty(&self) -> bool {
        self.positions.is_none() && self.velocities.is_none() && self.actuators.is_none()
    }
}

/// What one run drew for its joints: initial positions and velocities by joint, and the
/// actuators' signals by joint.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct JointDraws {
    pub positions: BTreeMap<String, f64>,
    pub velocities: BTreeMap<String, f64>,
    pub signals: BTreeMap<String, Signal>,
}

/// A model choice's joints as the draws need them.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ChoiceJoints {
    /// The moving joints (URDF names), in the model's order, with the range their position is
    /// clamped into (`None`: no limit or limits off).
    pub moving: Vec<(String, Option<[f64; 2]>)>,
    /// The joints the template's actuators drive, in actuator order, with the template's
    /// signal when it is a constant.
    pub actuated: Vec<(String, Option<f64>)>,
}

impl JointVary {
    /// Run `run_seed`'s draws for a model with `joints`.
    pub fn draw(&self, run_seed: u64, joints: &ChoiceJoints) -> JointDraws {
        let mut out = JointDraws::default();
        for (name, range) in &joints.moving {
            let rng = |key: &str| Rng::for_key(run_seed, &format!("{key}.{name}"));
            if let Some(d) = self.positions.as_ref().and_then(|p| p.for_joint(name)) {
                let mut q = d.sample(&mut rng("joints"))[0];
                if let Some([lo, hi]) = range {
                    q = q.clamp(*lo, *hi);
                }
                out.positions.insert(name.clone(), q);
            }
            if let Some(d) = self.velocities.as_ref().and_then(|p| p.for_joint(name)) {
                out.velocities
                    .insert(name.clone(), d.sample(&mut rng("joint_velocities"))[0]);
            }
        }
        if let Some(actuators) = &self.actuators {
            for (name, template) in &joints.actuated {
                if let Some(d) = actuators.for_joint(name) {
                    let mut rng = Rng::for_key(run_seed, &format!("actuators.{name}"));
                    out.signals
                        .insert(name.clone(), d.draw(&mut rng, *template));
                }
            }
        }
        out
    }

    /// Checks the named joints against a model choice; `prefix` is `spec.toml: vary`.
    pub fn check(&self, prefix: &str, joints: &ChoiceJoints) -> anyhow::Result<()> {
        let moving: Vec<String> = joints.moving.iter().map(|(n, _)| n.clone()).collect();
        if let Some(p) = &self.positions {
            p.check_names(&format!("{prefix}.joints"), &moving, "a moving joint")?;
        }
        if let Some(p) = &self.velocities {
            p.check_names(
                &format!("{prefix}.joint_velocities"),
                &moving,
                "a moving joint",
            )?;
        }
        if let Some(a) = &self.actuators {
            let actuated: Vec<String> = joints.actuated.iter().map(|(n, _)| n.clone()).collect();
            if actuated.is_empty() {
                bail!(
                    "{prefix}.actuators: the template has no [[scene.model.actuator]]: there is no \
                     signal to vary"
                );
            }
            a.check_names(
                &format!("{prefix}.actuators"),
                &actuated,
                "a joint with an actuator in the template",
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(text: &str) -> toml::Table {
        toml::from_str(text).unwrap()
    }

    fn arm() -> ChoiceJoints {
        ChoiceJoints {
            moving: vec![
                ("shoulder".into(), Some([-1.0, 1.0])),
                ("elbow".into(), None),
            ],
            actuated: vec![("elbow".into(), Some(0.7))],
        }
    }

    /// The two forms: a distribution for every joint, or per joint; each joint its own stream
    /// (adding a joint's draw leaves another's value alone), ranges clamp positions, actuators
    /// get constant or smooth signals.
    #[test]
    fn every_joint_or_each_draws_from_its_own_stream() {
        let every = JointVary::parse(
            "s: vary",
            &table("joints = { uniform = [-5, 5] }\njoint_velocities = { normal = { mean = 1, std = 0 } }"),
        )
        .unwrap();
        let d = every.draw(7, &arm());
        assert_eq!(d.positions.len(), 2);
        // U[-5, 5) into the range [-1, 1]: the shoulder is clamped, the elbow is not.
        assert!((-1.0..=1.0).contains(&d.positions["shoulder"]));
        assert!((-5.0..5.0).contains(&d.positions["elbow"]));
        assert_eq!(d.velocities["shoulder"], 1.0);
        assert_eq!(d.velocities["elbow"], 1.0);
        assert!(d.signals.is_empty());
        // The per-joint form for the elbow alone gives the elbow the same value.
        let each = JointVary::parse(
            "s: vary",
            &table("joints = { elbow = { uniform = [-5, 5] } }"),
        )
        .unwrap();
        let e = each.draw(7, &arm());
        assert_eq!(e.positions.len(), 1);
        assert_eq!(e.positions["elbow"], d.positions["elbow"]);
        // Another run, other values.
        assert_ne!(
            every.draw(8, &arm()).positions["elbow"],
            d.positions["elbow"]
        );
        let act = JointVary::parse(
            "s: vary",
            &table("actuators = { smooth = { amplitude = 0.5, cutoff_hz = 1 } }"),
        )
        .unwrap();
        let s = act.draw(7, &arm());
        assert_eq!(s.signals.len(), 1);
        // Without `offset`, about the template's constant target 0.7.
        assert!(matches!(
            s.signals["elbow"],
            Signal::Sines { offset: 0.7, .. }
        ));
        let given = JointVary::parse(
            "s: vary",
            &table("actuators = { smooth = { amplitude = 0.5, cutoff_hz = 1, offset = -0.2 } }"),
        )
        .unwrap();
        assert!(matches!(
            given.draw(7, &arm()).signals["elbow"],
            Signal::Sines { offset: -0.2, .. }
        ));
        assert_ne!(s.signals["elbow"], act.draw(8, &arm()).signals["elbow"]);
        let constant = JointVary::parse(
            "s: vary",
            &table("actuators = { elbow = { choice = [0.25] } }"),
        )
        .unwrap();
        assert_eq!(
            constant.draw(3, &arm()).signals["elbow"],
            Signal::Constant(0.25)
        );
    }

    /// Bad keys and names: one message naming the key, with the joints there are.
    #[test]
    fn unknown_joints_and_bad_draws_name_the_key() {
        for (text, needle) in [
            (
                "joints = 0.5",
                "s: vary.joints: expected a distribution for every joint",
            ),
            (
                "joints = { smooth = { amplitude = 1, cutoff_hz = 1 } }",
                "s: vary.joints: a smooth signal drives actuators",
            ),
            (
                "actuators = { elbow = { smooth = { amplitude = 1 } } }",
                "s: vary.actuators.elbow.smooth.cutoff_hz: missing",
            ),
            (
                "actuators = { smooth = { amplitude = 1, cutoff_hz = 1, seed = 2 } }",
                "s: vary.actuators.smooth.seed: unknown key",
            ),
            ("joints = {}", "s: vary.joints: empty table"),
            (
                "joints = { elbow = { uniform = [1, 0] } }",
                "s: vary.joints.elbow.uniform: lower bound 1 is above",
            ),
        ] {
            let e = format!(
                "{:#}",
                JointVary::parse("s: vary", &table(text)).unwrap_err()
            );
            assert!(e.contains(needle), "{text}: {e}");
        }
        for (text, needle) in [
            (
                "joints = { elbw = { uniform = [0, 1] } }",
                "s: vary.joints.elbw: not a moving joint (shoulder, elbow): did you mean `elbow`?",
            ),
            (
                "actuators = { shoulder = { uniform = [0, 1] } }",
                "s: vary.actuators.shoulder: not a joint with an actuator in the template (elbow)",
            ),
        ] {
            let v = JointVary::parse("s: vary", &table(text)).unwrap();
            let e = format!("{:#}", v.check("s: vary", &arm()).unwrap_err());
            assert!(e.contains(needle), "{text}: {e}");
        }
        let v = JointVary::parse("s: vary", &table("actuators = { uniform = [0, 1] }")).unwrap();
        let none = ChoiceJoints {
            actuated: vec![],
            ..arm()
        };
        let e = format!("{:#}", v.check("s: vary", &none).unwrap_err());
        assert!(
            e.contains("the template has no [[scene.model.actuator]]"),
            "{e}"
        );
    }
}
