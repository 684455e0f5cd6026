//! Contacts and the ground in every recording (issue 31): the MCAP `/contacts`
//! (`tumble.Contacts`) and `/contacts/scene` (Foxglove arrows and points) and the ground in
//! `/scene`, read by the Python `mcap` reader with `mcap-protobuf-support`; the ROS 2
//! `/contacts` (`mcap-ros2-support` and `rosbags`); the Rerun ground, points and arrows
//! (rerun-sdk 0.36.3); `STEM.contacts.parquet` (pandas and polars); `tumble convert` and
//! `tumble info` on a file with contacts.
//!
//! The contacts are synthetic (what the physics hands over, `sim::contact::ContactPoint`, turned
//! into recorded contacts by the run's own conversion) and written straight into the sinks, so
//! every value read back is checked against numbers chosen here: the force is the impulse over
//! the step, the normals, points, gaps and names are the input's, the arrows are the force
//! times the documented scale, the ground is drawn where the layout says. A run of a world with
//! a ground and colliders goes through `simulate_world`; a layout without contacts writes the
//! bytes it writes for frames without contacts, whatever the frames hold.

use crate::common;
use nalgebra::{Quaternion, Unit, UnitQuaternion, Vector3};
use serde_json::Value;
use std::path::{Path, PathBuf};
use tumble::record::{
    Format, FormatSet, Frame, GroundLayout, JointState, MechanismState, RecordingLayout,
    SinkOptions,
};
use tumble::scene::Scene;
use tumble::sim::contact::{Collider, ContactModel, ContactPoint, GROUND, Ground, Shape};

const DT: f64 = 1e-3;
/// Standard gravity and the reference arrow of the recordings' force scale (docs).
const G0: f64 = 9.80665;
const ARROW: f64 = 0.2;

const SCENE: &str = r#"[sim]
dt = 0.001
duration = 0.05
log_every = 10
gravity = [0.0, 0.0, -9.81]

[[model]]
urdf = "BOX"
name = "a"
position = [0.0, 0.0, 1.0]

[[model]]
urdf = "BOX"
name = "b"
position = [1.0, 0.0, 2.0]
"#;

fn scene(dir: &Path) -> Scene {
    let urdf = common::root().join("models/box.urdf");
    let path = dir.join("contact.toml");
    std::fs::write(&path, SCENE.replace("BOX", &urdf.display().to_string())).unwrap();
    Scene::load(&path).unwrap()
}

/// A tilted ground, away from the origin (so a pose drawn at the origin, or with the normal
/// ignored, is caught).
fn ground() -> GroundLayout {
    GroundLayout {
        normal: Vector3::new(0.0, -0.6, 0.8),
        point: Vector3::new(0.5, 0.25, -0.1),
    }
}

/// The synthetic contacts of recorded step `k` (of 0, 10, 20, 30): none at 0 and 30, body 0 on
/// the ground at 10, body 1 on the ground and body 1 against body 0 at 20.
fn points(step: u64) -> Vec<ContactPoint> {
    let n = ground().normal;
    match step {
        10 => vec![ContactPoint {
            body_a: 0,
            body_b: GROUND,
            point_world: Vector3::new(0.25, 0.5, 0.275),
            normal_world: n,
            // 58.86 N along the normal (the box's weight, 6 kg · 9.81), some friction.
            impulse_world: n * 0.05886 + Vector3::new(1e-3, 0.0, 0.0),
            gap_m: -2.5e-6,
        }],
        20 => vec![
            ContactPoint {
                body_a: 1,
                body_b: GROUND,
                point_world: Vector3::new(1.0, -0.5, 0.5),
                normal_world: n,
                impulse_world: n * 0.03 - Vector3::new(0.0, 0.0, 0.001),
                gap_m: 1e-7,
            },
            ContactPoint {
                body_a: 1,
                body_b: 0,
                point_world: Vector3::new(0.5, 0.0, 1.5),
                normal_world: Vector3::new(1.0, 0.0, 0.0),
                // Along −x: the arrow's rotation from +x is the degenerate half turn.
                impulse_world: Vector3::new(-0.004, 0.0, 0.0),
                gap_m: -1e-5,
            },
        ],
        _ => Vec::new(),
    }
}

const STEPS: [u64; 4] = [0, 10, 20, 30];

/// Writes the synthetic frames of `layout` into every format under `stem`; `contacts`: whether
/// the frames hold the synthetic contacts. Returns the files written.
fn write(layout: &RecordingLayout, stem: &Path, contacts: bool) -> Vec<PathBuf> {
    let formats = FormatSet::of(&[Format::Mcap, Format::Rrd, Format::Ros2, Format::Parquet]);
    let options = SinkOptions::default();
    std::fs::create_dir_all(stem.parent().unwrap()).unwrap();
    let mut sinks = Vec::new();
    let mut paths = Vec::new();
    for format in formats.iter() {
        for (_, path, sink) in tumble::record::open(format, stem, layout, &options) {
            sinks.push(sink.unwrap() as Box<dyn tumble::record::Sink>);
            paths.push(path);
        }
    }
    let poses: Vec<_> = (0..layout.frames.len())
        .map(|i| nalgebra::Isometry3::translation(i as f64, 0.0, 1.0))
        .collect();
    let bodies = vec![
        tumble::record::BodyState {
            linvel_world: Vector3::zeros(),
            angvel_world: Vector3::zeros(),
            angmom_world: Vector3::zeros(),
            kinetic_energy: 0.0,
            potential_energy: 1.0,
        };
        layout.bodies.len()
    ];
    let joints: Vec<JointState> = Vec::new();
    let mechanisms: Vec<MechanismState> = Vec::new();
    for step in STEPS {
        let mut states = Vec::new();
        if contacts {
            tumble::simulation::contact_states(&points(step), DT, &mut states);
        }
        let frame = Frame {
            step,
            time_ns: (step as f64 * DT * 1e9).round() as i64,
            world_from_link: &poses,
            bodies: &bodies,
            joints: &joints,
            mechanisms: &mechanisms,
            contacts: &states,
        };
        for sink in &mut sinks {
            sink.write(&frame).unwrap();
        }
    }
    let outputs: Vec<&Path> = paths.iter().map(PathBuf::as_path).collect();
    tumble::record::finish_all(sinks, Ok(()), &outputs).unwrap();
    paths
}

fn file(stem: &Path, ext: &str) -> PathBuf {
    tumble::record::format::with_extension(stem, ext)
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("{v} is not a number"))
}

fn v3(v: &[Value]) -> Vector3<f64> {
    Vector3::new(f(&v[0]), f(&v[1]), f(&v[2]))
}

fn close(a: &Vector3<f64>, b: &Vector3<f64>, tol: f64) -> bool {
    (a - b).norm() <= tol * b.norm().max(1.0)
}

/// A contact as a reader's CONTACT row should hold it: body_a, body_b, ground, [point, normal,
/// force, impulse], gap.
type Expected = (String, String, bool, [Vector3<f64>; 4], f64);

/// The contacts of step `step` as the readers should give them, with the force worked out here
/// as impulse / dt.
fn expected(names: &[String], step: u64) -> Vec<Expected> {
    points(step)
        .iter()
        .map(|p| {
            let b = if p.body_b == GROUND {
                "ground".to_string()
            } else {
                names[p.body_b as usize].clone()
            };
            (
                names[p.body_a as usize].clone(),
                b,
                p.body_b == GROUND,
                [
                    p.point_world,
                    p.normal_world,
                    p.impulse_world / DT,
                    p.impulse_world,
                ],
                p.gap_m,
            )
        })
        .collect()
}

/// Checks a reader's CONTACT rows (`rows`, one step's) against [`expected`].
fn check_contacts(what: &str, names: &[String], step: u64, rows: &[Value]) {
    let want = expected(names, step);
    assert_eq!(rows.len(), want.len(), "{what}: step {step}");
    for (row, (a, b, ground, vectors, gap)) in rows.iter().zip(want) {
        let row = row.as_array().unwrap();
        assert_eq!(row[0], a.as_str(), "{what}: step {step}: body_a");
        assert_eq!(row[1], b.as_str(), "{what}: step {step}: body_b");
        assert_eq!(row[2], ground, "{what}: step {step}: ground");
        for (k, (name, want)) in ["point", "normal", "force", "impulse"]
            .iter()
            .zip(vectors)
            .enumerate()
        {
            let got = v3(&row[3 + 3 * k..6 + 3 * k]);
            assert!(
                close(&got, &want, 1e-15),
                "{what}: step {step}: {name} {got} != {want}"
            );
        }
        assert_eq!(f(&row[15]), gap, "{what}: step {step}: gap");
    }
}

fn quaternion(v: &[Value]) -> UnitQuaternion<f64> {
    UnitQuaternion::new_normalize(Quaternion::new(f(&v[3]), f(&v[0]), f(&v[1]), f(&v[2])))
}

/// The arrows' scale the docs state: 0.2 m for the median model's weight at standard gravity
/// (both models here are one 6 kg box).
fn scale() -> f64 {
    ARROW / (6.0 * G0)
}

/// Every format records the synthetic contacts with the values given, and draws the ground
/// where the layout puts it (see the module doc); `tumble convert` replays the contacts into
/// the run's own `.rrd` and `tumble info` lists the topics.
#[test]
fn every_format_records_the_contacts_and_the_ground() {
    let dir = tempfile::tempdir().unwrap();
    let world = scene(dir.path()).build().unwrap();
    let mut layout = world.layout.clone();
    layout.ground = Some(ground());
    layout.contacts = true;
    let names: Vec<String> = layout.bodies.iter().map(|b| b.name.clone()).collect();
    assert_eq!(names.len(), 2);
    let stem = dir.path().join("out/run");
    let written = write(&layout, &stem, true);
    assert!(
        written.contains(&file(&stem, "contacts.parquet")),
        "{written:?}"
    );

    let py = common::run_py(
        "read_contacts.py",
        &[
            &file(&stem, "mcap"),
            &file(&stem, "ros2.mcap"),
            &file(&stem, "rrd"),
            &file(&stem, "contacts.parquet"),
        ],
    );

    // MCAP /contacts: one message per recorded step, the file's schema names every field.
    let mcap = &py["mcap"];
    assert_eq!(mcap["schemas"]["/contacts"], "tumble.Contacts");
    assert_eq!(mcap["schemas"]["/contacts/scene"], "foxglove.SceneUpdate");
    assert_eq!(
        mcap["contact_fields"],
        serde_json::json!([
            "body_a", "body_b", "ground", "point", "normal", "force", "impulse", "gap_m"
        ])
    );
    let messages = mcap["contacts"]["/contacts"].as_array().unwrap();
    assert_eq!(messages.len(), STEPS.len());
    for (m, step) in messages.iter().zip(STEPS) {
        let t = (step as f64 * DT * 1e9).round();
        assert_eq!((f(&m[0]), f(&m[1]), f(&m[2])), (t, t, step as f64));
        check_contacts("mcap", &names, step, m[3].as_array().unwrap());
    }

    // MCAP /contacts/scene: per step one `contacts` entity in `world`, a sphere at every point
    // and an arrow from it along the force, |F| · scale long; the scale is in the metadata.
    let scenes = mcap["scene"]["/contacts/scene"].as_array().unwrap();
    assert_eq!(scenes.len(), STEPS.len());
    for (m, step) in scenes.iter().zip(STEPS) {
        let entities = m[1].as_array().unwrap();
        assert_eq!(entities.len(), 1, "step {step}");
        let e = &entities[0];
        assert_eq!(
            (&e["id"], &e["frame_id"]),
            (&Value::from("contacts"), &Value::from("world"))
        );
        let recorded_scale: f64 = e["metadata"]["force_scale_m_per_n"]
            .as_str()
            .unwrap()
            .parse()
            .unwrap();
        assert!(
            (recorded_scale / scale() - 1.0).abs() < 1e-15,
            "{recorded_scale}"
        );
        let (spheres, arrows) = (
            e["spheres"].as_array().unwrap(),
            e["arrows"].as_array().unwrap(),
        );
        let input = points(step);
        assert_eq!(
            (spheres.len(), arrows.len()),
            (input.len(), input.len()),
            "step {step}"
        );
        for ((sphere, arrow), p) in spheres.iter().zip(arrows).zip(&input) {
            let at = v3(sphere[0].as_array().unwrap());
            assert_eq!(at, p.point_world, "step {step}: sphere");
            let pose = arrow[0].as_array().unwrap();
            assert_eq!(v3(pose), p.point_world, "step {step}: arrow tail");
            let force = p.impulse_world / DT;
            let direction = quaternion(&pose[3..]) * Vector3::x();
            assert!(
                close(&direction, &force.normalize(), 1e-12),
                "step {step}: arrow along {direction}, force {force}"
            );
            let length = f(&arrow[1]) + f(&arrow[3]);
            assert!(
                (length / (force.norm() * scale()) - 1.0).abs() < 1e-12,
                "step {step}: arrow {length} m for {} N",
                force.norm()
            );
        }
    }
    // The weight of one box (58.86 N at step 10, along the normal) is drawn about 0.2 m long.
    let weight_arrow = &scenes[1][1][0]["arrows"][0];
    let length = f(&weight_arrow[1]) + f(&weight_arrow[3]);
    assert!((0.19..0.21).contains(&length), "{length}");

    // MCAP /scene: the frames' entities, then the ground: a 20 m square slab 1 cm thick in
    // `world`, its top face through the ground's point, its z axis along the normal.
    let scene = mcap["scene"]["/scene"].as_array().unwrap();
    assert_eq!(scene.len(), 1);
    let entities = scene[0][1].as_array().unwrap();
    assert_eq!(entities.len(), layout.frames.len() + 1);
    let g = entities.last().unwrap();
    assert_eq!(
        (&g["id"], &g["frame_id"]),
        (&Value::from("ground"), &Value::from("world"))
    );
    let cube = &g["cubes"][0];
    let pose = cube[0].as_array().unwrap();
    let n = ground().normal.normalize();
    assert!(
        close(&v3(pose), &(ground().point - n * 0.005), 1e-15),
        "{pose:?}"
    );
    assert!(
        close(&(quaternion(&pose[3..]) * Vector3::z()), &n, 1e-15),
        "{pose:?}"
    );
    assert_eq!(
        v3(cube[1].as_array().unwrap()),
        Vector3::new(20.0, 20.0, 0.01)
    );

    // ROS 2 /contacts: both decoders read the values of the protobuf file.
    let ros = &py["ros2"];
    assert_eq!(
        ros["channels"]["/contacts"],
        serde_json::json!(["tumble_msgs/msg/Contacts", "cdr"])
    );
    for decoder in ["mcap_ros2", "rosbags"] {
        let messages = ros[decoder]["/contacts"].as_array().unwrap();
        assert_eq!(messages.len(), STEPS.len(), "{decoder}");
        for (m, step) in messages.iter().zip(STEPS) {
            assert_eq!(f(&m[2]), step as f64, "{decoder}");
            check_contacts(decoder, &names, step, m[3].as_array().unwrap());
        }
    }

    // Rerun: the ground as a static box (centre, half sizes, rotation in f32), the points and
    // the arrows per row, an empty row where nothing touches.
    let rrd = &py["rrd"];
    let ground_cells = &rrd["static"]["/world/ground"];
    let centre = v3(ground_cells["Boxes3D:centers"][0].as_array().unwrap());
    let want = (ground().point - n * 0.005).map(|x| x as f32 as f64);
    assert_eq!(centre, want);
    assert_eq!(
        v3(ground_cells["Boxes3D:half_sizes"][0].as_array().unwrap()),
        Vector3::new(10.0, 10.0, 0.005f32 as f64)
    );
    let q = ground_cells["Boxes3D:quaternions"][0].as_array().unwrap();
    assert!(close(&(quaternion(q) * Vector3::z()), &n, 1e-6), "{q:?}");
    assert_eq!(
        rrd["static"]["/world/contacts/points"]["CoordinateFrame:frame"],
        serde_json::json!(["world"])
    );
    let point_rows = rrd["rows"]["/world/contacts/points"].as_array().unwrap();
    let arrow_rows = rrd["rows"]["/world/contacts/forces"].as_array().unwrap();
    assert_eq!(
        (point_rows.len(), arrow_rows.len()),
        (STEPS.len(), STEPS.len())
    );
    for ((prow, arow), step) in point_rows.iter().zip(arrow_rows).zip(STEPS) {
        let input = points(step);
        let positions = prow[1]["Points3D:positions"].as_array().unwrap();
        let origins = arow[1]["Arrows3D:origins"].as_array().unwrap();
        let vectors = arow[1]["Arrows3D:vectors"].as_array().unwrap();
        assert_eq!(positions.len(), input.len(), "step {step}");
        for (((pos, origin), vector), p) in positions.iter().zip(origins).zip(vectors).zip(&input) {
            let f32x3 = |v: Vector3<f64>| v.map(|x| x as f32 as f64);
            assert_eq!(v3(pos.as_array().unwrap()), f32x3(p.point_world));
            assert_eq!(v3(origin.as_array().unwrap()), f32x3(p.point_world));
            assert_eq!(
                v3(vector.as_array().unwrap()),
                f32x3(p.impulse_world / DT * scale()),
                "step {step}"
            );
        }
    }

    // Parquet: one row per contact, the documented columns and units.
    let parquet = &py["parquet"];
    for reader in ["pandas", "polars"] {
        let table = &parquet[reader];
        assert_eq!(table["rows"], 3, "{reader}");
        let columns: Vec<&str> = table["columns"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| c.as_str().unwrap())
            .collect();
        assert_eq!(
            columns,
            [
                "run",
                "step",
                "time",
                "time_secs",
                "body_a",
                "body_b",
                "ground",
                "point_x",
                "point_y",
                "point_z",
                "normal_x",
                "normal_y",
                "normal_z",
                "force_x",
                "force_y",
                "force_z",
                "impulse_x",
                "impulse_y",
                "impulse_z",
                "gap_m"
            ],
            "{reader}"
        );
        let records = table["records"].as_array().unwrap();
        let mut rows = records.iter();
        for step in STEPS {
            let n = points(step).len();
            let one_step: Vec<Value> = rows
                .by_ref()
                .take(n)
                .map(|r| {
                    let r = r.as_array().unwrap();
                    assert_eq!(f(&r[0]), step as f64, "{reader}");
                    assert_eq!(f(&r[1]), (step as f64 * DT * 1e9).round(), "{reader}");
                    // [body_a, body_b, ground, vectors..., gap] as the other readers give it.
                    Value::Array(r[3..].to_vec())
                })
                .collect();
            check_contacts(reader, &names, step, &one_step);
        }
    }
    let units = &parquet["units"];
    assert_eq!(
        (
            &units["force_x"],
            &units["impulse_z"],
            &units["point_y"],
            &units["gap_m"]
        ),
        (
            &Value::from("N"),
            &Value::from("N s"),
            &Value::from("m"),
            &Value::from("m")
        )
    );

    // Rerun's own check of the file (every archetype's components as the viewer expects them).
    let verify = std::process::Command::new(common::venv_bin("rerun"))
        .args(["rrd", "verify"])
        .arg(file(&stem, "rrd"))
        .output()
        .unwrap();
    assert!(verify.status.success(), "{}", common::text(&verify.stderr));

    // `tumble convert`: the MCAP replays into the run's own `.rrd`, byte for byte (the
    // contacts read back from `/contacts`, the ground from the layout).
    let replayed = dir.path().join("replayed.rrd");
    tumble::replay::convert::convert(&file(&stem, "mcap"), &replayed, &Default::default()).unwrap();
    assert!(
        std::fs::read(&replayed).unwrap() == std::fs::read(file(&stem, "rrd")).unwrap(),
        "the replayed .rrd differs from the recorded one"
    );
    // `tumble info` lists the two topics, one message per recorded step each.
    let info = tumble::replay::info::info(&file(&stem, "mcap")).unwrap();
    for (topic, schema) in [
        ("/contacts", "tumble.Contacts"),
        ("/contacts/scene", "foxglove.SceneUpdate"),
    ] {
        let t = info.topics.iter().find(|t| t.topic == topic).unwrap();
        assert_eq!((t.schema.as_str(), t.messages), (schema, 4));
    }
}

/// A layout without contacts (no ground, `contacts = false`) writes no contact topic, series or
/// table: every file is byte for byte the one written for the same frames without contacts,
/// even when the frames hold some (as before contact existed; `scripts/compare_outputs.sh`
/// checks the bundled scenes against the binary before contact).
#[test]
fn a_layout_without_contacts_writes_the_files_it_wrote_before_contact() {
    let dir = tempfile::tempdir().unwrap();
    let layout = scene(dir.path()).build().unwrap().layout;
    assert!(layout.ground.is_none() && !layout.contacts);
    let with = write(&layout, &dir.path().join("with/run"), true);
    let without = write(&layout, &dir.path().join("without/run"), false);
    let listing = |files: &[PathBuf]| -> Vec<String> {
        files
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect()
    };
    assert_eq!(listing(&with), listing(&without));
    assert!(!listing(&with).iter().any(|n| n.contains("contacts")));
    for (a, b) in with.iter().zip(&without) {
        assert!(
            std::fs::read(a).unwrap() == std::fs::read(b).unwrap(),
            "{} differs",
            a.display()
        );
    }
}

/// A world with a ground and a collider tells the recorders through its layout
/// (`World::describe_contact`): a run then writes the contacts topic, series and table (here
/// empty: the body is 0.9 m above the ground for the whole run) and draws the ground; a world
/// whose contact model changed after its layout was described is refused before any file
/// exists.
#[test]
fn a_world_with_a_ground_records_its_contacts_and_draws_the_ground() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene(dir.path());
    let mut world = scene.build().unwrap();
    world.contact = ContactModel {
        ground: Some(Ground {
            normal: Unit::new_normalize(Vector3::z()),
            point: Vector3::zeros(),
            friction: 0.8,
            restitution: 0.0,
        }),
        colliders: vec![Collider {
            body: 0,
            body_from_shape: nalgebra::Isometry3::identity(),
            shape: Shape::Sphere { radius: 0.1 },
            friction: 0.8,
            restitution: 0.0,
            group: 0,
            self_collision: false,
        }],
        excluded_body_pairs: Vec::new(),
    };
    let options = tumble::simulation::SimulateOptions {
        rerun: Default::default(),
        formats: FormatSet::of(&[Format::Mcap, Format::Rrd, Format::Ros2, Format::Parquet]),
        threads: 1,
        mcap_compression: Default::default(),
        accuracy_model: Default::default(),
    };
    let stem = dir.path().join("out/run");
    let refused = tumble::simulation::simulate_world(&scene, &mut world.clone(), &stem, &options)
        .err()
        .unwrap();
    assert!(
        format!("{refused:#}").contains(
            "the recording layout says ground false, contacts false; the contact model says \
             ground true, contacts true (World::describe_contact was not called after the \
             contact model was filled)"
        ),
        "{refused:#}"
    );
    assert!(
        !dir.path().join("out").exists() || common::listing(&dir.path().join("out")).is_empty()
    );

    world.describe_contact();
    assert_eq!(
        (world.layout.ground, world.layout.contacts),
        (
            Some(GroundLayout {
                normal: Vector3::z(),
                point: Vector3::zeros()
            }),
            true
        )
    );
    let out = tumble::simulation::simulate_world(&scene, &mut world, &stem, &options).unwrap();
    assert!(
        out.written.contains(&file(&stem, "contacts.parquet")),
        "{:?}",
        out.written
    );
    let py = common::run_py(
        "read_contacts.py",
        &[
            &file(&stem, "mcap"),
            &file(&stem, "ros2.mcap"),
            &file(&stem, "rrd"),
            &file(&stem, "contacts.parquet"),
        ],
    );
    // Steps 0, 10, ..., 50: a message each, no contact in any.
    for (what, messages) in [
        ("mcap", &py["mcap"]["contacts"]["/contacts"]),
        ("mcap_ros2", &py["ros2"]["mcap_ros2"]["/contacts"]),
        ("rosbags", &py["ros2"]["rosbags"]["/contacts"]),
    ] {
        let messages = messages.as_array().unwrap();
        let steps: Vec<f64> = messages.iter().map(|m| f(&m[2])).collect();
        assert_eq!(steps, [0.0, 10.0, 20.0, 30.0, 40.0, 50.0], "{what}");
        assert!(
            messages.iter().all(|m| m[3].as_array().unwrap().is_empty()),
            "{what}"
        );
    }
    let ground_entity = py["mcap"]["scene"]["/scene"][0][1]
        .as_array()
        .unwrap()
        .iter()
        .find(|e| e["id"] == "ground")
        .cloned()
        .unwrap();
    let pose = ground_entity["cubes"][0][0].as_array().unwrap();
    assert_eq!(v3(pose), Vector3::new(0.0, 0.0, -0.005));
    let rows = py["rrd"]["rows"]["/world/contacts/points"]
        .as_array()
        .unwrap();
    assert_eq!(rows.len(), 6);
    assert!(
        rows.iter()
            .all(|r| r[1]["Points3D:positions"] == serde_json::json!([]))
    );
    assert!(py["rrd"]["static"]["/world/ground"]["Boxes3D:centers"].is_array());
    assert_eq!(py["parquet"]["pandas"]["rows"], 0);
    assert_eq!(py["parquet"]["polars"]["rows"], 0);
}

/// End to end with the contact physics: box `a` (6 kg, 0.1 × 0.2 × 0.3 m) resting on a level
/// frictionless ground, its collider the box itself. Every recorded step after the first holds its contacts with
/// the ground, at the ground's surface, the normal up; the forces sum to its weight
/// `m g = 58.86 N` (the impulses to `m g dt`: the force is the impulse over the step, not the
/// impulse), and the Parquet table holds the MCAP's values.
#[test]
fn a_box_resting_on_the_ground_records_its_weight() {
    let dir = tempfile::tempdir().unwrap();
    let text = SCENE
        .replace(
            "position = [0.0, 0.0, 1.0]",
            "position = [0.0, 0.0, 0.15]",
        )
        .replace(
            "BOX",
            &common::root().join("models/box.urdf").display().to_string(),
        );
    let path = dir.path().join("resting.toml");
    std::fs::write(&path, text).unwrap();
    let scene = Scene::load(&path).unwrap();
    let mut world = scene.build().unwrap();
    // The box in its body's principal frame (whose axes need not be the link's).
    let body_from_link = world.layout.bodies[0].link_from_principal.inverse();
    world.contact = ContactModel {
        ground: Some(Ground {
            normal: Unit::new_normalize(Vector3::z()),
            point: Vector3::zeros(),
            friction: 0.0,
            restitution: 0.0,
        }),
        colliders: vec![Collider {
            body: 0,
            body_from_shape: body_from_link,
            shape: Shape::Box {
                half_extents: Vector3::new(0.05, 0.1, 0.15),
            },
            friction: 0.0,
            restitution: 0.0,
            group: 0,
            self_collision: false,
        }],
        excluded_body_pairs: Vec::new(),
    };
    world.describe_contact();
    let options = tumble::simulation::SimulateOptions {
        rerun: Default::default(),
        formats: FormatSet::of(&[Format::Mcap, Format::Parquet]),
        threads: 1,
        mcap_compression: Default::default(),
        accuracy_model: Default::default(),
    };
    let stem = dir.path().join("out/run");
    tumble::simulation::simulate_world(&scene, &mut world, &stem, &options).unwrap();
    let py = common::run_py(
        "read_contacts.py",
        &[
            &file(&stem, "mcap"),
            Path::new("-"),
            Path::new("-"),
            &file(&stem, "contacts.parquet"),
        ],
    );
    let weight = 6.0 * 9.81;
    let messages = py["mcap"]["contacts"]["/contacts"].as_array().unwrap();
    assert_eq!(messages.len(), 6);
    assert!(messages[0][3].as_array().unwrap().is_empty(), "step 0");
    let mut rows = 0;
    for m in &messages[1..] {
        let contacts = m[3].as_array().unwrap();
        assert!(!contacts.is_empty(), "step {}", m[2]);
        rows += contacts.len();
        let mut total = Vector3::zeros();
        for c in contacts {
            let c = c.as_array().unwrap();
            assert_eq!(
                (c[0].as_str(), c[1].as_str(), &c[2]),
                (Some("a/box"), Some("ground"), &Value::Bool(true))
            );
            assert!(f(&c[5]).abs() < 1e-9, "point on the ground: {c:?}");
            assert_eq!(v3(&c[6..9]), Vector3::z());
            let (force, impulse) = (v3(&c[9..12]), v3(&c[12..15]));
            assert!(close(&force, &(impulse / DT), 1e-15), "{force} {impulse}");
            total += force;
        }
        // Measured: four contacts, |Σ F_z / (m g) − 1| ≤ 1.1e-12 (the active-set solve's
        // diagonal shift, docs/contact.md), Σ F_xy = 0.
        assert!(
            (total.z / weight - 1.0).abs() < 1e-10 && total.xy().norm() < 1e-10 * weight,
            "step {}: total force {total} N, weight {weight} N",
            m[2]
        );
    }
    for reader in ["pandas", "polars"] {
        assert_eq!(py["parquet"][reader]["rows"], rows, "{reader}");
    }
}
