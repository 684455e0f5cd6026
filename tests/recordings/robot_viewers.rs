//! Robots in the viewers (issue 32): a model with meshes records no inertia ellipsoids unless
//! asked (`--ellipsoids`), each mesh's data is written once per file, and both viewers open on
//! the robot (the Rerun blueprint's eye tracks its root link; `STEM.foxglove.json` follows its
//! root frame). Read back by the Python `mcap` reader and rerun-sdk 0.36.3.

use crate::common;
use common::{run_py, text, tumble};
use std::path::Path;

/// A floating three-link robot: two links share one STL mesh, the third has a box.
const MESHED_URDF: &str = r#"<?xml version="1.0"?>
<robot name="meshbot">
  <link name="pelvis">
    <inertial><mass value="3"/><inertia ixx="0.05" iyy="0.06" izz="0.07" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><mesh filename="cube.stl" scale="2 2 1"/></geometry></visual>
  </link>
  <joint name="hip" type="revolute">
    <parent link="pelvis"/><child link="thigh"/><origin xyz="0 0 -0.2"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="10" velocity="5"/>
  </joint>
  <link name="thigh">
    <inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.002" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><origin xyz="0 0 -0.1"/><geometry><mesh filename="cube.stl"/></geometry></visual>
  </link>
  <joint name="knee" type="revolute">
    <parent link="thigh"/><child link="shin"/><origin xyz="0 0 -0.3"/><axis xyz="0 1 0"/>
  </joint>
  <link name="shin">
    <inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.002" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><origin xyz="0 0 -0.1"/><geometry><box size="0.05 0.05 0.3"/></geometry></visual>
  </link>
</robot>
"#;

fn write_robot(d: &Path) {
    std::fs::copy(
        common::root().join("tests/data/policy/cube_0_1m.stl"),
        d.join("cube.stl"),
    )
    .unwrap();
    std::fs::write(d.join("meshbot.urdf"), MESHED_URDF).unwrap();
}

fn simulate_robot(d: &Path, out: &str, duration: &str, extra: &[&str]) {
    let mut args = vec![
        "simulate",
        "meshbot.urdf",
        "--articulated",
        "--base",
        "floating",
        "--position",
        "3,-1,2",
        "--angvel",
        "0.5,1,0",
        "--duration",
        duration,
        "--out",
        out,
    ];
    args.extend_from_slice(extra);
    let o = tumble(&args, d);
    assert!(o.status.success(), "{}", text(&o.stderr));
}

fn has_inertia_entity(py: &serde_json::Value) -> bool {
    py["rrd"]["entities"]
        .as_array()
        .unwrap()
        .iter()
        .any(|e| e.as_str().unwrap().contains("/inertia/"))
}

/// A model with meshes: no `/inertia` topic and no Rerun ellipsoid entity by default; both with
/// `--ellipsoids` (one per body); `--no-ellipsoids` with `--ellipsoids` is refused.
#[test]
fn meshed_robot_has_ellipsoids_only_with_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_robot(d);
    simulate_robot(d, "plain", "0.5", &[]);
    let py = run_py(
        "count_meshes.py",
        &[&d.join("plain.mcap"), &d.join("plain.rrd")],
    );
    let topics = py["mcap"]["topics"].as_array().unwrap();
    assert!(topics.contains(&"/scene".into()), "{topics:?}");
    assert!(!topics.contains(&"/inertia".into()), "{topics:?}");
    assert!(!has_inertia_entity(&py), "{}", py["rrd"]["entities"]);

    simulate_robot(d, "with", "0.5", &["--ellipsoids"]);
    let py = run_py(
        "count_meshes.py",
        &[&d.join("with.mcap"), &d.join("with.rrd")],
    );
    let topics = py["mcap"]["topics"].as_array().unwrap();
    assert!(topics.contains(&"/inertia".into()), "{topics:?}");
    assert_eq!(py["mcap"]["messages"]["/inertia"], 1);
    assert!(has_inertia_entity(&py), "{}", py["rrd"]["entities"]);
    let scene = run_py("read_scene.py", &[&d.join("with.mcap")]);
    let ids: Vec<&str> = scene["topics"]["/inertia"][0]["entities"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["id"].as_str().unwrap())
        .collect();
    assert_eq!(ids, ["inertia/pelvis", "inertia/thigh", "inertia/shin"]);

    let o = tumble(
        &[
            "simulate",
            "meshbot.urdf",
            "--out",
            "both",
            "--ellipsoids",
            "--no-ellipsoids",
        ],
        d,
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
}

/// Each mesh visual's data is in the files once, however many steps are recorded: the MCAP has
/// one `/scene` message whose triangle lists are the two mesh visuals (vertices as float32
/// values), the .rrd one `Asset3D` blob per mesh visual; a run ten times longer adds no mesh.
#[test]
fn mesh_data_is_written_once_per_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_robot(d);
    simulate_robot(d, "short", "0.5", &["--log-every", "1"]);
    let short = run_py(
        "count_meshes.py",
        &[&d.join("short.mcap"), &d.join("short.rrd")],
    );
    assert_eq!(short["mcap"]["messages"]["/scene"], 1, "{short}");
    assert_eq!(short["mcap"]["triangle_lists"], 2, "{short}");
    assert_eq!(short["mcap"]["f32_exact"], true);
    assert_eq!(short["rrd"]["asset3d_blobs"], 2, "{short}");
    assert_eq!(short["rrd"]["mesh3d_meshes"], 0, "{short}");
    let points = short["mcap"]["points"].as_u64().unwrap();
    assert!(points > 0);

    simulate_robot(d, "long", "5", &["--log-every", "1"]);
    let long = run_py(
        "count_meshes.py",
        &[&d.join("long.mcap"), &d.join("long.rrd")],
    );
    assert_eq!(long["mcap"]["messages"]["/scene"], 1, "{long}");
    assert_eq!(long["mcap"]["triangle_lists"], 2);
    assert_eq!(long["mcap"]["points"].as_u64().unwrap(), points);
    assert_eq!(long["rrd"]["asset3d_blobs"], 2, "{long}");
}

/// Both viewers open on the robot: the Rerun blueprint's eye tracks the root link's visual
/// entity and looks at the robot where it starts (not at the origin); `STEM.foxglove.json` is
/// the shipped layout with its 3D panel following the root frame. A scene of free bodies with
/// primitive shapes keeps the whole-run framing and gets no such layout.
#[test]
fn viewers_open_on_the_robot_and_follow_it() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_robot(d);
    simulate_robot(d, "run", "0.5", &[]);
    let bp = run_py("read_blueprint.py", &[&d.join("run.rrd")]);
    let entities = bp["entities"].as_object().unwrap();
    let (path, eye) = entities
        .iter()
        .find(|(k, _)| k.ends_with("/EyeControls3D"))
        .unwrap_or_else(|| panic!("no EyeControls3D: {bp}"));
    assert_eq!(
        eye["EyeControls3D:tracking_entity"],
        serde_json::json!(["/meshbot/visual_geometries/pelvis/visual_0"]),
        "{path}: {eye}"
    );
    let target: Vec<f64> = eye["EyeControls3D:look_target"][0]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    // The robot starts with its pelvis at (3, -1, 2) and hangs 0.8 m below it.
    assert!(
        (target[0] - 3.0).abs() < 0.3 && (target[1] + 1.0).abs() < 0.3,
        "{target:?}"
    );
    assert!(target[2] > 1.2 && target[2] < 2.2, "{target:?}");

    let layout: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("run.foxglove.json")).unwrap())
            .unwrap();
    let panel = &layout["configById"]["3D!tumble"];
    assert_eq!(panel["followTf"], "pelvis");
    assert_eq!(panel["followMode"], "follow-position");
    let distance = panel["cameraState"]["distance"].as_f64().unwrap();
    assert!(distance > 0.5 && distance < 5.0, "{distance}");
    assert_eq!(panel["topics"]["/scene"]["visible"], true);
    // The rest is the shipped layout's (its plots).
    let shipped: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(common::root().join("docs/foxglove/tumble-layout.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(layout["layout"], shipped["layout"]);

    // Welded to the world, the robot is framed over the run and not tracked.
    let o = tumble(
        &[
            "simulate",
            "meshbot.urdf",
            "--articulated",
            "--base",
            "fixed",
            "--duration",
            "0.5",
            "--out",
            "fixed",
            "--force",
        ],
        d,
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    let eye = eye_controls(&d.join("fixed.rrd"));
    assert!(eye.get("EyeControls3D:tracking_entity").is_none(), "{eye}");

    // `tumble convert` makes the same choices from the MCAP's layout: the run's own .rrd.
    let o = tumble(&["convert", "run.mcap", "--rrd", "conv.rrd"], d);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(
        std::fs::read(d.join("conv.rrd")).unwrap() == std::fs::read(d.join("run.rrd")).unwrap(),
        "convert gave another .rrd"
    );

    // Free boxes (the bundled default scene): no tracking, no robot layout.
    let o = tumble(
        &[
            "simulate",
            common::root().join("models/default.toml").to_str().unwrap(),
            "--out",
            "free",
            "--duration",
            "0.1",
        ],
        d,
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    let eye = eye_controls(&d.join("free.rrd"));
    assert!(eye.get("EyeControls3D:tracking_entity").is_none(), "{eye}");
    assert!(!d.join("free.foxglove.json").exists());
}

/// The 3D view's `EyeControls3D` properties in the blueprint of the recording `rrd`.
fn eye_controls(rrd: &std::path::Path) -> serde_json::Value {
    let bp = run_py("read_blueprint.py", &[rrd]);
    bp["entities"]
        .as_object()
        .unwrap()
        .iter()
        .find(|(k, _)| k.ends_with("/EyeControls3D"))
        .map(|(_, v)| v.clone())
        .unwrap()
}
