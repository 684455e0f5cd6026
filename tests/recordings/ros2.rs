//! ROS 2 recordings (`simulate --ros2`, dataset `record = ["ros2"]`) read back by two decoders
//! nobody on the tumble team wrote: `mcap-ros2-support` (with the file's own `ros2msg` schemas)
//! and `rosbags` (its own ROS 2 Humble typestore, plus `tumble_msgs` from the file's msg text),
//! compared value for value with the protobuf `.mcap` of the same run, itself decoded by the
//! Python `mcap` reader with `mcap-protobuf-support` (tests/py/read_mcap.py).

use crate::common;

use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;
use std::process::Command;

/// example-robot-data's `robots/` folder in the test venv (pip package, installed at test time).
fn robots_dir() -> PathBuf {
    let out = Command::new(common::python())
        .args([
            "-c",
            "import sysconfig, os; print(os.path.join(sysconfig.get_paths()['purelib'], \
             'cmeel.prefix', 'share', 'example-robot-data', 'robots'))",
        ])
        .output()
        .unwrap();
    let dir = PathBuf::from(common::text(&out.stdout).trim());
    assert!(dir.is_dir(), "{}", dir.display());
    dir
}

/// The values every decoder must agree on, as f64 vectors keyed by frame or body name.
fn rows(v: &Value) -> BTreeMap<String, Vec<Vec<f64>>> {
    v.as_object()
        .unwrap()
        .iter()
        .map(|(k, rows)| {
            let rows = rows
                .as_array()
                .unwrap()
                .iter()
                .map(|r| {
                    r.as_array()
                        .unwrap()
                        .iter()
                        .map(|x| x.as_f64().unwrap())
                        .collect()
                })
                .collect();
            (k.clone(), rows)
        })
        .collect()
}

/// A decoded ROS 2 file against the protobuf file of the same run: every transform and body
/// value bit for bit (both files store IEEE doubles; JSON carries them as shortest round-trip
/// decimals, read back exactly with serde_json's float_roundtrip), the stamps equal to the log
/// times, the steps equal to time / dt.
fn assert_same_values(decoder: &str, ros: &Value, protobuf: &Value, dt_ns: f64) {
    assert_eq!(ros["tf_parents"], serde_json::json!(["world"]), "{decoder}");
    // /tf: protobuf rows [t, tx, ty, tz, qx, qy, qz, qw]; ROS rows [t, stamp, tx, ..., qw].
    let (ros_tf, pb_tf) = (rows(&ros["frames"]), rows(&protobuf["frames"]));
    assert_eq!(
        ros_tf.keys().collect::<Vec<_>>(),
        pb_tf.keys().collect::<Vec<_>>(),
        "{decoder}: frame ids"
    );
    for (id, pb) in &pb_tf {
        let r = &ros_tf[id];
        assert_eq!(r.len(), pb.len(), "{decoder} {id}: transforms");
        for (r, pb) in r.iter().zip(pb) {
            assert_eq!(r[0], pb[0], "{decoder} {id}: log time");
            assert_eq!(r[1], r[0], "{decoder} {id}: header stamp = log time");
            assert_eq!(r[2..], pb[1..], "{decoder} {id} t={}", r[0]);
        }
    }
    // /bodies: protobuf [t, ke, pe, L, w, v]; ROS [t, stamp, step, ke, pe, L, w, v].
    let (ros_b, pb_b) = (rows(&ros["bodies"]), rows(&protobuf["bodies"]));
    assert_eq!(
        ros_b.keys().collect::<Vec<_>>(),
        pb_b.keys().collect::<Vec<_>>(),
        "{decoder}: body names"
    );
    for (name, pb) in &pb_b {
        let r = &ros_b[name];
        assert_eq!(r.len(), pb.len(), "{decoder} {name}: states");
        for (r, pb) in r.iter().zip(pb) {
            assert_eq!(r[0], pb[0], "{decoder} {name}: log time");
            assert_eq!(r[1], r[0], "{decoder} {name}: timestamp = log time");
            assert_eq!(r[2], (r[0] / dt_ns).round(), "{decoder} {name}: step");
            assert_eq!(r[3..], pb[1..], "{decoder} {name} t={}", r[0]);
        }
    }
    // total_energy = sum of the bodies' ke + pe at that time. The reference sum here runs in
    // name order, the file's in body order: equal up to the round-off of reordering a sum of
    // <= 10 terms (~1e-15 relative; measured at most 5.6e-16 of the largest term), bound 1e-13.
    for row in ros["total_energy"].as_array().unwrap() {
        let (t, total) = (row[0].as_f64().unwrap(), row[1].as_f64().unwrap());
        let (sum, scale) = pb_b
            .values()
            .flatten()
            .filter(|r| r[0] == t)
            .fold((0.0, 0.0_f64), |(s, m), r| {
                (s + r[1] + r[2], m.max(r[1].abs()).max(r[2].abs()))
            });
        assert!(
            (total - sum).abs() <= 1e-13 * scale.max(1.0),
            "{decoder} t={t}: total_energy {total} vs {sum}"
        );
    }
}

/// The three facts every ROS 2 file must show, whatever its models: profile, encodings, QoS.
fn assert_ros2_file(py: &Value, description_topics: &[&str]) {
    assert_eq!(py["profile"], "ros2");
    let channels = py["channels"].as_object().unwrap();
    let mut expected: BTreeMap<&str, &str> = BTreeMap::from([
        ("/tf", "tf2_msgs/msg/TFMessage"),
        ("/bodies", "tumble_msgs/msg/BodyStates"),
    ]);
    for t in description_topics {
        expected.insert(t, "std_msgs/msg/String");
    }
    let got: BTreeMap<&str, &str> = channels
        .iter()
        .map(|(t, c)| (t.as_str(), c["schema"].as_str().unwrap()))
        .collect();
    assert_eq!(got, expected);
    for (topic, c) in channels {
        assert_eq!(c["message_encoding"], "cdr", "{topic}");
        assert_eq!(c["schema_encoding"], "ros2msg", "{topic}");
    }
    // QoS as rosbags parsed it from offered_qos_profiles: reliable (1), keep-last (1),
    // automatic liveliness (1); descriptions transient local (1) depth 1, the rest volatile (2).
    for (topic, profiles) in py["rosbags_qos"].as_object().unwrap() {
        let p = profiles.as_array().unwrap();
        assert_eq!(p.len(), 1, "{topic}");
        let p = &p[0];
        assert_eq!(
            (&p["history"], &p["reliability"], &p["liveliness"]),
            (&1.into(), &1.into(), &1.into()),
            "{topic}"
        );
        let transient = description_topics.contains(&topic.as_str());
        assert_eq!(p["durability"], if transient { 1 } else { 2 }, "{topic}");
        let depth = match topic.as_str() {
            "/tf" => 100,
            "/bodies" => 10,
            _ => 1,
        };
        assert_eq!(p["depth"], depth, "{topic}");
    }
    // Summary with statistics, counts equal to what both decoders read.
    let stats = &py["statistics"];
    let counts = stats["channel_message_counts"].as_object().unwrap();
    for decoder in ["mcap_ros2", "rosbags"] {
        assert_eq!(
            &py[decoder]["counts"],
            &py["statistics"]["channel_message_counts"]
        );
    }
    let total: u64 = counts.values().map(|n| n.as_u64().unwrap()).sum();
    assert_eq!(stats["message_count"].as_u64().unwrap(), total);
    // Foxglove's rule: every chunk lists message indexes.
    let chunks = py["chunks"].as_array().unwrap();
    assert!(!chunks.is_empty());
    assert!(chunks.iter().all(|n| n.as_u64().unwrap() > 0), "{chunks:?}");
    // Each description: one message at t = 0, the same text in both decoders.
    for topic in description_topics {
        let a = &py["mcap_ros2"]["descriptions"][topic];
        assert_eq!(a.as_array().unwrap().len(), 1, "{topic}");
        assert_eq!(a[0][0], 0, "{topic}");
        assert_eq!(a, &py["rosbags"]["descriptions"][topic], "{topic}");
    }
}

fn strings(v: &Value) -> Vec<String> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|s| s.as_str().unwrap().to_string())
        .collect()
}

/// A three-model scene (a real robot with package:// meshes locked rigid, an arm of free links
/// with a massless frame, an unnamed box) simulated with `--ros2`: both decoders read the same
/// values as the protobuf file, and each model's `/robot_description` is a URDF urdfdom
/// accepts whose links are the frame ids and whose meshes are existing file:// paths.
#[test]
fn simulate_ros2_matches_the_protobuf_recording_in_two_independent_decoders() {
    let dir = tempfile::tempdir().unwrap();
    let models = common::root().join("models");
    let ur5 = robots_dir().join("ur_description/urdf/ur5_robot.urdf");
    let scene = dir.path().join("scene.toml");
    std::fs::write(
        &scene,
        format!(
            r#"[sim]
dt = 0.002
duration = 0.2
log_every = 5

[[model]]
urdf = "{ur5}"
name = "ur5"
bodies = "rigid"
allow_non_physical_inertia = true
angvel = [0.5, 1.0, 2.0]

[[model]]
urdf = "{arm}"
name = "arm"
position = [1.0, 0.0, 1.0]
angvel = [1.0, -2.0, 0.5]

[[model]]
urdf = "{bx}"
position = [-1.0, 0.0, 1.0]
angvel = [0.3, 4.0, 0.2]
"#,
            ur5 = ur5.display(),
            arm = models.join("arm.urdf").display(),
            bx = models.join("box.urdf").display(),
        ),
    )
    .unwrap();
    let stem = dir.path().join("out/run");
    let out = common::tumble(
        &[
            "simulate",
            scene.to_str().unwrap(),
            "--out",
            stem.to_str().unwrap(),
            "--ros2",
        ],
        dir.path(),
    );
    assert!(out.status.success(), "{}", common::text(&out.stderr));
    let ros2_path = dir.path().join("out/run.ros2.mcap");
    assert!(common::text(&out.stdout).contains(ros2_path.to_str().unwrap()));
    assert!(!dir.path().join("out/run.ros2.mcap.part").exists());

    let py = common::run_py("read_ros2.py", &[&ros2_path]);
    let pb = common::run_py("read_mcap.py", &[&dir.path().join("out/run.mcap")]);
    let topics = [
        "/ur5/robot_description",
        "/arm/robot_description",
        "/box/robot_description",
    ];
    assert_ros2_file(&py, &topics);
    for decoder in ["mcap_ros2", "rosbags"] {
        assert_same_values(decoder, &py[decoder], &pb, 2e6);
        assert!(py[decoder].get("time_mismatch").is_none(), "{decoder}");
    }
    // 0.2 s / 2 ms = 100 steps, every 5th and the initial state: 21 per topic, as in .mcap.
    assert_eq!(py["statistics"]["channel_message_counts"]["/tf"], 21);
    assert_eq!(pb["frames"]["box"].as_array().unwrap().len(), 21);
    // The same metadata record as the .mcap (scene, settings, layout).
    assert_eq!(py["metadata"]["tumble"], pb["metadata"]["tumble"]);
    assert!(
        py["metadata"]["tumble"]["scene"]
            .as_str()
            .unwrap()
            .contains("ur5_robot.urdf")
    );

    // The descriptions.
    let frame_ids: BTreeSet<String> = pb["frames"].as_object().unwrap().keys().cloned().collect();
    let description = |topic: &str| &py["descriptions"][topic];
    for topic in topics {
        let d = description(topic);
        let links = strings(&d["links"]);
        // urdfdom (via Pinocchio) parsed it as one tree: every link is one of its frames.
        let pin_frames: BTreeSet<String> = strings(&d["pinocchio_frames"]).into_iter().collect();
        assert!(links.iter().all(|l| pin_frames.contains(l)), "{topic}");
        for j in d["joints"].as_array().unwrap() {
            let names = strings(j);
            assert!(
                links.contains(&names[1]) && links.contains(&names[2]),
                "{topic}: {names:?}"
            );
        }
        assert_eq!(d["missing_meshes"], serde_json::json!([]), "{topic}");
    }
    // ur5, rigid: every link is a frame, named ur5/<link>; its meshes (visual and collision, as
    // many as the URDF has) are absolute file:// URIs of existing files.
    let ur5_links: BTreeSet<String> = strings(&description(topics[0])["links"])
        .into_iter()
        .collect();
    let ur5_frames: BTreeSet<String> = frame_ids
        .iter()
        .filter(|f| f.starts_with("ur5/"))
        .cloned()
        .collect();
    assert_eq!(ur5_links, ur5_frames);
    let meshes = strings(&description(topics[0])["meshes"]);
    let source = std::fs::read_to_string(&ur5).unwrap();
    assert_eq!(meshes.len(), source.matches("<mesh ").count());
    assert!(source.contains("package://"));
    assert!(meshes.len() >= 14, "{}", meshes.len()); // ur5: 7 links x visual + collision
    assert!(
        meshes.iter().all(|m| m.starts_with("file:///")),
        "{meshes:?}"
    );
    // arm, free links: every frame is a link; the one link without mass (tool0) has no frame.
    let arm_links: BTreeSet<String> = strings(&description(topics[1])["links"])
        .into_iter()
        .collect();
    let arm_frames: BTreeSet<String> = frame_ids
        .iter()
        .filter(|f| f.starts_with("arm/"))
        .cloned()
        .collect();
    assert_eq!(
        arm_links.difference(&arm_frames).collect::<Vec<_>>(),
        ["arm/tool0"]
    );
    assert!(arm_frames.is_subset(&arm_links));
    // box, no scene name: its link keeps its URDF name, which is its frame id.
    assert_eq!(strings(&description(topics[2])["links"]), ["box"]);
    assert!(frame_ids.contains("box"));
}

/// A dataset's per-run ROS 2 recording: one model, so the standard `/robot_description` topic;
/// the same values as the run's protobuf recording in both decoders.
#[test]
fn dataset_ros2_recording_matches_its_mcap() {
    let dir = tempfile::tempdir().unwrap();
    let spec = dir.path().join("d.toml");
    std::fs::write(
        &spec,
        format!(
            "[dataset]\nruns = 2\nseed = 3\nrecord = [\"mcap\", \"ros2\"]\nrecord_runs = 1\n\n\
             [scene.sim]\nduration = 0.05\ndt = 0.001\nlog_every = 5\n\n\
             [[scene.model]]\nurdf = {:?}\nname = \"arm\"\n\n[vary]\n\
             angvel = {{ normal = {{ mean = [0, 0, 0], std = [3, 3, 3] }} }}\n",
            common::root().join("models/arm.urdf").display().to_string()
        ),
    )
    .unwrap();
    let out_dir = dir.path().join("ds");
    let out = common::tumble(
        &[
            "dataset",
            spec.to_str().unwrap(),
            "--out",
            out_dir.to_str().unwrap(),
        ],
        dir.path(),
    );
    assert!(out.status.success(), "{}", common::text(&out.stderr));
    let rec = out_dir.join("recordings");
    assert!(
        !rec.join("run-000001.ros2.mcap").exists(),
        "record_runs = 1"
    );
    let py = common::run_py("read_ros2.py", &[&rec.join("run-000000.ros2.mcap")]);
    let pb = common::run_py("read_mcap.py", &[&rec.join("run-000000.mcap")]);
    assert_ros2_file(&py, &["/robot_description"]);
    for decoder in ["mcap_ros2", "rosbags"] {
        assert_same_values(decoder, &py[decoder], &pb, 1e6);
    }
    // 0.05 s / 1 ms = 50 steps, every 5th and the initial state: 11.
    assert_eq!(py["statistics"]["channel_message_counts"]["/bodies"], 11);
    assert_eq!(py["metadata"]["tumble"]["dataset_run"], "0");
    let links = strings(&py["descriptions"]["/robot_description"]["links"]);
    assert!(links.iter().all(|l| l.starts_with("arm/")), "{links:?}");
}

/// An existing STEM.ros2.mcap is not replaced without --force: exit 2, a message naming it, and
/// nothing else written.
#[test]
fn simulate_ros2_refuses_to_overwrite_without_force() {
    let dir = tempfile::tempdir().unwrap();
    let ros2 = dir.path().join("run.ros2.mcap");
    std::fs::write(&ros2, b"keep").unwrap();
    let urdf = common::root().join("models/box.urdf");
    let args = [
        "simulate",
        urdf.to_str().unwrap(),
        "--out",
        "run",
        "--ros2",
        "--duration",
        "0.01",
    ];
    let out = common::tumble(&args, dir.path());
    assert_eq!(out.status.code(), Some(2), "{}", common::text(&out.stderr));
    assert!(
        common::text(&out.stderr).contains("run.ros2.mcap"),
        "{}",
        common::text(&out.stderr)
    );
    assert_eq!(std::fs::read(&ros2).unwrap(), b"keep");
    assert!(!dir.path().join("run.mcap").exists());
    let mut forced = args.to_vec();
    forced.push("--force");
    let out = common::tumble(&forced, dir.path());
    assert!(out.status.success(), "{}", common::text(&out.stderr));
    assert_ne!(std::fs::read(&ros2).unwrap(), b"keep");
}

/// A JointState: stamp, names, positions, velocities, efforts.
type JointCase = (
    tumble::record::ros2::msgs::Stamp,
    Vec<String>,
    Vec<f64>,
    Vec<f64>,
    Vec<f64>,
);

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// tumble's CDR encoders write the bytes rosbags' own serializer writes for the same messages:
/// `sensor_msgs/msg/JointState` (what `/joint_states` will carry; names of odd lengths so that
/// every padding case occurs, empty and full arrays) and `tf2_msgs/msg/TFMessage` (empty, one
/// and several transforms, non-ASCII and empty frame ids).
#[test]
fn cdr_encoders_write_the_bytes_of_rosbags_serializer() {
    use nalgebra::{Isometry3, Translation3, UnitQuaternion};
    use tumble::record::ros2::msgs::{Stamp, joint_state, tf_message};
    let joint_cases: Vec<JointCase> = vec![
        (Stamp { sec: 0, nanosec: 0 }, vec![], vec![], vec![], vec![]),
        (
            Stamp { sec: 2, nanosec: 5 },
            vec!["j".into()],
            vec![0.5],
            vec![],
            vec![],
        ),
        (
            Stamp {
                sec: 7,
                nanosec: 999_999_999,
            },
            vec!["arm/shoulder".into(), "a/b".into(), "elbow_3".into()],
            vec![0.1, -2.5, 3.0e-300],
            vec![1.0, f64::MAX, -0.0],
            vec![],
        ),
    ];
    let poses = [
        Isometry3::from_parts(
            Translation3::new(1.0, -2.0, 0.125),
            UnitQuaternion::from_euler_angles(0.1, 0.2, 0.3),
        ),
        Isometry3::identity(),
        Isometry3::from_parts(
            Translation3::new(1e-9, 3e8, -7.0),
            UnitQuaternion::from_euler_angles(-3.0, 1.5, 2.0),
        ),
    ];
    let tf_cases: Vec<(Stamp, Vec<&str>)> = vec![
        (Stamp { sec: 1, nanosec: 2 }, vec![]),
        (Stamp { sec: 3, nanosec: 0 }, vec!["box"]),
        (
            Stamp {
                sec: 0,
                nanosec: 40,
            },
            vec!["ur5/base_link", "", "bras/épaule"],
        ),
    ];
    let spec = serde_json::json!({
        "joint_states": joint_cases.iter().map(|(s, n, p, v, e)| serde_json::json!({
            "sec": s.sec, "nanosec": s.nanosec, "frame_id": "", "name": n,
            "position": p, "velocity": v, "effort": e,
        })).collect::<Vec<_>>(),
        "tf": tf_cases.iter().map(|(s, children)| serde_json::json!({
            "sec": s.sec, "nanosec": s.nanosec, "parent": "world",
            "transforms": children.iter().zip(&poses).map(|(c, p)| {
                let t = p.translation.vector;
                let q = p.rotation.quaternion().coords;
                serde_json::json!([c, t.x, t.y, t.z, q.x, q.y, q.z, q.w])
            }).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
    });
    let dir = tempfile::tempdir().unwrap();
    let spec_path = dir.path().join("spec.json");
    std::fs::write(&spec_path, spec.to_string()).unwrap();
    let reference = common::run_py("cdr_reference.py", &[&spec_path]);
    let mut buf = Vec::new();
    for (k, (s, n, p, v, e)) in joint_cases.iter().enumerate() {
        joint_state(&mut buf, *s, n, p, v, e).unwrap();
        assert_eq!(
            hex(&buf),
            reference["joint_states"][k],
            "JointState case {k}"
        );
    }
    for (k, (s, children)) in tf_cases.iter().enumerate() {
        let transforms = children.iter().copied().zip(poses.iter());
        tf_message(&mut buf, *s, "world", transforms).unwrap();
        assert_eq!(hex(&buf), reference["tf"][k], "TFMessage case {k}");
    }
}

/// `convert` and `diff` given the ROS 2 file instead of the protobuf one: exit 2 and a message
/// naming the file and pointing to STEM.mcap (before: a protobuf decoding error), no output file.
#[test]
fn convert_and_diff_refuse_a_ros2_recording_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let urdf = common::root().join("models/box.urdf");
    let out = common::tumble(
        &[
            "simulate",
            urdf.to_str().unwrap(),
            "--out",
            "run",
            "--ros2",
            "--duration",
            "0.01",
        ],
        dir.path(),
    );
    assert!(out.status.success(), "{}", common::text(&out.stderr));
    for args in [
        vec!["convert", "run.ros2.mcap", "--rrd", "c.rrd"],
        vec!["diff", "run.ros2.mcap", "run.mcap"],
    ] {
        let out = common::tumble(&args, dir.path());
        let stderr = common::text(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(
            stderr.contains("run.ros2.mcap: a ROS 2 recording") && stderr.contains("STEM.mcap"),
            "{args:?}: {stderr}"
        );
        assert!(!stderr.contains("panicked"), "{stderr}");
    }
    assert!(!dir.path().join("c.rrd").exists());
    assert!(!dir.path().join("c.rrd.part").exists());
}

/// Articulated models' joints on `/joint_states` (`sensor_msgs/msg/JointState`): in both
/// decoders, one message per recorded step, the names prefixed as the frame ids (and as the
/// rewritten description names the joints, which `robot_state_publisher` matches), positions and
/// velocities bit for bit those of the protobuf `/joints` topic (read by the official `mcap`
/// reader), stamps equal to the log times, `effort` empty; a free body beside them changes
/// nothing, and a file without articulated models has no such channel (the test above).
#[test]
fn joint_states_carry_the_articulated_models_joints() {
    let dir = tempfile::tempdir().unwrap();
    let models = common::root().join("models");
    let scene = dir.path().join("scene.toml");
    std::fs::write(
        &scene,
        format!(
            r#"[sim]
dt = 0.001
duration = 0.1
log_every = 10

[[model]]
urdf = "{dp}"
name = "dp"
copies = 2
seed = 4
bodies = "articulated"
base = "fixed"
position = {{ uniform = [[-1.0, 0.0, 2.0], [1.0, 0.0, 2.0]] }}
joints = {{ shoulder = 2.0, elbow = 0.5 }}
joint_velocities = {{ elbow = -1.0 }}

[[model]]
urdf = "{bx}"
position = [3.0, 0.0, 1.0]
angvel = [0.3, 4.0, 0.2]
"#,
            dp = models.join("double_pendulum.urdf").display(),
            bx = models.join("box.urdf").display(),
        ),
    )
    .unwrap();
    let stem = dir.path().join("out/run");
    let out = common::tumble(
        &[
            "simulate",
            scene.to_str().unwrap(),
            "--out",
            stem.to_str().unwrap(),
            "--ros2",
        ],
        dir.path(),
    );
    assert!(out.status.success(), "{}", common::text(&out.stderr));
    let py = common::run_py("read_ros2.py", &[&dir.path().join("out/run.ros2.mcap")]);
    let pb = common::run_py("read_joints.py", &[&dir.path().join("out/run.mcap")]);
    let channel = &py["channels"]["/joint_states"];
    assert_eq!(channel["schema"], "sensor_msgs/msg/JointState");
    assert_eq!(channel["message_encoding"], "cdr");
    let qos = &py["rosbags_qos"]["/joint_states"][0];
    assert_eq!((&qos["durability"], &qos["depth"]), (&2.into(), &10.into()));
    // 0.1 s / 1 ms = 100 steps, every 10th and the initial state.
    assert_eq!(
        py["statistics"]["channel_message_counts"]["/joint_states"],
        11
    );
    let names = ["dp_0/elbow", "dp_0/shoulder", "dp_1/elbow", "dp_1/shoulder"];
    let protobuf = rows(&pb["joints"]);
    assert_eq!(protobuf.keys().collect::<Vec<_>>(), names);
    for decoder in ["mcap_ros2", "rosbags"] {
        let joints = &py[decoder]["joints"];
        let got: Vec<&String> = joints.as_object().unwrap().keys().collect();
        assert_eq!(got, names, "{decoder}");
        for name in names {
            let ros = joints[name].as_array().unwrap();
            let pb_rows = &protobuf[name];
            assert_eq!(ros.len(), 11, "{decoder} {name}");
            for (r, p) in ros.iter().zip(pb_rows) {
                // ROS [t, stamp, position, velocity, effort len, frame_id];
                // protobuf [t, step, position, velocity].
                let t = r[0].as_f64().unwrap();
                assert_eq!(t, p[0], "{decoder} {name}");
                assert_eq!(r[1].as_f64().unwrap(), t, "{decoder} {name}: stamp");
                assert_eq!(r[2].as_f64().unwrap(), p[2], "{decoder} {name}: position");
                assert_eq!(r[3].as_f64().unwrap(), p[3], "{decoder} {name}: velocity");
                assert_eq!((&r[4], &r[5]), (&0.into(), &"".into()), "{decoder} {name}");
            }
        }
        // The initial state is the scene's, read back from the poses and the projected momenta
        // (round-off: measured positions exact, velocities 6.5e-17 and 8.9e-16 off).
        for (name, q, v) in [("dp_1/shoulder", 2.0, 0.0), ("dp_1/elbow", 0.5, -1.0)] {
            let first = &joints[name][0];
            assert!((first[2].as_f64().unwrap() - q).abs() < 1e-14, "{first}");
            assert!((first[3].as_f64().unwrap() - v).abs() < 1e-14, "{first}");
        }
    }
    // The description of the table (its first copy's) names the same joints.
    let description = &py["descriptions"]["/dp_0/robot_description"];
    let described: BTreeSet<String> = description["joints"]
        .as_array()
        .unwrap()
        .iter()
        .map(|j| j[0].as_str().unwrap().to_string())
        .collect();
    assert!(described.contains("dp_0/shoulder") && described.contains("dp_0/elbow"));
}
