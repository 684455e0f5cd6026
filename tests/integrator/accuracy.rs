//! Accuracy on demand (issue 17): the error model against the exact torque-free motion, the
//! substep factors `--accuracy` chooses, their cost, and the a posteriori check.

use nalgebra::{Isometry3, UnitQuaternion, Vector3};
use tumble::scene::placement::rng::Rng;
use tumble::sim::Loads;
use tumble::sim::accuracy::Substepped;
use tumble::sim::accuracy::measure::achieved_error;
use tumble::sim::accuracy::model::ErrorModel;
use tumble::sim::accuracy::plan::{Plan, check};
use tumble::sim::{Bodies, Integrator};

use crate::common;
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

fn angmom_body(b: &BodyInit) -> Vector3<f64> {
    let q = b.world_from_body.rotation;
    b.principal_moments
        .component_mul(&q.inverse_transform_vector(&b.angvel_world))
}

/// The validation table of docs/accuracy.md: predicted against achieved error (k = 1) on states
/// the pilot never saw (seed 2), `h W` = 0.01, 0.1, 0.5, `T` = 50 s. Prints one line per case
/// (`kind r J_mid hW predicted achieved ratio`) and draws docs/accuracy/validation.png; not run
/// by default (about a minute):
/// `cargo test --release --test integrator accuracy::validation_table -- --ignored --nocapture`.
#[test]
#[ignore]
fn validation_table() {
    let model = ErrorModel::default();
    let mut points = Vec::new();
    for kind in [
        IntegratorKind::Variational,
        IntegratorKind::Variational4,
        IntegratorKind::Variational6,
    ] {
        for &r in &RATIOS {
            for b in shapes(r, 2, 2) {
                let j = b.principal_moments;
                let m = angmom_body(&b);
                for h_w in [0.01, 0.1, 0.5] {
                    let t: f64 = 50.0;
                    let cal = model.calibrate(kind, &settings(), &j, &m, t);
                    let pred = cal.predicted_error(h_w);
                    let steps = (t / h_w).round() as u64;
                    let Some(e) = achieved_error(kind, &settings(), &b, h_w, 1, steps) else {
                        continue;
                    };
                    println!(
                        "{} {r} {:.3} {h_w} {pred:.3e} {e:.3e} {:.3}",
                        kind.name(),
                        j.y,
                        e / pred
                    );
                    points.push(tumble::plot::accuracy::Point {
                        integrator: kind.name().into(),
                        predicted: pred,
                        achieved: e,
                    });
                }
            }
        }
    }
    let png = common::root().join("docs/accuracy/validation.png");
    std::fs::create_dir_all(png.parent().unwrap()).unwrap();
    tumble::plot::accuracy::validation(&png, &points).unwrap();
}

/// Issue 17's acceptance test: across inertia ratios 1..1e-3 (physical shapes, states of seed 3:
/// neither the validation's nor any pilot's), h|Ω|max = 1e-3, 0.1 and 3, T = 20 s, the factor
/// the model picks for TOL = 1e-3, 1e-6, 1e-9 (variational, order 2, and variational4) gives an achieved error (against the exact motion) within TOL, and within
/// 100x of it unless k = 1 already beats it. Why 100x holds: the model's achieved / predicted
/// ratio on the validation set is 0.2-1.27 in the asymptotic range the chosen substeps are in,
/// the factor is chosen for TOL / 2 (`model::SAFETY`), and rounding k up costs at most
/// `((k)/(k-1))^p` (16x for p = 4 at k = 2).
#[test]
fn chosen_factors_meet_the_tolerance_without_waste() {
    let model = ErrorModel::default();
    let t: f64 = 20.0;
    let mut worst_over: f64 = 0.0;
    let mut worst_under: f64 = f64::INFINITY;
    let mut cases = 0;
    for (kind, tols) in [
        (IntegratorKind::Variational, &[1e-3, 1e-6, 1e-9][..]),
        (IntegratorKind::Variational4, &[1e-3, 1e-6, 1e-9][..]),
    ] {
        for &tol in tols {
            for &r in &RATIOS {
                for b in shapes(r, 1, 3).into_iter().step_by(2) {
                    let j = b.principal_moments;
                    let m = angmom_body(&b);
                    for h_w in [1e-3, 0.1, 3.0] {
                        let steps = (t / h_w).round() as u64;
                        let f = model.factor(kind, &settings(), &j, &m, h_w, t, tol);
                        let Some(e) = achieved_error(kind, &settings(), &b, h_w, f.k, steps) else {
                            continue;
                        };
                        cases += 1;
                        let what = format!(
                            "{} TOL {tol:e} J {j:?} hW {h_w}: k {} achieved {e:.3e} predicted {:.3e}",
                            kind.name(),
                            f.k,
                            f.predicted_rad
                        );
                        assert!(e <= tol, "{what}");
                        worst_over = worst_over.max(e / tol);
                        if f.k > 1 {
                            assert!(e >= tol / 100.0, "wasteful: {what}");
                            worst_under = worst_under.min(e / tol);
                        }
                    }
                }
            }
        }
    }
    // Measured: 270 cases, achieved / TOL at most 0.579; at least 0.035 where k > 1.
    println!(
        "{cases} cases; achieved / TOL: max {worst_over:.3}, min where k > 1 {worst_under:.3}"
    );
    assert!(cases >= 250);
}

/// One fast body among many slow ones: the plan's cost (Σ k) is within 1.5x of the ideal
/// per-body choice (each body's smallest k whose achieved error meets TOL, found by search
/// against the exact motion) and far below giving every body the fast one's factor.
#[test]
fn mixed_batch_costs_near_the_ideal_choice() {
    let tol = 1e-4;
    let (dt, t) = (0.05, 20.0);
    let steps = (t / dt) as u64;
    let kind = IntegratorKind::Variational;
    let mut bodies = Vec::new();
    let mut rng = Rng::new(11);
    for i in 0..64 {
        let j = Vector3::new(0.3 + 0.01 * (i % 7) as f64, 0.8, 1.0);
        let dir = Vector3::new(
            rng.standard_normal(),
            rng.standard_normal(),
            rng.standard_normal(),
        )
        .normalize();
        bodies.push(body(j, UnitQuaternion::identity(), dir, 0.01));
    }
    bodies.push(body(
        Vector3::new(0.1, 0.95, 1.0),
        UnitQuaternion::from_euler_angles(0.2, 0.4, -0.3),
        Vector3::new(0.3, 1.0, 0.2).normalize(),
        5.0,
    ));
    let plan = Plan::new(
        kind,
        &settings(),
        &ErrorModel::default(),
        &bodies,
        dt,
        t,
        tol,
    );
    let ideal: Vec<u32> = bodies
        .iter()
        .map(|b| {
            let meets = |k: u32| achieved_error(kind, &settings(), b, dt, k, steps).unwrap() <= tol;
            let mut hi = 1;
            while !meets(hi) {
                hi *= 2;
            }
            let mut lo = hi / 2; // fails (or 0)
            while hi - lo > 1 {
                let mid = (lo + hi) / 2;
                if meets(mid) { hi = mid } else { lo = mid }
            }
            hi
        })
        .collect();
    let ideal_cost: u64 = ideal.iter().map(|&k| u64::from(k)).sum();
    let k_fast = *ideal.last().unwrap();
    let uniform_cost = u64::from(k_fast) * bodies.len() as u64;
    let ks = plan.ks();
    // Measured: plan 221 (fast k 157), ideal 175 (fast k 111): 1.26x; uniform 111 x 65 = 7215.
    println!(
        "plan {} (fast k {}), ideal {ideal_cost} (fast k {k_fast}), uniform {uniform_cost}",
        plan.cost(),
        ks[64]
    );
    assert!(
        ks[..64].iter().all(|&k| k == 1),
        "slow bodies substepped: {ks:?}"
    );
    assert!(ks[64] > 1);
    assert!(plan.cost() as f64 <= 1.5 * ideal_cost as f64);
    assert!(plan.cost() * 10 < uniform_cost);
}

/// The a posteriori check agrees with the exact error within Richardson's accuracy, and exceeds
/// the tolerance when the model is made 1e4x too optimistic (so its factor is far too small).
#[test]
fn posteriori_check_catches_a_too_optimistic_model() {
    let tol = 1e-5;
    let (dt, t) = (0.05, 20.0);
    let steps = (t / dt) as u64;
    let kind = IntegratorKind::Variational;
    let b = body(
        Vector3::new(0.2, 0.9, 1.0),
        UnitQuaternion::from_euler_angles(0.1, 0.2, 0.3),
        Vector3::new(0.4, 1.0, 0.3).normalize(),
        4.0,
    );
    let bodies = vec![b.clone()];
    for (scale, should_pass) in [(1.0, true), (1e-4, false)] {
        let plan = Plan::new(
            kind,
            &settings(),
            &ErrorModel { scale },
            &bodies,
            dt,
            t,
            tol,
        );
        let checked = check(&plan, &settings(), &bodies, &[0], steps);
        let exact = achieved_error(kind, &settings(), &b, dt, plan.factors[0].k, steps).unwrap();
        let est = checked[0].estimated_rad;
        // Richardson on a second-order error: est/exact within 20 % (measured 0.99-1.01).
        assert!(
            (est / exact - 1.0).abs() < 0.2,
            "scale {scale}: est {est:e} exact {exact:e}"
        );
        assert_eq!(
            est <= tol,
            should_pass,
            "scale {scale}: k {} est {est:e}",
            plan.factors[0].k
        );
    }
}

/// `Substepped` reuses the scheme's own step: k substeps of dt/k are the bits of the plain
/// integrator at dt/k stepped k times, for any grouping of the batch.
#[test]
fn substeps_are_the_schemes_own_steps() {
    let bodies: Vec<BodyInit> = shapes(0.1, 2, 5);
    let dt = 0.02;
    let ks: Vec<u32> = (0..bodies.len()).map(|i| 1 + (i % 3) as u32).collect();
    let mut batch = Bodies::new(&bodies);
    let mut mixed =
        Substepped::with_factors(IntegratorKind::Variational4, dt, &settings(), ks.clone());
    mixed.init(&batch);
    let g = Vector3::new(0.0, 0.0, -9.81);
    for _ in 0..50 {
        mixed.step(&mut batch, &Loads::uniform_gravity(g));
    }
    for (i, b) in bodies.iter().enumerate() {
        let mut one = Bodies::new(std::slice::from_ref(b));
        let mut plain = IntegratorKind::Variational4.build(dt / f64::from(ks[i]), &settings());
        plain.init(&one);
        for _ in 0..50 * ks[i] {
            plain.step(&mut one, &Loads::uniform_gravity(g));
        }
        assert_eq!(one.world_from_body[0], batch.world_from_body[i], "body {i}");
        assert_eq!(one.angmom_body[0], batch.angmom_body[i], "body {i}");
        assert_eq!(one.com_world[0], batch.com_world[i], "body {i}");
    }
}

/// `simulate --accuracy` on the mixed scene: one body substepped, the others not, the summary
/// and the JSON agree, the files are the same bytes on 1 and 2 threads; the hidden model scale
/// makes the a posteriori check warn; an articulated scene is refused with exit 2.
#[test]
fn simulate_accuracy_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let stem = |n: &str| dir.path().join(n).display().to_string();
    let mut mcaps = Vec::new();
    for threads in ["1", "2"] {
        let mut args = vec![
            "simulate",
            "models/accuracy_mixed.toml",
            "--accuracy",
            "1e-3",
            "--format",
            "mcap",
            "--threads",
            threads,
        ];
        // --verbose (one line per body) on one of the two runs: the files must not change.
        if threads == "2" {
            args.push("--verbose");
        }
        let out_stem = stem(threads);
        args.extend(["--out", &out_stem]);
        let out = common::tumble(&args, &common::root());
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "{stdout}{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(
            stdout.contains("bodies per substep factor: k=1: 999, k=9-16: 1"),
            "{stdout}"
        );
        assert!(!String::from_utf8_lossy(&out.stderr).contains("a posteriori check estimates"));
        let json: serde_json::Value = serde_json::from_slice(
            &std::fs::read(format!("{}.accuracy.json", stem(threads))).unwrap(),
        )
        .unwrap();
        let b = json["bodies"].as_array().unwrap();
        assert_eq!(b.len(), 1000);
        assert_eq!(b[999]["body"], "handle/t_handle");
        assert!(b[999]["substeps"].as_u64().unwrap() > 8);
        assert!(json["checked_error_max_rad"].as_f64().unwrap() <= 1e-3);
        // Verbose: a line per body, its factor as in the JSON.
        let lines: Vec<&str> = stdout
            .lines()
            .filter(|l| l.starts_with("  body "))
            .collect();
        if threads == "2" {
            assert_eq!(lines.len(), 1000);
            let handle = format!(
                "  body handle/t_handle (index 999): k = {},",
                b[999]["substeps"].as_u64().unwrap()
            );
            assert!(lines[999].starts_with(&handle), "{}", lines[999]);
        } else {
            assert!(lines.is_empty());
        }
        mcaps.push(std::fs::read(format!("{}.mcap", stem(threads))).unwrap());
    }
    assert!(
        mcaps[0] == mcaps[1],
        "--threads 1 and 2 differ with --accuracy"
    );
    let out = common::tumble(
        &[
            "simulate",
            "models/accuracy_mixed.toml",
            "--accuracy",
            "1e-3",
            "--format",
            "mcap",
            "--accuracy-model-scale",
            "1e-4",
            "--out",
            &stem("loose"),
        ],
        &common::root(),
    );
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("a posteriori check estimates"));
    let out = common::tumble(
        &[
            "simulate",
            "models/double_pendulum.toml",
            "--accuracy",
            "1e-3",
            "--format",
            "mcap",
            "--out",
            &stem("arm"),
        ],
        &common::root(),
    );
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("not supported for articulated models yet"),
        "{err}"
    );
    assert!(!std::path::Path::new(&format!("{}.mcap", stem("arm"))).exists());
}
