//! End to end: a scene simulated into MCAP and RRD, read back by the mcap crate, by the Python
//! `mcap` reader with protobuf decoding, and by rerun-sdk 0.36.3.

use crate::common;

use std::collections::BTreeMap;
use std::path::Path;
use tumble::record::rerun::RerunOptions;
use tumble::scene::Scene;

fn scene(dir: &Path) -> Scene {
    let models = common::root().join("models");
    let text = format!(
        r#"
[sim]
dt = 0.002
duration = 0.5
gravity = [0.0, 0.0, -9.81]
integrator = "variational"
log_every = 5

[[model]]
urdf = "{box}"
position = [0.0, 0.0, 1.0]
angvel = [0.3, 4.0, 0.2]

[[model]]
urdf = "{arm}"
name = "arm"
position = [1.0, 0.0, 1.0]
rpy = [0.1, 0.2, 0.3]
linvel = [0.0, 0.5, 2.0]
angvel = [1.0, -2.0, 0.5]
"#,
        box = models.join("box.urdf").display(),
        arm = models.join("arm.urdf").display()
    );
    let path = dir.join("scene.toml");
    std::fs::write(&path, &text).unwrap();
    Scene::load(&path).unwrap()
}

#[test]
fn mcap_and_rrd_read_back_by_independent_readers() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene(dir.path());
    let stem = dir.path().join("out/run");
    let out =
        tumble::simulation::simulate(&scene, &stem, &RerunOptions { ellipsoids: true }).unwrap();
    assert_eq!(out.mcap, dir.path().join("out/run.mcap"));
    assert!(!dir.path().join("out/run.mcap.part").exists());
    let (frame_ids, expected) = common::reference_frames(&scene);
    // 0.5 s / 0.002 s = 250 steps, every 5th recorded plus the initial state: 51 frames.
    assert_eq!(expected.len(), 51);
    assert!(
        frame_ids.iter().any(|f| f.starts_with("arm/")),
        "{frame_ids:?}"
    );

    // 1. The mcap crate: summary present, two channels with the declared schemas, every message's
    //    log time = publish time = k * 10 ms.
    let bytes = std::fs::read(&out.mcap).unwrap();
    let summary = mcap::Summary::read(&bytes)
        .unwrap()
        .expect("summary present");
    let topics: BTreeMap<String, String> = summary
        .channels
        .values()
        .map(|c| (c.topic.clone(), c.schema.as_ref().unwrap().name.clone()))
        .collect();
    assert_eq!(topics["/tf"], "foxglove.FrameTransforms");
    assert_eq!(topics["/bodies"], "tumble.BodyStates");
    let mut counts: BTreeMap<String, usize> = BTreeMap::new();
    for message in mcap::MessageStream::new(&bytes).unwrap() {
        let message = message.unwrap();
        assert_eq!(message.log_time, message.publish_time);
        assert_eq!(
            message.log_time % 10_000_000,
            0,
            "times are whole multiples of 5 * 2 ms"
        );
        *counts.entry(message.channel.topic.clone()).or_default() += 1;
    }
    // One /tf and one /bodies message per recorded step; the geometry once, at t = 0.
    let expected_counts: BTreeMap<String, usize> =
        [("/tf", 51), ("/bodies", 51), ("/scene", 1), ("/inertia", 1)]
            .into_iter()
            .map(|(t, n)| (t.to_string(), n))
            .collect();
    assert_eq!(counts, expected_counts);
    let metadata = mcap::read::LinearReader::new(&bytes)
        .unwrap()
        .filter_map(|r| match r.unwrap() {
            mcap::records::Record::Metadata(m) => Some(m),
            _ => None,
        })
        .next()
        .expect("metadata record");
    assert_eq!(metadata.name, "tumble");
    assert_eq!(metadata.metadata["integrator"], "variational");
    assert_eq!(metadata.metadata["tool_version"], tumble::VERSION);
    assert!(metadata.metadata["scene"].contains("log_every = 5"));

    // 2. The Python mcap reader with protobuf decoding: every pose equals the simulation's
    //    (protobuf doubles: bit-exact), timestamps agree.
    let py = common::run_py("read_mcap.py", &[&out.mcap]);
    assert_eq!(py["times_agree"], true);
    assert_eq!(py["schemas"]["/tf"], "foxglove.FrameTransforms");
    assert_eq!(py["metadata"]["tumble"]["integrator"], "variational");
    for (j, id) in frame_ids.iter().enumerate() {
        let rows = py["frames"][id]
            .as_array()
            .unwrap_or_else(|| panic!("frame {id} missing"));
        assert_eq!(rows.len(), expected.len());
        for (row, (t, poses)) in rows.iter().zip(&expected) {
            assert_eq!(row[0].as_i64().unwrap(), *t);
            for k in 0..7 {
                assert_eq!(
                    row[k + 1].as_f64().unwrap(),
                    poses[j][k],
                    "{id} t={t} k={k}"
                );
            }
        }
    }
    let bodies = py["bodies"].as_object().unwrap();
    assert_eq!(bodies.len(), frame_ids.len());
    // Angular momentum about each centre of mass is constant in free flight (variational
    // integrator: round-off; measured relative change ~1e-16).
    for (name, rows) in bodies {
        let rows = rows.as_array().unwrap();
        let l = |r: &serde_json::Value| [3, 4, 5].map(|k| r[k].as_f64().unwrap());
        let (l0, l1) = (l(&rows[0]), l(rows.last().unwrap()));
        let n0 = (l0[0] * l0[0] + l0[1] * l0[1] + l0[2] * l0[2]).sqrt();
        let d =
            ((l0[0] - l1[0]).powi(2) + (l0[1] - l1[1]).powi(2) + (l0[2] - l1[2]).powi(2)).sqrt();
        assert!(
            d <= 1e-12 * n0.max(1e-300),
            "{name}: |ΔL| = {d:e}, |L| = {n0:e}"
        );
    }

    // 3. rerun-sdk 0.36.3: `rerun rrd verify` accepts the file and the dataframe API reads back
    //    transforms equal to the MCAP poses at f32 precision.
    let verify = std::process::Command::new(common::venv_bin("rerun"))
        .args(["rrd", "verify"])
        .arg(&out.rrd)
        .output()
        .unwrap();
    assert!(
        verify.status.success(),
        "rerun rrd verify failed:\n{}\n{}",
        String::from_utf8_lossy(&verify.stdout),
        String::from_utf8_lossy(&verify.stderr)
    );
    let rrd = common::run_py("read_rrd.py", &[&out.rrd]);
    for id in &frame_ids {
        let mcap_rows = py["frames"][id].as_array().unwrap();
        let rrd_rows = rrd["frames"][id]
            .as_array()
            .unwrap_or_else(|| panic!("rrd lacks frame {id}"));
        assert_eq!(rrd_rows.len(), mcap_rows.len(), "{id}");
        for (a, b) in rrd_rows.iter().zip(mcap_rows) {
            assert_eq!(a[0].as_i64(), b[0].as_i64(), "{id}: sim_time");
            // f32 storage: relative eps 6e-8 on values ≲ 3 m → 2e-7 m; quaternions up to sign.
            for k in 1..4 {
                let (x, y) = (a[k].as_f64().unwrap(), b[k].as_f64().unwrap());
                assert!(
                    (x - y).abs() <= 1e-6 * y.abs().max(1.0),
                    "{id} k={k}: {x} vs {y}"
                );
            }
            let dot: f64 = (4..8)
                .map(|k| a[k].as_f64().unwrap() * b[k].as_f64().unwrap())
                .sum();
            assert!((dot.abs() - 1.0).abs() < 1e-6, "{id}: quaternion dot {dot}");
        }
    }
}
