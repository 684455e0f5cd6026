//! The Rerun recorder, checked with readers we did not write: `rerun rrd verify` and the
//! rerun-sdk 0.36.3 dataframe API (`tests/py/read_rrd.py`), both from the venv that
//! `scripts/pyenv.sh` creates. These tests fail (they do not skip) when that venv cannot be made.

use crate::common;
use nalgebra::{Isometry3, Translation3, Unit, UnitQuaternion, Vector3};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;
use tumble::model::{Geometry, Visual};
use tumble::record::rerun::{RerunOptions, create};
use tumble::record::{BodyLayout, BodyState, Frame, FrameLayout, RecordingLayout, Sink};

const STEPS: u64 = 200;
const DT_NS: i64 = 2_500_000;
const GRAVITY: f64 = -9.81;

fn visual(name: Option<&str>, geometry: Geometry, rgba: Option<[f32; 4]>) -> Visual {
    Visual {
        name: name.map(str::to_owned),
        link_from_visual: Isometry3::new(Vector3::new(0.1, -0.2, 0.3), Vector3::new(0.0, 0.4, 0.0)),
        geometry,
        rgba,
    }
}

/// A 1-triangle ASCII STL.
fn write_stl(dir: &Path) -> PathBuf {
    let path = dir.join("tri.stl");
    std::fs::write(
        &path,
        "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n\
         endloop\nendfacet\nendsolid t\n",
    )
    .unwrap();
    path
}

/// Three frames (one with a prefixed id, one without visuals), every primitive, a mesh, a DAE
/// mesh whose file is missing and an unresolved mesh (both skipped), two bodies. (A DAE that
/// exists becomes a `Mesh3D`: tests/recordings/viewers.rs.)
fn layout(mesh_dir: &Path) -> RecordingLayout {
    let stl = write_stl(mesh_dir);
    let frames = vec![
        FrameLayout {
            frame_id: "box".into(),
            model: "box".into(),
            link: "box".into(),
            visuals: vec![
                visual(
                    None,
                    Geometry::Box {
                        size: Vector3::new(0.4, 0.2, 0.1),
                    },
                    Some([0.8, 0.1, 0.1, 1.0]),
                ),
                visual(Some("ball"), Geometry::Sphere { radius: 0.05 }, None),
            ]
            .into(),
        },
        FrameLayout {
            frame_id: "arm/link1".into(),
            model: "arm".into(),
            link: "link1".into(),
            visuals: vec![
                visual(
                    None,
                    Geometry::Cylinder {
                        radius: 0.05,
                        length: 0.3,
                    },
                    Some([0.2, 0.2, 0.9, 0.5]),
                ),
                visual(
                    None,
                    Geometry::Capsule {
                        radius: 0.03,
                        length: 0.2,
                    },
                    None,
                ),
                visual(
                    Some("mesh"),
                    Geometry::Mesh {
                        uri: "package://arm/tri.stl".into(),
                        path: Some(stl),
                        scale: Vector3::new(0.5, 0.5, 2.0),
                    },
                    None,
                ),
                visual(
                    None,
                    Geometry::Mesh {
                        uri: "package://arm/shell.dae".into(),
                        path: Some(mesh_dir.join("shell.dae")),
                        scale: Vector3::repeat(1.0),
                    },
                    None,
                ),
                visual(
                    None,
                    Geometry::Mesh {
                        uri: "package://missing/x.stl".into(),
                        path: None,
                        scale: Vector3::repeat(1.0),
                    },
                    None,
                ),
            ]
            .into(),
        },
        FrameLayout {
            frame_id: "arm/link2".into(),
            model: "arm".into(),
            link: "link2".into(),
            visuals: Vec::new().into(),
        },
    ];
    let bodies = vec![
        BodyLayout {
            name: "box".into(),
            frame: 0,
            mass: 2.0,
            link_from_principal: Isometry3::identity(),
            principal_moments: Vector3::new(0.0083, 0.0283, 0.0333),
        },
        BodyLayout {
            name: "arm/link1".into(),
            frame: 1,
            mass: 1.0,
            link_from_principal: Isometry3::new(
                Vector3::new(0.0, 0.0, 0.1),
                Vector3::new(0.3, 0.0, 0.0),
            ),
            principal_moments: Vector3::new(0.01, 0.01, 0.002),
        },
    ];
    let mut metadata = BTreeMap::new();
    metadata.insert("scene".into(), "[[model]]\nurdf = \"box.urdf\"\n".into());
    metadata.insert("dt".into(), "0.0025".into());
    RecordingLayout {
        name: "rerun_sink_test".into(),
        frames,
        bodies,
        metadata,
        topic_groups: Vec::new(),
        robot_descriptions: Vec::new(),
        ..Default::default()
    }
}

fn axis() -> Unit<Vector3<f64>> {
    Unit::new_normalize(Vector3::new(1.0, 2.0, 2.0))
}

/// The analytic motion: frame 0 spins about a fixed axis and flies on a parabola; frame 1
/// turns about z on a circle; frame 2 is rigidly attached to frame 1.
fn poses(t: f64) -> Vec<Isometry3<f64>> {
    let p0 = Vector3::new(1.0 * t, 0.0, 5.0 * t + 0.5 * GRAVITY * t * t);
    let box_pose = Isometry3::from_parts(
        Translation3::from(p0),
        UnitQuaternion::from_axis_angle(&axis(), 3.0 * t),
    );
    let link1 = Isometry3::from_parts(
        Translation3::new(t.cos(), t.sin(), 0.5),
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), -2.0 * t),
    );
    let link2 = link1 * Isometry3::new(Vector3::new(0.0, 0.0, 0.3), Vector3::new(0.2, 0.0, 0.0));
    vec![box_pose, link1, link2]
}

fn states(t: f64) -> Vec<BodyState> {
    let v0 = Vector3::new(1.0, 0.0, 5.0 + GRAVITY * t);
    let w0 = axis().into_inner() * 3.0;
    let z0 = 5.0 * t + 0.5 * GRAVITY * t * t;
    vec![
        BodyState {
            linvel_world: v0,
            angvel_world: w0,
            angmom_world: w0 * 0.02,
            kinetic_energy: 0.5 * 2.0 * v0.norm_squared(),
            potential_energy: -2.0 * GRAVITY * z0,
        },
        BodyState {
            linvel_world: Vector3::new(-t.sin(), t.cos(), 0.0),
            angvel_world: Vector3::new(0.0, 0.0, -2.0),
            angmom_world: Vector3::new(0.0, 0.0, -0.004),
            kinetic_energy: 0.5 + 0.004,
            potential_energy: -GRAVITY * 0.5,
        },
    ]
}

fn time_ns(step: u64) -> i64 {
    step as i64 * DT_NS
}

/// Writes the whole recording to `path` and returns the sink's warnings.
fn write_recording(path: &Path, mesh_dir: &Path, options: &RerunOptions) -> Vec<String> {
    let layout = layout(mesh_dir);
    let sink = create(path, &layout, options).expect("create");
    let warnings = sink.warnings().to_vec();
    let mut sink: Box<dyn Sink> = Box::new(sink);
    for step in 0..STEPS {
        let t = time_ns(step) as f64 * 1e-9;
        let (poses, states) = (poses(t), states(t));
        sink.write(&Frame {
            step,
            time_ns: time_ns(step),
            world_from_link: &poses,
            bodies: &states,
            joints: &[],
            mechanisms: &[],
            contacts: &[],
        })
        .expect("write");
    }
    sink.finish().expect("finish");
    warnings
}

/// The venv's python (created on first use by `scripts/pyenv.sh`). Panics with a clear message
/// when it cannot be made: these tests must not pass silently without their readers.
fn python() -> &'static Path {
    static PYTHON: OnceLock<PathBuf> = OnceLock::new();
    PYTHON.get_or_init(|| {
        let out = Command::new("bash")
            .arg(common::root().join("scripts/pyenv.sh"))
            .output()
            .unwrap_or_else(|err| panic!("cannot run bash scripts/pyenv.sh: {err}"));
        assert!(
            out.status.success(),
            "scripts/pyenv.sh failed (Python 3 with venv and PyPI access are needed for the \
             Rerun reader tests):\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let python = PathBuf::from(String::from_utf8(out.stdout).unwrap().trim());
        assert!(
            python.exists(),
            "scripts/pyenv.sh printed {python:?}, which does not exist"
        );
        python
    })
}

/// Runs a venv tool; `CI=1` turns the Rerun CLI's usage analytics off.
fn run(program: &Path, args: &[&std::ffi::OsStr]) -> String {
    let out = Command::new(program)
        .args(args)
        .env("CI", "1")
        .output()
        .unwrap_or_else(|err| panic!("cannot run {}: {err}", program.display()));
    assert!(
        out.status.success(),
        "{} {:?} failed:\n{}\n{}",
        program.display(),
        args,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

fn rrd_verify(path: &Path) {
    let rerun = python().with_file_name("rerun");
    run(
        &rerun,
        &["rrd".as_ref(), "verify".as_ref(), path.as_os_str()],
    );
}

fn read_rrd(path: &Path) -> serde_json::Value {
    let script = common::root().join("tests/py/read_rrd.py");
    let stdout = run(python(), &[script.as_os_str(), path.as_os_str()]);
    serde_json::from_str(&stdout).expect("read_rrd.py prints JSON")
}

fn entities(read: &serde_json::Value) -> Vec<String> {
    read["entities"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e.as_str().unwrap().to_owned())
        .collect()
}

#[test]
fn transforms_read_back_by_frame_id_match_to_f32_precision() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.rrd");
    let warnings = write_recording(&path, dir.path(), &RerunOptions::default());
    assert_eq!(
        warnings.len(),
        2,
        "missing DAE and unresolved meshes: {warnings:?}"
    );
    assert!(warnings[0].contains("shell.dae"), "{warnings:?}");
    assert!(warnings[1].contains("missing/x.stl"), "{warnings:?}");
    assert!(!dir.path().join("scene.rrd.part").exists());

    rrd_verify(&path);
    let read = read_rrd(&path);

    // Only simulation timelines: no log_time / log_tick wall clock.
    assert_eq!(read["timelines"], serde_json::json!(["sim_time", "step"]));

    let frames = read["frames"].as_object().unwrap();
    let ids: Vec<&str> = frames.keys().map(String::as_str).collect();
    assert_eq!(ids, ["arm/link1", "arm/link2", "box"]);
    for id in &ids {
        assert_eq!(read["parents"][id], "world", "parent of {id}");
    }

    // Bounds: values are stored as f32, so a read value is exactly `written as f32` (checked
    // bit for bit), which is within 2^-24 (~6e-8) relative of the f64 value: |dx| <= 1e-6 m
    // for the positions here (|x| < 2 m); quaternion components are compared up to sign to the
    // analytic rotation with |dq| <= 1e-6.
    let mut worst_position = 0.0_f64;
    let mut worst_quaternion = 0.0_f64;
    for (index, id) in ["box", "arm/link1", "arm/link2"].iter().enumerate() {
        let rows = frames[*id].as_array().unwrap();
        assert_eq!(rows.len(), STEPS as usize, "rows of {id}");
        for (step, row) in rows.iter().enumerate() {
            let row: Vec<f64> = row
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap())
                .collect();
            let step = step as u64;
            assert_eq!(row[0] as i64, time_ns(step), "time of {id} at step {step}");
            assert_eq!(row[0], time_ns(step) as f64, "times are exact integers");
            let t = time_ns(step) as f64 * 1e-9;
            let pose = poses(t)[index];
            let q = pose.rotation.quaternion();
            let written = [
                pose.translation.x,
                pose.translation.y,
                pose.translation.z,
                q.i,
                q.j,
                q.k,
                q.w,
            ];
            for (k, (&got, &want)) in row[1..].iter().zip(&written).enumerate() {
                assert_eq!(got, want as f32 as f64, "{id} step {step} component {k}");
            }
            for k in 0..3 {
                let err = (row[1 + k] - written[k]).abs();
                worst_position = worst_position.max(err);
                assert!(err <= 1e-6, "{id} step {step}: position error {err}");
            }
            // Analytic quaternion of the motion, independent of nalgebra's sign choice.
            let analytic = match index {
                0 => UnitQuaternion::from_axis_angle(&axis(), 3.0 * t),
                1 => UnitQuaternion::from_axis_angle(&Vector3::z_axis(), -2.0 * t),
                _ => pose.rotation,
            };
            let a = analytic.quaternion();
            let a = [a.i, a.j, a.k, a.w];
            let same: f64 = (0..4)
                .map(|k| (row[4 + k] - a[k]).abs())
                .fold(0.0, f64::max);
            let flipped: f64 = (0..4)
                .map(|k| (row[4 + k] + a[k]).abs())
                .fold(0.0, f64::max);
            let err = same.min(flipped);
            worst_quaternion = worst_quaternion.max(err);
            assert!(err <= 1e-6, "{id} step {step}: quaternion error {err}");
        }
    }
    // Measured: position error ~6e-8, quaternion error ~6e-8 (f32 rounding).
    eprintln!("worst position error {worst_position:e} m, quaternion {worst_quaternion:e}");

    let entities = entities(&read);
    for expected in [
        "/",
        "/metadata",
        "/box/visual_geometries/box/visual_0",
        "/box/visual_geometries/box/ball",
        "/arm/visual_geometries/link1/visual_0",
        "/arm/visual_geometries/link1/visual_1",
        "/arm/visual_geometries/link1/mesh",
        "/box/inertia/box",
        "/arm/inertia/link1",
        "/box/world_from_link/box",
        "/arm/world_from_link/link1",
        "/arm/world_from_link/link2",
        "/plots/energy/box",
        "/plots/energy/arm/link1",
        "/plots/angular_momentum/box",
        "/plots/angular_momentum/arm/link1",
        "/plots/scene/energy",
    ] {
        assert!(
            entities.iter().any(|e| e == expected),
            "{expected} missing from {entities:?}"
        );
    }
    // Skipped meshes leave no entity behind.
    assert!(
        !entities
            .iter()
            .any(|e| e.ends_with("link1/visual_3") || e.ends_with("link1/visual_4"))
    );
}

/// Same inputs give the same recording: every chunk, row id, time and value printed by Rerun's
/// own `rerun rrd print -vvv` is identical. (The encoded bytes are not compared: Rerun's Arrow
/// IPC encoding is not canonical, and two encodings of equal chunks differ in byte order.)
#[test]
fn same_inputs_give_identical_recordings() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.rrd"), dir.path().join("b.rrd"));
    write_recording(&a, dir.path(), &RerunOptions::default());
    write_recording(&b, dir.path(), &RerunOptions::default());
    let rerun = python().with_file_name("rerun");
    let print = |p: &Path| {
        run(
            &rerun,
            &[
                "rrd".as_ref(),
                "print".as_ref(),
                "-vvv".as_ref(),
                p.as_os_str(),
            ],
        )
    };
    let (a_text, b_text) = (print(&a), print(&b));
    assert!(
        a_text.contains("sim_time") && a_text.lines().count() > 1000,
        "{a_text}"
    );
    assert!(a_text == b_text, "the two recordings differ");
}

#[test]
fn ellipsoids_can_be_left_out() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("plain.rrd");
    write_recording(&path, dir.path(), &RerunOptions { ellipsoids: false });
    rrd_verify(&path);
    let entities = entities(&read_rrd(&path));
    assert!(
        !entities.iter().any(|e| e.contains("/inertia/")),
        "{entities:?}"
    );
    assert!(entities.iter().any(|e| e == "/plots/energy/box"));
}

#[test]
fn nothing_under_the_final_name_without_finish() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("unfinished.rrd");
    let part = dir.path().join("unfinished.rrd.part");
    let layout = layout(dir.path());

    // Dropped after some frames, without finish.
    {
        let mut sink = create(&path, &layout, &RerunOptions::default()).unwrap();
        assert!(part.exists(), "writes go to the .part file first");
        for step in 0..10 {
            let t = time_ns(step) as f64 * 1e-9;
            let (poses, states) = (poses(t), states(t));
            sink.write(&Frame {
                step,
                time_ns: time_ns(step),
                world_from_link: &poses,
                bodies: &states,
                joints: &[],
                mechanisms: &[],
                contacts: &[],
            })
            .unwrap();
        }
        assert!(!path.exists());
    }
    assert!(!path.exists(), "unfinished recording under the final name");
    assert!(!part.exists(), "unfinished recording left as .part");

    // A bad frame is an error, and the dropped sink leaves nothing either.
    {
        let mut sink = create(&path, &layout, &RerunOptions::default()).unwrap();
        let poses = poses(0.0);
        let states = states(0.0);
        let err = sink
            .write(&Frame {
                step: 0,
                time_ns: 0,
                world_from_link: &poses[..1],
                bodies: &states,
                joints: &[],
                mechanisms: &[],
                contacts: &[],
            })
            .unwrap_err();
        assert!(err.to_string().contains("link poses"), "{err}");
    }
    assert!(!path.exists() && !part.exists());

    // A directory that does not exist: an error, no file.
    let missing = dir.path().join("no/such/dir/x.rrd");
    assert!(create(&missing, &layout, &RerunOptions::default()).is_err());
    assert!(!missing.exists());
}
