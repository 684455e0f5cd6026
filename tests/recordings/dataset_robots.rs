//! Datasets of robots (issue 32): `vary.joints`, `vary.joint_velocities`, `vary.actuators`
//! drawn per run into articulated runs, and the `joints/` table that holds them.
//!
//! The robot is the bundled two-joint arm (`models/arm.urdf`, welded base) with two position
//! servos; every dataset is a dozen runs of a few hundred steps.

use super::dataset::{f64s, i64s, read, rows, strs};
use crate::common::{root, text, tumble};
use std::path::{Path, PathBuf};
use tumble::dataset::{DatasetSpec, Options, generate};

/// The servos of models/arm_servo.toml, targets 0 unless varied.
const SERVOS: &str = r#"
[[scene.model.actuator]]
joint = "shoulder"
kind = "position"
target = 0.0
kp = 400.0
kd = 8.1

[[scene.model.actuator]]
joint = "elbow"
kind = "position"
target = 0.0
kp = 800.0
kd = 11.3
"#;

/// A spec of `runs` runs of the arm, 0.3 s at 1 ms, every step recorded, with `vary`.
fn arm_spec(dir: &Path, name: &str, runs: u64, vary: &str) -> PathBuf {
    let spec = format!(
        "[dataset]\nruns = {runs}\nseed = 5\nruns_per_file = 5\n\n\
         [scene.sim]\nduration = 0.3\ndt = 0.001\nlog_every = 1\ngravity = [0.0, 0.0, -9.81]\n\n\
         [[scene.model]]\nurdf = \"{}\"\nname = \"arm\"\nbodies = \"articulated\"\nbase = \"fixed\"\n\
         {SERVOS}\n[vary]\n{vary}\n",
        root().join("models/arm.urdf").display()
    );
    let path = dir.join(name);
    std::fs::write(&path, spec).unwrap();
    path
}

fn generate_into(spec: &Path, out: &Path) {
    let spec = DatasetSpec::load(spec).unwrap();
    let opts = Options {
        out: out.to_path_buf(),
        threads: Some(2),
        ..Default::default()
    };
    generate(&spec, &opts).unwrap();
}

/// The joints table's rows of `joint` at step `step`, one per run: (position, velocity).
fn at_step(dir: &Path, joint: &str, step: i64) -> Vec<(f64, f64)> {
    let b = read(&dir.join("joints"));
    let (steps, names) = (i64s(&b, "step"), strs(&b, "joint"));
    let (q, v) = (f64s(&b, "position"), f64s(&b, "velocity"));
    (0..steps.len())
        .filter(|&i| steps[i] == step && names[i] == joint)
        .map(|i| (q[i], v[i]))
        .collect()
}

/// Each run starts at its own drawn joint positions (inside the drawn interval), the elbow at
/// its own drawn rate and the shoulder at rest; the servos track smooth targets that
/// stay within the amplitude and are band-limited (their second difference bounded by
/// `A (2π f_c)²`); a key for the elbow alone draws the elbow the same values (each joint its
/// own stream, to the round-off of reading the angle back) and leaves the shoulder at the
/// template's 0.
#[test]
fn joints_rates_and_servo_targets_are_drawn_per_run() {
    let dir = tempfile::tempdir().unwrap();
    let runs = 12;
    let every = arm_spec(
        dir.path(),
        "every.toml",
        runs,
        "joints = { uniform = [-0.5, 0.5] }\n\
         joint_velocities = { elbow = { normal = { mean = 0, std = 0.5 } } }\n\
         actuators = { smooth = { amplitude = 0.8, cutoff_hz = 1.5 } }",
    );
    let out = dir.path().join("every");
    generate_into(&every, &out);
    let b = read(&out.join("joints"));
    // 12 runs × 301 recorded steps × 2 joints.
    assert_eq!(b.iter().map(|b| b.num_rows()).sum::<usize>(), 12 * 301 * 2);
    let shoulder = at_step(&out, "arm/shoulder", 0);
    let elbow = at_step(&out, "arm/elbow", 0);
    assert_eq!((shoulder.len(), elbow.len()), (12, 12));
    let mut starts: Vec<f64> = shoulder.iter().chain(&elbow).map(|(q, _)| *q).collect();
    assert!(starts.iter().all(|q| (-0.5..0.5).contains(q)), "{starts:?}");
    starts.sort_by(f64::total_cmp);
    starts.dedup();
    assert_eq!(starts.len(), 24, "every run and joint its own draw");
    // The shoulder starts at rest: its rate is the projection of the momenta onto the joints'
    // velocity constraints, 0 to round-off (measured ≤ 2.7e-17 rad/s); the elbow's drawn rates
    // are N(0, 0.5²) (measured |v| ≥ 0.022).
    assert!(
        shoulder.iter().all(|(_, v)| v.abs() < 1e-12),
        "{shoulder:?}"
    );
    assert!(elbow.iter().all(|(_, v)| v.abs() > 1e-6), "{elbow:?}");

    // The targets, run by run (rows are in run, step, joint order).
    let (run, name, target) = (i64s(&b, "run"), strs(&b, "joint"), f64s(&b, "target"));
    let bound = 0.8 * (std::f64::consts::TAU * 1.5).powi(2);
    let mut first_targets = Vec::new();
    for r in 0..runs as i64 {
        for j in ["arm/shoulder", "arm/elbow"] {
            let t: Vec<f64> = (0..run.len())
                .filter(|&i| run[i] == r && name[i] == j)
                .map(|i| target[i])
                .collect();
            assert_eq!(t.len(), 301);
            assert!(t.iter().all(|x| x.abs() <= 0.8), "run {r} {j}");
            // |s''| ≤ A (2π f_c)² = 71.1 rad/s²; measured at most 25.6 over these runs.
            let worst = t
                .windows(3)
                .map(|w| (w[2] - 2.0 * w[1] + w[0]).abs() / 1e-6)
                .fold(0.0, f64::max);
            assert!(worst <= bound, "run {r} {j}: {worst}");
            let spread = t.iter().cloned().fold(f64::MIN, f64::max)
                - t.iter().cloned().fold(f64::MAX, f64::min);
            assert!(spread > 1e-4, "run {r} {j}: the target moves ({spread})");
            first_targets.push(t[0]);
        }
    }
    first_targets.sort_by(f64::total_cmp);
    first_targets.dedup();
    assert_eq!(first_targets.len(), 24, "a signal per run and joint");

    let elbow_only = arm_spec(
        dir.path(),
        "elbow.toml",
        runs,
        "joints = { elbow = { uniform = [-0.5, 0.5] } }",
    );
    let out2 = dir.path().join("elbow");
    generate_into(&elbow_only, &out2);
    let elbow2 = at_step(&out2, "arm/elbow", 0);
    // The recorded position is read back from the links' poses, so it carries their round-off,
    // which depends on the shoulder's angle too (measured ≤ 7.3e-16 rad apart).
    assert_eq!(elbow2.len(), elbow.len());
    for ((a, _), (b, _)) in elbow2.iter().zip(&elbow) {
        assert!((a - b).abs() < 1e-14, "{a} vs {b}");
    }
    assert!(
        at_step(&out2, "arm/shoulder", 0)
            .iter()
            .all(|(q, v)| *q == 0.0 && v.abs() < 1e-12)
    );
}

/// A dataset run is exactly the scene with its drawn values written in: run 3's initial joint
/// positions and constant servo targets (read back from its joints rows) put into a scene that
/// `tumble simulate --format parquet` runs give the same joint rows, bit for bit. Drawn
/// positions beyond a joint's range start at its bound (the arm's elbow: ±2.5 rad).
#[test]
fn a_dataset_run_is_the_scene_of_its_drawn_values() {
    let dir = tempfile::tempdir().unwrap();
    let spec = arm_spec(
        dir.path(),
        "constant.toml",
        8,
        "joints = { uniform = [-4, 4] }\nactuators = { uniform = [-1, 1] }",
    );
    let out = dir.path().join("constant");
    generate_into(&spec, &out);
    let b = read(&out.join("joints"));
    let run = i64s(&b, "run");
    let this: Vec<usize> = (0..run.len()).filter(|&i| run[i] == 3).collect();
    let (names, q, target) = (strs(&b, "joint"), f64s(&b, "position"), f64s(&b, "target"));
    let value =
        |rows: &[usize], j: &str, col: &[f64]| col[*rows.iter().find(|&&i| names[i] == j).unwrap()];
    let (q_s, q_e) = (
        value(&this, "arm/shoulder", &q),
        value(&this, "arm/elbow", &q),
    );
    let (r_s, r_e) = (
        value(&this, "arm/shoulder", &target),
        value(&this, "arm/elbow", &target),
    );
    let scene = format!(
        "[sim]\nduration = 0.3\ndt = 0.001\nlog_every = 1\ngravity = [0.0, 0.0, -9.81]\n\n\
         [[model]]\nurdf = \"{}\"\nname = \"arm\"\nbodies = \"articulated\"\nbase = \"fixed\"\n\
         joints = {{ shoulder = {q_s:?}, elbow = {q_e:?} }}\n{}",
        root().join("models/arm.urdf").display(),
        SERVOS
            .replace("[[scene.model.actuator]]", "[[model.actuator]]")
            .replacen("target = 0.0", &format!("target = {r_s:?}"), 1)
            .replacen("target = 0.0", &format!("target = {r_e:?}"), 1)
    );
    let path = dir.path().join("run3.toml");
    std::fs::write(&path, scene).unwrap();
    let stem = dir.path().join("run3");
    let o = tumble(
        &[
            "simulate",
            path.to_str().unwrap(),
            "--format",
            "parquet",
            "--out",
            stem.to_str().unwrap(),
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    let single = read(&dir.path().join("run3.joints.parquet"));
    // Compare every column but `run` (0 for simulate, 3 here).
    let strip = |rows: Vec<String>| -> Vec<String> {
        rows.into_iter()
            .map(|r| r.split_once(',').unwrap().1.to_string())
            .collect()
    };
    let dataset_rows: Vec<String> = strip(rows(&b))
        .into_iter()
        .enumerate()
        .filter(|(i, _)| run[*i] == 3)
        .map(|(_, r)| r)
        .collect();
    assert_eq!(dataset_rows.len(), 301 * 2);
    assert_eq!(strip(rows(&single)), dataset_rows);

    // U[-4, 4) clamped into the ranges: shoulder [-3.14, 3.14], elbow [-2.5, 2.5]; over 8 runs
    // some elbow draws fall outside (measured: 4 of 8; one read back as 2.4999999999999996)
    // and start at the bound.
    let elbow = at_step(&out, "arm/elbow", 0);
    assert!(elbow.iter().all(|(q, _)| q.abs() <= 2.5));
    assert!(elbow.iter().any(|(q, _)| q.abs() == 2.5), "{elbow:?}");
    // The shoulder's URDF range, `<limit lower="-3.14" upper="3.14">` (not π).
    #[allow(clippy::approx_constant)]
    let shoulder_bound = 3.14;
    assert!(
        at_step(&out, "arm/shoulder", 0)
            .iter()
            .all(|(q, _)| q.abs() <= shoulder_bound)
    );
}

/// Joint names are checked against the model with a suggestion, and a key that needs
/// actuators refuses a template without them: one message naming the spec and key, exit 2,
/// nothing written.
#[test]
fn wrong_joint_names_are_refused_with_a_suggestion() {
    let dir = tempfile::tempdir().unwrap();
    let spec = arm_spec(
        dir.path(),
        "typo.toml",
        2,
        "joints = { elbw = { uniform = [0, 1] } }",
    );
    let out = dir.path().join("typo");
    // `tumble dataset SPEC --out OUT` must exit 2: its stderr.
    let refused = || {
        let o = tumble(
            &[
                "dataset",
                spec.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
            ],
            dir.path(),
        );
        let err = text(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        err
    };
    let err = refused();
    assert!(
        err.contains("typo.toml: vary.joints.elbw: not a moving joint (shoulder, elbow): did you mean `elbow`?"),
        "{err}"
    );
    assert!(!out.join("manifest.json").exists());
    let text_spec = std::fs::read_to_string(&spec)
        .unwrap()
        .replace(SERVOS, "")
        .replace("joints = { elbw", "actuators = { elbow");
    std::fs::write(&spec, text_spec).unwrap();
    let err = refused();
    assert!(
        err.contains("vary.actuators: the template has no [[scene.model.actuator]]"),
        "{err}"
    );
}

/// The runs table's energy balance of driven robots: `E_T − E_0 − (input_work − dissipated)`
/// is the variational scheme's own error, second order in the step (the same runs at 1 ms and
/// 0.5 ms: residuals in the ratio ≈ 4), the joint constraints hold to round-off, and a welded
/// base's angular momentum, not conserved, has no drift figure (null, not a number that reads
/// as a blow-up).
#[test]
fn the_runs_table_balances_a_driven_robots_energy() {
    let dir = tempfile::tempdir().unwrap();
    let vary = "joints = { uniform = [-0.5, 0.5] }\nactuators = { uniform = [-1, 1] }";
    let mut residuals = Vec::new();
    for (name, dt) in [("coarse", "0.001"), ("fine", "0.0005")] {
        let spec = arm_spec(dir.path(), &format!("{name}.toml"), 6, vary);
        let text = std::fs::read_to_string(&spec)
            .unwrap()
            .replace("dt = 0.001", &format!("dt = {dt}"));
        std::fs::write(&spec, text).unwrap();
        let out = dir.path().join(name);
        generate_into(&spec, &out);
        let b = read(&out.join("runs"));
        let input = f64s(&b, "input_work");
        assert!(
            input.iter().all(|w| w.abs() > 1e-3),
            "the servos work: {input:?}"
        );
        assert!(f64s(&b, "dissipated").iter().all(|d| *d == 0.0));
        // Gap and misalignment: measured ≤ 6.5e-14 m and 2.8e-14 rad.
        assert!(f64s(&b, "constraint_residual_m").iter().all(|r| *r < 1e-12));
        assert!(
            f64s(&b, "constraint_residual_rad")
                .iter()
                .all(|r| *r < 1e-12)
        );
        // Fixed base: both momentum figures are null (read back as NaN).
        assert!(
            f64s(&b, "angular_momentum_drift_rel")
                .iter()
                .all(|x| x.is_nan())
        );
        assert!(
            f64s(&b, "angular_momentum_change_abs")
                .iter()
                .all(|x| x.is_nan())
        );
        residuals.push(f64s(&b, "energy_balance_residual"));
    }
    // Per run: |residual(1 ms)| / |residual(0.5 ms)| near 4 (second order; measured 3.996 to
    // 4.014, residuals 7e-6 to 2.1e-4 J at 1 ms against |input_work| 0.08 to 1.3 J).
    for (coarse, fine) in residuals[0].iter().zip(&residuals[1]) {
        let ratio = coarse.abs() / fine.abs();
        assert!((3.5..4.5).contains(&ratio), "{coarse} vs {fine}: {ratio}");
    }
}

/// The runs table's other energy terms: URDF damping's `dissipated` and the ground's
/// `contact_work` enter `energy_balance_residual` with their signs (a damped arm: the residual
/// is a small fraction of what damping removed; a cube dropped onto the ground: the impact's
/// loss is contact work, and the residual is round-off of it), and `energy_drift_rel` is
/// `(E_final − E_initial) / |E_initial|`.
#[test]
fn damping_and_contact_enter_the_runs_tables_energy_balance() {
    let dir = tempfile::tempdir().unwrap();
    // The arm with <dynamics damping="0.5"/> on both joints, and no servo: it swings down.
    let urdf = std::fs::read_to_string(root().join("models/arm.urdf"))
        .unwrap()
        .replace(
            "<limit lower=\"-3.14\"",
            "<dynamics damping=\"0.5\"/>\n    <limit lower=\"-3.14\"",
        )
        .replace(
            "<limit lower=\"-2.5\"",
            "<dynamics damping=\"0.5\"/>\n    <limit lower=\"-2.5\"",
        );
    assert_eq!(urdf.matches("damping=\"0.5\"").count(), 2);
    std::fs::write(dir.path().join("damped_arm.urdf"), urdf).unwrap();
    let spec = dir.path().join("damped.toml");
    std::fs::write(
        &spec,
        "[dataset]\nruns = 4\nseed = 3\n\n[scene.sim]\nduration = 1.0\ndt = 0.001\n\n\
         [[scene.model]]\nurdf = \"damped_arm.urdf\"\nname = \"arm\"\nbodies = \"articulated\"\n\
         base = \"fixed\"\n\n[vary]\njoints = { uniform = [0.5, 1.5] }\n",
    )
    .unwrap();
    let out = dir.path().join("damped");
    generate_into(&spec, &out);
    let b = read(&out.join("runs"));
    let (dissipated, residual) = (f64s(&b, "dissipated"), f64s(&b, "energy_balance_residual"));
    let (e0, e1, drift) = (
        f64s(&b, "energy_initial"),
        f64s(&b, "energy_final"),
        f64s(&b, "energy_drift_rel"),
    );
    for r in 0..4 {
        // Measured: 0.026 to 0.69 J dissipated (the shoulder turns about the vertical),
        // residuals at most 1.5e-7 of it (O(h²)).
        assert!(dissipated[r] > 0.01, "{dissipated:?}");
        assert!(
            residual[r].abs() < 1e-5 * dissipated[r],
            "{residual:?} {dissipated:?}"
        );
        assert_eq!(drift[r], (e1[r] - e0[r]) / e0[r].abs());
    }

    // A cube dropped 0.5 m onto the ground (models/contact_box.toml as a template).
    let spec = dir.path().join("drop.toml");
    std::fs::write(
        &spec,
        format!(
            "[dataset]\nruns = 3\nseed = 3\n\n[scene.sim]\nduration = 0.6\ndt = 0.001\n\n\
             [scene.ground]\nheight = 0.0\nfriction = 0.8\nrestitution = 0.0\n\n\
             [[scene.model]]\nurdf = \"{}\"\ncollisions = \"urdf\"\nposition = [0.0, 0.0, 0.6]\n\n\
             [vary]\nposition = {{ uniform = [[-1, -1, 0.6], [1, 1, 0.7]] }}\n",
            root().join("models/cube.urdf").display()
        ),
    )
    .unwrap();
    let out = dir.path().join("drop");
    generate_into(&spec, &out);
    let b = read(&out.join("runs"));
    let (contact, residual) = (
        f64s(&b, "contact_work"),
        f64s(&b, "energy_balance_residual"),
    );
    for r in 0..3 {
        // The landing's kinetic energy (8 kg × g × 0.5 to 0.6 m) is lost to contact: measured
        // −40.4 to −45.4 J, residuals 3.3e-13 J (free fall is exact in the scheme).
        assert!(contact[r] < -30.0, "{contact:?}");
        assert!(
            residual[r].abs() < 1e-9 * contact[r].abs(),
            "{residual:?} {contact:?}"
        );
    }
}
