//! The variational integrator against closed forms and conservation laws.

use crate::common::bodies::{body, tumbling_body};
use nalgebra::{UnitQuaternion, Vector3};
use tumble::sim::Loads;
use tumble::sim::integrators::{Integrator, Potential, Variational, VariationalSettings};
use tumble::sim::reference::{Axisymmetric, parabola, rotation_error};
use tumble::sim::so3;
use tumble::sim::{Bodies, BodyInit};

fn run(
    init: &BodyInit,
    dt: f64,
    steps: u64,
    settings: VariationalSettings,
    g: Vector3<f64>,
) -> Bodies {
    let mut bodies = Bodies::new(std::slice::from_ref(init));
    let mut integ = Variational::new(dt, settings);
    integ.init(&bodies);
    for _ in 0..steps {
        integ.step(&mut bodies, &Loads::uniform_gravity(g));
    }
    bodies
}

/// Spatial angular momentum `R_k M_k` is conserved to round-off over 1e5 steps, and the energy
/// error stays bounded with no drift (it oscillates with the tumbling period).
#[test]
fn momentum_conserved_and_energy_bounded_over_1e5_steps() {
    let init = tumbling_body();
    let dt = 0.01;
    let mut bodies = Bodies::new(std::slice::from_ref(&init));
    let mut integ = Variational::new(dt, VariationalSettings::default());
    integ.init(&bodies);
    let g = Vector3::zeros();
    let l0 = bodies.angmom_world(0);
    let e0 = bodies.rotational_energy(0);
    let steps = 100_000;
    let mut l_err_max: f64 = 0.0;
    let mut e_err_first: f64 = 0.0; // max over the first tenth
    let mut e_err_last: f64 = 0.0; // max over the last tenth
    for k in 1..=steps {
        integ.step(&mut bodies, &Loads::uniform_gravity(g));
        l_err_max = l_err_max.max((bodies.angmom_world(0) - l0).norm() / l0.norm());
        let e_err = (bodies.rotational_energy(0) - e0).abs() / e0;
        if k <= steps / 10 {
            e_err_first = e_err_first.max(e_err);
        }
        if k > steps - steps / 10 {
            e_err_last = e_err_last.max(e_err);
        }
    }
    // Round-off: ~sqrt(1e5) * 1e-16 ≈ 3e-14 for a random walk. Measured 8.0e-14.
    assert!(l_err_max < 1e-12, "angular momentum drift {l_err_max:e}");
    // The energy error itself: measured 2.13e-5 in both tenths (its O(h²) order is checked in
    // `energy_error_is_second_order`); bound 2.5e-5, the margin for rounding differences only
    // (the run is deterministic).
    assert!(e_err_first < 2.5e-5, "energy error {e_err_first:e}");
    // No drift: the last tenth's maximum error is no larger than the first tenth's (within 10 %).
    // Measured ratio 0.99999998.
    assert!(
        e_err_last <= 1.1 * e_err_first,
        "energy drift: {e_err_first:e} -> {e_err_last:e}"
    );
}

/// The energy error of the tumbling body is O(h²): its largest value over the same 100 s at
/// h = 0.01 s and 0.005 s has the ratio 4.
#[test]
fn energy_error_is_second_order() {
    let init = tumbling_body();
    let max_energy_error = |dt: f64| {
        let mut bodies = Bodies::new(std::slice::from_ref(&init));
        let mut integ = Variational::new(dt, VariationalSettings::default());
        integ.init(&bodies);
        let e0 = bodies.rotational_energy(0);
        let mut worst: f64 = 0.0;
        for _ in 0..(100.0 / dt).round() as u64 {
            integ.step(&mut bodies, &Loads::none());
            worst = worst.max((bodies.rotational_energy(0) - e0).abs() / e0);
        }
        worst
    };
    let (coarse, fine) = (max_energy_error(0.01), max_energy_error(0.005));
    let order = (coarse / fine).log2();
    // Measured 1.999995 (2.13e-5 and 5.32e-6); bound ±0.01 (the next term is O(h⁴): relative
    // size (h|Ω|)² = 9e-4 at h = 0.01 s).
    assert!(
        (order - 2.0).abs() < 0.01,
        "{coarse:e} / {fine:e}: order {order}"
    );
}

/// Global order 2 in orientation against the axisymmetric closed form.
#[test]
fn orientation_converges_with_order_two() {
    let reference = Axisymmetric {
        ip: 2.0,
        i3: 0.6,
        world_from_body_0: UnitQuaternion::from_euler_angles(0.3, -0.5, 0.8),
        omega_body_0: Vector3::new(0.6, -0.3, 2.5),
    };
    let init = body(
        Vector3::new(reference.ip, reference.ip, reference.i3),
        reference.world_from_body_0,
        reference.world_from_body_0 * reference.omega_body_0,
    );
    let t_end: f64 = 4.0;
    let settings = VariationalSettings {
        newton_tol: 1e-15,
        newton_max_iters: 50,
        ..Default::default()
    };
    let errors: Vec<f64> = [0.02, 0.01, 0.005, 0.0025]
        .iter()
        .map(|&dt| {
            let steps = (t_end / dt).round() as u64;
            let b = run(&init, dt, steps, settings, Vector3::zeros());
            rotation_error(&b.world_from_body[0], &reference.orientation(t_end))
        })
        .collect();
    for w in errors.windows(2) {
        let order = (w[0] / w[1]).log2();
        // Measured orders 1.9999976, 1.9999994, 1.9999998.
        assert!(
            (order - 2.0).abs() < 0.1,
            "errors {errors:?}, order {order}"
        );
    }
    // The error itself is small: measured 3.7e-4 rad at dt = 0.02 s.
    assert!(errors[0] < 1e-3, "{errors:?}");
}

/// The symmetric potential gives the exact parabola (round-off only); the end-point potential
/// lags by exactly `t h g / 2`.
#[test]
fn parabola_exact_with_symmetric_potential_and_offset_with_end_point() {
    let init = tumbling_body();
    let g = Vector3::new(0.0, 0.0, -9.81);
    let dt = 0.01;
    let t = 1.0;
    let steps = 100;
    let (c_exact, v_exact) = parabola(
        &init.world_from_body.translation.vector,
        &init.linvel_world,
        &Loads::uniform_gravity(g),
        t,
    );

    let sym = run(&init, dt, steps, VariationalSettings::default(), g);
    // Round-off over 100 steps: measured 3.1e-15 m and 8.9e-15 m/s.
    assert!(
        (sym.com_world[0] - c_exact).norm() < 1e-13,
        "{}",
        sym.com_world[0] - c_exact
    );
    assert!((sym.linvel_world[0] - v_exact).norm() < 1e-12);

    let end = run(
        &init,
        dt,
        steps,
        VariationalSettings {
            potential: Potential::EndPoint,
            ..Default::default()
        },
        g,
    );
    let offset = end.com_world[0] - c_exact;
    let predicted = -g * (t * dt / 2.0); // the position lags by t h g / 2 = 0.04905 m (upwards)
    // Exact up to round-off: measured difference 3.4e-15 m.
    assert!(
        (offset - predicted).norm() < 1e-12,
        "offset {offset}, predicted {predicted}"
    );
    assert!((predicted.norm() - 0.04905).abs() < 1e-12);
}

/// The discrete Legendre transform: the initial body momentum is exactly `J Ω0`, so the recorded
/// angular velocity at t = 0 equals the requested one (taking ξ0 = hΩ0 would be off by O(h)),
/// and ξ0 solves `J ξ = h T(ξ)^T M0` (checked with the matrix `T` of `so3::t_matrix`, not the
/// integrator's own vector form), which differs from `hΩ0` by exactly
/// `-(h²/2) J⁻¹ (Ω0 × M0) + O(h³)` (`T(ξ)^T M = M - ξ×M/2 + O(ξ²)`).
#[test]
fn initial_momentum_is_j_omega() {
    let init = tumbling_body();
    let bodies = Bodies::new(std::slice::from_ref(&init));
    let omega = bodies.angvel_world(0);
    assert!((omega - init.angvel_world).norm() < 1e-15 * init.angvel_world.norm().max(1.0) * 10.0);
    let m0 = bodies.angmom_body[0];
    let j = bodies.inertia_body[0];
    let omega0 = bodies.angvel_body(0);
    let remainder = |h: f64| {
        let mut integ = Variational::new(h, VariationalSettings::default());
        integ.init(&bodies);
        let xi = integ.xi()[0];
        // The implicit equation. The stopping rule allows 1e-12 · h|M0|∞, but Newton converges
        // quadratically and stops far below: measured 5.0e-17 (h = 0.1 s) and 1.6e-15
        // (h = 0.05 s) relative to h|M0|∞; bound 1e-14.
        let residual = j.component_mul(&xi) - so3::t_matrix(&xi).transpose() * m0 * h;
        let relative = residual.amax() / (h * m0.amax());
        assert!(relative < 1e-14, "h = {h}: residual {relative:e}");
        let leading = -(omega0.cross(&m0)).component_div(&j) * (h * h / 2.0);
        // The second-order term is really there: measured |ξ0 - hΩ0| = 1.26e-2 at h = 0.1 s.
        assert!((xi - omega0 * h).norm() > 0.5 * leading.norm());
        (xi - omega0 * h - leading).norm()
    };
    let (coarse, fine) = (remainder(0.1), remainder(0.05));
    // What is left is O(h³): halving h divides it by 8. Measured log2 ratio 2.994 (remainders
    // 9.8e-4 and 1.23e-4 rad); bound ±0.15 (the O(h⁴) term at h|Ω| = 0.3).
    let order = (coarse / fine).log2();
    assert!(
        (order - 3.0).abs() < 0.15,
        "{coarse:e} / {fine:e}: order {order}"
    );
}
