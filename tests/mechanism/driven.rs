//! Driven robots, the scene side (issue 30): `[[model.actuator]]`, URDF damping and effort
//! limits, and `[[model.load]]` read into the exact `JointDrive`s of the mechanism and
//! `BodyLoad`s of the world; signals from CSV tables and from recorded MCAP logs (tumble's own
//! and hand-built). The motion they cause is the physics' (tests elsewhere).

use crate::common;

use nalgebra::{UnitQuaternion, Vector3};
use std::path::Path;
use tumble::scene::Scene;
use tumble::sim::loads::{BodyLoad, LoadFrame};
use tumble::sim::mechanism::{Actuator, ActuatorKind, JointDrive};
use tumble::sim::signal::Signal;
use tumble::world::World;

/// A temporary folder holding `driven_arm.urdf`, `double_pendulum.urdf` and `files`.
fn folder(files: &[(&str, &str)]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for (from, name) in [
        ("tests/data/mechanism/driven_arm.urdf", "driven_arm.urdf"),
        ("models/double_pendulum.urdf", "double_pendulum.urdf"),
    ] {
        std::fs::copy(common::root().join(from), dir.path().join(name)).unwrap();
    }
    for (name, text) in files {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    dir
}

/// The world of `scene` written as `scene.toml` in `dir`.
fn world(dir: &Path, scene: &str) -> World {
    Scene::parse(scene, &dir.join("scene.toml"))
        .expect("the scene parses")
        .build()
        .expect("the scene builds")
}

const ARM: &str = "[sim]\nduration = 0.01\n[[model]]\nurdf = \"driven_arm.urdf\"\n\
                   bodies = \"articulated\"\nbase = \"fixed\"\n";

/// The coordinate of joint `name` in the world's first mechanism.
fn coordinate(world: &World, name: &str) -> usize {
    world.mechanisms[0]
        .coordinates
        .iter()
        .position(|c| c.name == name)
        .unwrap_or_else(|| panic!("no coordinate {name}"))
}

fn damping_only(coordinate: usize, damping: f64) -> JointDrive {
    JointDrive {
        coordinate,
        actuator: None,
        damping,
    }
}

/// Three actuators (written out of coordinate order) and the URDF's damping: one drive per
/// coordinate, sorted, each with the values the scene and the URDF give; the compound joint's
/// stages get their damping like any coordinate; the locked and fixed joints get none.
#[test]
fn actuators_and_urdf_damping_become_the_mechanisms_drives() {
    let dir = folder(&[("wrist.csv", "time,wrist\n0,0\n1,2\n2.5,-1\n")]);
    let scene = format!(
        "{ARM}\
         [[model.actuator]]\njoint = \"wrist\"\nkind = \"velocity\"\ntarget = {{ table = \"wrist.csv\" }}\n\
         kd = 2.0\neffort_limit = 1.5\n\
         [[model.actuator]]\njoint = \"elbow\"\nkind = \"position\"\n\
         target = {{ sine = {{ amplitude = 0.5, frequency_hz = 0.5, phase = 0.1, offset = 0.2 }} }}\n\
         kp = 80.0\nkd = 4.0\n\
         [[model.actuator]]\njoint = \"slide\"\nkind = \"motor\"\neffort = 0.5\neffort_limit = 0\n"
    );
    let w = world(dir.path(), &scene);
    let c = |name| coordinate(&w, name);
    let mut expected = vec![
        JointDrive {
            coordinate: c("elbow"),
            actuator: Some(Actuator {
                kind: ActuatorKind::Position {
                    target: Signal::Sine {
                        amplitude: 0.5,
                        frequency_hz: 0.5,
                        phase: 0.1,
                        offset: 0.2,
                    },
                    kp: 80.0,
                    kd: 4.0,
                },
                // The URDF's <limit effort="12">.
                effort_limit: Some(12.0),
            }),
            damping: 0.3,
        },
        JointDrive {
            coordinate: c("slide"),
            actuator: Some(Actuator {
                kind: ActuatorKind::Motor {
                    effort: Signal::Constant(0.5),
                },
                // effort_limit = 0 overrides the URDF's 50: none.
                effort_limit: None,
            }),
            damping: 2.0,
        },
        JointDrive {
            coordinate: c("wrist"),
            actuator: Some(Actuator {
                kind: ActuatorKind::Velocity {
                    target: Signal::Table {
                        times_secs: vec![0.0, 1.0, 2.5],
                        values: vec![0.0, 2.0, -1.0],
                    },
                    kd: 2.0,
                },
                effort_limit: Some(1.5),
            }),
            // The wrist has no <dynamics>.
            damping: 0.0,
        },
        // The mimic follower keeps its own damping.
        damping_only(c("finger"), 0.05),
        damping_only(c("thumb"), 0.4),
        // The compound joint's two stages.
        damping_only(c("shoulder_yaw"), 0.2),
        damping_only(c("shoulder_pitch"), 0.25),
    ];
    expected.sort_by_key(|d| d.coordinate);
    let drives = &w.mechanisms[0].drives;
    assert_eq!(drives, &expected);
    assert!(drives.windows(2).all(|p| p[0].coordinate < p[1].coordinate));
}

/// `joint_damping = false` leaves the URDF's damping out, actuators stay (damping 0); a locked
/// joint's damping is left out with the joint.
#[test]
fn joint_damping_false_and_locked_joints_remove_damping() {
    let dir = folder(&[]);
    let motor = "[[model.actuator]]\njoint = \"elbow\"\nkind = \"motor\"\neffort = -1.25\n";
    let w = world(dir.path(), &format!("{ARM}joint_damping = false\n{motor}"));
    assert_eq!(
        w.mechanisms[0].drives,
        vec![JointDrive {
            coordinate: coordinate(&w, "elbow"),
            actuator: Some(Actuator {
                kind: ActuatorKind::Motor {
                    effort: Signal::Constant(-1.25)
                },
                effort_limit: Some(12.0),
            }),
            damping: 0.0,
        }]
    );
    let w = world(
        dir.path(),
        &format!("{ARM}locked_joints = [\"thumb\", \"slide\"]\n"),
    );
    let mut expected = vec![
        damping_only(coordinate(&w, "elbow"), 0.3),
        damping_only(coordinate(&w, "finger"), 0.05),
        damping_only(coordinate(&w, "shoulder_yaw"), 0.2),
        damping_only(coordinate(&w, "shoulder_pitch"), 0.25),
    ];
    expected.sort_by_key(|d| d.coordinate);
    assert_eq!(w.mechanisms[0].drives, expected);
    // No actuator and no damping: no drive at all (the bundled models, unchanged).
    let w = world(
        dir.path(),
        "[[model]]\nurdf = \"double_pendulum.urdf\"\nbodies = \"articulated\"\nbase = \"fixed\"\n",
    );
    assert!(w.mechanisms[0].drives.is_empty());
    assert!(w.body_loads.is_empty());
}

/// The world pose of a load's point and axes: the body's pose composed with the load's
/// point and rotation in the body.
fn load_pose(w: &World, load: &BodyLoad) -> (Vector3<f64>, UnitQuaternion<f64>) {
    let body = w.bodies[load.body].world_from_body;
    (
        (body * nalgebra::Point3::from(load.point_body)).coords,
        body.rotation * load.body_from_link,
    )
}

fn close(a: Vector3<f64>, b: Vector3<f64>) -> bool {
    (a - b).amax() < 1e-12
}

/// The body named `name` in the layout (the same order as the world's bodies).
fn body_named(w: &World, name: &str) -> usize {
    w.layout
        .bodies
        .iter()
        .position(|b| b.name == name)
        .unwrap_or_else(|| panic!("no body {name}"))
}

/// Loads on an articulated model with copies: one per copy, each on the body its link rides
/// on (the camera, fixed to the hand, on the hand's body), acting at the link frame's origin
/// (its world position by the URDF's chain of origins) with the link's axes.
#[test]
fn loads_ride_the_body_of_their_link_in_every_copy() {
    let dir = folder(&[("push.csv", "time,force_x,force_z\n0,1,2\n1,3,4\n")]);
    let scene = format!(
        "{ARM}name = \"arm\"\ncopies = 2\nposition = [1.0, 2.0, 3.0]\n\
         [[model.load]]\nlink = \"camera\"\nforce = [0.0, 0.0, 5.0]\ntorque = [0, 0, 0.1]\n\
         [[model.load]]\nlink = \"thumb_link\"\nframe = \"link\"\n\
         force = [0, 0, {{ table = \"push.csv\" }}]\n"
    );
    let w = world(dir.path(), &scene);
    assert_eq!(w.body_loads.len(), 4);
    let origin = Vector3::new(1.0, 2.0, 3.0);
    for (copy, loads) in w.body_loads.chunks(2).enumerate() {
        let (camera, thumb) = (&loads[0], &loads[1]);
        // The camera rides on the hand's body (camera_mount is fixed).
        assert_eq!(camera.body, body_named(&w, &format!("arm_{copy}/hand")));
        assert_eq!(
            thumb.body,
            body_named(&w, &format!("arm_{copy}/thumb_link"))
        );
        // camera: 0.1 + 0.5 + 0.5 + 0.05 + 0.05 above the base frame.
        let (at, _) = load_pose(&w, camera);
        assert!(close(at, origin + Vector3::new(0.0, 0.0, 1.2)), "{at}");
        assert_eq!(camera.frame, LoadFrame::World);
        assert_eq!(
            camera.force,
            [0.0, 0.0, 5.0].map(Signal::Constant),
            "numbers are constant signals"
        );
        assert_eq!(camera.torque, [0.0, 0.0, 0.1].map(Signal::Constant));
        // thumb_link: (0, 0.05, 0.4) from the forearm at 0.6, turned 90° about z.
        let (at, axes) = load_pose(&w, thumb);
        assert!(close(at, origin + Vector3::new(0.0, 0.05, 1.0)), "{at}");
        let turn = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_2);
        assert!(axes.angle_to(&turn) < 1e-12);
        assert_eq!(thumb.frame, LoadFrame::Link);
        assert_eq!(
            thumb.force,
            [
                Signal::Constant(0.0),
                Signal::Constant(0.0),
                Signal::Table {
                    times_secs: vec![0.0, 1.0],
                    values: vec![2.0, 4.0]
                }
            ]
        );
    }
}

/// Loads in the other body modes: each link its own body (`links`), or every link on the
/// one body (`rigid`); a floating articulated base takes a load on its root link.
#[test]
fn loads_in_links_rigid_and_floating_models() {
    let dir = folder(&[]);
    let load = "[[model.load]]\nlink = \"hand\"\nforce = [1, 0, 0]\n";
    let hand = Vector3::new(0.0, 0.0, 1.15);
    for (bodies, name) in [("links", "hand"), ("rigid", "driven_arm")] {
        let scene = format!("[[model]]\nurdf = \"driven_arm.urdf\"\nbodies = \"{bodies}\"\n{load}");
        let w = world(dir.path(), &scene);
        assert_eq!(w.body_loads.len(), 1, "{bodies}");
        let l = &w.body_loads[0];
        assert_eq!(l.body, body_named(&w, name), "{bodies}");
        let (at, axes) = load_pose(&w, l);
        assert!(close(at, hand), "{bodies}: {at}");
        assert!(axes.angle() < 1e-12, "{bodies}");
        assert_eq!(l.force, [1.0, 0.0, 0.0].map(Signal::Constant));
    }
    let scene = "[sim]\ngravity = [0, 0, 0]\n[[model]]\nurdf = \"driven_arm.urdf\"\n\
                 bodies = \"articulated\"\n[[model.load]]\nlink = \"base\"\ntorque = [0, 0, 1]\n";
    let w = world(dir.path(), scene);
    assert_eq!(w.body_loads.len(), 1);
    assert_eq!(w.body_loads[0].body, body_named(&w, "base"));
    assert!(close(load_pose(&w, &w.body_loads[0]).0, Vector3::zeros()));
}

/// Runs `tumble simulate scene --out stem --ros2` in `dir`.
fn simulate(dir: &Path, scene: &str, stem: &str) {
    let path = dir.join(format!("{stem}.toml"));
    std::fs::write(&path, scene).unwrap();
    let run = std::process::Command::new(common::exe())
        .arg("simulate")
        .arg(&path)
        .arg("--out")
        .arg(dir.join(stem))
        .arg("--ros2")
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
}

fn table(signal: &Signal) -> (&[f64], &[f64]) {
    match signal {
        Signal::Table { times_secs, values } => (times_secs, values),
        other => panic!("not a table: {other:?}"),
    }
}

fn target(drive: &JointDrive) -> &Signal {
    match &drive.actuator.as_ref().unwrap().kind {
        ActuatorKind::Position { target, .. } | ActuatorKind::Velocity { target, .. } => target,
        ActuatorKind::Motor { effort } => effort,
    }
}

/// A recording tumble wrote is read back as a signal: the ROS 2 file's `/joint_states` (CDR)
/// and the `.mcap`'s `/joints` (protobuf) give the same positions and velocities, one row per
/// recorded step from t = 0, starting at the recorded run's initial joint position.
#[test]
fn tumbles_own_recordings_read_back_as_log_signals() {
    let dir = folder(&[]);
    simulate(
        dir.path(),
        "[sim]\nduration = 0.05\nlog_every = 10\n[[model]]\nurdf = \"double_pendulum.urdf\"\n\
         bodies = \"articulated\"\nbase = \"fixed\"\njoints = { shoulder = 0.3 }\n\
         joint_velocities = { elbow = -0.5 }\n",
        "run",
    );
    let model = |name: &str, log: &str, topic: &str| {
        format!(
            "[[model]]\nurdf = \"double_pendulum.urdf\"\nname = \"{name}\"\nbodies = \"articulated\"\n\
             base = \"fixed\"\n\
             [[model.actuator]]\njoint = \"shoulder\"\nkind = \"position\"\nkp = 10\n\
             target = {{ log = \"{log}\", topic = \"{topic}\" }}\n\
             [[model.actuator]]\njoint = \"elbow\"\nkind = \"velocity\"\nkd = 1\n\
             target = {{ log = \"{log}\", topic = \"{topic}\" }}\n"
        )
    };
    let scene = format!(
        "{}{}",
        model("ros", "run.ros2.mcap", "/joint_states"),
        model("proto", "run.mcap", "/joints")
    );
    let w = world(dir.path(), &scene);
    let (ros, proto) = (&w.mechanisms[0].drives, &w.mechanisms[1].drives);
    assert_eq!(ros.len(), 2);
    for k in 0..2 {
        let (times, values) = table(target(&ros[k]));
        assert_eq!(table(target(&proto[k])), (times, values));
        assert_eq!(times.len(), 6);
        for (i, t) in times.iter().enumerate() {
            assert_eq!(*t, i as f64 / 100.0, "{times:?}");
        }
    }
    assert!((table(target(&ros[0])).1[0] - 0.3).abs() < 1e-12);
    assert!((table(target(&ros[1])).1[0] + 0.5).abs() < 1e-12);
    // The run moved: the positions are no constant.
    assert!(table(target(&ros[0])).1[5] != 0.3);
}

/// `sensor_msgs/msg/JointState` in little-endian CDR, spelt out byte by byte.
fn joint_state_cdr(names: &[&str], position: &[f64], effort: &[f64]) -> Vec<u8> {
    let mut b = vec![0u8, 1, 0, 0];
    let align = |b: &mut Vec<u8>, n: usize| {
        while !(b.len() - 4).is_multiple_of(n) {
            b.push(0);
        }
    };
    let u32 = |b: &mut Vec<u8>, v: u32| {
        align(b, 4);
        b.extend(v.to_le_bytes());
    };
    u32(&mut b, 12); // stamp.sec
    u32(&mut b, 0); // stamp.nanosec
    u32(&mut b, 5); // frame_id "base"
    b.extend(b"base\0");
    u32(&mut b, names.len() as u32);
    for n in names {
        u32(&mut b, n.len() as u32 + 1);
        b.extend(n.as_bytes());
        b.push(0);
    }
    for values in [position, &[][..], effort] {
        u32(&mut b, values.len() as u32);
        for v in values {
            align(&mut b, 8);
            b.extend(v.to_le_bytes());
        }
    }
    b
}

/// `tumble.JointState` with an effort (tag 4), as recordings of driven robots write it.
#[derive(Clone, PartialEq, prost::Message)]
struct JointStateProto {
    #[prost(string, tag = "1")]
    name: String,
    #[prost(double, tag = "2")]
    position: f64,
    #[prost(double, tag = "3")]
    velocity: f64,
    #[prost(double, optional, tag = "4")]
    effort: Option<f64>,
    #[prost(double, optional, tag = "5")]
    target: Option<f64>,
    #[prost(bool, tag = "6")]
    saturated: bool,
}

#[derive(Clone, PartialEq, prost::Message)]
struct JointStatesProto {
    #[prost(uint64, tag = "2")]
    step: u64,
    #[prost(message, repeated, tag = "3")]
    joints: Vec<JointStateProto>,
}

/// An MCAP file with `/arm/joint_states` (CDR) and `/joints` (protobuf), log times from
/// `start_ns`; messages that do not name the joint are skipped but start the clock.
pub(crate) fn hand_built_log(start_ns: u64) -> Vec<u8> {
    use prost::Message as _;
    let mut out = std::io::Cursor::new(Vec::new());
    let mut w = mcap::Writer::new(&mut out).unwrap();
    let ros = w
        .add_schema("sensor_msgs/msg/JointState", "ros2msg", b"")
        .unwrap();
    let ros = w
        .add_channel(ros, "/arm/joint_states", "cdr", &Default::default())
        .unwrap();
    let proto = w.add_schema("tumble.JointStates", "protobuf", b"").unwrap();
    let proto = w
        .add_channel(proto, "/joints", "protobuf", &Default::default())
        .unwrap();
    let mut write = |channel_id, sequence, log_time, data: &[u8]| {
        let header = mcap::records::MessageHeader {
            channel_id,
            sequence,
            log_time,
            publish_time: log_time,
        };
        w.write_to_known_channel(&header, data).unwrap();
    };
    write(
        ros,
        0,
        start_ns,
        &joint_state_cdr(&["gripper"], &[0.0], &[]),
    );
    for (k, (dt_ns, effort)) in [
        (250_000_000, 1.5),
        (750_000_000, -2.0),
        (2_000_000_000, 0.25),
    ]
    .into_iter()
    .enumerate()
    {
        let t = start_ns + dt_ns;
        write(
            ros,
            k as u32 + 1,
            t,
            &joint_state_cdr(&["arm/shoulder", "arm/elbow"], &[0.1, 0.2], &[9.0, effort]),
        );
        let joints = vec![JointStateProto {
            name: "elbow".into(),
            position: 0.5 * k as f64,
            velocity: 0.0,
            effort: Some(effort),
            target: Some(0.0),
            saturated: false,
        }];
        let message = JointStatesProto {
            step: k as u64,
            joints,
        };
        write(proto, k as u32, t, &message.encode_to_vec());
    }
    w.finish().unwrap();
    drop(w);
    out.into_inner()
}

/// A hand-built log (a ROS 2 bag's form, and tumble's protobuf with efforts): a motor's
/// effort from each, the log's joint named with `joint = ...`, times from the topic's first
/// message.
#[test]
fn hand_built_logs_read_back_as_log_signals() {
    let dir = folder(&[]);
    std::fs::write(
        dir.path().join("bag.mcap"),
        hand_built_log(1_700_000_000_000_000_000),
    )
    .unwrap();
    let scene = "[[model]]\nurdf = \"double_pendulum.urdf\"\nbodies = \"articulated\"\n\
                 base = \"fixed\"\n[[model.actuator]]\njoint = \"elbow\"\nkind = \"motor\"\n\
                 effort = { log = \"bag.mcap\", topic = \"/arm/joint_states\", joint = \"arm/elbow\" }\n\
                 [[model.actuator]]\njoint = \"shoulder\"\nkind = \"position\"\nkp = 1\n\
                 target = { log = \"bag.mcap\", topic = \"/joints\", joint = \"elbow\" }\n";
    let w = world(dir.path(), scene);
    let drives = &w.mechanisms[0].drives;
    let by_name = |name| {
        drives
            .iter()
            .find(|d| d.coordinate == coordinate(&w, name))
            .unwrap()
    };
    assert_eq!(
        target(by_name("elbow")),
        &Signal::Table {
            // From the topic's first message (which does not name the joint).
            times_secs: vec![0.25, 0.75, 2.0],
            values: vec![1.5, -2.0, 0.25],
        }
    );
    assert_eq!(
        target(by_name("shoulder")),
        &Signal::Table {
            times_secs: vec![0.0, 0.5, 1.75],
            values: vec![0.0, 0.5, 1.0],
        }
    );
}

/// A damped model (the arm's URDF damping) stepped by a composition with a negative substep
/// gets the note that its dampers anti-damp there; the same scene with `variational`, or the
/// composition without damping, gets none.
#[test]
fn compositions_with_damping_get_a_note() {
    let dir = folder(&[]);
    let note = |w: &World| w.notes.iter().any(|n| n.contains("anti-damp"));
    let with = |integrator: &str, damping: bool| {
        let sim = format!("[sim]\nduration = 0.01\nintegrator = \"{integrator}\"\n");
        let rest = ARM.trim_start_matches("[sim]\nduration = 0.01\n");
        let extra = if damping {
            ""
        } else {
            "joint_damping = false\n"
        };
        world(dir.path(), &format!("{sim}{rest}{extra}"))
    };
    assert!(note(&with("variational4", true)));
    assert!(note(&with("variational6", true)));
    assert!(!note(&with("variational", true)));
    assert!(!note(&with("variational4", false)));
}
