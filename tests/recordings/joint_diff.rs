//! `tumble diff` on joints: a driven run against its own ROS 2 recording (every difference 0),
//! against a robot log written by `mcap-ros2-support`'s writer with known offsets (each joint's
//! largest difference and its time worked out by hand), and two logs at different rates (linear
//! interpolation, exact on positions linear in time).

use super::drives::{JOINTS, driven_world, file, record, scene};
use crate::common;
use serde_json::Value;
use std::path::Path;

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("{v} is not a number"))
}

/// `tumble diff ARGS --json` in `dir`: the exit code and the report.
fn diff(dir: &Path, args: &[&str]) -> (i32, Value) {
    let mut all = vec!["diff"];
    all.extend_from_slice(args);
    all.push("--json");
    let out = common::tumble(&all, dir);
    let code = out.status.code().unwrap();
    assert!(code < 2, "{}", common::text(&out.stderr));
    (code, serde_json::from_slice(&out.stdout).unwrap())
}

/// Writes `spec` ({"times_ns", "joints"}) as a ROS 2 log at `path` (tests/py/write_joint_log.py).
fn write_log(dir: &Path, path: &Path, spec: &Value) {
    let spec_path = dir.join(format!(
        "{}.json",
        path.file_name().unwrap().to_string_lossy()
    ));
    std::fs::write(&spec_path, spec.to_string()).unwrap();
    common::run_py("write_joint_log.py", &[&spec_path, path]);
}

/// A driven run against its own ROS 2 recording: joints only (the ROS 2 file's frames are not
/// read), every difference exactly 0 on the shared timestamps. Against a log whose joint `j`
/// is the run's plus `c_j t` (and one joint more): each joint's largest difference is
/// `c_j T` at the last time `T`, its RMS `c_j sqrt(mean t²)`; the extra joint is listed, not
/// compared; `--joint-tolerance` decides the exit status.
#[test]
fn a_run_against_the_log_it_follows() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = scene(d);
    let mut world = driven_world(&scene);
    let stem = record(&scene, &mut world, d);
    let (mcap, ros2) = (file(&stem, "mcap"), file(&stem, "ros2.mcap"));

    let (code, r) = diff(d, &[mcap.to_str().unwrap(), ros2.to_str().unwrap()]);
    assert_eq!(code, 0, "{r}");
    assert_eq!(r["frames_compared"], false);
    assert_eq!(r["bodies"], serde_json::json!([]));
    assert!(
        r["warnings"][0]
            .as_str()
            .unwrap()
            .contains("frames not compared, joints only"),
        "{r}"
    );
    let j = &r["joints"];
    assert_eq!(
        (&j["topic_a"], &j["topic_b"]),
        (&"/joints".into(), &"/joint_states".into())
    );
    assert_eq!(j["aligned_on"], "common timestamps");
    assert_eq!(
        (&j["samples_compared"], &j["interpolated"]),
        (&21.into(), &0.into())
    );
    let names: Vec<&str> = j["joints"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, JOINTS);
    assert_eq!(j["err_max"], 0.0);
    assert_eq!(
        (&j["tolerance"], &j["within_tolerance"]),
        (&0.0.into(), &true.into())
    );

    // The log: the run's positions (read by the Python reader) plus c_j t, and a gripper.
    let py = common::run_py("read_joints.py", &[&mcap]);
    let times: Vec<u64> = py["joints"][JOINTS[0]]
        .as_array()
        .unwrap()
        .iter()
        .map(|row| row[0].as_u64().unwrap())
        .collect();
    let rate = |k: usize| 0.01 * (k + 1) as f64;
    let mut joints = serde_json::Map::new();
    for (k, name) in JOINTS.iter().enumerate() {
        let positions: Vec<f64> = py["joints"][name]
            .as_array()
            .unwrap()
            .iter()
            .map(|row| f(&row[2]) + rate(k) * f(&row[0]) / 1e9)
            .collect();
        joints.insert(name.to_string(), positions.into());
    }
    joints.insert("gripper".into(), vec![0.04; times.len()].into());
    let log = d.join("robot.mcap");
    write_log(
        d,
        &log,
        &serde_json::json!({"times_ns": times, "joints": joints}),
    );
    let (code, r) = diff(d, &[mcap.to_str().unwrap(), log.to_str().unwrap()]);
    assert_eq!(code, 1, "judged against 0: {r}");
    let j = &r["joints"];
    assert_eq!(j["unmatched_b"], serde_json::json!(["gripper"]));
    assert_eq!(j["unmatched_a"], serde_json::json!([]));
    let t_end = times[times.len() - 1] as f64 / 1e9;
    let mean_t2 = times.iter().map(|&t| (t as f64 / 1e9).powi(2)).sum::<f64>() / times.len() as f64;
    for (k, x) in j["joints"].as_array().unwrap().iter().enumerate() {
        let c = rate(k);
        // measured: within 1.1e-17 of c T and of the RMS (the sum and the difference of the
        // positions round)
        assert!((f(&x["err_max"]) - c * t_end).abs() < 1e-13, "{x}");
        assert_eq!(f(&x["err_max_time"]), t_end, "{x}");
        assert!((f(&x["err_end"]) - c * t_end).abs() < 1e-13, "{x}");
        assert!((f(&x["err_rms"]) - c * mean_t2.sqrt()).abs() < 1e-13, "{x}");
    }
    let worst = rate(JOINTS.len() - 1) * t_end; // 0.06 rad/s × 0.2 s
    assert!((f(&j["err_max"]) - worst).abs() < 1e-13, "{j}");
    for (tolerance, expected) in [("0.0119", 1), ("0.0121", 0)] {
        let (code, r) = diff(
            d,
            &[
                mcap.to_str().unwrap(),
                log.to_str().unwrap(),
                "--joint-tolerance",
                tolerance,
            ],
        );
        assert_eq!(
            code, expected,
            "--joint-tolerance {tolerance}: {}",
            r["joints"]
        );
    }
    // The text report lists the joints and the one only in the log.
    let out = common::tumble(&["diff", mcap.to_str().unwrap(), log.to_str().unwrap()], d);
    let text = common::text(&out.stdout);
    assert!(text.contains("joints only in b: gripper"), "{text}");
    assert!(text.contains("dp_1/shoulder"), "{text}");
}

/// Two logs at different rates and phases: the coarser one's times are compared and the other
/// interpolated linearly, which is exact for positions linear in time: the difference of
/// `0.5 t` and `0.5 t + 0.002 t` is `0.002 t` at every compared time, largest at the last
/// one inside both spans. `--rrd` writes that difference as a series.
#[test]
fn logs_at_other_times_are_interpolated() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let a_times: Vec<u64> = (0..=20).map(|k| k * 10_000_000).collect(); // 0 .. 0.2 s
    let b_times: Vec<u64> = (0..67).map(|k| 1_000_000 + k * 3_000_000).collect(); // 1 .. 199 ms
    let pos = |t: u64, slope: f64| slope * t as f64 / 1e9;
    let a = d.join("a.mcap");
    let b = d.join("b.mcap");
    write_log(
        d,
        &a,
        &serde_json::json!({"times_ns": a_times,
            "joints": {"j": a_times.iter().map(|&t| pos(t, 0.5)).collect::<Vec<_>>()}}),
    );
    write_log(
        d,
        &b,
        &serde_json::json!({"times_ns": b_times,
            "joints": {"j": b_times.iter().map(|&t| pos(t, 0.502)).collect::<Vec<_>>()}}),
    );
    let (code, r) = diff(
        d,
        &[
            a.to_str().unwrap(),
            b.to_str().unwrap(),
            "--rrd",
            "diff.rrd",
        ],
    );
    assert_eq!(code, 1, "{r}");
    let j = &r["joints"];
    assert_eq!(j["aligned_on"], "a");
    // a's times inside b's span [1 ms, 199 ms]: 10 .. 190 ms; b is interpolated at those it
    // does not share (10, 40, .., 190 ms are b's too: 1 + 3k ms).
    let shared = a_times.iter().filter(|t| b_times.contains(t)).count();
    assert_eq!(shared, 7);
    assert_eq!(
        (&j["samples_compared"], &j["interpolated"]),
        (&19.into(), &12.into())
    );
    assert_eq!((f(&j["time_start"]), f(&j["time_end"])), (0.01, 0.19));
    let x = &j["joints"][0];
    // measured: 5.3e-18 from 0.002 × 0.19
    assert!((f(&x["err_max"]) - 0.002 * 0.19).abs() < 1e-15, "{x}");
    assert_eq!(f(&x["err_max_time"]), 0.19);
    let series = common::run_py("read_scalars.py", &[&d.join("diff.rrd")]);
    let rows = series["/plots/diff/joint_error/j"].as_array().unwrap();
    assert_eq!(rows.len(), 19);
    for row in rows {
        let t = f(&row[0]) / 1e9;
        assert!((f(&row[1]) - 0.002 * t).abs() < 1e-15, "{row}");
    }
}

/// Two tumble recordings with frames and joints: both compared; the joints are reported but,
/// without `--joint-tolerance`, do not change the verdict (a diff of frames keeps its meaning).
#[test]
fn frames_and_joints_are_compared_together() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = scene(d);
    let mut world = driven_world(&scene);
    let mcap = file(&record(&scene, &mut world, d), "mcap");
    let m = mcap.to_str().unwrap();
    let (code, r) = diff(d, &[m, m]);
    assert_eq!(code, 0, "{r}");
    assert_eq!(r["frames_compared"], true);
    assert!(!r["bodies"].as_array().unwrap().is_empty());
    assert_eq!(
        (&r["pos_err_max"], &r["rot_err_max"]),
        (&0.0.into(), &0.0.into())
    );
    let j = &r["joints"];
    assert_eq!(j["joints"].as_array().unwrap().len(), 6);
    assert_eq!(
        (&j["tolerance"], &j["within_tolerance"]),
        (&Value::Null, &Value::Null)
    );
    let (code, r) = diff(d, &[m, m, "--joint-tolerance", "0"]);
    assert_eq!((code, &r["joints"]["within_tolerance"]), (0, &true.into()));
}

/// A run driven by a robot's log, end to end: a log on a wall clock (its first message at
/// 1.7e9 s) written by `mcap-ros2-support`'s writer drives both joints' position servos
/// (`target = { log = ... }`, whose clock starts at the log's first message). The recorded
/// targets are the log's positions (linear in time, so exact between its rows); the diff
/// refuses the two clocks without `--zero-start` and with it compares each recorded sample with
/// the log's row at the same time, so its per-joint largest difference is the largest
/// `|position − target|` of the run's own `/joints`.
#[test]
fn a_run_driven_by_a_log_against_that_log() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let t0: u64 = 1_700_000_000_000_000_000;
    let times: Vec<u64> = (0..=60).map(|k| t0 + k * 5_000_000).collect(); // 0 .. 0.3 s
    let shoulder = |t: f64| 0.3 + 0.5 * t;
    let log = d.join("robot.mcap");
    write_log(
        d,
        &log,
        &serde_json::json!({"times_ns": times, "velocity": true, "joints": {
            "shoulder": times.iter().map(|&t| shoulder((t - t0) as f64 / 1e9)).collect::<Vec<_>>(),
            "elbow": vec![-0.2; times.len()],
        }}),
    );
    let dp = common::root().join("models/double_pendulum.urdf");
    std::fs::write(
        d.join("follow.toml"),
        format!(
            r#"[sim]
dt = 0.001
duration = 0.3
log_every = 10

[[model]]
urdf = "{}"
bodies = "articulated"
base = "fixed"
joints = {{ shoulder = 0.3, elbow = -0.2 }}

[[model.actuator]]
joint = "shoulder"
kind = "position"
target = {{ log = "robot.mcap", topic = "/joint_states" }}
kp = 2000.0
kd = 100.0

[[model.actuator]]
joint = "elbow"
kind = "position"
target = {{ log = "robot.mcap", topic = "/joint_states" }}
kp = 2000.0
kd = 100.0
"#,
            dp.display()
        ),
    )
    .unwrap();
    let out = common::tumble(
        &[
            "simulate",
            "follow.toml",
            "--out",
            "run",
            "--format",
            "mcap",
        ],
        d,
    );
    assert!(out.status.success(), "{}", common::text(&out.stderr));
    let py = common::run_py("read_joints.py", &[&d.join("run.mcap")]);
    let mut worst = [0.0f64; 2];
    for (k, name) in ["shoulder", "elbow"].iter().enumerate() {
        let states = py["joints"][name].as_array().unwrap();
        let efforts = py["efforts"][name].as_array().unwrap();
        assert_eq!(states.len(), 31, "{name}");
        for (s, e) in states.iter().zip(efforts) {
            let t = f(&s[0]) / 1e9;
            let target = f(&e[3]);
            let expected = if k == 0 { shoulder(t) } else { -0.2 };
            assert!(
                (target - expected).abs() < 1e-12,
                "{name} at {t} s: {target}"
            );
            worst[k] = worst[k].max((f(&s[2]) - target).abs());
        }
    }
    // The servos follow the log: a PD servo trails a ramp r' = 0.5 rad/s by about
    // kd r'/kp = 0.025 rad, gravity adds a little (measured: 0.0297 rad shoulder, 0.0019 elbow).
    assert!(
        (0.02..0.04).contains(&worst[0]) && worst[1] < 0.01,
        "{worst:?}"
    );

    let run = d.join("run.mcap");
    let out = common::tumble(&["diff", run.to_str().unwrap(), "robot.mcap"], d);
    assert_eq!(out.status.code(), Some(2));
    let stderr = common::text(&out.stderr);
    assert!(
        stderr.contains("do not overlap") && stderr.contains("--zero-start"),
        "{stderr}"
    );
    let (code, r) = diff(d, &[run.to_str().unwrap(), "robot.mcap", "--zero-start"]);
    assert_eq!(code, 1, "judged against 0: {r}");
    let j = &r["joints"];
    assert_eq!(j["aligned_on"], "common timestamps");
    assert_eq!(
        (&j["samples_compared"], &j["interpolated"]),
        (&31.into(), &0.into())
    );
    assert_eq!(
        (f(&j["offset_a"]), f(&j["offset_b"])),
        (0.0, t0 as f64 / 1e9)
    );
    for (x, w) in j["joints"].as_array().unwrap().iter().zip(worst) {
        assert_eq!(f(&x["err_max"]), w, "{x}");
    }
}
