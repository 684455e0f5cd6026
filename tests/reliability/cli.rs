//! The `tumble` binary on good and bad input: exit codes, one clear message, no panic, and
//! nothing half-written under the final output names.

use crate::common;

use common::{text, tumble};

use std::path::{Path, PathBuf};
use std::process::Output;

/// Files in `dir` (recursively), as paths relative to it.
fn files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let p = entry.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push(p.strip_prefix(dir).unwrap().to_path_buf());
            }
        }
    }
    out.sort();
    out
}

/// Asserts a failed run: exit code 2, a single `error: ...` message naming every needle, and
/// no panic.
fn assert_error(out: &Output, needles: &[&str]) {
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "stderr: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(stderr.starts_with("error: "), "{stderr}");
    assert_eq!(stderr.matches("error:").count(), 1, "one message: {stderr}");
    for needle in needles {
        assert!(stderr.contains(needle), "{needle:?} not in {stderr:?}");
    }
}

#[test]
fn simulate_writes_both_files_and_says_where() {
    let dir = tempfile::tempdir().unwrap();
    let scene = common::root().join("models/box.toml");
    let out = tumble(
        &[
            "simulate",
            scene.to_str().unwrap(),
            "--out",
            "runs/box",
            "--duration",
            "0.1",
        ],
        dir.path(),
    );
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert_eq!(
        files(dir.path()),
        [
            PathBuf::from("runs/box.mcap"),
            PathBuf::from("runs/box.rrd")
        ]
    );
    assert!(
        stdout.contains("runs/box.mcap") && stdout.contains("runs/box.rrd"),
        "{stdout}"
    );
    assert!(stdout.contains("rerun runs/box.rrd"), "{stdout}");
    assert!(stdout.contains("100 steps"), "{stdout}");
}

/// Without arguments the bundled default scene runs and lands in `logs/`.
#[test]
fn simulate_without_arguments_runs_the_default_scene() {
    let dir = tempfile::tempdir().unwrap();
    let out = tumble(&["simulate", "--duration", "0.05"], dir.path());
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert_eq!(
        files(dir.path()),
        [
            PathBuf::from("logs/default.mcap"),
            PathBuf::from("logs/default.rrd")
        ]
    );
    assert!(text(&out.stdout).contains("rerun logs/default.rrd"));
}

/// A URDF given directly runs alone at the origin, with the velocity flags: the recording, read
/// by the Python `mcap` reader, starts at exactly the `--angvel` given, with the angular momentum
/// `I ω` of the URDF's inertia (the file's closed forms), and `--gravity 0,0,0` leaves the body
/// at rest with no potential energy (the default gravity would give `v_z = -9.81 t`).
#[test]
fn simulate_a_urdf_directly() {
    let dir = tempfile::tempdir().unwrap();
    let urdf = common::root().join("models/t_handle.urdf");
    let out = tumble(
        &[
            "simulate",
            urdf.to_str().unwrap(),
            "--out",
            "th",
            "--duration",
            "0.02",
            "--angvel",
            "0,20,0.01",
            "--gravity",
            "0,0,0",
        ],
        dir.path(),
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert_eq!(
        files(dir.path()),
        [PathBuf::from("th.mcap"), PathBuf::from("th.rrd")]
    );
    let decoded = common::run_py("read_mcap.py", &[&dir.path().join("th.mcap")]);
    let rows = decoded["bodies"]["t_handle"]
        .as_array()
        .unwrap_or_else(|| panic!("no body t_handle in {decoded}"));
    // 20 steps of the default 1 ms, every 10th logged: steps 0, 10, 20.
    assert_eq!(rows.len(), 3, "{decoded}");
    let row = |k: usize| -> Vec<f64> {
        rows[k]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect()
    };
    // The principal axes are the link axes (no off-diagonal terms) and the link starts at the
    // identity pose: I = diag(539/12e6, 263/4.8e6, 2291/24e6) kg m² (models/t_handle.urdf).
    let inertia = [539.0 / 12e6, 263.0 / 4.8e6, 2291.0 / 24e6];
    let omega0 = [0.0, 20.0, 0.01];
    let first = row(0);
    assert_eq!(first[0], 0.0);
    for k in 0..3 {
        // ω is recorded as given (M0 = J Ω0, then Ω = J⁻¹ M): measured error 1.7e-18 rad/s;
        // bound 1e-12.
        assert!((first[6 + k] - omega0[k]).abs() < 1e-12, "ω {first:?}");
    }
    for r in 0..rows.len() {
        let r = row(r);
        for k in 0..3 {
            // Angular momentum I ω0, conserved to round-off by the scheme: measured ≤ 2.2e-19
            // kg m²/s (|L| = 1.1e-3); bound 1e-15.
            assert!(
                (r[3 + k] - inertia[k] * omega0[k]).abs() < 1e-15,
                "L at t = {} ns: {r:?}",
                r[0]
            );
            // No gravity, no initial velocity: at rest exactly.
            assert_eq!(r[9 + k], 0.0, "v {r:?}");
        }
        assert_eq!(r[2], 0.0, "potential energy {r:?}");
    }
}

#[test]
fn bad_scene_is_one_message_and_no_files() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("s.toml"),
        "[sim]\ndt = 0.01\nspeed = 3\n[[model]]\nurdf = \"x.urdf\"\n",
    )
    .unwrap();
    let out = tumble(&["simulate", "s.toml", "--out", "o"], dir.path());
    assert_error(&out, &["s.toml", "speed"]);
    assert_eq!(files(dir.path()), [PathBuf::from("s.toml")]);
}

#[test]
fn invalid_link_is_named_with_its_rule_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let urdf = r#"<robot name="r"><link name="wheel"><inertial><mass value="-1"/>
        <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link></robot>"#;
    std::fs::write(dir.path().join("bad.urdf"), urdf).unwrap();
    let out = tumble(&["simulate", "bad.urdf", "--out", "o"], dir.path());
    assert_error(&out, &["bad.urdf", "wheel", "mass"]);
    assert_eq!(files(dir.path()), [PathBuf::from("bad.urdf")]);
    // inspect reports the problem and exits 1 (the input has problems, the command worked).
    let out = tumble(&["inspect", "bad.urdf"], dir.path());
    assert_eq!(out.status.code(), Some(1), "{}", text(&out.stderr));
    assert!(text(&out.stdout).contains("wheel"));
}

#[test]
fn bad_flags_and_missing_files() {
    let dir = tempfile::tempdir().unwrap();
    let out = tumble(&["simulate", "nowhere.toml"], dir.path());
    assert_error(&out, &["nowhere.toml"]);
    let out = tumble(&["inspect", "nowhere.urdf"], dir.path());
    assert_error(&out, &["nowhere.urdf"]);
    let box_scene = common::root().join("models/box.toml");
    let scene = box_scene.to_str().unwrap();
    let out = tumble(&["simulate", scene, "--dt", "0", "--out", "o"], dir.path());
    assert_error(&out, &["sim.dt"]);
    let out = tumble(
        &["simulate", scene, "--integrator", "euler99", "--out", "o"],
        dir.path(),
    );
    assert_error(&out, &["euler99"]);
    let out = tumble(
        &["simulate", scene, "--angvel", "1,2,3", "--out", "o"],
        dir.path(),
    );
    assert_error(&out, &["--angvel"]);
    // clap rejects malformed vectors with its usage error (exit 2).
    let out = tumble(
        &["simulate", scene, "--gravity", "1,2", "--out", "o"],
        dir.path(),
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("three comma-separated numbers"));
    assert!(files(dir.path()).is_empty(), "{:?}", files(dir.path()));
}

/// An output folder that cannot be created (a file is in the way) is an error naming it, and
/// nothing is left behind.
#[test]
fn unwritable_output_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("blocker"), "").unwrap();
    let scene = common::root().join("models/box.toml");
    let out = tumble(
        &["simulate", scene.to_str().unwrap(), "--out", "blocker/run"],
        dir.path(),
    );
    assert_error(&out, &["blocker"]);
    assert_eq!(files(dir.path()), [PathBuf::from("blocker")]);
}

#[test]
fn inspect_json_of_the_arm() {
    let dir = tempfile::tempdir().unwrap();
    let urdf = common::root().join("models/arm.urdf");
    let out = tumble(&["inspect", urdf.to_str().unwrap(), "--json"], dir.path());
    assert!(out.status.success(), "{}", text(&out.stderr));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let links = json["links"].as_array().unwrap();
    let names: Vec<_> = links.iter().map(|l| l["name"].as_str().unwrap()).collect();
    assert_eq!(names, ["base", "upper_arm", "forearm", "hand", "tool0"]);
    // The masses written in models/arm.urdf (<mass value=...>); tool0 has no <inertial> (a
    // massless frame).
    let masses: Vec<Option<f64>> = links.iter().map(|l| l["mass"].as_f64()).collect();
    assert_eq!(
        masses,
        [Some(2.0), Some(1.5), Some(1.0), Some(0.3), Some(0.0)]
    );
    // 2.0 + 1.5 + 1.0 + 0.3 = 4.8 (rounding of 0.3 only: measured 0); bound 1e-12.
    let total = json["total_mass"].as_f64().unwrap();
    assert!((total - 4.8).abs() < 1e-12, "total_mass {total}");
}

/// A scene that starts with no energy (bodies at rest, no gravity) reports the energy change as
/// an absolute figure, not a relative one divided by zero (it printed "relative change
/// 3.52e294").
#[test]
fn a_scene_at_rest_reports_an_absolute_energy_change() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::copy(common::root().join("models/box.urdf"), d.join("box.urdf")).unwrap();
    std::fs::write(
        d.join("rest.toml"),
        "[sim]\nduration = 0.01\n[[model]]\nurdf = \"box.urdf\"\n",
    )
    .unwrap();
    let out = common::tumble(&["simulate", "rest.toml", "--format", "mcap"], d);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    let line = stdout.lines().find(|l| l.starts_with("energy ")).unwrap();
    assert!(line.contains("(absolute change "), "{line}");
    assert!(!line.contains("relative change 3"), "{line}");
}
