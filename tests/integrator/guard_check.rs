//! `Guard::check`, the divergence guard of every run, on hand-built states: which body stops the
//! run, at which energy exactly, and what the message says. Regression tests for the gaps a
//! mutation run found (docs/mutants.md): two bodies failing at one step, energy and pose failing
//! together on one body, a Newton failure and a state failure on different bodies, the energy
//! limit itself, and the growth ratio printed.
//!
//! Every state here is exact in binary floating point (moments and momenta are small integers or
//! powers of two), so the energies and ratios are asserted with `==`.

use nalgebra::{Isometry3, Quaternion, UnitQuaternion, Vector3};
use tumble::sim::guard::{Cause, DEFAULT_DIVERGENCE_ENERGY_RATIO, Divergence, Guard};
use tumble::sim::{Bodies, BodyInit, StepStats};

/// Principal moments `J = (1, 2, 4)` kg m² (inverses exact) spinning at `Ω = (1, 0, 0)` rad/s:
/// `M = (1, 0, 0)`, `T0 = M·J⁻¹M / 2 = 0.5` J.
fn body() -> BodyInit {
    BodyInit {
        mass: 1.0,
        principal_moments: Vector3::new(1.0, 2.0, 4.0),
        world_from_body: Isometry3::identity(),
        linvel_world: Vector3::zeros(),
        angvel_world: Vector3::new(1.0, 0.0, 0.0),
    }
}

/// `n` identical bodies and their guard (energy ratio 100, Newton failures stop the run).
fn batch(n: usize) -> (Bodies, Guard) {
    let bodies = Bodies::new(&vec![body(); n]);
    let guard = Guard::new(&bodies, DEFAULT_DIVERGENCE_ENERGY_RATIO, Some(1024));
    (bodies, guard)
}

/// `M = (5, 2, 58)` with `J = (1, 2, 4)`: `2T = 25 + 2 + 841 = 868`, i.e. `T = 868 T0` exactly.
const M_868: Vector3<f64> = Vector3::new(5.0, 2.0, 58.0);

fn no_failure() -> StepStats {
    StepStats::default()
}

fn newton_failure(body: usize) -> StepStats {
    StepStats {
        newton_failures: 1,
        failed_body: Some(body),
        ..StepStats::default()
    }
}

fn nan_quaternion() -> UnitQuaternion<f64> {
    UnitQuaternion::new_unchecked(Quaternion::new(f64::NAN, 0.0, 0.0, 0.0))
}

#[test]
fn an_unchanged_state_passes() {
    let (bodies, guard) = batch(3);
    assert_eq!(guard.check(&bodies, &no_failure(), 1), None);
}

/// With `|` replaced by `^` in the batch-wide fold, two bodies failing at the same step cancel
/// out and the run goes on to the end (seen by hand: two identical diverging boxes then exit 0).
#[test]
fn two_bodies_diverging_at_the_same_step_stop_the_run() {
    for failing in [vec![0, 1], vec![1, 2], vec![0, 1, 2], vec![0, 2]] {
        let (mut bodies, guard) = batch(3);
        for &i in &failing {
            bodies.angmom_body[i] = M_868;
        }
        let stop = guard.check(&bodies, &no_failure(), 7);
        assert_eq!(
            stop,
            Some(Divergence {
                body: failing[0],
                step: 7,
                cause: Cause::EnergyGrowth {
                    ratio: 868.0,
                    limit: 100.0
                },
            }),
            "failing bodies {failing:?}"
        );
    }
}

/// With `|` replaced by `^` between the energy test and the finiteness test, a body whose energy
/// and pose fail at the same step would pass.
#[test]
fn energy_and_pose_failing_together_on_one_body_stop_the_run() {
    let (mut bodies, guard) = batch(2);
    bodies.angmom_body[1] = M_868;
    bodies.com_world[1] = Vector3::new(f64::NAN, 0.0, 0.0);
    assert_eq!(
        guard.check(&bodies, &no_failure(), 3),
        Some(Divergence {
            body: 1,
            step: 3,
            cause: Cause::NonFinite { what: "position" },
        })
    );
    // Energy and orientation, energy and linear velocity.
    let (mut bodies, guard) = batch(1);
    bodies.angmom_body[0] = M_868;
    bodies.world_from_body[0] = nan_quaternion();
    assert_eq!(
        guard.check(&bodies, &no_failure(), 3).map(|d| d.cause),
        Some(Cause::NonFinite {
            what: "orientation"
        })
    );
    let (mut bodies, guard) = batch(1);
    bodies.angmom_body[0] = M_868;
    bodies.linvel_world[0] = Vector3::new(0.0, f64::INFINITY, 0.0);
    assert_eq!(
        guard.check(&bodies, &no_failure(), 3).map(|d| d.cause),
        Some(Cause::NonFinite {
            what: "linear velocity"
        })
    );
}

/// The limit is `ratio · T0` per body, and the rule is strict: `T = 100 T0` passes, the next
/// representable energy above it stops the run (`2.0 + limit` or `2.0 / limit` in place of
/// `2.0 * limit` would stop far below it, a limit from another body's `T0` would misplace it).
#[test]
fn the_energy_limit_is_the_ratio_times_each_bodys_initial_energy() {
    // Body 0: T0 = 0.5 J, limit 50 J. Body 1: Ω = (0, 0, 2) rad/s, M = (0, 0, 8), T0 = 8 J,
    // limit 800 J.
    let fast = BodyInit {
        angvel_world: Vector3::new(0.0, 0.0, 2.0),
        ..body()
    };
    let mut bodies = Bodies::new(&[body(), fast.clone()]);
    let guard = Guard::new(&bodies, 100.0, None);
    assert_eq!(bodies.rotational_energy(0), 0.5);
    assert_eq!(bodies.rotational_energy(1), 8.0);
    // At the limits exactly: M = (10, 0, 0) gives T = 50 J; M = (0, 0, 80) gives T = 800 J.
    bodies.angmom_body[0] = Vector3::new(10.0, 0.0, 0.0);
    bodies.angmom_body[1] = Vector3::new(0.0, 0.0, 80.0);
    assert_eq!(bodies.rotational_energy(0), 50.0);
    assert_eq!(bodies.rotational_energy(1), 800.0);
    assert_eq!(guard.check(&bodies, &no_failure(), 1), None);
    // Just above body 0's limit: M_y = 2^-20 adds M_y²/J_y = 2^-41 to 2T = 100, so
    // T/T0 = 2T = 100 + 2^-41 (exact: the spacing of doubles near 100 is 2^-46).
    bodies.angmom_body[0].y = 2f64.powi(-20);
    let stop = guard
        .check(&bodies, &no_failure(), 2)
        .expect("above the limit");
    assert_eq!(stop.body, 0);
    assert_eq!(
        stop.cause,
        Cause::EnergyGrowth {
            ratio: 100.0 + 2f64.powi(-41),
            limit: 100.0
        }
    );
    // Just above body 1's limit only (body 0 back at its limit): M_x = 2^-16 adds 2^-32 to
    // 2T = 1600.
    bodies.angmom_body[0].y = 0.0;
    bodies.angmom_body[1].x = 2f64.powi(-16);
    let stop = guard
        .check(&bodies, &no_failure(), 2)
        .expect("above the limit");
    assert_eq!(stop.body, 1);
    // Another ratio moves the limit with it: at ratio 1e3, T = 800 J on body 1 passes.
    let guard = Guard::new(&Bodies::new(&[body(), fast]), 1e3, None);
    assert_eq!(guard.check(&bodies, &no_failure(), 2), None);
}

/// The ratio in the message is `T / T0` (the "grew to 868 times"), printed with 4
/// significant digits, with the limit that was passed.
#[test]
fn the_message_gives_the_energy_growth_ratio_and_the_limit() {
    let (mut bodies, guard) = batch(1);
    bodies.angmom_body[0] = M_868;
    let stop = guard.check(&bodies, &no_failure(), 7).unwrap();
    assert_eq!(
        stop.cause,
        Cause::EnergyGrowth {
            ratio: 868.0,
            limit: 100.0
        }
    );
    assert_eq!(
        stop.cause.to_string(),
        "its rotational kinetic energy grew to 8.680e2 times the initial value \
         (limit sim.divergence_energy_ratio = 100): the integrator is unstable at this step size"
    );
}

/// A Newton failure on one body and a bad state on another at the same step: the lower index
/// is named, with its own cause. On the same body the Newton failure is named (it is the cause:
/// the state is the unconverged solve's).
#[test]
fn newton_and_state_failures_on_different_bodies_name_the_lower_index() {
    let (mut bodies, guard) = batch(3);
    bodies.angmom_body[1] = M_868;
    let newton_on_2 = guard.check(&bodies, &newton_failure(2), 4);
    assert_eq!(
        newton_on_2,
        Some(Divergence {
            body: 1,
            step: 4,
            cause: Cause::EnergyGrowth {
                ratio: 868.0,
                limit: 100.0
            },
        })
    );
    let newton_on_0 = guard.check(&bodies, &newton_failure(0), 4);
    assert_eq!(
        newton_on_0,
        Some(Divergence {
            body: 0,
            step: 4,
            cause: Cause::NewtonFailed { max_substeps: 1024 },
        })
    );
    let newton_on_1 = guard.check(&bodies, &newton_failure(1), 4);
    assert_eq!(
        newton_on_1.map(|d| (d.body, d.cause)),
        Some((1, Cause::NewtonFailed { max_substeps: 1024 }))
    );
    // Newton alone.
    let (bodies, guard) = batch(3);
    assert_eq!(
        guard.check(&bodies, &newton_failure(2), 5),
        Some(Divergence {
            body: 2,
            step: 5,
            cause: Cause::NewtonFailed { max_substeps: 1024 },
        })
    );
    assert_eq!(
        Cause::NewtonFailed { max_substeps: 1024 }.to_string(),
        "the implicit step's Newton solve did not converge, not even split into 1024 substeps"
    );
}

/// With substepping off (`None`), a Newton failure is counted by the integrator, not a stop.
#[test]
fn newton_failures_do_not_stop_a_run_without_substepping() {
    let bodies = Bodies::new(&[body(), body()]);
    let guard = Guard::new(&bodies, 100.0, None);
    assert_eq!(guard.check(&bodies, &newton_failure(1), 5), None);
}

/// Each non-finite state variable is named, checked in the order angular momentum,
/// orientation, position, linear velocity; a NaN energy from finite but overflowing momenta
/// is named as the energy.
#[test]
fn each_non_finite_state_variable_is_named() {
    type Spoil = fn(&mut Bodies);
    let cases: [(Spoil, &str); 5] = [
        (
            |b| b.angmom_body[0] = Vector3::new(0.0, 0.0, f64::NAN),
            "angular momentum",
        ),
        (|b| b.world_from_body[0] = nan_quaternion(), "orientation"),
        (
            |b| b.com_world[0] = Vector3::new(0.0, f64::NEG_INFINITY, 0.0),
            "position",
        ),
        (
            |b| b.linvel_world[0] = Vector3::new(0.0, 0.0, f64::NAN),
            "linear velocity",
        ),
        (
            // Finite momentum, infinite energy (1e200² overflows).
            |b| b.angmom_body[0] = Vector3::new(1e200, 0.0, 0.0),
            "rotational kinetic energy",
        ),
    ];
    for (spoil, what) in cases {
        let (mut bodies, guard) = batch(2);
        spoil(&mut bodies);
        // Angular momentum before orientation: both spoiled, the momentum is named.
        assert_eq!(
            guard.check(&bodies, &no_failure(), 9),
            Some(Divergence {
                body: 0,
                step: 9,
                cause: Cause::NonFinite { what },
            }),
            "{what}"
        );
        assert_eq!(
            Cause::NonFinite { what }.to_string(),
            format!("its {what} is not finite (NaN or infinite)")
        );
    }
    let (mut bodies, guard) = batch(1);
    bodies.angmom_body[0] = Vector3::new(f64::NAN, 0.0, 0.0);
    bodies.world_from_body[0] = nan_quaternion();
    assert_eq!(
        guard.check(&bodies, &no_failure(), 9).map(|d| d.cause),
        Some(Cause::NonFinite {
            what: "angular momentum"
        })
    );
}

/// A body far away and fast, but finite, is not a divergence: the guard's finiteness test sums
/// the pose and velocity (a product there would overflow at 1e200 m · 1e200 m/s and stop the run).
#[test]
fn a_huge_but_finite_translation_is_not_a_divergence() {
    let (mut bodies, guard) = batch(2);
    bodies.com_world[1] = Vector3::new(1e200, 0.0, 0.0);
    bodies.linvel_world[1] = Vector3::new(0.0, 1e200, 0.0);
    assert_eq!(guard.check(&bodies, &no_failure(), 1), None);
}

/// Issue 28 item 9: a body whose values are all finite but whose position and velocity
/// components sum past the largest f64 (`linvel = [1e308, 1e308, 0]`) was reported as an
/// energy growth of "1.000e0 times (limit 100)". It is named as out of range, and a huge limit
/// reads as `1e300`, not as 301 digits.
#[test]
fn finite_values_too_large_to_add_are_out_of_range_not_an_energy_growth() {
    let (mut bodies, guard) = batch(2);
    bodies.linvel_world[1] = Vector3::new(1e308, 1e308, 0.0);
    let stop = guard.check(&bodies, &no_failure(), 1).unwrap();
    assert_eq!(stop.body, 1);
    assert_eq!(
        stop.cause,
        Cause::OutOfRange {
            what: "position or linear velocity"
        }
    );
    let text = stop.cause.to_string();
    assert!(text.contains("went out of range"), "{text}");
    assert!(!text.contains("grew"), "{text}");
    let cause = Cause::EnergyGrowth {
        ratio: 2e300,
        limit: 1e300,
    };
    assert!(
        cause.to_string().contains(
            "grew to 2.000e300 times the initial value (limit sim.divergence_energy_ratio = 1e300)"
        ),
        "{cause}"
    );
}
