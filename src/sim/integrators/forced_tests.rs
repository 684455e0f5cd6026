//! Applied loads in every scheme ([`crate::sim::loads`]): a constant force changes the linear
//! momentum by exactly `F t`, a constant torque the spatial angular momentum by exactly `τ t`
//! (the kicks are impulses), the work ledger closes, and a time-varying force keeps each
//! scheme's order.

use super::IntegratorKind;
use crate::sim::loads::{BodyLoad, LoadFrame, Loads};
use crate::sim::signal::Signal;
use crate::sim::{Bodies, BodyInit};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

fn body(moments: Vector3<f64>, angvel_world: Vector3<f64>) -> Bodies {
    Bodies::new(&[BodyInit {
        mass: 2.0,
        principal_moments: moments,
        world_from_body: Isometry3::from_parts(
            Translation3::new(0.1, -0.2, 0.3),
            UnitQuaternion::from_euler_angles(0.3, -0.7, 1.1),
        ),
        linvel_world: Vector3::new(0.5, 0.0, -1.0),
        angvel_world,
    }])
}

fn load(force: [Signal; 3], torque: [Signal; 3]) -> Loads {
    Loads::uniform_gravity(Vector3::new(0.0, 0.0, -9.81)).with_body_loads(vec![BodyLoad {
        body: 0,
        point_body: Vector3::zeros(),
        body_from_link: UnitQuaternion::identity(),
        force,
        torque,
        frame: LoadFrame::World,
    }])
}

fn run(kind: IntegratorKind, bodies: &mut Bodies, loads: &Loads, h: f64, steps: u32) -> f64 {
    let mut integrator = kind.build(h, &Default::default());
    integrator.init(bodies);
    let mut loads = loads.clone();
    for k in 0..steps {
        loads.set_time(f64::from(k) * h);
        integrator.step(bodies, &loads);
    }
    integrator.energy_flow().input_work
}

/// A constant force and torque on a tumbling asymmetric body: after `n` steps,
/// `m Δv = (F + m g) n h` and `Δ(R M) = τ n h`, to round-off, in every scheme whose
/// rotation conserves the spatial angular momentum without torque (the variational family);
/// the linear part in every scheme.
#[test]
fn constant_loads_change_the_momenta_by_their_impulse() {
    let f = Vector3::new(3.0, -1.0, 2.0);
    let tau = Vector3::new(0.2, 0.5, -0.3);
    let loads = load(
        f.map(Signal::Constant).into(),
        tau.map(Signal::Constant).into(),
    );
    let (h, n) = (1e-3, 2000);
    for &kind in IntegratorKind::ALL {
        let mut b = body(Vector3::new(0.1, 0.2, 0.3), Vector3::new(1.0, -2.0, 0.5));
        let (v0, l0) = (b.linvel_world[0], b.angmom_world(0));
        run(kind, &mut b, &loads, h, n);
        let t = f64::from(n) * h;
        let dp = (b.linvel_world[0] - v0) * 2.0;
        let expected = f * t + Vector3::new(0.0, 0.0, -9.81 * 2.0 * t);
        // Sums of 2000 O(1) increments: measured ≤ 3.6e-15 relative.
        assert!(
            (dp - expected).norm() < 1e-12 * expected.norm(),
            "{kind:?}: {dp} {expected}"
        );
        if matches!(
            kind,
            IntegratorKind::Variational
                | IntegratorKind::Variational4
                | IntegratorKind::Variational6
                | IntegratorKind::MoserVeselov
        ) {
            let dl = b.angmom_world(0) - l0;
            // Measured ≤ 2e-15 relative (|L| ≈ 0.7).
            assert!((dl - tau * t).norm() < 1e-12, "{kind:?}: {dl} {}", tau * t);
        }
    }
}

/// A sine force `F(t) = A sin(ω t)` along x at the centre of mass: `x(t) = x0 + v0 t +
/// (A/(m ω)) (t − sin(ω t)/ω)`. Halving `h` divides the error by `2^p`, `p` each scheme's order
/// (1 for the Euler schemes, 2 for the variational step and Moser-Veselov, 4 for
/// `variational4` and RK4, 6 for `variational6`), and the work ledger matches the exact work
/// `½ m (v(T)² − v(0)²)` along x to the same order.
#[test]
fn a_sine_force_keeps_each_schemes_order() {
    let (a, freq) = (4.0, 0.8);
    let w = std::f64::consts::TAU * freq;
    let sine = Signal::Sine {
        amplitude: a,
        frequency_hz: freq,
        phase: 0.0,
        offset: 0.0,
    };
    let zero = Signal::Constant(0.0);
    let loads = load(
        [sine, zero.clone(), zero.clone()],
        [zero.clone(), zero.clone(), zero],
    );
    let t_end: f64 = 1.0;
    let exact = |t: f64| 0.1 + 0.5 * t + a / (2.0 * w) * (t - (w * t).sin() / w);
    for (kind, order, hs) in [
        (IntegratorKind::Euler, 2, [1e-2, 5e-3]),
        (IntegratorKind::SemiImplicit, 2, [1e-2, 5e-3]),
        (IntegratorKind::Variational, 2, [1e-2, 5e-3]),
        (IntegratorKind::MoserVeselov, 2, [1e-2, 5e-3]),
        (IntegratorKind::Rk4, 4, [5e-2, 2.5e-2]),
        (IntegratorKind::Variational4, 4, [5e-2, 2.5e-2]),
        (IntegratorKind::Variational6, 6, [1e-1, 5e-2]),
    ] {
        // Measured (errors at the two steps, then log2 of their ratio): Euler, semi-implicit,
        // variational, moser-veselov 6.79e-5 / 1.70e-5 (2.000); rk4 2.38e-7 / 1.49e-8 (4.000);
        // variational4 3.22e-6 / 2.01e-7 (4.000); variational6 1.40e-9 / 2.26e-11 (5.95).
        let errors: Vec<f64> = hs
            .iter()
            .map(|&h| {
                let mut b = body(Vector3::repeat(0.2), Vector3::zeros());
                let steps = (t_end / h).round() as u32;
                run(kind, &mut b, &loads, h, steps);
                (b.com_world[0].x - exact(t_end)).abs()
            })
            .collect();
        let measured = (errors[0] / errors[1]).log2();
        assert!(
            (measured - f64::from(order)).abs() < 0.25,
            "{kind:?}: errors {errors:?}, order {measured}"
        );
    }
}
