//! Big scenes (issue 16): `copies` and per-copy draws, the batched Rerun layout that keeps a
//! 10 000-body file valid, byte identity across `--threads`, and `--format`.

use crate::common;
use crate::common::urdfs::copy_models;

use common::{text, tumble};
use std::collections::BTreeSet;
use std::path::Path;
use tumble::dataset::DatasetSpec;
use tumble::dataset::sample::draw;
use tumble::scene::Scene;

/// Regression test for the lost 10 000-body run ("writing the footer of ….rrd.part: Parser
/// error: Unable to get root as message: TooManyTables", nothing written): the bundled swarm
/// (10 000 bodies) records; `rerun rrd verify` accepts the file; the MCAP, read by the
/// official Python reader, holds every frame of every step; the Rerun file's batched entities
/// hold every copy's pose (the box entity's instances are the boxes' `/tf` poses, as float32,
/// in copy order); `tumble convert` rebuilds the same `.rrd` bytes from the MCAP.
#[test]
fn ten_thousand_bodies_record_verify_and_replay() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = common::root().join("models/swarm.toml");
    let out = tumble(
        &[
            "simulate",
            scene.to_str().unwrap(),
            "--duration",
            "0.05",
            "--out",
            "swarm",
        ],
        d,
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(text(&out.stdout).contains("simulated 10000 bodies"));
    let verify = std::process::Command::new(common::venv_bin("rerun"))
        .args(["rrd", "verify"])
        .arg(d.join("swarm.rrd"))
        .output()
        .unwrap();
    assert!(
        verify.status.success(),
        "rerun rrd verify: {}{}",
        text(&verify.stdout),
        text(&verify.stderr)
    );
    let entity = "/box/visual_geometries/box/body";
    let py = common::run_py(
        "read_scale.py",
        &[
            &d.join("swarm.mcap"),
            &d.join("swarm.rrd"),
            Path::new(entity),
        ],
    );
    // 50 steps recorded every 10th: steps 0, 10, ..., 50.
    let m = &py["mcap"];
    assert_eq!(m["tf_messages"], 6);
    assert!(
        m["transforms_per_message"]
            .as_array()
            .unwrap()
            .iter()
            .all(|n| n == 10_000)
    );
    assert_eq!(m["frame_ids"], 10_000);
    assert_eq!(m["topics"]["/bodies"], 6);
    let r = &py["rrd"];
    let entities: BTreeSet<&str> = r["entities"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e.as_str().unwrap())
        .collect();
    // One entity per shape and one per ellipsoid kind: not one per body.
    assert!(entities.contains(entity), "{entities:?}");
    assert!(entities.contains("/disc/inertia/disc"), "{entities:?}");
    assert!(entities.len() < 10, "{entities:?}");
    assert_eq!(r["rows"], 6);
    assert!(
        r["instances_per_row"]
            .as_array()
            .unwrap()
            .iter()
            .all(|n| n == 4000)
    );
    let first_tf = m["first_tf"].as_object().unwrap();
    let translations = r["first_translations"].as_array().unwrap();
    for (i, t) in translations.iter().enumerate() {
        let pose = first_tf[&format!("box_{i:04}/box")].as_array().unwrap();
        for k in 0..3 {
            let want = pose[k].as_f64().unwrap() as f32;
            assert_eq!(t[k].as_f64().unwrap() as f32, want, "box_{i:04} axis {k}");
        }
    }
    let converted = tumble(&["convert", "swarm.mcap", "--rrd", "replay.rrd"], d);
    assert!(converted.status.success(), "{}", text(&converted.stderr));
    assert!(
        std::fs::read(d.join("swarm.rrd")).unwrap() == std::fs::read(d.join("replay.rrd")).unwrap(),
        "convert does not rebuild the batched .rrd byte for byte"
    );
    // `tumble info` lists the first 20 frames and bodies and says how many more there are;
    // `--all` lists every one.
    let info = tumble(&["info", "swarm.mcap"], d);
    assert!(info.status.success(), "{}", text(&info.stderr));
    let report = text(&info.stdout);
    let head: String = report.chars().take(1500).collect();
    assert!(
        report.contains("10000 frames: box_0000/box, box_0001/box"),
        "{head}"
    );
    assert!(
        report.contains("box_0019/box ... and 9980 more (tumble info --all"),
        "{head}"
    );
    assert!(!report.contains("box_0020/box"), "{head}");
    assert!(
        report.lines().count() < 60,
        "{} lines",
        report.lines().count()
    );
    let all = tumble(&["info", "swarm.mcap", "--all"], d);
    let all = text(&all.stdout);
    assert!(all.contains("disc_2999/disc"));
    assert_eq!(all.matches(" mass ").count(), 10_000);
}

/// Copy `i` of a `[[model]]` with `seed = S` starts exactly where run `i` of a dataset with
/// master seed `S` and the same distributions starts (same generators and key streams): the
/// reference is the dataset's own `draw`, and the built scene's initial frames and velocities.
#[test]
fn copies_draw_what_the_dataset_draws() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    copy_models(d, &["box", "t_handle", "disc"]);
    let dists = r#"position = { uniform = [[-3.0, -2.0, 0.0], [3.0, 2.0, 5.0]] }
orientation = "uniform"
linvel = { normal = { mean = [0.0, 0.0, 1.0], std = [0.5, 0.5, 0.5] } }
angvel = { choice = [[1.0, 2.0, 3.0], [0.0, -4.0, 0.5]] }
"#;
    let scene_text = format!(
        "[sim]\nduration = 0.0\n[[model]]\nurdf = \"box.urdf\"\nname = \"b\"\ncopies = 12\nseed = 77\n{dists}"
    );
    let spec_text = format!(
        "[dataset]\nruns = 12\nseed = 77\n[scene.sim]\nduration = 0.0\n[[scene.model]]\nurdf = \"box.urdf\"\n[vary]\n{dists}"
    );
    let scene = Scene::parse(&scene_text, &d.join("copies.toml")).unwrap();
    let spec = DatasetSpec::parse(&spec_text, &d.join("spec.toml")).unwrap();
    let (ids, frames) = common::reference_frames(&scene);
    let expected_ids: Vec<String> = (0..12).map(|i| format!("b_{i:02}/box")).collect();
    assert_eq!(ids, expected_ids);
    let world = scene.build().unwrap();
    for i in 0..12 {
        let params = draw(&spec, i as u64);
        let pose = frames[0].1[i];
        for k in 0..3 {
            // world_from_link = (world_from_model · link_from_principal) · principal_from_link:
            // round-off of one product (measured ≤ 9e-16 m).
            assert!(
                (pose[k] - params.root_position_world[k]).abs() < 1e-14,
                "copy {i}: position {pose:?} vs {:?}",
                params.root_position_world
            );
        }
        let q = params.root_orientation_xyzw;
        let dot: f64 = (0..4).map(|k| pose[3 + k] * q[k]).sum();
        // The same rotation up to the quaternion's sign (measured |1 − |q·q'|| ≤ 4e-16).
        assert!(
            (dot.abs() - 1.0).abs() < 1e-14,
            "copy {i}: {pose:?} vs {q:?}"
        );
        assert_eq!(
            world.bodies[i].linvel_world,
            nalgebra::Vector3::from(params.linvel_world),
            "copy {i}"
        );
        assert_eq!(
            world.bodies[i].angvel_world,
            nalgebra::Vector3::from(params.angvel_world),
            "copy {i}"
        );
    }
    // Not all the same (the draws do vary): the first two copies differ.
    assert_ne!(frames[0].1[0], frames[0].1[1]);
}

/// Bad copies and distributions name the file, the model and the key.
#[test]
fn bad_copies_and_draws_are_refused_with_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    copy_models(d, &["box", "t_handle", "disc"]);
    for (keys, needle) in [
        ("copies = 0", "model[0].copies must be between 1 and"),
        (
            "position = { uniform = [[1, 0, 0], [0, 1, 1]] }",
            "model[0].position.uniform: lower bound 1",
        ),
        (
            "orientation = \"sideways\"",
            "model[0].orientation: expected \"uniform\"",
        ),
        (
            "angvel = { normal = { mean = [0, 0, 0] } }",
            "model[0].angvel.normal: missing std",
        ),
    ] {
        std::fs::write(
            d.join("bad.toml"),
            format!("[[model]]\nurdf = \"box.urdf\"\n{keys}\n"),
        )
        .unwrap();
        let out = tumble(&["simulate", "bad.toml", "--out", "bad"], d);
        assert_eq!(out.status.code(), Some(2), "{keys}");
        let err = text(&out.stderr);
        assert!(
            err.contains("bad.toml") && err.contains(needle),
            "{keys}: {err}"
        );
        assert!(!d.join("bad.mcap").exists() && !d.join("bad.rrd").exists());
    }
}

fn big_scene(d: &Path, copies: u32) {
    copy_models(d, &["box", "t_handle", "disc"]);
    std::fs::write(
        d.join("big.toml"),
        format!(
            r#"[sim]
duration = 0.03
log_every = 5
[[model]]
urdf = "box.urdf"
name = "box"
copies = {copies}
seed = 5
position = {{ uniform = [[-5.0, -5.0, -5.0], [5.0, 5.0, 5.0]] }}
orientation = "uniform"
angvel = {{ normal = {{ mean = [0.0, 0.0, 0.0], std = [20.0, 20.0, 20.0] }} }}
[[model]]
urdf = "t_handle.urdf"
name = "h"
copies = 300
seed = 6
orientation = "uniform"
angvel = {{ uniform = [[-9.0, -9.0, -9.0], [9.0, 9.0, 9.0]] }}
"#
        ),
    )
    .unwrap();
}

/// The recordings do not depend on the thread count: 1, 2 and 3 stepping threads write the same
/// bytes (MCAP, batched `.rrd`, Parquet), for a scene big enough to be split (1500 bodies, above
/// the 256-frame batched threshold).
#[test]
fn threads_write_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    big_scene(d, 1200);
    let files = ["mcap", "rrd", "trajectories.parquet", "bodies.parquet"];
    let mut reference: Option<Vec<Vec<u8>>> = None;
    for threads in ["1", "2", "3"] {
        let stem = format!("t{threads}");
        let out = tumble(
            &[
                "simulate",
                "big.toml",
                "--out",
                &stem,
                "--threads",
                threads,
                "--format",
                "mcap,rrd,parquet",
            ],
            d,
        );
        assert!(out.status.success(), "{}", text(&out.stderr));
        assert!(text(&out.stdout).contains(&format!("on {threads} thread")));
        let bytes: Vec<Vec<u8>> = files
            .iter()
            .map(|ext| std::fs::read(d.join(format!("{stem}.{ext}"))).unwrap())
            .collect();
        match &reference {
            None => reference = Some(bytes),
            Some(r) => {
                for (k, ext) in files.iter().enumerate() {
                    assert!(r[k] == bytes[k], "{ext} differs with {threads} threads");
                }
            }
        }
    }
}

/// `--format` writes exactly the files it names (`parquet` its three tables, the joints table
/// without rows for a scene without articulated models), and the Parquet tables read in pandas
/// with one trajectory row per body and recorded step.
#[test]
fn format_writes_exactly_what_it_names() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    copy_models(d, &["box", "t_handle", "disc"]);
    std::fs::write(
        d.join("s.toml"),
        "[sim]\nduration = 0.02\n[[model]]\nurdf = \"box.urdf\"\nname = \"b\"\ncopies = 3\nangvel = [0.0, 3.0, 0.1]\n",
    )
    .unwrap();
    for (format, expected) in [
        ("mcap", vec!["x.mcap"]),
        ("rrd", vec!["x.rrd"]),
        (
            "parquet",
            vec![
                "x.bodies.parquet",
                "x.joints.parquet",
                "x.trajectories.parquet",
            ],
        ),
        (
            "mcap,parquet",
            vec![
                "x.bodies.parquet",
                "x.joints.parquet",
                "x.mcap",
                "x.trajectories.parquet",
            ],
        ),
        ("ros2,rrd", vec!["x.ros2.mcap", "x.rrd"]),
    ] {
        let out_dir = d.join(format.replace(',', "_"));
        std::fs::create_dir_all(&out_dir).unwrap();
        let out = tumble(
            &[
                "simulate",
                d.join("s.toml").to_str().unwrap(),
                "--out",
                out_dir.join("x").to_str().unwrap(),
                "--format",
                format,
            ],
            d,
        );
        assert!(out.status.success(), "{format}: {}", text(&out.stderr));
        let mut written: Vec<String> = std::fs::read_dir(&out_dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        written.sort();
        assert_eq!(written, expected, "--format {format}");
    }
    // The Parquet tables, read by pandas: 3 bodies x 3 recorded steps (0, 10, 20).
    let py = common::run_py(
        "read_parquet_run.py",
        &[
            &d.join("parquet/x.trajectories.parquet"),
            &d.join("parquet/x.bodies.parquet"),
        ],
    );
    assert_eq!(py["trajectory_rows"], 9);
    assert_eq!(py["bodies_rows"], 3);
    assert_eq!(
        py["bodies"],
        serde_json::json!(["b_0/box", "b_1/box", "b_2/box"])
    );
    assert_eq!(py["steps"], serde_json::json!([0, 10, 20]));
    // No articulated model: the joints table is there, with its columns and no rows.
    let joints = common::run_py(
        "read_parquet_joints.py",
        &[&d.join("parquet/x.joints.parquet")],
    );
    assert_eq!(joints["pandas"]["rows"], 0);
    assert_eq!(joints["polars"]["rows"], 0);
    // 11 columns, and `at_limit` since joint limits (issue 31).
    assert_eq!(joints["polars"]["columns"].as_array().unwrap().len(), 12);
    let bad = tumble(&["simulate", "s.toml", "--format", "mcap,csv"], d);
    assert_eq!(bad.status.code(), Some(2));
    assert!(
        text(&bad.stderr).contains("unknown format \"csv\""),
        "{}",
        text(&bad.stderr)
    );
}

/// `--mcap-compression`: the default `auto` writes LZ4 chunks from 1000 bodies up and zstd
/// below; `zstd`, `lz4` and `none` are what they say. The Python `mcap` reader decodes every
/// variant to the same messages (same count, same digest over topic, time and data).
#[test]
fn mcap_compression_auto_picks_lz4_for_big_scenes_and_every_choice_reads_the_same() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    big_scene(d, 700); // 700 boxes + 300 handles = 1000 bodies: the threshold
    let runs: [(&str, Option<&str>, &str); 4] = [
        ("auto", None, "lz4"),
        ("zstd", Some("zstd"), "zstd"),
        ("lz4", Some("lz4"), "lz4"),
        ("none", Some("none"), ""),
    ];
    let mut paths = Vec::new();
    for (stem, choice, _) in &runs {
        let mut args = vec!["simulate", "big.toml", "--out", stem, "--format", "mcap"];
        if let Some(c) = choice {
            args.extend(["--mcap-compression", c]);
        }
        let out = tumble(&args, d);
        assert!(out.status.success(), "{}", text(&out.stderr));
        paths.push(d.join(format!("{stem}.mcap")));
    }
    // One body fewer than the threshold: auto keeps zstd.
    let small = std::fs::read_to_string(d.join("big.toml"))
        .unwrap()
        .replace("copies = 700", "copies = 699");
    std::fs::write(d.join("small.toml"), small).unwrap();
    let out = tumble(
        &[
            "simulate",
            "small.toml",
            "--out",
            "small",
            "--format",
            "mcap",
        ],
        d,
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    let small_path = d.join("small.mcap");
    let mut all: Vec<&Path> = paths.iter().map(|p| p.as_path()).collect();
    all.push(&small_path);
    let report = common::run_py("mcap_compression.py", &all);
    let get = |p: &Path| &report[p.to_str().unwrap()];
    for ((stem, _, expected), path) in runs.iter().zip(&paths) {
        assert_eq!(
            get(path)["compressions"],
            serde_json::json!([expected]),
            "{stem}"
        );
        // 7 recorded steps (0 to 30 every 5) on /tf and /bodies, plus /scene and /inertia.
        assert_eq!(get(path)["messages"], 16, "{stem}");
        assert_eq!(get(path)["digest"], get(&paths[0])["digest"], "{stem}");
    }
    assert_eq!(
        get(&small_path)["compressions"],
        serde_json::json!(["zstd"])
    );
    assert!(
        std::fs::metadata(&paths[1]).unwrap().len() < std::fs::metadata(&paths[2]).unwrap().len(),
        "zstd smaller than lz4"
    );
    let out = tumble(
        &[
            "simulate",
            "big.toml",
            "--out",
            "x",
            "--mcap-compression",
            "brotli",
        ],
        d,
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("expected auto, zstd, lz4 or none"));
    assert!(!d.join("x.mcap").exists());
}

/// Keeps every frame it is given (step, first pose's x, every body's kinetic energy), slowly
/// when `delay` is set, so that frame buffers are still held while the run builds the next.
type Kept = std::sync::Arc<std::sync::Mutex<Vec<(u64, f64, Vec<f64>)>>>;

struct Keep {
    seen: Kept,
    delay: std::time::Duration,
}

impl tumble::record::Sink for Keep {
    fn write(&mut self, frame: &tumble::record::Frame<'_>) -> anyhow::Result<()> {
        std::thread::sleep(self.delay);
        self.seen.lock().unwrap().push((
            frame.step,
            frame.world_from_link[0].translation.x,
            frame.bodies.iter().map(|b| b.kinetic_energy).collect(),
        ));
        Ok(())
    }
    fn finish(self: Box<Self>) -> anyhow::Result<()> {
        Ok(())
    }
}

/// The run builds each frame once, in a buffer the pipelined sinks share: no sink copies a
/// frame (the share made no copy of its own), and two slow sinks on their own threads see the
/// same frames as a sink on the stepping thread, so no buffer was rewritten while a sink still
/// held it.
#[test]
fn pipelined_sinks_take_the_frames_without_a_copy() {
    use tumble::record::pipelined::{FrameShare, Pipelined};
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    big_scene(d, 700);
    let scene = Scene::load(&d.join("big.toml")).unwrap();
    let world = scene.build().unwrap();
    let share = FrameShare::default();
    let logs: Vec<Kept> = (0..3).map(|_| Kept::default()).collect();
    let mut sinks: Vec<Box<dyn tumble::record::Sink>> = vec![Box::new(Keep {
        seen: std::sync::Arc::clone(&logs[0]),
        delay: std::time::Duration::ZERO,
    })];
    for (k, log) in logs.iter().enumerate().skip(1) {
        let sink = Keep {
            seen: std::sync::Arc::clone(log),
            delay: std::time::Duration::from_millis(2 * k as u64),
        };
        sinks.push(Box::new(
            Pipelined::shared(Box::new(sink), "keep", &share, 1).unwrap(),
        ));
    }
    // Finished by the run (every sink's `finish`).
    let summary = common::run_scene_parts(&scene, &world, 2, &scene.run_settings(), sinks);
    assert_eq!(share.buffers(), 0, "a pipelined sink copied a frame");
    let direct = logs[0].lock().unwrap().clone();
    // duration 0.03 s at dt 1 ms, every 5th step: steps 0, 5, ..., 30.
    assert_eq!(summary.frames_recorded, 7);
    assert_eq!(direct.len(), 7);
    assert_eq!(direct.last().unwrap().0, 30);
    for log in &logs[1..] {
        assert_eq!(*log.lock().unwrap(), direct);
    }
}

/// The run summary measures the recorded states: its initial energy is the scene's,
/// `Σ ½ m |v|² + ½ Ωᵀ J Ω` (body-frame `Ω = Rᵀ ω`; the swarm has no gravity), computed here from
/// the initial states, and its angular momentum change is measured over the steps, neither
/// zero nor a constant (a frame builder that left the energies or momenta out would report
/// one).
#[test]
fn the_run_summary_measures_the_recorded_energy_and_momentum() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    copy_models(d, &["box", "t_handle", "disc"]);
    let swarm = std::fs::read_to_string(common::root().join("models/swarm.toml"))
        .unwrap()
        .replace("copies = 4000", "copies = 400")
        .replace("copies = 3000", "copies = 300");
    std::fs::write(d.join("swarm.toml"), swarm).unwrap();
    let scene = Scene::load(&d.join("swarm.toml")).unwrap();
    let world = scene.build().unwrap();
    let expected = initial_energy(&world, &nalgebra::Vector3::zeros());
    let mut run = scene.run_settings();
    run.steps = 200;
    for threads in [1, 2] {
        let summary = common::run_scene_parts(&scene, &world, threads, &run, Vec::new());
        let rel = (summary.energy_initial - expected).abs() / expected;
        // Rounding of a 1000-term sum and of `J Ω` and back: measured 0 (1 and 2 threads).
        assert!(
            rel <= 1e-12,
            "initial energy {} against {expected}",
            summary.energy_initial
        );
        // The variational step keeps the energy within O(h²) of its initial value, without
        // drift: measured 1.0e-8 after 200 steps (1 and 2 threads).
        assert!((summary.energy_final - expected).abs() <= 1e-6 * expected);
        // Conserved to rounding by the variational step: measured 6.2e-15 over 200 steps
        // (1 and 2 threads).
        assert!(
            summary.angmom_rel_change_max > 0.0 && summary.angmom_rel_change_max < 1e-12,
            "{}",
            summary.angmom_rel_change_max
        );
    }
}

/// The same for an articulated scene, whose summary comes from the frame builder's reported
/// states: the initial energy is `Σ ½ m |v|² + ½ Ωᵀ J Ω − m g·c` over the links' bodies, from the
/// scene's initial states (consistent with the joints, so the reported projection keeps them),
/// and the momentum change is measured.
#[test]
fn an_articulated_run_summary_measures_the_reported_energy() {
    let scene = Scene::load(&common::root().join("models/satellite_arm.toml")).unwrap();
    let world = scene.build().unwrap();
    let g = scene.gravity();
    let expected = initial_energy(&world, &g);
    let mut run = scene.run_settings();
    run.steps = 100;
    let summary = common::run_scene_parts(&scene, &world, 1, &run, Vec::new());
    let rel = (summary.energy_initial - expected).abs() / expected.abs();
    // Measured: exact (0), and a momentum change of 2.6e-16 over 100 steps.
    assert!(
        rel <= 1e-9,
        "initial energy {} against {expected}",
        summary.energy_initial
    );
    assert!(
        summary.angmom_rel_change_max > 0.0 && summary.angmom_rel_change_max < 1e-12,
        "{}",
        summary.angmom_rel_change_max
    );
}

/// `Σ ½ m |v|² + ½ Ωᵀ J Ω − m g·c` over the scene's initial states (body-frame `Ω = Rᵀ ω`),
/// computed here, apart from the simulator's own energy code.
fn initial_energy(world: &tumble::world::World, g: &nalgebra::Vector3<f64>) -> f64 {
    world
        .bodies
        .iter()
        .map(|b| {
            let omega_body = b.world_from_body.rotation.inverse() * b.angvel_world;
            0.5 * b.mass * b.linvel_world.norm_squared()
                + 0.5 * omega_body.dot(&b.principal_moments.component_mul(&omega_body))
                - b.mass * g.dot(&b.world_from_body.translation.vector)
        })
        .sum()
}
