//! A robot through the CLI (issue 32): `simulate URDF --articulated --base`, the note when a
//! URDF's links are simulated as free bodies, `inspect`'s joints, and "did you mean" for
//! misspelt joint and link names in a scene.

use crate::common;

use arrow_array::{Array, Float64Array, RecordBatch, StringArray};
use common::{text, tumble};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use std::path::{Path, PathBuf};

/// Two links with mass on the revolute `elbow`, anchored at (0, 0, 1); the arm's centre of mass
/// is 0.3 m from the anchor.
fn arm_urdf() -> PathBuf {
    common::root().join("tests/data/cli/two_link_arm.urdf")
}

const ANCHOR: [f64; 3] = [0.0, 0.0, 1.0];
const ARM_COM_FROM_ANCHOR: f64 = 0.3;

fn batches(path: &Path) -> Vec<RecordBatch> {
    ParquetRecordBatchReaderBuilder::try_new(std::fs::File::open(path).unwrap())
        .unwrap()
        .build()
        .unwrap()
        .map(|b| b.unwrap())
        .collect()
}

/// The recorded centre-of-mass positions of body `body`, in time order.
fn positions(path: &Path, body: &str) -> Vec<[f64; 3]> {
    let mut out = Vec::new();
    for b in batches(path) {
        let names = b.column_by_name("body").unwrap();
        let names = names.as_any().downcast_ref::<StringArray>().unwrap();
        let col = |c: &str| {
            b.column_by_name(c)
                .unwrap()
                .as_any()
                .downcast_ref::<Float64Array>()
                .unwrap()
                .clone()
        };
        let (x, y, z) = (col("position_x"), col("position_y"), col("position_z"));
        for r in 0..b.num_rows() {
            if names.value(r) == body {
                out.push([x.value(r), y.value(r), z.value(r)]);
            }
        }
    }
    out
}

fn body_names(path: &Path) -> Vec<String> {
    let mut names: Vec<String> = batches(path)
        .iter()
        .flat_map(|b| {
            let a = b.column_by_name("body").unwrap();
            let a = a.as_any().downcast_ref::<StringArray>().unwrap();
            (0..a.len())
                .map(|r| a.value(r).to_string())
                .collect::<Vec<_>>()
        })
        .collect();
    names.sort();
    names.dedup();
    names
}

fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

fn simulate_arm(dir: &Path, stem: &str, extra: &[&str]) -> std::process::Output {
    let urdf = arm_urdf();
    let mut args = vec![
        "simulate",
        urdf.to_str().unwrap(),
        "--duration",
        "0.5",
        "--format",
        "parquet",
        "--out",
        stem,
    ];
    args.extend_from_slice(extra);
    tumble(&args, dir)
}

const NOTE: &str = "its links move as free bodies";

#[test]
fn articulated_with_a_fixed_base_keeps_the_joint() {
    let dir = tempfile::tempdir().unwrap();
    let out = simulate_arm(dir.path(), "fixed", &["--articulated", "--base", "fixed"]);
    let stderr = text(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        !stderr.contains(NOTE),
        "no note with --articulated: {stderr}"
    );
    let table = dir.path().join("fixed.trajectories.parquet");
    // The base is welded to the world: the arm is the one body.
    let names = body_names(&table);
    assert_eq!(names.len(), 1, "{names:?}");
    let arm = positions(&table, &names[0]);
    assert_eq!(arm.len(), 51);
    for p in &arm {
        let d = distance(*p, ANCHOR);
        assert!(
            (d - ARM_COM_FROM_ANCHOR).abs() < 1e-6,
            "the arm's centre of mass left its circle about the anchor: {d} m at {p:?}"
        );
    }
    // And it swings: gravity turns it about the hinge.
    let last = arm.last().unwrap();
    assert!(last[2] < ANCHOR[2] - 0.1, "the arm did not swing: {last:?}");
    assert!(
        (arm[0][0] - ARM_COM_FROM_ANCHOR).abs() < 1e-9,
        "starts horizontal: {:?}",
        arm[0]
    );

    // A floating base: two bodies joined, the anchor falls with them, the joint still holds.
    let out = simulate_arm(dir.path(), "floating", &["--articulated"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let table = dir.path().join("floating.trajectories.parquet");
    assert_eq!(body_names(&table).len(), 2);
}

#[test]
fn free_links_fall_apart_with_a_note_naming_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let out = simulate_arm(dir.path(), "free", &[]);
    let stderr = text(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert_eq!(stderr.matches(NOTE).count(), 1, "one note: {stderr}");
    assert!(stderr.contains("`elbow`"), "{stderr}");
    assert!(stderr.contains("--articulated"), "{stderr}");
    let table = dir.path().join("free.trajectories.parquet");
    let names = body_names(&table);
    assert_eq!(names.len(), 2, "{names:?}");
    // Nothing holds the arm: it falls away from the (unheld) anchor, 0.5 g t^2 = 1.2 m.
    let arm = names.iter().find(|n| n.contains("arm")).unwrap();
    let last = *positions(&table, arm).last().unwrap();
    assert!(distance(last, ANCHOR) > 1.0, "{last:?}");
}

#[test]
fn base_without_articulated_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let out = simulate_arm(dir.path(), "x", &["--base", "fixed"]);
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.starts_with("error: --base"), "{stderr}");
    assert!(stderr.contains("--articulated"), "{stderr}");
    assert!(!dir.path().join("x.trajectories.parquet").exists());
    // And both flags belong to a URDF input: a scene says `bodies` and `base` itself.
    let scene = common::root().join("models/box.toml");
    let out = tumble(
        &[
            "simulate",
            scene.to_str().unwrap(),
            "--articulated",
            "--out",
            "y",
        ],
        dir.path(),
    );
    assert_eq!(out.status.code(), Some(2), "{}", text(&out.stderr));
    assert!(text(&out.stderr).contains("apply to a URDF input"));
}

#[test]
fn inspect_lists_the_joints() {
    let dir = tempfile::tempdir().unwrap();
    let urdf = arm_urdf();
    let out = tumble(&["inspect", urdf.to_str().unwrap()], dir.path());
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(stdout.contains("joints (1, 1 moving)"), "{stdout}");
    assert!(
        stdout.contains(
            "  joint `elbow` revolute: `base` -> `arm`, axis [0 1.00000 0], limits lower -2.50000 \
             upper 2.50000, effort 12.0000, velocity 3.50000, damping 0.0100000, friction 0.0200000"
        ),
        "{stdout}"
    );
    // The lines that were there before stay.
    assert!(stdout.contains("link `arm` (from <inertial>)"), "{stdout}");
    assert!(stdout.contains("no problems found"), "{stdout}");

    let out = tumble(&["inspect", "--json", urdf.to_str().unwrap()], dir.path());
    assert!(out.status.success(), "{}", text(&out.stderr));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let joints = json["joints"].as_array().unwrap();
    assert_eq!(joints.len(), 1);
    let j = &joints[0];
    assert_eq!(j["name"], "elbow");
    assert_eq!(j["type"], "revolute");
    assert_eq!(j["parent"], "base");
    assert_eq!(j["child"], "arm");
    assert_eq!(j["axis"], serde_json::json!([0.0, 1.0, 0.0]));
    assert_eq!(j["lower"], -2.5);
    assert_eq!(j["upper"], 2.5);
    assert_eq!(j["effort"], 12.0);
    assert_eq!(j["velocity"], 3.5);
    assert_eq!(j["damping"], 0.01);
    assert_eq!(j["friction"], 0.02);
    assert_eq!(
        j["origin"]["translation"],
        serde_json::json!([0.0, 0.0, 1.0])
    );
    assert!(j["mimic"].is_null());
}

/// Runs a scene around the arm (`model` is the `[[model]]` table's extra lines) and asserts one
/// error, exit 2, naming the scene file, the key and the suggestion.
fn assert_suggests(model: &str, key: &str, suggestion: &str) {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.toml");
    std::fs::write(
        &scene,
        format!(
            "[sim]\nduration = 0.01\n\n[[model]]\nurdf = {:?}\n{model}",
            arm_urdf().display().to_string()
        ),
    )
    .unwrap();
    let out = tumble(
        &[
            "simulate",
            "scene.toml",
            "--out",
            "run",
            "--format",
            "parquet",
        ],
        dir.path(),
    );
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(
        stderr.starts_with("error: scene.toml: model[0]"),
        "{stderr}"
    );
    assert_eq!(stderr.matches("error:").count(), 1, "one message: {stderr}");
    assert!(stderr.contains(key), "{key:?} not in {stderr}");
    assert!(
        stderr.contains(&format!("did you mean `{suggestion}`?")),
        "no suggestion `{suggestion}` in {stderr}"
    );
    assert!(!dir.path().join("run.trajectories.parquet").exists());
}

#[test]
fn a_misspelt_actuator_joint_gets_the_closest_name() {
    assert_suggests(
        "bodies = \"articulated\"\n\n[[model.actuator]]\njoint = \"elbw\"\nkind = \"motor\"\neffort = 0.1\n",
        "actuator[0].joint: no joint `elbw`",
        "elbow",
    );
}

#[test]
fn misspelt_names_in_other_keys_get_the_closest_name() {
    assert_suggests(
        "bodies = \"articulated\"\nlocked_joints = [\"elbov\"]\n",
        "locked_joints",
        "elbow",
    );
    assert_suggests(
        "bodies = \"articulated\"\njoint_velocities = { Elbow = 1.0 }\n",
        "joint_velocities.Elbow",
        "elbow",
    );
    assert_suggests(
        "joints = { ellbow = 0.5 }\n",
        "joints.ellbow: no joint named `ellbow`",
        "elbow",
    );
    assert_suggests(
        "\n[[model.load]]\nlink = \"amr\"\nforce = [0.0, 0.0, 1.0]\n",
        "load[0].link: no link `amr`",
        "arm",
    );
    assert_suggests(
        "links = { bsae = { density = 500.0 } }\n",
        "links.bsae",
        "base",
    );
}
