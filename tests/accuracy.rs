//! Accuracy on demand (issue 17): the error model against the exact torque-free motion, the
//! substep factors `--accuracy` chooses, their cost, and the a posteriori check.

use nalgebra::{Isometry3, UnitQuaternion, Vector3};
use tumble::dataset::rng::Rng;
use tumble::sim::accuracy::measure::achieved_error;
use tumble::sim::accuracy::model::{ErrorModel, factor_from};
use tumble::sim::integrators::VariationalSettings;
use tumble::sim::limits::spin_rate_max;
use tumble::sim::{BodyInit, IntegratorKind};

/// A body with principal moments `j`, orientation `q0` and body angular velocity along `dir`
/// scaled so that its largest |Ω| on the orbit is `w_max` rad/s.
fn body(j: Vector3<f64>, q0: UnitQuaternion<f64>, dir: Vector3<f64>, w_max: f64) -> BodyInit {
    let m = j.component_mul(&dir);
    let s = w_max / spin_rate_max(&j, &m);
    BodyInit {
        mass: 1.0,
        principal_moments: j,
        world_from_body: Isometry3::from_parts(Default::default(), q0),
        linvel_world: Vector3::zeros(),
        angvel_world: q0 * (dir * s),
    }
}

/// Physical bodies of inertia ratio `r`: moments `(r, m, 1)` with the intermediate moment `m`
/// from the smallest the triangle inequality allows (`max(r, 1 - r)`: the flat disk at r = 0.5,
/// a slightly flattened rod below) to 1 (the round rod), five values, each with `states` random
/// spin directions and orientations drawn from `seed`.
fn shapes(r: f64, states: usize, seed: u64) -> Vec<BodyInit> {
    let mut rng = Rng::new(seed);
    let mut out = Vec::new();
    let lo = r.max(1.0 - r);
    for f in [0.0, 0.1, 0.5, 0.9, 1.0] {
        let j = Vector3::new(r, lo + f * (1.0 - lo), 1.0);
        for _ in 0..states {
            let dir = Vector3::new(
                rng.standard_normal(),
                rng.standard_normal(),
                rng.standard_normal(),
            )
            .normalize();
            let q0 = UnitQuaternion::from_euler_angles(
                rng.uniform01() * 6.0,
                rng.uniform01() * 3.0,
                rng.uniform01() * 6.0,
            );
            out.push(body(j, q0, dir, 1.0));
        }
    }
    out
}

fn settings() -> VariationalSettings {
    VariationalSettings {
        newton_tol: 1e-15,
        newton_max_iters: 30,
        ..Default::default()
    }
}

/// Inertia ratios of the tests.
const RATIOS: [f64; 5] = [1.0, 0.5, 0.1, 1e-2, 1e-3];

#[test]
#[ignore]
fn dump_validation() {
    let model = ErrorModel::default();
    for kind in [
        IntegratorKind::Variational,
        IntegratorKind::Variational4,
        IntegratorKind::Variational6,
    ] {
        for &r in &RATIOS {
            for b in shapes(r, 2, 2) {
                let j = b.principal_moments;
                let m = j.component_mul(&(b.world_from_body.rotation.inverse() * b.angvel_world));
                for h_w in [0.01, 0.1, 0.5] {
                    let t = 50.0;
                    let cal = model.calibrate(kind, &settings(), &j, &m, t);
                    let pred = cal.predicted_error(h_w);
                    let Some(e) = achieved_error(kind, &settings(), &b, h_w, 1, (t / h_w) as u64)
                    else {
                        continue;
                    };
                    println!(
                        "{} {r} {:.3} {h_w} pred {pred:.3e} got {e:.3e} ratio {:.3}",
                        kind.name(),
                        j.y,
                        e / pred
                    );
                }
            }
        }
    }
}

#[test]
#[ignore]
fn debug_ref() {
    use tumble::sim::Bodies;
    use tumble::sim::Integrator;
    use tumble::sim::reference::TorqueFree;
    let b = &shapes(1e-3, 2, 2)[0];
    let exact = TorqueFree::new(b).unwrap();
    println!(
        "{:?} {:?}",
        b.principal_moments,
        b.world_from_body.rotation.inverse() * b.angvel_world
    );
    let mut runs = Vec::new();
    for h in [0.01, 0.005] {
        let mut bodies = Bodies::new(std::slice::from_ref(b));
        let mut integ = IntegratorKind::Variational6.build(h, &settings());
        integ.init(&bodies);
        let n = (10.0 / h).round() as u64;
        for _ in 0..n {
            integ.step(&mut bodies, &Vector3::zeros());
        }
        runs.push(bodies.world_from_body[0]);
    }
    println!(
        "richardson {:e} exact {:e} {:e}",
        runs[0].angle_to(&runs[1]),
        runs[0].angle_to(&exact.orientation(10.0)),
        runs[1].angle_to(&exact.orientation(10.0))
    );
}
