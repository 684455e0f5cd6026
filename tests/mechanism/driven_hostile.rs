//! Bad actuators, loads and signals (issue 30), through the `tumble` binary: each is one error
//! (exit status 2) naming the scene file, the model and the key, with no panic and nothing
//! written ([`super::hostile::refused_with`]).

use super::hostile::refused_with;

const ARM: &str = "[sim]\nduration = 0.01\n[[model]]\nurdf = \"driven_arm.urdf\"\n\
                   bodies = \"articulated\"\nbase = \"fixed\"\n";

fn refused(scene: &str, expected: &[&str]) {
    refused_with(scene, &[], expected);
}

fn motor(joint: &str) -> String {
    format!("[[model.actuator]]\njoint = \"{joint}\"\nkind = \"motor\"\neffort = 1.0\n")
}

#[test]
fn actuators_on_joints_that_cannot_take_one_are_refused() {
    refused(
        &format!("{ARM}{}", motor("elbw")),
        &[
            "model[0]: actuator[0].joint: no joint `elbw` in model `driven_arm`",
            "driven_arm.urdf",
            "elbow",
        ],
    );
    refused(
        &format!("{ARM}{}", motor("camera_mount")),
        &["actuator[0].joint: joint `camera_mount` of model `driven_arm` is fixed"],
    );
    refused(
        &format!("{ARM}locked_joints = [\"thumb\"]\n{}", motor("thumb")),
        &["actuator[0].joint: joint `thumb`", "locked (locked_joints)"],
    );
    refused(
        &format!("{ARM}{}", motor("tool_joint")),
        &[
            "actuator[0].joint: joint `tool_joint`",
            "locked (no mass hangs from it)",
        ],
    );
    refused(
        &format!("{ARM}{}", motor("finger")),
        &[
            "actuator[0].joint: joint `finger`",
            "mimics `wrist`",
            "drive `wrist` instead",
        ],
    );
    refused(
        &format!(
            "{ARM}{}{}{}",
            motor("elbow"),
            motor("wrist"),
            motor("elbow")
        ),
        &["actuator[2].joint: joint `elbow` already has an actuator (actuator[0])"],
    );
    // Everything locked: the model is one rigid body, the reason still named.
    refused(
        "[[model]]\nurdf = \"double_pendulum.urdf\"\nbodies = \"articulated\"\n\
         locked_joints = [\"shoulder\", \"elbow\"]\n[[model.actuator]]\njoint = \"elbow\"\n\
         kind = \"motor\"\neffort = 1\n",
        &["actuator[0].joint: joint `elbow`", "locked (locked_joints)"],
    );
    for bodies in ["links", "rigid"] {
        refused(
            &format!(
                "[[model]]\nurdf = \"driven_arm.urdf\"\nbodies = \"{bodies}\"\n{}",
                motor("elbow")
            ),
            &[
                "model[0]: actuator[0]",
                "bodies = \"articulated\" models only",
                &format!("bodies = \"{bodies}\""),
            ],
        );
    }
}

#[test]
fn bad_actuator_values_are_refused() {
    let servo = |rest: &str| {
        format!(
            "{ARM}[[model.actuator]]\njoint = \"elbow\"\nkind = \"position\"\ntarget = 0.1\n{rest}"
        )
    };
    refused(
        &servo("kp = -80\n"),
        &["model[0]: actuator[0].kp: must be a finite number >= 0 (got -80)"],
    );
    refused(
        &servo("kp = 80\nkd = -4\n"),
        &["actuator[0].kd: must be a finite number >= 0"],
    );
    refused(
        &servo("kp = inf\n"),
        &["actuator[0].kp: must be a finite number >= 0"],
    );
    refused(&servo(""), &["actuator[0].kp: missing"]);
    refused(
        &servo("kp = 1\neffort_limit = -3\n"),
        &["actuator[0].effort_limit: must be a finite number >= 0"],
    );
    refused(
        &servo("kp = 1\ngain = 3\n"),
        &["actuator[0].gain: unknown key"],
    );
    refused(
        &servo("kp = 1\neffort = 3\n"),
        &["actuator[0].effort: a position actuator takes no `effort`"],
    );
    refused(
        &format!("{ARM}[[model.actuator]]\njoint = \"elbow\"\nkind = \"velocity\"\ntarget = 1.0\n"),
        &["actuator[0].kd: missing"],
    );
    refused(
        &format!("{ARM}[[model.actuator]]\njoint = \"elbow\"\nkind = \"torque\"\neffort = 1.0\n"),
        &[
            "actuator[0].kind: unknown kind \"torque\"",
            "\"motor\", \"position\" or \"velocity\"",
        ],
    );
    refused(
        &format!("{ARM}[[model.actuator]]\njoint = \"elbow\"\neffort = 1.0\n"),
        &["actuator[0].kind: missing"],
    );
    refused(
        &format!("{ARM}[[model.actuator]]\njoint = \"elbow\"\nkind = \"motor\"\neffort = nan\n"),
        &["actuator[0].effort: must be finite"],
    );
    refused(
        &format!(
            "{ARM}[[model.actuator]]\njoint = \"elbow\"\nkind = \"motor\"\neffort = {{ sine = {{ amplitude = 1 }} }}\n"
        ),
        &["actuator[0].effort.sine.frequency_hz: missing"],
    );
}

#[test]
fn bad_signal_tables_are_refused() {
    let with_table = |file: &str| {
        format!(
            "{ARM}[[model.actuator]]\njoint = \"elbow\"\nkind = \"position\"\nkp = 1\n\
             target = {{ table = \"{file}\" }}\n"
        )
    };
    refused_with(
        &with_table("t.csv"),
        &[("t.csv", b"time,wrist\n0,1\n")],
        &[
            "actuator[0].target.table",
            "t.csv",
            "no column `elbow` (the header has: time, wrist)",
        ],
    );
    refused_with(
        &with_table("t.csv"),
        &[("t.csv", b"time,elbow\n0,1\n2,1\n1,1\n")],
        &["actuator[0].target.table", "line 4: `time` must increase"],
    );
    refused_with(
        &with_table("t.csv"),
        &[("t.csv", b"time,elbow\n0,1\n2,inf\n")],
        &["actuator[0].target.table", "line 3: `elbow` must be finite"],
    );
    refused(
        &with_table("missing.csv"),
        &["actuator[0].target.table: cannot read"],
    );
}

/// An MCAP log of `sensor_msgs/msg/JointState` on `/js` naming `elbow`: one message per
/// `(log time ns, effort)`, efforts left out when `efforts` is false; and a `/text` topic of
/// another type.
fn log(messages: &[(u64, f64)], efforts: bool) -> Vec<u8> {
    let cdr = |effort: f64| {
        let mut b = vec![0u8, 1, 0, 0];
        b.extend([0; 8]); // stamp
        b.extend(1u32.to_le_bytes()); // frame_id ""
        b.extend([0, 0, 0, 0]); // its NUL, padded to 16
        b.extend(1u32.to_le_bytes()); // one name
        b.extend(6u32.to_le_bytes());
        b.extend(b"elbow\0");
        b.extend([0, 0]); // padded to 32
        b.extend(0u32.to_le_bytes()); // no position
        b.extend(0u32.to_le_bytes()); // no velocity
        if efforts {
            b.extend(1u32.to_le_bytes());
            b.extend([0; 4]); // padded to 48
            b.extend(effort.to_le_bytes());
        } else {
            b.extend(0u32.to_le_bytes());
        }
        b
    };
    let mut out = std::io::Cursor::new(Vec::new());
    let mut w = mcap::Writer::new(&mut out).unwrap();
    let schema = w
        .add_schema("sensor_msgs/msg/JointState", "ros2msg", b"")
        .unwrap();
    let js = w
        .add_channel(schema, "/js", "cdr", &Default::default())
        .unwrap();
    let text = w.add_schema("std_msgs/msg/String", "ros2msg", b"").unwrap();
    let text = w
        .add_channel(text, "/text", "cdr", &Default::default())
        .unwrap();
    for (k, &(log_time, effort)) in messages.iter().enumerate() {
        let header = |channel_id| mcap::records::MessageHeader {
            channel_id,
            sequence: k as u32,
            log_time,
            publish_time: log_time,
        };
        w.write_to_known_channel(&header(js), &cdr(effort)).unwrap();
        w.write_to_known_channel(&header(text), &[0, 1, 0, 0, 1, 0, 0, 0, 0])
            .unwrap();
    }
    w.finish().unwrap();
    drop(w);
    out.into_inner()
}

#[test]
fn bad_log_signals_are_refused() {
    let with_log = |signal: &str| {
        format!("{ARM}[[model.actuator]]\njoint = \"elbow\"\nkind = \"motor\"\neffort = {signal}\n")
    };
    let good = log(&[(0, 1.0), (1_000_000, 2.0)], true);
    let files = |bytes: &[u8]| vec![("bag.mcap", bytes.to_vec())];
    let run = |signal: &str, bytes: &[u8], expected: &[&str]| {
        let owned = files(bytes);
        let refs: Vec<(&str, &[u8])> = owned.iter().map(|(n, b)| (*n, b.as_slice())).collect();
        refused_with(&with_log(signal), &refs, expected);
    };
    run(
        "{ log = \"bag.mcap\", topic = \"/joint_states\" }",
        &good,
        &[
            "actuator[0].effort.log",
            "bag.mcap",
            "no topic `/joint_states` in the log (its topics: /js, /text)",
        ],
    );
    run(
        "{ log = \"bag.mcap\", topic = \"/js\", joint = \"arm/elbow\" }",
        &good,
        &[
            "actuator[0].effort.log",
            "no message on `/js` names joint `arm/elbow`",
            "the joints they name: elbow",
        ],
    );
    run(
        "{ log = \"bag.mcap\", topic = \"/text\" }",
        &good,
        &[
            "topic `/text` carries `std_msgs/msg/String` messages",
            "sensor_msgs/msg/JointState",
        ],
    );
    run(
        "{ log = \"bag.mcap\", topic = \"/js\" }",
        &log(&[(0, 1.0), (2_000_000, 2.0), (1_000_000, 3.0)], true),
        &["message 3 on `/js` has log time 0.001 s, not after the previous row's (0.002 s)"],
    );
    run(
        "{ log = \"bag.mcap\", topic = \"/js\" }",
        &log(&[(0, 1.0), (1_000_000, 1.0), (1_000_000, 3.0)], true),
        &["message 3 on `/js`", "needs increasing times"],
    );
    run(
        "{ log = \"bag.mcap\", topic = \"/js\" }",
        &log(&[(0, 1.0), (1_000_000, f64::NAN)], true),
        &[
            "message 2 on `/js`: joint `elbow`'s effort is NaN",
            "finite",
        ],
    );
    run(
        "{ log = \"bag.mcap\", topic = \"/js\" }",
        &log(&[(0, 1.0)], false),
        &["message 1 on `/js` names joint `elbow` but carries no effort for it"],
    );
    run(
        "{ log = \"bag.mcap\", topic = \"/js\" }",
        b"time,elbow\n0,1\n",
        &["actuator[0].effort.log", "not an MCAP file"],
    );
    let cut = &good[..good.len() / 2];
    run(
        "{ log = \"bag.mcap\", topic = \"/js\" }",
        cut,
        &["actuator[0].effort.log", "damaged or cut short"],
    );
    run(
        "{ log = \"bag.mcap\" }",
        &good,
        &["actuator[0].effort.topic: missing"],
    );
    run(
        "{ log = \"bag.mcap\", topic = \"/js\", column = \"x\" }",
        &good,
        &["actuator[0].effort.column: unknown key of a log signal"],
    );
    run(
        "{ log = \"none.mcap\", topic = \"/js\" }",
        &good,
        &["actuator[0].effort.log", "none.mcap"],
    );
}

#[test]
fn bad_loads_are_refused() {
    let load = |rest: &str| format!("{ARM}[[model.load]]\n{rest}");
    refused(
        &load("link = \"hnd\"\nforce = [0, 0, 1]\n"),
        &[
            "model[0]: load[0].link: no link `hnd` in model `driven_arm`",
            "hand",
        ],
    );
    refused(
        &load("link = \"hand\"\nforce = [0, 0, 1]\nframe = \"body\"\n"),
        &["load[0].frame: expected \"world\" or \"link\""],
    );
    refused(
        &load("link = \"hand\"\nforce = [0, 1]\n"),
        &["load[0].force: expected 3 components [x, y, z] (got 2)"],
    );
    refused(
        &load("link = \"hand\"\ntorque = [0, 1, 2, 3]\n"),
        &["load[0].torque: expected 3 components [x, y, z] (got 4)"],
    );
    refused(
        &load("link = \"hand\"\nforce = [0, nan, 1]\n"),
        &["load[0].force[1]: must be finite"],
    );
    refused(
        &load("link = \"hand\"\n"),
        &["load[0]: a load needs a force, a torque or both"],
    );
    refused(
        &load("link = \"hand\"\nforce = [0, 0, { log = \"x.mcap\", topic = \"/js\" }]\n"),
        &["load[0].force[2].log: a recorded log drives actuators only"],
    );
    refused_with(
        &load("link = \"hand\"\nforce = [0, 0, { table = \"f.csv\" }]\n"),
        &[("f.csv", b"time,force_x\n0,1\n")],
        &["load[0].force[2].table", "no column `force_z`"],
    );
    refused(
        &load("link = \"base\"\nforce = [0, 0, 1]\n"),
        &["load[0].link: link `base` of model `driven_arm` is welded to the world"],
    );
    refused(
        &load("link = \"shoulder_link\"\nforce = [0, 0, 1]\n"),
        &[
            "load[0].link: link `shoulder_link`",
            "inside a compound joint",
        ],
    );
    refused(
        "[[model]]\nurdf = \"driven_arm.urdf\"\n[[model.load]]\nlink = \"tool0\"\nforce = [0, 0, 1]\n",
        &[
            "load[0].link: link `tool0` of model `driven_arm` has no mass",
            "bodies = \"links\"",
        ],
    );
}

/// The URDF's damping and effort, when used, must be numbers that make sense.
#[test]
fn bad_urdf_damping_and_effort_are_refused() {
    let urdf =
        std::fs::read_to_string(crate::common::root().join("tests/data/mechanism/driven_arm.urdf"))
            .unwrap();
    let damped = urdf.replace("damping=\"0.3\"", "damping=\"-0.3\"");
    assert_ne!(damped, urdf);
    let scene = ARM.replace("driven_arm.urdf", "bad_arm.urdf");
    refused_with(
        &scene,
        &[("bad_arm.urdf", damped.as_bytes())],
        &[
            "joint_damping: joint `elbow` of model `driven_arm`",
            "damping=\"-0.3\"",
            "joint_damping = false",
        ],
    );
    let nan = urdf.replace("damping=\"2.0\"", "damping=\"nan\"");
    refused_with(
        &scene,
        &[("bad_arm.urdf", nan.as_bytes())],
        &[
            "joint_damping: joint `slide`",
            "must be a finite number >= 0",
        ],
    );
    let effort = urdf.replace("effort=\"12\"", "effort=\"-12\"");
    refused_with(
        &format!("{scene}{}", motor("elbow")),
        &[("bad_arm.urdf", effort.as_bytes())],
        &[
            "actuator[0]: joint `elbow` of model `driven_arm` has <limit effort=\"-12\">",
            "effort_limit",
        ],
    );
    refused(
        "[[model]]\nurdf = \"driven_arm.urdf\"\njoint_damping = false\n",
        &["model[0].joint_damping applies to bodies = \"articulated\" only"],
    );
}

/// `--accuracy` plans substeps from the error model of torque-free motion: a scene with
/// applied loads is refused (with the way out), not planned wrong.
#[test]
fn accuracy_with_applied_loads_is_refused() {
    refused(
        "[sim]\nduration = 0.01\naccuracy = 1e-3\n[[model]]\nurdf = \"chain3_free.urdf\"\n\
         [[model.load]]\nlink = \"link1\"\nforce = [0.0, 0.0, 1.0]\ntorque = [0.0, 0.0, 0.0]\n",
        &[
            "--accuracy (sim.accuracy) is not supported with applied loads yet",
            "choose dt by hand",
        ],
    );
}
