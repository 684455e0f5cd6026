//! A controller's inputs to a running simulation (issue 33: `set_efforts` and `set_targets`
//! from a Python loop). [`hold`] replaces every actuator's signal in a built [`World`] by a
//! [`Held`] one that follows the scene's signal until the controller sets a value, then holds
//! the last value set (zero-order hold: the value set before a step is that step's constant
//! input). Set values by the recorded joint name ([`crate::record::JointLayout::name`]).
//!
//! Each mechanism gets its own model (copies of one URDF share theirs otherwise), so every copy
//! is driven on its own.

use crate::record::ActuatorLaw;
use crate::sim::mechanism::ActuatorKind;
use crate::sim::signal::{Held, Signal};
use crate::world::World;
use anyhow::bail;
use std::collections::HashMap;
use std::sync::Arc;

/// One actuated joint's held input.
#[derive(Debug, Clone)]
pub struct HeldInput {
    /// The recorded joint name.
    pub joint: String,
    pub law: ActuatorLaw,
    pub held: Held,
}

/// Every actuated joint's held input, by recorded joint name.
#[derive(Debug, Clone, Default)]
pub struct Inputs {
    /// In the order of the recording layout's joints.
    pub joints: Vec<HeldInput>,
    index: HashMap<String, usize>,
}

/// Which input a controller sets: a motor's effort or a servo's target.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InputKind {
    /// `set_efforts`: motors (`τ = u`).
    Effort,
    /// `set_targets`: position and velocity servos (their `r` or `w`).
    Target,
}

impl InputKind {
    fn accepts(self, law: ActuatorLaw) -> bool {
        match self {
            InputKind::Effort => law == ActuatorLaw::Motor,
            InputKind::Target => law != ActuatorLaw::Motor,
        }
    }

    fn what(self) -> &'static str {
        match self {
            InputKind::Effort => "an effort (motor actuators)",
            InputKind::Target => "a target (position and velocity servos)",
        }
    }
}

/// Replaces every actuator's signal in `world` by a held one ([`Held`], the module doc).
pub fn hold(world: &mut World) -> Inputs {
    let mut inputs = Inputs::default();
    for (mechanism, layout) in world.mechanisms.iter_mut().zip(&world.layout.mechanisms) {
        if mechanism.drives.iter().all(|d| d.actuator.is_none()) {
            continue;
        }
        let model = Arc::make_mut(&mut Arc::make_mut(mechanism).shared);
        for drive in &mut model.drives {
            let Some(actuator) = drive.actuator.as_mut() else {
                continue;
            };
            let (law, signal) = match &actuator.kind {
                ActuatorKind::Motor { effort } => (ActuatorLaw::Motor, effort),
                ActuatorKind::Position { target, .. } => (ActuatorLaw::Position, target),
                ActuatorKind::Velocity { target, .. } => (ActuatorLaw::Velocity, target),
            };
            let held = match signal {
                Signal::Held(h) => h.clone(),
                other => Held::new(other.clone()),
            };
            actuator.set_signal(Signal::Held(held.clone()));
            let joint = world.layout.joints[layout.joints.start + drive.coordinate]
                .name
                .clone();
            inputs.index.insert(joint.clone(), inputs.joints.len());
            inputs.joints.push(HeldInput { joint, law, held });
        }
    }
    inputs
}

impl Inputs {
    /// Sets the inputs `values` names (every name checked before any is set: a bad call
    /// changes nothing). An unknown joint, a joint without an actuator of `kind`'s law, or a
    /// value that is not finite is an error naming it.
    pub fn set(&self, kind: InputKind, values: &[(String, f64)]) -> anyhow::Result<()> {
        let mut chosen = Vec::with_capacity(values.len());
        for (name, value) in values {
            let Some(&i) = self.index.get(name) else {
                let known: Vec<&str> = self
                    .joints
                    .iter()
                    .filter(|j| kind.accepts(j.law))
                    .map(|j| j.joint.as_str())
                    .collect();
                bail!(
                    "{name}: no actuated joint of that name takes {}{}",
                    kind.what(),
                    match crate::message::did_you_mean(name, known.iter().copied()) {
                        _ if known.is_empty() => " (the scene has none)".to_string(),
                        close if !close.is_empty() => close,
                        _ => format!(" (those that do: {})", known.join(", ")),
                    }
                );
            };
            let input = &self.joints[i];
            if !kind.accepts(input.law) {
                bail!(
                    "{name}: its actuator is a {} actuator, which takes {}; not {}",
                    input.law.name(),
                    match input.law {
                        ActuatorLaw::Motor => InputKind::Effort.what(),
                        _ => InputKind::Target.what(),
                    },
                    kind.what()
                );
            }
            if !value.is_finite() {
                bail!("{name}: the value {value} is not finite");
            }
            chosen.push((i, *value));
        }
        for (i, value) in chosen {
            self.joints[i].held.set(value);
        }
        Ok(())
    }

    /// The joints `kind` sets, in order ([`Inputs::set_in_order`]'s order).
    pub fn names(&self, kind: InputKind) -> impl Iterator<Item = &str> {
        self.joints
            .iter()
            .filter(move |j| kind.accepts(j.law))
            .map(|j| j.joint.as_str())
    }

    /// Sets every input of `kind`, in the order of [`Inputs::names`] (no name lookup: a
    /// controller's every-step call). A count that is not theirs, or a value that is not
    /// finite, is an error and nothing is set.
    pub fn set_in_order(&self, kind: InputKind, values: &[f64]) -> anyhow::Result<()> {
        let count = self.names(kind).count();
        if values.len() != count {
            bail!(
                "{} values for the {count} joints that take {} ({})",
                values.len(),
                kind.what(),
                self.names(kind).collect::<Vec<_>>().join(", ")
            );
        }
        if let Some((name, value)) = self.names(kind).zip(values).find(|(_, v)| !v.is_finite()) {
            bail!("{name}: the value {value} is not finite");
        }
        let inputs = self.joints.iter().filter(|j| kind.accepts(j.law));
        for (input, value) in inputs.zip(values) {
            input.held.set(*value);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Scene;
    use crate::simulation::Simulation;

    /// A rotor (a 2 kg body, izz = 0.05 kg m², on a continuous joint about z through its centre
    /// of mass, gravity along z: no torque from it) with a motor, and models/arm.urdf with two
    /// position servos at constant targets.
    fn scene(dir: &std::path::Path, motor: f64, targets: [f64; 2]) -> Scene {
        std::fs::write(
            dir.join("rotor.urdf"),
            r#"<robot name="rotor"><link name="base"/>
<link name="wheel"><inertial><mass value="2"/><inertia ixx="0.03" iyy="0.04" izz="0.05" ixy="0" ixz="0" iyz="0"/></inertial></link>
<joint name="spin" type="continuous"><parent link="base"/><child link="wheel"/><axis xyz="0 0 1"/></joint>
</robot>"#,
        )
        .unwrap();
        let arm = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/arm.urdf");
        let text = format!(
            "[sim]\ndt = 0.001\nduration = 1.0\ngravity = [0.0, 0.0, -9.81]\n\
             [[model]]\nurdf = \"rotor.urdf\"\nbodies = \"articulated\"\nbase = \"fixed\"\n\
             [[model.actuator]]\njoint = \"spin\"\nkind = \"motor\"\neffort = {motor:?}\n\
             [[model]]\nurdf = {arm:?}\nname = \"arm\"\nbodies = \"articulated\"\nbase = \"fixed\"\n\
             position = [1.0, 0.0, 0.0]\n\
             [[model.actuator]]\njoint = \"shoulder\"\nkind = \"position\"\ntarget = {:?}\n\
             kp = 400.0\nkd = 8.1\n\
             [[model.actuator]]\njoint = \"elbow\"\nkind = \"position\"\ntarget = {:?}\n\
             kp = 800.0\nkd = 11.3\n",
            targets[0], targets[1]
        );
        Scene::parse(&text, &dir.join("scene.toml")).unwrap()
    }

    fn run(
        scene: &Scene,
        inputs: impl FnOnce(&mut World) -> Option<Inputs>,
        steps: u64,
    ) -> Vec<(f64, f64)> {
        let mut world = scene.build().unwrap();
        let held = inputs(&mut world);
        let mut sim = Simulation::of_world(
            &world,
            scene.integrator(),
            scene.sim.dt,
            &scene.variational_settings(),
            1,
            &scene.run_settings(),
        )
        .unwrap();
        if let Some(held) = held {
            // Between steps: a motor impulse 0.5 N m for 100 steps, then -1.5 N m for 40.
            held.set(InputKind::Effort, &[("spin".into(), 0.5)])
                .unwrap();
            sim.advance(100).unwrap();
            held.set(InputKind::Effort, &[("spin".into(), -1.5)])
                .unwrap();
            sim.advance(40).unwrap();
        }
        sim.advance(steps).unwrap();
        let frame = sim.frame().clone();
        frame
            .joints
            .iter()
            .map(|j| (j.position, j.velocity))
            .collect()
    }

    /// Held inputs set to the scene's own constants step the same bits as the scene; a motor
    /// effort changed between steps is each step's constant input: the rotor's rate is the
    /// impulse over izz, `(0.5 · 0.1 − 1.5 · 0.04) / 0.05 = −0.2 rad/s`.
    #[test]
    fn held_inputs_are_each_steps_constant_input() {
        let dir = tempfile::tempdir().unwrap();
        let plain = scene(dir.path(), 0.0, [0.3, -0.2]);
        let reference = run(&plain, |_| None, 200);
        let same = run(
            &plain,
            |w| {
                let inputs = hold(w);
                let names: Vec<&str> = inputs.joints.iter().map(|j| j.joint.as_str()).collect();
                assert_eq!(names, ["spin", "arm/shoulder", "arm/elbow"]);
                let set = [
                    ("arm/shoulder".to_string(), 0.3),
                    ("arm/elbow".into(), -0.2),
                ];
                inputs.set(InputKind::Target, &set).unwrap();
                None
            },
            200,
        );
        assert_eq!(
            format!("{reference:?}"),
            format!("{same:?}"),
            "the same bits through held inputs"
        );
        let driven = run(&plain, |w| Some(hold(w)), 0);
        let rate = driven[0].1;
        // Measured: |rate + 0.2| = 2.8e-17 (the impulse summed over 140 steps in round-off).
        assert!((rate + 0.2).abs() < 1e-13, "rotor rate {rate}");
        // The continuous motion under the piecewise constant effort (a = u / izz: 10 then
        // -30 rad/s²): θ = ½ a₁ t₁² + ω₁ t₂ + ½ a₂ t₂², t₁ = 0.1 s, ω₁ = 1 rad/s, t₂ = 0.04 s:
        // 0.066 rad. The variational step with a held effort is exact for it.
        let theta = 0.5 * 10.0 * 0.1_f64.powi(2) + 1.0 * 0.04 - 0.5 * 30.0 * 0.04_f64.powi(2);
        // Measured: 0 rad (the same bits).
        assert!(
            (driven[0].0 - theta).abs() < 1e-12,
            "{} vs {theta}",
            driven[0].0
        );
    }

    /// Bad names and laws are refused with the joint named, and nothing is set by a bad call.
    #[test]
    fn bad_inputs_name_the_joint_and_change_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let mut world = scene(dir.path(), 0.25, [0.0, 0.0]).build().unwrap();
        let inputs = hold(&mut world);
        let e = inputs
            .set(
                InputKind::Effort,
                &[("spin".into(), 1.0), ("spn".into(), 2.0)],
            )
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "spn: no actuated joint of that name takes an effort (motor actuators): did you mean `spin`?"
        );
        assert_eq!(
            inputs.joints[0].held.value(),
            None,
            "the good name was not set"
        );
        let e = inputs
            .set(InputKind::Effort, &[("arm/elbow".into(), 1.0)])
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("arm/elbow: its actuator is a position actuator"),
            "{e}"
        );
        let e = inputs
            .set(InputKind::Target, &[("zzz".into(), 1.0)])
            .unwrap_err()
            .to_string();
        assert!(
            e.ends_with("(those that do: arm/shoulder, arm/elbow)"),
            "{e}"
        );
        let e = inputs
            .set(InputKind::Target, &[("arm/elbow".into(), f64::NAN)])
            .unwrap_err()
            .to_string();
        assert_eq!(e, "arm/elbow: the value NaN is not finite");
        assert_eq!(inputs.joints[0].held.scene(), &Signal::Constant(0.25));
        let names: Vec<&str> = inputs.names(InputKind::Target).collect();
        assert_eq!(names, ["arm/shoulder", "arm/elbow"]);
        let e = inputs
            .set_in_order(InputKind::Target, &[1.0])
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "1 values for the 2 joints that take a target (position and velocity servos) \
             (arm/shoulder, arm/elbow)"
        );
        let e = inputs
            .set_in_order(InputKind::Target, &[1.0, f64::INFINITY])
            .unwrap_err()
            .to_string();
        assert_eq!(e, "arm/elbow: the value inf is not finite");
        assert_eq!(
            inputs.joints[1].held.value(),
            None,
            "nothing set by a bad call"
        );
        inputs
            .set_in_order(InputKind::Target, &[0.5, -0.5])
            .unwrap();
        assert_eq!(inputs.joints[1].held.value(), Some(0.5));
        assert_eq!(inputs.joints[2].held.value(), Some(-0.5));
        assert_eq!(
            inputs.joints[0].held.value(),
            None,
            "the motor is not a target"
        );
    }
}
