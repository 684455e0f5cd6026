//! Hostile input to articulated scenes, through the `tumble` binary: each case is one clear
//! error (exit status 2) naming the scene file and the key, joint or link at fault, with no
//! panic and nothing written under the output name (nor a `.part` file).

use crate::common;

use std::path::Path;
use std::process::Command;

/// Writes `scene` as `bad.toml` next to copies of the models it uses, runs
/// `tumble simulate bad.toml --out <dir>/out`, and checks the outcome.
fn refused(scene: &str, expected: &[&str]) {
    refused_with(scene, &[], expected);
}

/// [`refused`] with more files next to the scene: `(name, bytes)`.
pub(crate) fn refused_with(scene: &str, files: &[(&str, &[u8])], expected: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    for (name, bytes) in files {
        std::fs::write(dir.path().join(name), bytes).unwrap();
    }
    for model in ["double_pendulum.urdf", "chain3_free.urdf", "cart_pole.urdf"] {
        std::fs::copy(
            common::root().join("models").join(model),
            dir.path().join(model),
        )
        .unwrap();
    }
    let data = common::root().join("tests/data/mechanism");
    for entry in std::fs::read_dir(&data).unwrap() {
        let path = entry.unwrap().path();
        std::fs::copy(&path, dir.path().join(path.file_name().unwrap())).unwrap();
    }
    let scene_path = dir.path().join("bad.toml");
    std::fs::write(&scene_path, scene).unwrap();
    let out = dir.path().join("out");
    let run = Command::new(env!("CARGO_BIN_EXE_tumble"))
        .arg("simulate")
        .arg(&scene_path)
        .arg("--out")
        .arg(&out)
        .output()
        .expect("cannot run tumble");
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(
        run.status.code(),
        Some(2),
        "scene:\n{scene}\nstderr:\n{stderr}"
    );
    for bad in ["panicked", "RUST_BACKTRACE"] {
        assert!(!stderr.contains(bad), "{stderr}");
    }
    assert!(
        stderr.contains("bad.toml"),
        "the error names the scene file:\n{stderr}"
    );
    for want in expected {
        assert!(stderr.contains(want), "expected {want:?} in:\n{stderr}");
    }
    // One error: a single `error:` line group, nothing else claimed.
    assert_eq!(stderr.matches("error:").count(), 1, "{stderr}");
    let leftovers: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .filter_map(|e| {
            let name = e.unwrap().file_name().to_string_lossy().into_owned();
            name.starts_with("out").then_some(name)
        })
        .collect();
    assert!(leftovers.is_empty(), "files written: {leftovers:?}");
    assert!(!Path::new(&out).exists());
}

const PENDULUM: &str = "[sim]\nduration = 0.01\n[[model]]\nurdf = \"double_pendulum.urdf\"\n\
                        bodies = \"articulated\"\nbase = \"fixed\"\n";

#[test]
fn unknown_joint_names_are_refused_naming_the_key_and_joint() {
    refused(
        &format!("{PENDULUM}joints = {{ shoulder = 0.1, wrist = 0.2 }}\n"),
        &["model[0]", "no joint named `wrist`"],
    );
    refused(
        &format!("{PENDULUM}joint_velocities = {{ knee = 1.0 }}\n"),
        &["model[0]", "joint_velocities.knee", "no joint named `knee`"],
    );
    refused(
        &format!("{PENDULUM}locked_joints = [\"elbow\", \"hip\"]\n"),
        &["model[0]", "locked_joints", "no joint named `hip`"],
    );
}

#[test]
fn non_finite_joint_values_are_refused() {
    refused(
        &format!("{PENDULUM}joints = {{ shoulder = nan }}\n"),
        &["model[0].joints.shoulder must be a finite number"],
    );
    refused(
        &format!("{PENDULUM}joint_velocities = {{ elbow = nan }}\n"),
        &["model[0].joint_velocities.elbow must be a finite number"],
    );
    refused(
        &format!("{PENDULUM}joint_velocities = {{ elbow = inf }}\n"),
        &[
            "model[0].joint_velocities.elbow must be a finite number",
            "inf",
        ],
    );
}

#[test]
fn misspelt_keys_and_values_are_refused() {
    refused(
        "[[model]]\nurdf = \"double_pendulum.urdf\"\nbodies = \"articulated\"\nbase = \"fixd\"\n",
        &[
            "base",
            "unknown variant `fixd`, expected `floating` or `fixed`",
        ],
    );
    refused(
        "[[model]]\nurdf = \"double_pendulum.urdf\"\nbodies = \"articulatd\"\n",
        &["bodies", "unknown variant `articulatd`", "`articulated`"],
    );
    refused(
        "[[model]]\nurdf = \"double_pendulum.urdf\"\nbodies = \"articulated\"\nlocked_joint = [\"elbow\"]\n",
        &["unknown field `locked_joint`"],
    );
}

#[test]
fn unsupported_integrators_are_refused_before_anything_is_written() {
    for integrator in ["rk4", "euler", "semi-implicit", "moser-veselov"] {
        refused(
            &PENDULUM.replace(
                "[sim]\n",
                &format!("[sim]\nintegrator = \"{integrator}\"\n"),
            ),
            &[
                &format!("sim.integrator = \"{integrator}\" cannot step model[0]"),
                "`variational`, `variational4`, `variational6`",
            ],
        );
    }
}

#[test]
fn articulated_keys_on_other_modes_are_refused() {
    for (key, value) in [
        ("base", "\"fixed\""),
        ("joint_velocities", "{ elbow = 1.0 }"),
        ("locked_joints", "[\"elbow\"]"),
    ] {
        refused(
            &format!(
                "[[model]]\nurdf = \"double_pendulum.urdf\"\nbodies = \"rigid\"\n{key} = {value}\n"
            ),
            &[&format!(
                "model[0].{key} applies to bodies = \"articulated\" only"
            )],
        );
    }
    refused(
        &format!("{PENDULUM}linvel = [1.0, 0.0, 0.0]\n"),
        &["base = \"fixed\" welds the root link", "linvel and angvel"],
    );
}

#[test]
fn velocities_of_joints_that_do_not_move_are_refused() {
    refused(
        &format!("{PENDULUM}locked_joints = [\"elbow\"]\njoint_velocities = {{ elbow = 1.0 }}\n"),
        &[
            "joint_velocities.elbow",
            "locked (locked_joints)",
            "it does not move",
        ],
    );
}

#[test]
fn mimic_joints_take_their_values_from_their_leader() {
    let mimic =
        "[[model]]\nurdf = \"mimic_pendulum.urdf\"\nbodies = \"articulated\"\nbase = \"fixed\"\n";
    refused(
        &format!("{mimic}joints = {{ elbow = 0.3 }}\n"),
        &[
            "joints.elbow",
            "mimics `shoulder`",
            "set `shoulder` instead",
        ],
    );
    refused(
        &format!("{mimic}joint_velocities = {{ elbow = 0.3 }}\n"),
        &["joint_velocities.elbow", "mimics `shoulder`"],
    );
    refused(
        &format!("{mimic}locked_joints = [\"elbow\"]\n"),
        &["locked_joints names `elbow`, which mimics `shoulder`: lock `shoulder` instead"],
    );
}

/// Massless links entered by a moving joint that no compound joint can absorb are refused
/// naming the link, the joint and the ways out; never a division by zero.
#[test]
fn massless_links_that_cannot_be_compound_joints_are_refused() {
    refused(
        "[[model]]\nurdf = \"massless_branch.urdf\"\nbodies = \"articulated\"\n",
        &[
            "link `hub` has no mass and is entered by the moving joint `j1`",
            "carries 2 moving joints",
            "links.hub.inertia = \"geometry\"",
            "locked_joints = [\"j1\"]",
        ],
    );
    refused(
        "[[model]]\nurdf = \"massless_offset.urdf\"\nbodies = \"articulated\"\n",
        &[
            "link `virtual` has no mass",
            "are 1.000e-1 m apart",
            "must meet at one point",
        ],
    );
    refused(
        "[[model]]\nurdf = \"massless_root.urdf\"\nbodies = \"articulated\"\n",
        &[
            "the root link `world_frame` has no mass",
            "base = \"floating\"",
            "use base = \"fixed\"",
        ],
    );
    refused(
        "[[model]]\nurdf = \"planar.urdf\"\nbodies = \"articulated\"\n",
        &["joint `slide2d` is planar", "locked_joints = [\"slide2d\"]"],
    );
    refused(
        "[[model]]\nurdf = \"double_pendulum.urdf\"\nbodies = \"articulated\"\nbase = \"fixed\"\n\
         locked_joints = [\"shoulder\", \"elbow\"]\n",
        &[
            "base = \"fixed\"",
            "no moving joint left",
            "nothing would move",
        ],
    );
}

/// The same massless root is fine with a fixed base: it is the world.
#[test]
fn a_massless_root_with_a_fixed_base_runs() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(
        common::root().join("tests/data/mechanism/massless_root.urdf"),
        dir.path().join("m.urdf"),
    )
    .unwrap();
    let scene = dir.path().join("ok.toml");
    std::fs::write(
        &scene,
        "[sim]\nduration = 0.1\n[[model]]\nurdf = \"m.urdf\"\nbodies = \"articulated\"\n\
         base = \"fixed\"\njoints = { j1 = 0.5 }\n",
    )
    .unwrap();
    let run = Command::new(env!("CARGO_BIN_EXE_tumble"))
        .args(["simulate", scene.to_str().unwrap(), "--out"])
        .arg(dir.path().join("out"))
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(dir.path().join("out.mcap").exists());
}
