//! Tests of the drive rows ([`super::drives`]) on the pendulum of [`super::tests::pendulum`]
//! (a rod of mass 1 kg, centre 1 m below a pivot on the world, `I = 1.01 kg m²` about it):
//! a motor against the closed form, a stiff servo settling, a damper that only removes energy
//! and whose dissipation closes the balance.

use super::super::drive::{Actuator, ActuatorKind, JointDrive};
use super::super::rows::BodyPose;
use super::super::{Mechanism, MechanismModel};
use super::tests::pendulum;
use super::*;
use crate::sim::signal::Signal;
use nalgebra::Vector3;
use std::sync::Arc;

/// Moment of inertia of the test pendulum about its pivot, `I_yy + m d²`, kg m².
const I_PIVOT: f64 = 1.01;

fn driven(theta0: f64, drive: JointDrive) -> (Mechanism, Bodies) {
    let (model, inits, _) = pendulum(theta0);
    let mut shared = MechanismModel::clone(&model.shared);
    shared.drives = vec![drive];
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

/// The pendulum's kinetic energy from the momenta projected onto the joint's velocity
/// constraints (what a recording reports).
fn kinetic(model: &Mechanism, bodies: &Bodies) -> f64 {
    let mut reporter = super::super::project::Reporter::new(model);
    reporter
        .report(model, bodies, &Loads::none(), 0.0)
        .totals
        .kinetic_energy
}

fn motor(effort: Signal) -> JointDrive {
    JointDrive {
        coordinate: 0,
        actuator: Some(Actuator {
            kind: ActuatorKind::Motor { effort },
            effort_limit: None,
        }),
        damping: 0.0,
    }
}

/// A position servo on the pendulum's hinge, `τ = kp (target − θ) − kd θ̇`, with joint damping
/// `damping`.
fn position_servo(target: f64, kp: f64, kd: f64, damping: f64) -> JointDrive {
    JointDrive {
        coordinate: 0,
        actuator: Some(Actuator {
            kind: ActuatorKind::Position {
                target: Signal::Constant(target),
                kp,
                kd,
            },
            effort_limit: None,
        }),
        damping,
    }
}

/// Runs `steps` steps of `h` without gravity; returns the worst |θ − exact(t)|.
fn run(
    model: &Mechanism,
    bodies: &mut Bodies,
    h: f64,
    steps: u32,
    exact: &dyn Fn(f64) -> f64,
) -> f64 {
    let mut state = MechanismState::new(model);
    let mut warm = Warm::new(model);
    let settings = VariationalSettings::default();
    let mut loads = Loads::none();
    let mut worst: f64 = 0.0;
    let mut reference = model.coordinates[0].initial;
    for k in 0..steps {
        loads.set_time(f64::from(k) * h);
        let stats = step(model, &mut state, &mut warm, bodies, h, &loads, &settings);
        assert_eq!(stats.newton_failures, 0);
        reference = angle(model, bodies, reference);
        worst = worst.max((reference - exact(f64::from(k + 1) * h)).abs());
    }
    // The ledger: a constant motor's work is τ (θ_N − θ_0) whatever the steps (Σ τ Δθ).
    if let Some(Actuator {
        kind: ActuatorKind::Motor {
            effort: Signal::Constant(tau),
        },
        ..
    }) = &model.drives[0].actuator
    {
        let work = state.ws.drive_work.actuators;
        let expected = tau * (reference - model.coordinates[0].initial);
        // Sums of the steps' τ Δθ: measured ≤ 2e-15 relative.
        assert!(
            (work - expected).abs() <= 1e-12 * expected.abs(),
            "{work} {expected}"
        );
        assert_eq!(state.ws.drive_work.damping, 0.0);
    }
    worst
}

/// A constant motor torque on the pendulum without gravity: `θ = θ0 + τ t² / (2 I)`, to
/// second order in `h` (the maximal-coordinate step moves the centre along the chord).
#[test]
fn a_constant_motor_torque_gives_the_parabola() {
    let exact = |t: f64| 0.3 + 0.5 * t * t / (2.0 * I_PIVOT);
    let mut errors = Vec::new();
    for (h, steps) in [(1e-2, 200), (5e-3, 400)] {
        let (model, mut bodies) = driven(0.3, motor(Signal::Constant(0.5)));
        errors.push(run(&model, &mut bodies, h, steps, &exact));
    }
    let ratio = errors[0] / errors[1];
    // Measured 8.0e-6 and 2.0e-6 rad over 2 s (θ reaches 1.3 rad): ratio 4.0.
    assert!(errors[0] < 1e-5, "{errors:?}");
    assert!((3.8..4.2).contains(&ratio), "{errors:?} ratio {ratio}");
}

/// A sine motor torque `τ = A sin(ω t)`: `θ = θ0 + (A / (I ω)) (t − sin(ω t)/ω)`. The error is
/// second order in `h`: halving `h` divides it by 4.
#[test]
fn a_sine_motor_torque_is_second_order() {
    let (a, f) = (2.0, 1.5);
    let w = std::f64::consts::TAU * f;
    let exact = |t: f64| 0.1 + a / (I_PIVOT * w) * (t - (w * t).sin() / w);
    let sine = Signal::Sine {
        amplitude: a,
        frequency_hz: f,
        phase: 0.0,
        offset: 0.0,
    };
    let mut errors = Vec::new();
    for (h, steps) in [(1e-2, 100), (5e-3, 200)] {
        let (model, mut bodies) = driven(0.1, motor(sine.clone()));
        errors.push(run(&model, &mut bodies, h, steps, &exact));
    }
    let ratio = errors[0] / errors[1];
    // Measured 7.9e-4 and 2.0e-4 rad over 1 s: ratio 4.0 (order 2).
    assert!(errors[0] < 2e-3, "{errors:?}");
    assert!((3.6..4.4).contains(&ratio), "{errors:?} ratio {ratio}");
}

/// A position servo at `h² kp / I = 100` (h = 10 ms) with critical damping stays stable and
/// settles at its target; explicit, it would blow up in one step (`h √(kp/I) = 10 > 2`).
#[test]
fn a_stiff_servo_settles_at_its_target() {
    let h = 1e-2;
    let kp = 100.0 * I_PIVOT / (h * h);
    let kd = 2.0 * (kp * I_PIVOT).sqrt();
    let servo = position_servo(0.8, kp, kd, 0.0);
    let (model, mut bodies) = driven(0.0, servo);
    let mut state = MechanismState::new(&model);
    let mut warm = Warm::new(&model);
    let settings = VariationalSettings::default();
    let mut loads = Loads::uniform_gravity(Vector3::new(0.0, 0.0, -9.81));
    let mut theta = 0.0;
    let mut worst: f64 = 0.0;
    let mut iters = 0;
    for k in 0..200 {
        loads.set_time(f64::from(k) * h);
        let stats = step(
            &model,
            &mut state,
            &mut warm,
            &mut bodies,
            h,
            &loads,
            &settings,
        );
        assert_eq!(stats.newton_failures, 0, "step {k}");
        assert_eq!(stats.substepped, 0, "step {k}");
        iters = iters.max(stats.newton_iters_max);
        theta = angle(&model, &bodies, theta);
        worst = worst.max((theta - 0.8).abs());
    }
    // The midpoint spring is A-stable, not L-stable: the first step overshoots to 1.11 rad
    // (36 θ₁ = 40 from the linear recursion at h² kp/I = 100, h kd/I = 20), then the ringing
    // decays. Gravity pulls the rod back with m g d sin θ = 7.0 N m: the servo's steady error
    // is that over kp (6.9e-6 rad). Measured: |θ − 0.8| at most 0.311 rad, then settled to
    // the steady error within 1e-12 rad.
    let steady = 9.81 * (0.8f64).sin() / kp;
    assert!((theta - (0.8 - steady)).abs() < 1e-9, "{theta}");
    assert!(worst < 0.35, "{worst}");
    // Newton on the drive row converges quadratically (an exact Jacobian): measured at most
    // 4 iterations per step (a Jacobian off by the row's scale converges linearly, if at all).
    assert!(iters <= 5, "{iters}");
}

/// The pendulum spinning at 3 rad/s about its pivot under joint damping `b` without gravity,
/// stepped `steps` times by `h`: the kinetic energy after each step (projected), and the
/// recorded dissipation.
fn spin_down(b: f64, h: f64, steps: u32) -> (Vec<f64>, f64) {
    let damper = JointDrive {
        coordinate: 0,
        actuator: None,
        damping: b,
    };
    let (model, mut bodies) = driven(0.0, damper);
    let omega = Vector3::new(0.0, 3.0, 0.0);
    bodies.angmom_body[0] = bodies.world_from_body[0]
        .inverse_transform_vector(&omega)
        .component_mul(&bodies.inertia_body[0]);
    bodies.linvel_world[0] = omega.cross(&bodies.com_world[0]);
    let mut state = MechanismState::new(&model);
    let mut warm = Warm::new(&model);
    let settings = VariationalSettings::default();
    let loads = Loads::none();
    let mut energies = vec![kinetic(&model, &bodies)];
    for _ in 0..steps {
        let stats = step(
            &model,
            &mut state,
            &mut warm,
            &mut bodies,
            h,
            &loads,
            &settings,
        );
        assert_eq!(stats.newton_failures, 0);
        energies.push(kinetic(&model, &bodies));
    }
    (energies, state.ws.drive_work.damping)
}

/// Joint damping never adds energy: the kinetic energy falls (or stays at round-off once the
/// spin stops) at every step, at every `a = bh/(2I)` from 0.05 to 500. The implicit damper's
/// rate factor per step is `(1 − a)/(1 + a)`, of modulus below 1 for every `a > 0` (A-stable);
/// for `a ≫ 1` it tends to −1 (not L-stable: the rate alternates in sign and decays slowly),
/// the price of the symmetric step the compositions need (docs/forces.md).
#[test]
fn damping_never_adds_energy_at_any_step() {
    let h = 1e-2;
    for a in [0.05, 1.0, 500.0] {
        let (energies, dissipated) = spin_down(2.0 * a * I_PIVOT / h, h, 50);
        let floor = 1e-25 * energies[0];
        for pair in energies.windows(2) {
            assert!(
                pair[1] <= pair[0] + floor,
                "a = {a}: {} -> {}",
                pair[0],
                pair[1]
            );
        }
        // Energy after 50 steps: the rate factor's square per step, ((1 − a)/(1 + a))^100
        // (4.502e-5 at a = 0.05, 0 at a = 1, 0.6703 at a = 500); measured 4.5016e-5,
        // 1.3e-35 and 0.6703 (relative differences 1.5e-4, -, 2e-10: the chord of the
        // maximal-coordinate step).
        let expected = ((1.0 - a) / (1.0 + a)).powi(100);
        let last = energies[50] / energies[0];
        assert!(dissipated > 0.0, "a = {a}");
        assert!(
            (last - expected).abs() <= 1e-3 * expected + 1e-30,
            "a = {a}: {last} vs {expected}"
        );
    }
}

/// The damper's balance: the kinetic energy lost equals the recorded dissipation
/// `Σ b Δθ²/h` to O(h²) (the maximal-coordinate step moves the centre along the chord).
#[test]
fn the_damping_balance_closes_to_second_order() {
    let b = 10.1;
    let open = |h: f64, steps: u32| {
        let (energies, dissipated) = spin_down(b, h, steps);
        (energies[0] - energies[energies.len() - 1] - dissipated).abs() / energies[0]
    };
    let (coarse, fine) = (open(1e-2, 50), open(5e-3, 100));
    // Measured 7.4e-5 and 1.9e-5 of the initial 4.5 J: ratio 4.0.
    assert!(coarse < 1e-4, "{coarse:e}");
    assert!((3.6..4.4).contains(&(coarse / fine)), "{coarse:e} {fine:e}");
}

/// Which drives skip `θ_{k+1}` and `∇θ(q_{k+1})` in Newton's iterations: a motor without
/// damping; not a servo, not a damped motor, not a damper alone.
#[test]
fn only_undamped_motors_are_time_only() {
    let (model, _) = driven(0.3, motor(Signal::Constant(0.5)));
    assert!(super::drives::time_only(&model, &model.drives[0]));
    let damped = JointDrive {
        damping: 0.1,
        ..motor(Signal::Constant(0.5))
    };
    assert!(!super::drives::time_only(&model, &damped));
    let damper = JointDrive {
        coordinate: 0,
        actuator: None,
        damping: 0.1,
    };
    assert!(!super::drives::time_only(&model, &damper));
    let servo = position_servo(0.2, 50.0, 1.0, 0.0);
    assert!(!super::drives::time_only(&model, &servo));
}

/// The time-only path (effort once per attempt, `θ_{k+1}` and `∇θ(q_{k+1})` once at the
/// commit) steps the same bits as the general drive row, which evaluates them at every
/// iterate: a sine motor that saturates at its effort limit, under gravity, 400 steps.
#[test]
fn a_time_only_motor_steps_the_bits_of_the_general_row() {
    let mut drive = motor(Signal::Sine {
        amplitude: 3.0,
        frequency_hz: 2.0,
        phase: 0.4,
        offset: 0.5,
    });
    drive.actuator.as_mut().unwrap().effort_limit = Some(2.5);
    let run_bits = |general: bool| {
        let (model, mut bodies) = driven(0.7, drive.clone());
        let mut state = MechanismState::new(&model);
        if general {
            state
                .ws
                .drives
                .time_only
                .iter_mut()
                .for_each(|t| *t = false);
        }
        assert_eq!(state.ws.drives.time_only, [!general]);
        let mut warm = Warm::new(&model);
        let settings = VariationalSettings::default();
        let mut loads = Loads::uniform_gravity(Vector3::new(0.0, 0.0, -9.81));
        let h = 4e-3;
        let mut bits = Vec::new();
        for k in 0..400 {
            loads.set_time(f64::from(k) * h);
            step(
                &model,
                &mut state,
                &mut warm,
                &mut bodies,
                h,
                &loads,
                &settings,
            );
            let q = bodies.world_from_body[0].coords;
            let values = [
                q.x,
                q.y,
                q.z,
                q.w,
                bodies.angmom_body[0].y,
                bodies.com_world[0].x,
            ];
            bits.extend(values.iter().map(|v| v.to_bits()));
        }
        let work = state.ws.drive_work.actuators;
        bits.push(work.to_bits());
        (bits, work)
    };
    let (deferred, work) = run_bits(false);
    let (general, _) = run_bits(true);
    // The motor did work (it saturates at 2.5 N m and turns the rod): measured −0.121 J.
    assert!(work.abs() > 0.05, "{work}");
    assert!(deferred == general, "the time-only path changed the bits");
}

/// The pendulum's workspace with both poses at the body's pose, the drive's start row taken at
/// `h`, the drive impulse `ν = nu` and the child's largest torque impulse `impulse_scale`.
fn drive_row_workspace(
    drive: JointDrive,
    h: f64,
    nu: f64,
    impulse_scale: f64,
) -> (Mechanism, Workspace) {
    let (model, bodies) = driven(0.7, drive);
    let mut ws = MechanismState::new(&model).ws;
    let pose = BodyPose {
        rot: bodies.world_from_body[0].to_rotation_matrix().into_inner(),
        com: bodies.com_world[0],
    };
    ws.pose_k[0] = pose;
    ws.pose_next[0] = pose;
    ws.time0_secs = 0.0;
    ws.drive_rows_start(&model, h).unwrap();
    let (j, row) = ws.drives.slot[0];
    ws.lambda[j][row] = nu;
    ws.impulse_scale[0] = impulse_scale;
    (model, ws)
}

/// An undamped motor's row at an iterate, by hand: residual `r = ν − (h/2) τ̄`, diagonal 1, and
/// the convergence ratio `|r| / (tol · max(|ν|, (h/2)|τ̄|, impulse scale))`, each of the three
/// scales the largest in turn.
#[test]
fn an_undamped_motor_row_reads_its_residual_against_its_scale() {
    let (h, tol) = (0.01, 1e-9);
    // τ̄ = 2 N m: (h/2) τ̄ = 0.01.
    for (nu, impulse_scale, scale) in [(0.5, 0.02, 0.5), (0.004, 0.002, 0.01), (0.004, 0.3, 0.3)] {
        let (model, mut ws) =
            drive_row_workspace(motor(Signal::Constant(2.0)), h, nu, impulse_scale);
        assert!(ws.drives.time_only[0]);
        let ratio = ws.drive_rows_end(&model, h, tol).unwrap();
        let (j, row) = ws.drives.slot[0];
        let r = nu - 0.01;
        assert_eq!(ws.constraint_residual[j][row], r);
        assert_eq!(ws.solver.free_row_diag[j][row], 1.0);
        let expected = r.abs() / (tol * scale);
        assert!(
            (ratio - expected).abs() <= 1e-12 * expected,
            "{ratio} {expected}"
        );
    }
}

/// A stiff servo's row (`c = (h/4) kp + kd/2 = 7.5 ≥ 1`) divided by `c`: right row `∇θ(q_{k+1})`,
/// diagonal `1/c`, residual `r/c` with `r = ν − (h/2) kp (r_target − θ)` at `θ_k = θ_{k+1}`.
#[test]
fn a_stiff_servo_row_is_divided_by_its_slope() {
    let (h, tol, kp, kd) = (0.01, 1e-9, 1000.0, 10.0);
    let servo = position_servo(0.8, kp, kd, 0.0);
    let nu = 0.3;
    let (model, mut ws) = drive_row_workspace(servo, h, nu, 0.0);
    assert!(!ws.drives.time_only[0]);
    ws.drive_rows_end(&model, h, tol).unwrap();
    let (j, row) = ws.drives.slot[0];
    let c = 0.25 * h * kp + 0.5 * kd;
    // τ̄ = kp (0.8 − 0.7) = 100 N m; r = 0.3 − 0.5 = −0.2.
    let r = nu - 0.5 * h * kp * (0.8 - 0.7);
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs().max(1e-300);
    assert!(
        close(ws.constraint_residual[j][row], r / c),
        "{}",
        ws.constraint_residual[j][row]
    );
    assert!(close(ws.solver.free_row_diag[j][row], 1.0 / c));
    let (_, ga, gb) = model.coordinates[0]
        .kind
        .gradient(&BodyPose::identity(), &ws.pose_next[0], 0.7)
        .unwrap();
    // The hinge's unit gradient (about the y axis): a unit torque row each side.
    assert!(
        (gb.norm() - 1.0).abs() < 1e-12 && (ga.norm() - 1.0).abs() < 1e-12,
        "{ga} {gb}"
    );
    let (jp, jc) = &ws.jac_next[j];
    for col in 0..6 {
        assert!((jp[(row, col)] - ga[col]).abs() <= 1e-15, "{jp}");
        assert!((jc[(row, col)] - gb[col]).abs() <= 1e-15, "{jc}");
    }
}

/// A damped servo's convergence ratio at an iterate, by hand: `|r| / (tol · scale + floor)`,
/// `scale = max(|ν|, (h/2) magnitude, impulse scale)`, and the floor of `θ`'s round-off through
/// the slope, `(h/2) |slope| · 8 ε (max |c_child| + length scale)`, alone when `tol = 0`.
#[test]
fn a_damped_servo_row_reads_its_residual_against_its_scale_and_floor() {
    let (h, kp, kd, b) = (0.01, 1000.0, 10.0, 2.0);
    let servo = position_servo(0.8, kp, kd, b);
    // At θ_k = θ_{k+1} = 0.7: τ̄ = kp (0.8 − 0.7) = 100 N m, (h/2) τ̄ = 0.5; slope
    // −b/h − kp/2 − kd/h = −1700; magnitude b·140 + kp (0.8 + 0.7) + kd·140 = 3180, (h/2)·that
    // = 15.9 (140 = (|θ_k| + |θ_{k+1}|)/h).
    let slope = 1700.0;
    for (nu, impulse_scale, tol, scale) in [
        (40.0, 0.0, 1e-9, 40.0),
        (0.3, 0.0, 1e-9, 15.9),
        (0.3, 50.0, 1e-9, 50.0),
        (0.3, 0.0, 0.0, 15.9),
    ] {
        let (model, mut ws) = drive_row_workspace(servo.clone(), h, nu, impulse_scale);
        let ratio = ws.drive_rows_end(&model, h, tol).unwrap();
        let com = ws.pose_next[0].com.amax();
        // The rod's centre 1 m from the pivot at 0.7 rad: max(sin, cos) 0.7.
        assert!((com - 0.7f64.cos()).abs() < 1e-12, "{com}");
        let floor = 0.5 * h * slope * 8.0 * f64::EPSILON * (com + model.length_scale);
        let r: f64 = nu - 0.5;
        let expected = r.abs() / (tol * scale + floor);
        assert!(
            (ratio - expected).abs() <= 1e-9 * expected,
            "{ratio} {expected} ({nu}, {tol})"
        );
    }
}
