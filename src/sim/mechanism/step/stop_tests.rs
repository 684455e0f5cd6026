//! Tests of the stop rows ([`super::stops`]) on the pendulum of [`super::tests::pendulum`] (a
//! rod of mass 1 kg, centre `d = 1 m` below a pivot on the world, `I = 1.01 kg m²` about it;
//! `θ` about the world y axis, the centre at `(−d sin θ, 0, −d cos θ)`): a limit that stops
//! it inelastically, friction that holds it and one that slides.

use super::super::rows::BodyPose;
use super::super::{JointStop, Mechanism, MechanismModel, StopMode};
use super::tests::pendulum;
use super::*;
use nalgebra::Vector3;
use std::sync::Arc;

const G: f64 = 9.81;

fn stopped(theta0: f64, stop: JointStop) -> (Mechanism, Bodies) {
    let (model, inits, _) = pendulum(theta0);
    let mut shared = MechanismModel::clone(&model.shared);
    shared.stops = vec![stop];
    shared.validate().unwrap();
    let model = Mechanism {
        shared: Arc::new(shared),
        ..model
    };
    (model, Bodies::new(&inits))
}

fn angle(model: &Mechanism, bodies: &Bodies, reference: f64) -> f64 {
    let pose = BodyPose {
        rot: bodies.world_from_body[0].to_rotation_matrix().into_inner(),
        com: bodies.com_world[0],
    };
    model.coordinates[0]
        .kind
        .value(&BodyPose::identity(), &pose, reference)
        .unwrap()
}

/// The pendulum's energy as a recording reports it (projected momenta), J.
fn energy(model: &Mechanism, bodies: &Bodies, loads: &Loads) -> f64 {
    let mut reporter = super::super::project::Reporter::new(model);
    reporter.report(model, bodies, loads, 0.0).totals.energy()
}

struct Run {
    /// Angles after each step.
    theta: Vec<f64>,
    energy: Vec<f64>,
    work: DriveWork,
    modes: Vec<StopMode>,
    iters_max: u32,
}

fn run(model: &Mechanism, bodies: &mut Bodies, h: f64, steps: u32, loads: &Loads) -> Run {
    let mut state = MechanismState::new(model);
    let mut warm = Warm::new(model);
    let settings = VariationalSettings::default();
    let mut reference = model.coordinates[0].initial;
    let mut out = Run {
        theta: Vec::new(),
        energy: vec![energy(model, bodies, loads)],
        work: DriveWork::default(),
        modes: Vec::new(),
        iters_max: 0,
    };
    for _ in 0..steps {
        let stats = step(model, &mut state, &mut warm, bodies, h, loads, &settings);
        assert_eq!(
            (stats.newton_failures, stats.substepped),
            (0, 0),
            "{stats:?}"
        );
        out.iters_max = out.iters_max.max(stats.newton_iters_max);
        reference = angle(model, bodies, reference);
        out.theta.push(reference);
        out.energy.push(energy(model, bodies, loads));
        out.modes
            .push(state.ws.stops.mode.first().copied().unwrap_or_default());
    }
    out.work = state.ws.drive_work;
    out
}

/// Released from horizontal (`θ0 = −π/2`) towards an upper limit at `θ = −0.5`: it stops
/// there and stays (no rebound), and the limit removes the kinetic energy at impact,
/// `m g d cos(0.5)` (energy conservation from the release), to O(h).
#[test]
fn a_pendulum_stops_at_its_limit_and_loses_its_impact_energy() {
    let upper: f64 = -0.5;
    let impact = G * upper.cos();
    let gravity = Loads::uniform_gravity(Vector3::new(0.0, 0.0, -G));
    let mut errors = Vec::new();
    for h in [1e-3, 5e-4] {
        let stop = JointStop {
            coordinate: 0,
            limits: Some([-3.0, upper]),
            friction: 0.0,
        };
        let (model, mut bodies) = stopped(-std::f64::consts::FRAC_PI_2, stop);
        let steps = (1.0 / h) as u32;
        let r = run(&model, &mut bodies, h, steps, &gravity);
        let hit = r.theta.iter().position(|&t| t >= upper - 1e-9).unwrap();
        // Impact after ≈ 0.41 s (a quarter period is longer: the limit comes first).
        assert!((0.3..0.5).contains(&(hit as f64 * h)), "hit at step {hit}");
        let overshoot = r.theta.iter().map(|t| t - upper).fold(f64::MIN, f64::max);
        let rebound = r.theta[hit..]
            .iter()
            .map(|t| upper - t)
            .fold(f64::MIN, f64::max);
        // The bound holds to the row tolerance (1e-12 rad): measured 3.2e-13 / 3.6e-13 rad.
        assert!(overshoot < 1e-12, "overshoot {overshoot:e}");
        // No bounce: the joint stays at the limit, measured 3.2e-13 / 3.6e-13 rad below it.
        assert!(rebound < 1e-12, "rebound {rebound:e}");
        assert!(r.modes[hit..].iter().all(|&m| m == StopMode::Upper));
        // Energy lost, reported and accounted, against the closed form.
        let lost = r.energy[0] - r.energy[r.energy.len() - 1];
        let err_lost = (lost - impact).abs() / impact;
        let err_ledger = (r.work.limits - impact).abs() / impact;
        assert_eq!(r.work.friction, 0.0);
        errors.push((err_lost, err_ledger, overshoot, rebound, r.iters_max));
    }
    eprintln!("{errors:?}");
    // Measured (h = 1 ms / 0.5 ms), relative to the closed form: the reported loss 3.2e-7 /
    // 7.9e-8, the limit's ledger 7.2e-7 / 1.8e-7; both fall 4x per halving (the O(h) terms of
    // the two impact steps cancel here); at most 3 Newton iterations per step, switches included.
    for &(lost, ledger, .., iters) in &errors {
        assert!(lost < 1e-5 && ledger < 1e-5, "{errors:?}");
        assert!(iters <= 4, "{errors:?}");
    }
    assert!(errors[1].0 < 0.5 * errors[0].0, "{errors:?}");
    assert!(errors[1].1 < 0.5 * errors[0].1, "{errors:?}");
}

/// Without a limit reached and without friction the step is the unlimited one, bit for bit.
#[test]
fn a_limit_never_reached_changes_no_bit() {
    let gravity = Loads::uniform_gravity(Vector3::new(0.0, 0.0, -G));
    let (plain, inits, _) = pendulum(1.0);
    let mut bodies = Bodies::new(&inits);
    let a = run(&plain, &mut bodies, 1e-3, 2000, &gravity);
    let stop = JointStop {
        coordinate: 0,
        limits: Some([-1.5, 1.5]),
        friction: 0.0,
    };
    let (model, mut limited) = stopped(1.0, stop);
    let b = run(&model, &mut limited, 1e-3, 2000, &gravity);
    assert_eq!(a.theta, b.theta);
    assert_eq!(bodies.angmom_body, limited.angmom_body);
    assert_eq!(bodies.linvel_world, limited.linvel_world);
    assert_eq!(b.work.limits, 0.0);
}

/// Friction above the gravity torque holds the pendulum where it is (stiction): over 10 s the
/// angle does not move beyond round-off.
#[test]
fn friction_above_the_load_holds_the_joint() {
    let theta0 = 0.6;
    // Gravity torque m g d sin θ0 = 5.54 N m; friction 6 N m.
    let stop = JointStop {
        coordinate: 0,
        limits: None,
        friction: 6.0,
    };
    let gravity = Loads::uniform_gravity(Vector3::new(0.0, 0.0, -G));
    let (model, mut bodies) = stopped(theta0, stop);
    let r = run(&model, &mut bodies, 1e-3, 10_000, &gravity);
    let drift = r
        .theta
        .iter()
        .map(|t| (t - theta0).abs())
        .fold(0.0, f64::max);
    eprintln!("drift {drift:e} work {:?}", r.work);
    // Round-off: measured 1.2e-14 rad.
    assert!(drift < 1e-13, "drift {drift:e}");
    assert!(r.modes.iter().all(|&m| m == StopMode::Stick));
    // Nothing moves, nothing is dissipated: measured 2.3e-14 J.
    assert!(r.work.friction.abs() < 1e-12, "{:?}", r.work);
}

/// Friction below the load, without gravity, against a motor: the angular acceleration is
/// `(τ − F)/I`, and friction removes `F |Δθ|`.
#[test]
fn friction_below_the_load_slides_with_coulomb_torque() {
    use super::super::drive::{Actuator, ActuatorKind, JointDrive};
    use crate::sim::signal::Signal;
    let (tau, f) = (2.0, 0.5);
    let i_pivot = 1.01;
    let mut errors = Vec::new();
    for h in [1e-2, 5e-3] {
        let (model, mut bodies) = stopped(
            0.0,
            JointStop {
                coordinate: 0,
                limits: None,
                friction: f,
            },
        );
        let mut shared = MechanismModel::clone(&model.shared);
        shared.drives = vec![JointDrive {
            coordinate: 0,
            actuator: Some(Actuator {
                kind: ActuatorKind::Motor {
                    effort: Signal::Constant(tau),
                },
                effort_limit: None,
            }),
            damping: 0.0,
        }];
        shared.validate().unwrap();
        let model = Mechanism {
            shared: Arc::new(shared),
            ..model
        };
        let steps = (1.0 / h) as u32;
        let r = run(&model, &mut bodies, h, steps, &Loads::none());
        let theta = r.theta[r.theta.len() - 1];
        let exact = (tau - f) / (2.0 * i_pivot);
        let err = (theta - exact).abs() / exact;
        let dissipation = (r.work.friction - f * theta).abs() / (f * theta);
        let balance =
            (r.energy[r.energy.len() - 1] - r.energy[0]) - (r.work.actuators - r.work.friction);
        errors.push((err, dissipation, balance.abs(), r.iters_max));
        assert!(
            r.modes[1..].iter().all(|&m| m == StopMode::Slide(1)),
            "{:?}",
            &r.modes[..3]
        );
    }
    eprintln!("{errors:?}");
    // Measured (h = 10 ms / 5 ms): θ(1 s) off (τ − F)/(2I) by 3.3e-3 / 1.7e-3 relative (O(h):
    // the friction impulse acts at the start of the step only); the ledger off F θ by
    // 9.9e-3 / 5.0e-3 (it lags half a step: F h θ̇ / 2); the energy balance (reported change
    // − motor work + friction) closes to 1.7e-5 / 4.2e-6 J.
    for &(err, diss, balance, _) in &errors {
        assert!(err < 5e-3 && diss < 1.5e-2 && balance < 5e-5, "{errors:?}");
    }
    assert!(errors[1].0 < 0.6 * errors[0].0 && errors[1].1 < 0.6 * errors[0].1);
}
