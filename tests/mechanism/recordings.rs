//! Recordings of articulated models: `/tf` as for every model, the new `/joints` and
//! `/mechanisms` topics read back by the official Python `mcap` reader, the Rerun series read
//! back by rerun-sdk, and `tumble info`, `diff`, `convert` on articulated files.

use crate::common;

use std::path::{Path, PathBuf};

/// Runs `tumble simulate <scene> --out <dir>/<stem>` on a bundled scene text (paths relative
/// to `models/`), returning the MCAP and RRD paths.
fn simulate(dir: &Path, stem: &str, scene: &str, extra: &[&str]) -> (PathBuf, PathBuf) {
    let scene_path = common::root()
        .join("models")
        .join(format!("test_{stem}_{}.toml", std::process::id()));
    std::fs::write(&scene_path, scene).unwrap();
    let out = dir.join(stem);
    let mut args = vec![
        "simulate",
        scene_path.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let run = common::tumble(&args, dir);
    std::fs::remove_file(&scene_path).ok();
    assert!(run.status.success(), "{}", common::text(&run.stderr));
    (out.with_extension("mcap"), out.with_extension("rrd"))
}

const PENDULUM: &str = "[sim]\ndt = 0.001\nduration = 2.0\nlog_every = 10\n[[model]]\n\
                        urdf = \"double_pendulum.urdf\"\nbodies = \"articulated\"\nbase = \"fixed\"\n\
                        position = [0.0, 0.0, 2.0]\njoints = { shoulder = 2.0, elbow = 0.5 }\n";

fn rows(v: &serde_json::Value) -> Vec<Vec<f64>> {
    serde_json::from_value(v.clone()).unwrap()
}

/// The joint angles on `/joints` are those of the link frames on `/tf` (both decoded by the
/// official reader): the upper rod turns by the shoulder angle about y, the lower by shoulder
/// plus elbow; `/mechanisms`' energy is `/bodies`' total; schemas and times as documented.
#[test]
fn joints_and_mechanisms_topics_match_the_link_frames() {
    let dir = tempfile::tempdir().unwrap();
    let (mcap, _) = simulate(dir.path(), "dp", PENDULUM, &[]);
    let got = common::run_py("read_joints.py", &[&mcap]);
    assert_eq!(got["schemas"]["/joints"], "tumble.JointStates");
    assert_eq!(got["schemas"]["/mechanisms"], "tumble.MechanismStates");
    assert_eq!(got["times_agree"], true);
    let shoulder = rows(&got["joints"]["shoulder"]);
    let elbow = rows(&got["joints"]["elbow"]);
    let upper = rows(&got["frames"]["upper"]);
    let lower = rows(&got["frames"]["lower"]);
    assert_eq!(shoulder.len(), 201);
    // A rotation about y by θ is the quaternion (0, sin θ/2, 0, cos θ/2).
    let angle = |r: &[f64]| 2.0 * r[5].atan2(r[7]);
    let wrap = |x: f64| {
        (x + std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI) - std::f64::consts::PI
    };
    let mut worst: f64 = 0.0;
    for k in 0..shoulder.len() {
        assert_eq!(shoulder[k][0], upper[k][0], "same timestamps");
        assert_eq!(shoulder[k][1], (10 * k) as f64, "step numbers");
        worst = worst.max(wrap(angle(&upper[k]) - shoulder[k][2]).abs());
        worst = worst.max(wrap(angle(&lower[k]) - shoulder[k][2] - elbow[k][2]).abs());
        // The frames stay in the x-z plane: a pure rotation about y.
        assert!(
            upper[k][4].abs() < 1e-12 && upper[k][6].abs() < 1e-12,
            "{:?}",
            upper[k]
        );
    }
    eprintln!("joint angles vs /tf: {worst:e} rad");
    // Readback of the same poses: round-off plus the joint tolerance. Measured 4.4e-16 rad.
    assert!(worst < 1e-11, "{worst:e}");
    let m = rows(&got["mechanisms"]["double_pendulum"]);
    let total = rows(&got["total_energy"]);
    let mut energy_gap: f64 = 0.0;
    for (m, t) in m.iter().zip(&total) {
        assert_eq!(m[1], t[1]);
        // energy = kinetic + potential, and the sum over the model's bodies.
        assert!((m[13] - m[11] - m[12]).abs() < 1e-12 * m[13].abs().max(1.0));
        energy_gap = energy_gap.max((m[13] - t[2]).abs());
        // The constraint residual at the tolerance: ≤ 1e-12 · L (L = 0.5 m) and ≤ 1e-12 rad.
        assert!(m[14] <= 5.1e-13 && m[15] <= 1e-12, "{m:?}");
    }
    eprintln!("/mechanisms vs /bodies energy: {energy_gap:e} J");
    // Two sums of the same projected energies: measured 7.1e-15 J.
    assert!(energy_gap < 1e-12, "{energy_gap:e}");
}

/// A free-floating chain's momenta as the official reader decodes them: constant to round-off.
#[test]
fn free_chain_momenta_are_constant_in_the_recording() {
    let dir = tempfile::tempdir().unwrap();
    let scene = std::fs::read_to_string(common::root().join("models/chain3_free.toml")).unwrap();
    let (mcap, _) = simulate(
        dir.path(),
        "chain",
        &scene.replace("duration = 20.0", "duration = 5.0"),
        &[],
    );
    let got = common::run_py("read_joints.py", &[&mcap]);
    let m = rows(&got["mechanisms"]["chain3_free"]);
    let (mut dp, mut dl): (f64, f64) = (0.0, 0.0);
    for r in &m {
        for k in 0..3 {
            dp = dp.max((r[2 + k] - m[0][2 + k]).abs());
            dl = dl.max((r[5 + k] - m[0][5 + k]).abs());
        }
    }
    eprintln!("recorded momenta: ΔP {dp:e}, ΔL {dl:e}");
    // Round-off over 5000 steps (|P| = 0.33 kg m/s, |L| = 1.57 kg m²/s): measured 9.3e-15
    // kg m/s and 1.5e-14 kg m²/s.
    assert!(dp < 1e-12 && dl < 1e-12, "ΔP {dp:e}, ΔL {dl:e}");
    assert_eq!(rows(&got["joints"]["j1"]).len(), 501);
}

/// The Rerun file holds the same joint and model series (read by rerun-sdk), and `tumble
/// convert` rebuilds it byte for byte from the MCAP alone.
#[test]
fn rerun_series_and_convert() {
    let dir = tempfile::tempdir().unwrap();
    let (mcap, rrd) = simulate(dir.path(), "dp", PENDULUM, &[]);
    let mcap_values = common::run_py("read_joints.py", &[&mcap]);
    let scalars = common::run_py("read_scalars.py", &[&rrd]);
    let position = rows(&scalars["/plots/joints/position/shoulder"]);
    let velocity = rows(&scalars["/plots/joints/velocity/elbow"]);
    let residual = rows(&scalars["/plots/mechanisms/double_pendulum/constraint_residual"]);
    let energy = rows(&scalars["/plots/mechanisms/double_pendulum/energy"]);
    let shoulder = rows(&mcap_values["joints"]["shoulder"]);
    let elbow = rows(&mcap_values["joints"]["elbow"]);
    let model = rows(&mcap_values["mechanisms"]["double_pendulum"]);
    assert_eq!(position.len(), shoulder.len());
    for k in 0..shoulder.len() {
        // f64 series in both files: equal bit for bit.
        assert_eq!(position[k], vec![shoulder[k][0], shoulder[k][2]]);
        assert_eq!(velocity[k], vec![elbow[k][0], elbow[k][3]]);
        assert_eq!(residual[k][1..], model[k][14..16]);
        assert_eq!(energy[k][1..], model[k][11..14]);
    }
    // The legend of a plot of several joints tells them apart: each series is named after its
    // joint (a plot holds every joint's position, another every velocity).
    let names = common::run_py("read_series_names.py", &[&rrd]);
    for joint in ["shoulder", "elbow"] {
        for kind in ["position", "velocity"] {
            assert_eq!(
                names[format!("/plots/joints/{kind}/{joint}")],
                serde_json::json!([joint]),
                "{kind} {joint}"
            );
        }
    }
    let converted = dir.path().join("converted.rrd");
    let run = common::tumble(
        &[
            "convert",
            mcap.to_str().unwrap(),
            "--rrd",
            converted.to_str().unwrap(),
        ],
        dir.path(),
    );
    assert!(run.status.success(), "{}", common::text(&run.stderr));
    assert_eq!(
        std::fs::read(&converted).unwrap(),
        std::fs::read(&rrd).unwrap(),
        "convert differs"
    );
}

/// Every chunk of an articulated MCAP lists message indexes (Foxglove refuses chunks without).
#[test]
fn every_chunk_has_message_indexes() {
    let dir = tempfile::tempdir().unwrap();
    let scene = std::fs::read_to_string(common::root().join("models/satellite_arm.toml")).unwrap();
    let (mcap, _) = simulate(dir.path(), "sat", &scene, &[]);
    let got = common::run_py("mcap_chunks.py", &[&mcap]);
    let file = &got["files"][mcap.to_str().unwrap()];
    let chunks = file["chunks"].as_array().unwrap();
    assert!(chunks.len() > 10, "{}", chunks.len());
    for c in chunks {
        assert!(c["message_indexes"].as_u64().unwrap() > 0, "{c}");
    }
    assert_eq!(file["counts"]["/joints"], 2001);
    assert_eq!(file["counts"]["/mechanisms"], 2001);
}

/// `info` lists the models and joints; `diff` compares articulated recordings (the same file:
/// equal; two integrators: different, naming the massless interior link too).
#[test]
fn info_and_diff_on_articulated_recordings() {
    let dir = tempfile::tempdir().unwrap();
    let scene = std::fs::read_to_string(common::root().join("models/satellite_arm.toml"))
        .unwrap()
        .replace("duration = 20.0", "duration = 2.0");
    let (a, _) = simulate(dir.path(), "a", &scene, &[]);
    let (b, _) = simulate(dir.path(), "b", &scene, &["--integrator", "variational4"]);
    let info = common::tumble(&["info", a.to_str().unwrap()], dir.path());
    let text = common::text(&info.stdout);
    assert!(info.status.success(), "{}", common::text(&info.stderr));
    for want in [
        "1 articulated models, 4 joints",
        "satellite_arm            floating base, 4 bodies, 4 joints",
        "joint shoulder_pitch     revolute, URDF range [-1.5, 1.5]",
        "/joints              tumble.JointStates",
        "/mechanisms          tumble.MechanismStates",
        "summary statistics agree",
    ] {
        assert!(text.contains(want), "{want:?} in:\n{text}");
    }
    let json = common::tumble(&["info", "--json", a.to_str().unwrap()], dir.path());
    let json: serde_json::Value = serde_json::from_slice(&json.stdout).unwrap();
    assert_eq!(json["mechanisms"][0]["base"], "floating");
    assert_eq!(json["joints"][3]["name"], "wrist");
    let same = common::tumble(
        &["diff", a.to_str().unwrap(), a.to_str().unwrap()],
        dir.path(),
    );
    assert_eq!(
        same.status.code(),
        Some(0),
        "{}",
        common::text(&same.stdout)
    );
    let diff = common::tumble(
        &["diff", a.to_str().unwrap(), b.to_str().unwrap()],
        dir.path(),
    );
    let text = common::text(&diff.stdout);
    assert_eq!(diff.status.code(), Some(1), "{text}");
    assert!(
        text.contains("shoulder_link") && text.contains("DIFFERENT"),
        "{text}"
    );
}

/// `/tf` carries the same frame ids in articulated mode as in the other modes (every link,
/// massless ones included).
#[test]
fn frame_ids_are_those_of_the_other_modes() {
    let text = |mode: &str| {
        format!("[[model]]\nurdf = \"satellite_arm.urdf\"\nname = \"sat\"\nbodies = \"{mode}\"\n")
    };
    let path = common::root().join("models/x.toml");
    let ids = |mode: &str| {
        let world = tumble::scene::Scene::parse(&text(mode), &path)
            .unwrap()
            .build()
            .unwrap();
        world
            .layout
            .frames
            .iter()
            .map(|f| f.frame_id.clone())
            .collect::<Vec<_>>()
    };
    assert_eq!(ids("articulated"), ids("rigid"));
    assert!(ids("articulated").contains(&"sat/shoulder_link".to_string()));
    assert!(ids("articulated").contains(&"sat/tool0".to_string()));
}

/// More than 16 articulated models (20 double pendulums, `copies = 20`): the Rerun series are
/// batched, one entity per quantity with one instance per joint or model (it took 4 ms and
/// 0.2 MB per copy with an entity per joint: 1000 copies 4.0 s and 218 MB before any step).
/// Read by rerun-sdk: the instances are the MCAP's `/joints` and `/mechanisms` values bit for
/// bit, in layout order, named after their joint or `<model> <value>`; no per-joint entity is
/// left; `rerun rrd verify` accepts the file; convert rebuilds the same bytes.
#[test]
fn many_models_batch_their_rerun_series() {
    let dir = tempfile::tempdir().unwrap();
    let scene = "[sim]\ndt = 0.001\nduration = 0.5\nlog_every = 10\n[[model]]\n\
                 urdf = \"double_pendulum.urdf\"\nname = \"p\"\nbodies = \"articulated\"\n\
                 base = \"fixed\"\ncopies = 20\nseed = 3\n\
                 position = { uniform = [[-5.0, -5.0, 2.0], [5.0, 5.0, 2.0]] }\n\
                 joints = { shoulder = 2.0, elbow = 0.5 }\n";
    let (mcap, rrd) = simulate(dir.path(), "many", scene, &[]);
    let mcap_values = common::run_py("read_joints.py", &[&mcap]);
    let scalars = common::run_py("read_scalars.py", &[&rrd]);
    let names = common::run_py("read_series_names.py", &[&rrd]);
    let joints: Vec<String> = (0..20)
        .flat_map(|i| ["shoulder", "elbow"].map(|j| format!("p_{i:02}/{j}")))
        .collect();
    assert_eq!(
        names["/plots/joints/position"],
        serde_json::json!(joints),
        "legend names in layout order"
    );
    let energy_names: Vec<String> = (0..20)
        .flat_map(|i| ["kinetic", "potential", "total"].map(|n| format!("p_{i:02} {n}")))
        .collect();
    assert_eq!(
        names["/plots/mechanisms/energy"],
        serde_json::json!(energy_names)
    );
    let entities: Vec<&String> = scalars.as_object().unwrap().keys().collect();
    assert!(
        !entities
            .iter()
            .any(|e| e.starts_with("/plots/joints/position/")),
        "{entities:?}"
    );
    let position = rows(&scalars["/plots/joints/position"]);
    let velocity = rows(&scalars["/plots/joints/velocity"]);
    let residual = rows(&scalars["/plots/mechanisms/constraint_residual"]);
    assert_eq!(position.len(), 51);
    for (j, name) in joints.iter().enumerate() {
        let recorded = rows(&mcap_values["joints"][name]);
        assert_eq!(recorded.len(), 51, "{name}");
        for k in 0..51 {
            assert_eq!(position[k][0], recorded[k][0], "time");
            assert_eq!(position[k][1 + j], recorded[k][2], "{name} position {k}");
            assert_eq!(velocity[k][1 + j], recorded[k][3], "{name} velocity {k}");
        }
    }
    for i in 0..20 {
        let model = rows(&mcap_values["mechanisms"][&format!("p_{i:02}")]);
        for k in 0..51 {
            assert_eq!(
                residual[k][1 + 2 * i..3 + 2 * i],
                model[k][14..16],
                "p_{i:02} {k}"
            );
        }
    }
    let verify = std::process::Command::new(common::venv_bin("rerun"))
        .args(["rrd", "verify", rrd.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(verify.status.success(), "{}", common::text(&verify.stderr));
    let converted = dir.path().join("converted.rrd");
    let run = common::tumble(
        &[
            "convert",
            mcap.to_str().unwrap(),
            "--rrd",
            converted.to_str().unwrap(),
        ],
        dir.path(),
    );
    assert!(run.status.success(), "{}", common::text(&run.stderr));
    assert!(std::fs::read(&converted).unwrap() == std::fs::read(&rrd).unwrap());
}
