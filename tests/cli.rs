//! The `tumble` binary on good and bad input: exit codes, one clear message, no panic, and
//! nothing half-written under the final output names.

mod common;

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

/// A URDF given directly runs alone at the origin, with the velocity flags.
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
    let sum: f64 = links.iter().filter_map(|l| l["mass"].as_f64()).sum();
    assert!((json["total_mass"].as_f64().unwrap() - sum).abs() < 1e-12);
}
