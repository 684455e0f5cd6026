//! Driven joints in every recording (issue 30): the effort applied (actuator plus damping), the
//! commanded target and the saturation, on the MCAP `/joints` (read by the Python `mcap` reader
//! with `mcap-protobuf-support`), in the ROS 2 `/joint_states` `effort` (`mcap-ros2-support` and
//! `rosbags`), in the Rerun series (rerun-sdk 0.36.3) and in `STEM.joints.parquet` (pandas and
//! polars), each checked against the drive laws worked out here from the recorded time,
//! position and velocity, and the formats against each other value for value.
//!
//! The drives are put on the built world's mechanisms directly (the scene keys that describe
//! them are the scene's business); `World::describe_drives` then tells the recorders. What the
//! drives do to the motion is the integrator's business: every check here holds whatever the
//! joints do, because each recorded effort is checked against the recorded state.

use crate::common;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use tumble::record::{Format, FormatSet};
use tumble::scene::Scene;
use tumble::sim::mechanism::{Actuator, ActuatorKind, JointDrive};
use tumble::sim::signal::Signal;
use tumble::simulation::{SimulateOptions, simulate_world};
use tumble::world::World;

/// dp_0's shoulder: a position servo toward `0.2 + 0.5 sin(2π 0.5 t)`, its effort limited.
const KP: f64 = 40.0;
const KD: f64 = 3.0;
const LIMIT: f64 = 60.0;
const SHOULDER_DAMPING: f64 = 0.1;
/// dp_0's elbow: a constant motor, damped.
const MOTOR: f64 = 0.7;
const ELBOW_DAMPING: f64 = 0.05;
/// dp_1's shoulder: a velocity servo toward 1 rad/s.
const VELOCITY_KD: f64 = 2.0;
/// cp's hinge: damping alone.
const HINGE_DAMPING: f64 = 0.3;

fn servo_target(t: f64) -> f64 {
    0.2 + 0.5 * (std::f64::consts::TAU * 0.5 * t).sin()
}

/// cp's slide motor: the table (0 s, 0 N), (0.1 s, 2 N), linear between, held after.
fn slide_effort(t: f64) -> f64 {
    if t >= 0.1 { 2.0 } else { 20.0 * t }
}

const SCENE: &str = r#"[sim]
dt = 0.001
duration = 0.2
log_every = 10

[[model]]
urdf = "DP"
name = "dp"
copies = 2
seed = 1
bodies = "articulated"
base = "fixed"
position = { uniform = [[-1.0, 0.0, 2.0], [1.0, 0.0, 2.0]] }
joints = { shoulder = 2.0, elbow = 0.5 }
joint_velocities = { elbow = -1.0 }

[[model]]
urdf = "CP"
name = "cp"
bodies = "articulated"
base = "fixed"
position = [3.0, 0.0, 1.5]
joints = { hinge = 1.0 }
joint_velocities = { slide = 0.5 }
"#;

pub(crate) fn scene(dir: &Path) -> Scene {
    let models = common::root().join("models");
    let text = SCENE
        .replace(
            "DP",
            &models.join("double_pendulum.urdf").display().to_string(),
        )
        .replace("CP", &models.join("cart_pole.urdf").display().to_string());
    let path = dir.join("driven.toml");
    std::fs::write(&path, &text).unwrap();
    Scene::load(&path).unwrap()
}

fn actuator(kind: ActuatorKind, effort_limit: Option<f64>) -> Option<Actuator> {
    Some(Actuator { kind, effort_limit })
}

/// Puts `drives` (by joint name) on mechanism `k` of `world`.
fn drive(world: &mut World, k: usize, drives: Vec<(&str, Option<Actuator>, f64)>) {
    let mechanism = Arc::make_mut(&mut world.mechanisms[k]);
    let model = Arc::make_mut(&mut mechanism.shared);
    let mut list: Vec<JointDrive> = drives
        .into_iter()
        .map(|(name, actuator, damping)| JointDrive {
            coordinate: model
                .coordinates
                .iter()
                .position(|c| c.name == name)
                .unwrap_or_else(|| panic!("no joint {name}")),
            actuator,
            damping,
        })
        .collect();
    list.sort_by_key(|d| d.coordinate);
    model.drives = list;
    model.validate().unwrap();
}

/// The scene's world with the drives of the module doc (dp_1's elbow undriven).
pub(crate) fn driven_world(scene: &Scene) -> World {
    let mut world = scene.build().unwrap();
    let names: Vec<&str> = world
        .layout
        .mechanisms
        .iter()
        .map(|m| m.name.as_str())
        .collect();
    assert_eq!(names, ["dp_0", "dp_1", "cp"]);
    drive(
        &mut world,
        0,
        vec![
            (
                "shoulder",
                actuator(
                    ActuatorKind::Position {
                        target: Signal::Sine {
                            amplitude: 0.5,
                            frequency_hz: 0.5,
                            phase: 0.0,
                            offset: 0.2,
                        },
                        kp: KP,
                        kd: KD,
                    },
                    Some(LIMIT),
                ),
                SHOULDER_DAMPING,
            ),
            (
                "elbow",
                actuator(
                    ActuatorKind::Motor {
                        effort: Signal::Constant(MOTOR),
                    },
                    None,
                ),
                ELBOW_DAMPING,
            ),
        ],
    );
    drive(
        &mut world,
        1,
        vec![(
            "shoulder",
            actuator(
                ActuatorKind::Velocity {
                    target: Signal::Constant(1.0),
                    kd: VELOCITY_KD,
                },
                None,
            ),
            0.0,
        )],
    );
    drive(
        &mut world,
        2,
        vec![
            (
                "slide",
                actuator(
                    ActuatorKind::Motor {
                        effort: Signal::Table {
                            times_secs: vec![0.0, 0.1],
                            values: vec![0.0, 2.0],
                        },
                    },
                    None,
                ),
                0.0,
            ),
            ("hinge", None, HINGE_DAMPING),
        ],
    );
    world.describe_drives();
    world
}

/// Runs `world` of `scene` to every format under `dir/out/run`; the stem.
pub(crate) fn record(scene: &Scene, world: &mut World, dir: &Path) -> PathBuf {
    let stem = dir.join("out/run");
    let options = SimulateOptions {
        rerun: Default::default(),
        formats: FormatSet::of(&[Format::Mcap, Format::Rrd, Format::Ros2, Format::Parquet]),
        threads: 1,
        mcap_compression: Default::default(),
        accuracy_model: Default::default(),
    };
    simulate_world(scene, world, &stem, &options).unwrap();
    stem
}

pub(crate) fn file(stem: &Path, ext: &str) -> PathBuf {
    let mut s = stem.as_os_str().to_owned();
    s.push(".");
    s.push(ext);
    PathBuf::from(s)
}

pub(crate) const JOINTS: [&str; 6] = [
    "dp_0/shoulder",
    "dp_0/elbow",
    "dp_1/shoulder",
    "dp_1/elbow",
    "cp/slide",
    "cp/hinge",
];

/// What a joint's drive makes of a recorded sample `(t, θ, θ̇)`: (effort, target, saturated).
fn expected(joint: &str, t: f64, theta: f64, rate: f64) -> (f64, Option<f64>, bool) {
    match joint {
        "dp_0/shoulder" => {
            let raw = KP * (servo_target(t) - theta) - KD * rate;
            let clamped = raw.clamp(-LIMIT, LIMIT);
            (
                clamped - SHOULDER_DAMPING * rate,
                Some(servo_target(t)),
                raw.abs() > LIMIT,
            )
        }
        "dp_0/elbow" => (MOTOR - ELBOW_DAMPING * rate, None, false),
        "dp_1/shoulder" => (VELOCITY_KD * (1.0 - rate), Some(1.0), false),
        "cp/slide" => (slide_effort(t), None, false),
        "cp/hinge" => (-HINGE_DAMPING * rate, None, false),
        _ => (0.0, None, false),
    }
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * b.abs().max(1.0)
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("{v} is not a number"))
}

/// One recorded sample of a joint as the protobuf `/joints` holds it.
#[derive(Debug, Clone, PartialEq)]
struct Sample {
    t_ns: f64,
    step: f64,
    position: f64,
    velocity: f64,
    effort: f64,
    target: Option<f64>,
    saturated: bool,
    /// Whether the message carries an effort (every driven joint's, even 0; no undriven one's).
    has_effort: bool,
}

/// The samples of every joint, from read_joints.py's output.
fn samples(py: &Value) -> std::collections::BTreeMap<String, Vec<Sample>> {
    let mut out = std::collections::BTreeMap::new();
    for name in JOINTS {
        let states = py["joints"][name].as_array().unwrap();
        let efforts = py["efforts"][name].as_array().unwrap();
        assert_eq!(states.len(), efforts.len(), "{name}");
        let rows = states
            .iter()
            .zip(efforts)
            .map(|(s, e)| {
                assert_eq!((&s[0], &s[1]), (&e[0], &e[1]), "{name}: time and step");
                Sample {
                    t_ns: f(&s[0]),
                    step: f(&s[1]),
                    position: f(&s[2]),
                    velocity: f(&s[3]),
                    effort: f(&e[2]),
                    target: e[3].as_f64(),
                    saturated: e[4].as_bool().unwrap(),
                    has_effort: e[5].as_bool().unwrap(),
                }
            })
            .collect();
        out.insert(name.to_string(), rows);
    }
    out
}

/// The protobuf `/joints` of a driven run: its schema declares `effort = 4` (proto3 optional:
/// present for every driven joint, even when 0), `target = 5` (optional: present exactly where
/// a servo commands one) and `saturated = 6`, and every recorded value is the drive's law at
/// the recorded time, position and velocity; the position servo is saturated at some samples
/// and not at others (so the flag is checked both ways); an undriven joint records no effort
/// (reading 0), no target, not saturated. Then the other formats carry the same values: ROS 2
/// `effort` (both decoders), the Rerun series, the Parquet joints table (pandas and polars);
/// and `tumble convert` replays the driven MCAP into the run's own `.rrd`.
#[test]
fn every_format_records_the_drives() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene(dir.path());
    let mut world = driven_world(&scene);
    let stem = record(&scene, &mut world, dir.path());
    let mcap = file(&stem, "mcap");

    // MCAP, read by the official Python reader with the file's own schema.
    let py = common::run_py("read_joints.py", &[&mcap]);
    assert_eq!(
        py["joint_fields"],
        serde_json::json!([
            "name",
            "position",
            "velocity",
            "effort",
            "target",
            "saturated",
            "at_limit"
        ])
    );
    let pb = samples(&py);
    let (mut saturated, mut free) = (0, 0);
    for (name, rows) in &pb {
        assert_eq!(
            rows.len(),
            21,
            "{name}: 200 steps, every 10th and the first"
        );
        for s in rows {
            let t = s.t_ns / 1e9;
            // Present for every driven joint, even when 0 (cp/slide's table starts at 0 N).
            assert_eq!(s.has_effort, name != "dp_1/elbow", "{name} at {t} s");
            let (effort, target, sat) = expected(name, t, s.position, s.velocity);
            assert!(
                close(s.effort, effort),
                "{name} at {t} s: effort {} != {effort}",
                s.effort
            );
            match (s.target, target) {
                (Some(a), Some(b)) => assert!(close(a, b), "{name} at {t} s: target {a} != {b}"),
                (a, b) => assert_eq!(a, b, "{name} at {t} s: target"),
            }
            assert_eq!(s.saturated, sat, "{name} at {t} s: saturated");
            if name == "dp_0/shoulder" {
                if sat {
                    saturated += 1;
                } else {
                    free += 1;
                }
            }
        }
    }
    // measured: 4 saturated samples (the start: |raw| = 72 N m at t = 0), 17 not once the servo
    // pulls the joint toward its target (10 and 11 before the integrator applied the drives)
    assert!(
        saturated > 0 && free > 0,
        "{saturated} saturated, {free} not"
    );
    // The effort of a motor on a prismatic joint is the table's, in N (0 at t = 0).
    let slide = &pb["cp/slide"];
    assert_eq!((slide[0].effort, slide[20].effort), (0.0, 2.0));

    // ROS 2: `effort` filled for every joint, equal to the protobuf's.
    let ros = common::run_py("read_ros2.py", &[&file(&stem, "ros2.mcap")]);
    for decoder in ["mcap_ros2", "rosbags"] {
        for name in JOINTS {
            let rows = ros[decoder]["joints"][name].as_array().unwrap();
            assert_eq!(rows.len(), 21, "{decoder} {name}");
            for (r, s) in rows.iter().zip(&pb[name]) {
                assert_eq!(f(&r[0]), s.t_ns, "{decoder} {name}");
                assert_eq!(r[4], 6, "{decoder} {name}: one effort per joint");
                assert_eq!(f(&r[6]), s.effort, "{decoder} {name}: effort");
            }
        }
    }

    // The layout JSON (the same in both MCAP files) lists the drives, for replay.
    let layout: Value =
        serde_json::from_str(ros["metadata"]["tumble"]["layout_json"].as_str().unwrap()).unwrap();
    let joint_names: Vec<&str> = layout["joints"]
        .as_array()
        .unwrap()
        .iter()
        .map(|j| j["name"].as_str().unwrap())
        .collect();
    assert_eq!(joint_names, JOINTS);
    assert_eq!(
        layout["drives"],
        serde_json::json!([
            {"joint": 0, "actuator": "position", "effort_limit": LIMIT, "damping": SHOULDER_DAMPING},
            {"joint": 1, "actuator": "motor", "effort_limit": null, "damping": ELBOW_DAMPING},
            {"joint": 2, "actuator": "velocity", "effort_limit": null, "damping": 0.0},
            {"joint": 4, "actuator": "motor", "effort_limit": null, "damping": 0.0},
            {"joint": 5, "actuator": null, "effort_limit": null, "damping": HINGE_DAMPING},
        ])
    );

    // Parquet joints table: pandas and polars read the protobuf's values.
    let parquet = common::run_py("read_parquet_joints.py", &[&file(&stem, "joints.parquet")]);
    let drive_names = [
        ("dp_0/shoulder", Some("position")),
        ("dp_0/elbow", Some("motor")),
        ("dp_1/shoulder", Some("velocity")),
        ("dp_1/elbow", None),
        ("cp/slide", Some("motor")),
        ("cp/hinge", Some("damping")),
    ];
    for reader in ["pandas", "polars"] {
        let table = &parquet[reader];
        assert_eq!(table["rows"], 6 * 21, "{reader}");
        assert_eq!(
            table["columns"],
            serde_json::json!([
                "run",
                "step",
                "time",
                "time_secs",
                "joint",
                "position",
                "velocity",
                "effort",
                "target",
                "saturated",
                "drive",
                "at_limit"
            ]),
            "{reader}"
        );
        for (name, drive) in drive_names {
            let rows = table["joints"][name].as_array().unwrap();
            assert_eq!(rows.len(), 21, "{reader} {name}");
            for (r, s) in rows.iter().zip(&pb[name]) {
                let got = Sample {
                    t_ns: f(&r[1]),
                    step: f(&r[0]),
                    position: f(&r[3]),
                    velocity: f(&r[4]),
                    effort: f(&r[5]),
                    target: r[6].as_f64(),
                    saturated: r[7].as_bool().unwrap(),
                    // the table has no presence: what the MCAP says
                    has_effort: s.has_effort,
                };
                assert_eq!(&got, s, "{reader} {name}");
                assert_eq!(f(&r[2]), s.t_ns * 1e-9, "{reader} {name}: time_secs");
                assert_eq!(r[8].as_str(), drive, "{reader} {name}: drive");
            }
        }
    }
    let dtypes = &parquet["polars"]["dtypes"];
    for (column, dtype) in [
        ("position", "Float64"),
        ("effort", "Float64"),
        ("target", "Float64"),
        ("saturated", "Boolean"),
        ("drive", "String"),
        ("joint", "String"),
    ] {
        assert_eq!(dtypes[column], dtype, "polars {column}");
    }
    assert_eq!(parquet["pandas"]["dtypes"]["saturated"], "bool");
    assert_eq!(parquet["units"]["effort"], "N m or N");
    assert_eq!(parquet["units"]["position"], "rad or m");

    // Rerun: the effort of every driven joint, the servos' targets, the limited actuator's
    // saturation (0/1), the f64 values of the MCAP; nothing for the undriven joint.
    let rrd = file(&stem, "rrd");
    let scalars = common::run_py("read_scalars.py", &[&rrd]);
    let series = |entity: &str| -> Vec<(f64, f64)> {
        scalars[entity]
            .as_array()
            .unwrap_or_else(|| panic!("{entity} missing"))
            .iter()
            .map(|r| (f(&r[0]), f(&r[1])))
            .collect()
    };
    for name in JOINTS {
        let entity = format!("/plots/joints/effort/{name}");
        if name == "dp_1/elbow" {
            assert!(scalars.get(&entity).is_none(), "{entity}");
            continue;
        }
        let expected: Vec<(f64, f64)> = pb[name].iter().map(|s| (s.t_ns, s.effort)).collect();
        assert_eq!(series(&entity), expected, "{entity}");
    }
    for (kind, name) in [
        ("position_target", "dp_0/shoulder"),
        ("velocity_target", "dp_1/shoulder"),
    ] {
        let expected: Vec<(f64, f64)> = pb[name]
            .iter()
            .map(|s| (s.t_ns, s.target.unwrap()))
            .collect();
        assert_eq!(series(&format!("/plots/joints/{kind}/{name}")), expected);
    }
    let saturation: Vec<(f64, f64)> = pb["dp_0/shoulder"]
        .iter()
        .map(|s| (s.t_ns, if s.saturated { 1.0 } else { 0.0 }))
        .collect();
    assert_eq!(series("/plots/joints/saturated/dp_0/shoulder"), saturation);
    let targets: Vec<&String> = scalars
        .as_object()
        .unwrap()
        .keys()
        .filter(|k| k.contains("target") || k.contains("saturated"))
        .collect();
    assert_eq!(
        targets,
        [
            "/plots/joints/position_target/dp_0/shoulder",
            "/plots/joints/saturated/dp_0/shoulder",
            "/plots/joints/velocity_target/dp_1/shoulder"
        ]
    );
    let names = common::run_py("read_series_names.py", &[&rrd]);
    assert_eq!(
        names["/plots/joints/position_target/dp_0/shoulder"],
        serde_json::json!(["dp_0/shoulder target"])
    );
    assert_eq!(
        names["/plots/joints/effort/cp/slide"],
        serde_json::json!(["cp/slide"])
    );
    // Each servo's measured series and its target share a colour (Tableau 10 in joint order:
    // blue, orange), the target wide and translucent; other series keep the viewer's colours.
    let style = common::run_py("read_series_names.py", &[&rrd, Path::new("--style")]);
    for (entity, colour, width) in [
        ("/plots/joints/position/dp_0/shoulder", 0x1f77b4ff_u64, None),
        (
            "/plots/joints/position_target/dp_0/shoulder",
            0x1f77b478,
            Some(3.0),
        ),
        ("/plots/joints/velocity/dp_1/shoulder", 0xff7f0eff, None),
        (
            "/plots/joints/velocity_target/dp_1/shoulder",
            0xff7f0e78,
            Some(3.0),
        ),
    ] {
        assert_eq!(
            style[entity]["colors"],
            serde_json::json!([colour]),
            "{entity}"
        );
        assert_eq!(
            style[entity]["widths"],
            width.map_or(Value::Null, |w: f64| serde_json::json!([w])),
            "{entity}"
        );
    }
    for entity in [
        "/plots/joints/velocity/dp_0/shoulder",
        "/plots/joints/position/dp_1/elbow",
        "/plots/joints/effort/dp_0/shoulder",
    ] {
        assert_eq!(style[entity]["colors"], Value::Null, "{entity}");
    }
    // The blueprint: the position target in the joint positions plot, the velocity servo's
    // velocity against its target, the efforts.
    let queries = blueprint_queries(&rrd);
    for expected in [
        serde_json::json!([
            "+ /plots/joints/position/**",
            "+ /plots/joints/position_target/**"
        ]),
        serde_json::json!([
            "+ /plots/joints/velocity/dp_1/shoulder",
            "+ /plots/joints/velocity_target/**"
        ]),
        serde_json::json!(["+ /plots/joints/effort/**"]),
    ] {
        assert!(queries.contains(&expected), "{expected} not in {queries:?}");
    }

    // `tumble info` lists what drives each joint.
    let out = common::tumble(&["info", mcap.to_str().unwrap(), "--json"], dir.path());
    assert!(out.status.success(), "{}", common::text(&out.stderr));
    let info: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(
        info["joints"][0]["drive"],
        serde_json::json!({"kind": "position", "effort_limit": LIMIT, "damping": SHOULDER_DAMPING})
    );
    assert_eq!(info["joints"][5]["drive"]["kind"], "damping");
    assert!(
        info["joints"][3].get("drive").is_none(),
        "{}",
        info["joints"][3]
    );

    // `tumble convert` replays the driven MCAP into the very .rrd the run wrote.
    let converted = dir.path().join("conv.rrd");
    let out = common::tumble(
        &[
            "convert",
            mcap.to_str().unwrap(),
            "--rrd",
            converted.to_str().unwrap(),
        ],
        dir.path(),
    );
    assert!(out.status.success(), "{}", common::text(&out.stderr));
    assert!(std::fs::read(&converted).unwrap() == std::fs::read(&rrd).unwrap());
}

/// Every plot's `ViewContents:query` of the blueprint of `rrd`.
fn blueprint_queries(rrd: &Path) -> Vec<Value> {
    let bp = common::run_py("read_blueprint.py", &[rrd]);
    bp["entities"]
        .as_object()
        .unwrap()
        .values()
        .filter_map(|c| c.get("ViewContents:query").cloned())
        .collect()
}

/// A run without drives records what it recorded before drives existed: the `/joints` schema
/// declares no drive field, ROS 2 `effort` is empty, no drive series or plot in Rerun, no
/// `drives` in the layout JSON; the joints table has every joint with effort 0, no target, no
/// drive.
#[test]
fn a_run_without_drives_records_no_drive_fields() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene(dir.path());
    let mut world = scene.build().unwrap();
    assert!(world.layout.drives.is_empty());
    let stem = record(&scene, &mut world, dir.path());
    let py = common::run_py("read_joints.py", &[&file(&stem, "mcap")]);
    assert_eq!(
        py["joint_fields"],
        // The URDFs' limits are on: `at_limit` (not a drive field) is declared.
        serde_json::json!(["name", "position", "velocity", "at_limit"])
    );
    let ros = common::run_py("read_ros2.py", &[&file(&stem, "ros2.mcap")]);
    for name in JOINTS {
        for r in ros["rosbags"]["joints"][name].as_array().unwrap() {
            assert_eq!((&r[4], &r[6]), (&0.into(), &Value::Null), "{name}");
        }
    }
    let rrd = file(&stem, "rrd");
    let scalars = common::run_py("read_scalars.py", &[&rrd]);
    assert!(scalars["/plots/joints/position/dp_0/shoulder"].is_array());
    assert!(
        !scalars
            .as_object()
            .unwrap()
            .keys()
            .any(|k| k.contains("effort") || k.contains("target") || k.contains("saturated")),
        "{:?}",
        scalars.as_object().unwrap().keys().collect::<Vec<_>>()
    );
    assert!(blueprint_queries(&rrd).contains(&serde_json::json!(["+ /plots/joints/position/**"])));
    let layout = ros["metadata"]["tumble"]["layout_json"].as_str().unwrap();
    assert!(!layout.contains("drives"), "{layout}");
    let parquet = common::run_py("read_parquet_joints.py", &[&file(&stem, "joints.parquet")]);
    for reader in ["pandas", "polars"] {
        let table = &parquet[reader];
        assert_eq!(table["rows"], 6 * 21, "{reader}");
        for name in JOINTS {
            for r in table["joints"][name].as_array().unwrap() {
                assert_eq!(
                    (&r[5], &r[6], &r[7], &r[8]),
                    (&0.0.into(), &Value::Null, &false.into(), &Value::Null),
                    "{reader} {name}"
                );
            }
        }
    }
}

/// A world whose mechanisms have drives its recording layout does not list (built without
/// `World::describe_drives`) is refused before anything is stepped or written: its recordings
/// would leave the drives out.
#[test]
fn a_layout_that_hides_drives_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene(dir.path());
    let mut world = driven_world(&scene);
    world.layout.drives.clear();
    let err = tumble::simulation::Simulation::of_world(
        &world,
        scene.integrator(),
        scene.sim.dt,
        &scene.variational_settings(),
        1,
        &scene.run_settings(),
    )
    .err()
    .expect("refused");
    assert!(
        err.to_string()
            .contains("lists 0 joint drives, the mechanisms have 5"),
        "{err}"
    );
}

/// A recording's efforts drive another run (`effort = { log = ... }` on `/joints`, read by the
/// scene's own log reader): every driven joint's effort is in the log even where it is 0 (the
/// elbow's sine motor at t = 0), and the second run's recorded efforts are the first run's,
/// sample for sample (a motor's effort is its signal, and the log's rows are at those times).
#[test]
fn recorded_efforts_drive_another_run() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let dp = common::root().join("models/double_pendulum.urdf");
    let scene = |actuators: &str| {
        format!(
            "[sim]\ndt = 0.001\nduration = 0.2\nlog_every = 10\n\n[[model]]\nurdf = \"{}\"\n\
             bodies = \"articulated\"\nbase = \"fixed\"\njoints = {{ shoulder = 1.0 }}\n{actuators}",
            dp.display()
        )
    };
    std::fs::write(
        d.join("one.toml"),
        scene(
            "[[model.actuator]]\njoint = \"shoulder\"\nkind = \"position\"\ntarget = 0.2\nkp = 50.0\n\
             kd = 2.0\n[[model.actuator]]\njoint = \"elbow\"\nkind = \"motor\"\n\
             effort = { sine = { amplitude = 1.0, frequency_hz = 1.0 } }\n",
        ),
    )
    .unwrap();
    let log = "{ log = \"one.mcap\", topic = \"/joints\" }";
    std::fs::write(
        d.join("two.toml"),
        scene(&format!(
            "[[model.actuator]]\njoint = \"shoulder\"\nkind = \"motor\"\neffort = {log}\n\
             [[model.actuator]]\njoint = \"elbow\"\nkind = \"motor\"\neffort = {log}\n"
        )),
    )
    .unwrap();
    for run in ["one", "two"] {
        let out = common::tumble(
            &[
                "simulate",
                &format!("{run}.toml"),
                "--out",
                run,
                "--format",
                "mcap",
            ],
            d,
        );
        assert!(out.status.success(), "{run}: {}", common::text(&out.stderr));
    }
    let one = common::run_py("read_joints.py", &[&d.join("one.mcap")]);
    let two = common::run_py("read_joints.py", &[&d.join("two.mcap")]);
    // The elbow's motor is 0 at t = 0, and its effort is in the message all the same.
    assert_eq!(one["efforts"]["elbow"][0][2], 0.0);
    assert_eq!(one["efforts"]["elbow"][0][5], true);
    for joint in ["shoulder", "elbow"] {
        let (a, b) = (
            one["efforts"][joint].as_array().unwrap(),
            two["efforts"][joint].as_array().unwrap(),
        );
        assert_eq!(a.len(), 21, "{joint}");
        for (x, y) in a.iter().zip(b) {
            assert_eq!(x[0], y[0], "{joint}: time");
            assert_eq!(f(&x[2]), f(&y[2]), "{joint} at {} ns", x[0]);
        }
    }
}
