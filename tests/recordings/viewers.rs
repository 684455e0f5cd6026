//! What real viewers need from tumble's recordings (issue 13): Foxglove's reader refuses any MCAP
//! chunk whose chunk index lists no message indexes, so every MCAP tumble writes (simulate, trade,
//! dataset) is checked chunk by chunk with the Python `mcap` reader and the mcap crate.

use crate::common;

use common::{run_py, text, tumble};
use std::path::{Path, PathBuf};

/// A scene with the bundled box and arm, long enough to fill several 64 KiB chunks.
fn write_scene(dir: &Path, duration: f64) -> PathBuf {
    let models = common::root().join("models");
    let path = dir.join("scene.toml");
    std::fs::write(
        &path,
        format!(
            "[sim]\ndt = 0.001\nduration = {duration}\nlog_every = 1\n\n\
             [[model]]\nurdf = \"{}\"\nposition = [0, 0, 1]\nangvel = [0.3, 4.0, 0.2]\n\n\
             [[model]]\nurdf = \"{}\"\nname = \"arm\"\nposition = [1, 0, 1]\n",
            models.join("box.urdf").display(),
            models.join("arm.urdf").display()
        ),
    )
    .unwrap();
    path
}

/// Every chunk index of `file` lists at least one message index (Python reader and mcap crate
/// agree on the number of chunks); returns the number of chunks.
fn assert_every_chunk_indexed(py: &serde_json::Value, file: &Path) -> usize {
    let key = file.display().to_string();
    let info = &py["files"][&key];
    let chunks = info["chunks"]
        .as_array()
        .unwrap_or_else(|| panic!("{key}: no summary: {py}"));
    assert!(!chunks.is_empty(), "{key}: no chunk");
    for (i, c) in chunks.iter().enumerate() {
        assert!(
            c["message_indexes"].as_u64().unwrap() > 0,
            "{key}: chunk {i} lists no message indexes (Foxglove refuses the file): {c}"
        );
    }
    let bytes = std::fs::read(file).unwrap();
    let summary = mcap::Summary::read(&bytes).unwrap().expect("summary");
    assert_eq!(summary.chunk_indexes.len(), chunks.len(), "{key}");
    for ci in &summary.chunk_indexes {
        assert!(!ci.message_index_offsets.is_empty(), "{key}: {ci:?}");
    }
    chunks.len()
}

#[test]
fn every_mcap_tumble_writes_has_message_indexes_in_every_chunk() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut files = Vec::new();

    // simulate: one short run (one chunk) and one of several chunks.
    let scene = write_scene(d, 0.01);
    let out = tumble(&["simulate", scene.to_str().unwrap(), "--out", "short"], d);
    assert!(out.status.success(), "{}", text(&out.stderr));
    files.push(d.join("short.mcap"));
    let out = tumble(
        &[
            "simulate",
            scene.to_str().unwrap(),
            "--out",
            "long",
            "--duration",
            "2",
            "--ros2",
        ],
        d,
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    files.push(d.join("long.mcap"));
    files.push(d.join("long.ros2.mcap"));

    // trade: the side-by-side recording (one topic group per integrator).
    let out = tumble(
        &[
            "trade",
            "--out",
            "trade",
            "--dt",
            "0.01",
            "--duration",
            "0.5",
            "--integrators",
            "variational,rk4",
            "--repeats",
            "1",
        ],
        d,
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    files.push(d.join("trade/trade.mcap"));

    // dataset: per-run recordings.
    let spec = d.join("spec.toml");
    std::fs::write(
        &spec,
        format!(
            "[dataset]\nruns = 2\nseed = 1\nrecord = [\"mcap\", \"ros2\"]\nrecord_runs = 2\n\n\
             [scene.sim]\nduration = 0.05\n\n[[scene.model]]\nurdf = \"{}\"\n",
            common::root().join("models/arm.urdf").display()
        ),
    )
    .unwrap();
    let out = tumble(&["dataset", spec.to_str().unwrap(), "--out", "ds", "-q"], d);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let mut dataset_files: Vec<PathBuf> = walk(&d.join("ds"))
        .into_iter()
        .filter(|p| p.extension().is_some_and(|e| e == "mcap"))
        .collect();
    dataset_files.sort();
    assert_eq!(dataset_files.len(), 4, "{dataset_files:?}"); // 2 runs x (.mcap, .ros2.mcap)
    files.extend(dataset_files);

    let args: Vec<&Path> = files.iter().map(PathBuf::as_path).collect();
    let py = run_py("mcap_chunks.py", &args);
    let chunks: Vec<usize> = files
        .iter()
        .map(|f| assert_every_chunk_indexed(&py, f))
        .collect();
    // Measured: short 1 chunk, long 23 chunks (2001 steps of 5 frames and 5 bodies); before the
    // fix every file's first chunk held only schemas and channels (0 message indexes).
    assert_eq!(chunks[0], 1, "{chunks:?}");
    assert!(chunks[1] >= 10, "{chunks:?}");
    // long.ros2.mcap: measured 34 chunks (CDR strings repeat every frame id in every message).
    assert!(chunks[2] >= 10, "{chunks:?}");
}

fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            out.extend(walk(&path));
        } else {
            out.push(path);
        }
    }
    out
}

const SHAPES_URDF: &str = r#"<?xml version="1.0"?>
<robot name="shapes">
  <material name="blue"><color rgba="0.1 0.2 0.9 1"/></material>
  <link name="base">
    <inertial><mass value="2"/><inertia ixx="0.1" iyy="0.2" izz="0.25" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual name="slab">
      <origin xyz="0.1 0 0.05" rpy="0 0 1.5707963267948966"/>
      <geometry><box size="0.3 0.2 0.1"/></geometry>
      <material name="blue"/>
    </visual>
    <visual>
      <origin xyz="0 0 -0.2"/>
      <geometry><capsule radius="0.05" length="0.2"/></geometry>
    </visual>
  </link>
  <joint name="j" type="fixed"><parent link="base"/><child link="tip"/><origin xyz="0 0 0.5"/></joint>
  <link name="tip">
    <inertial><mass value="1"/><inertia ixx="0.01" iyy="0.02" izz="0.025" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><mesh filename="cube.stl" scale="2 1 -1"/></geometry></visual>
    <visual><geometry><sphere radius="0.07"/></geometry></visual>
    <visual><geometry><cylinder radius="0.02" length="0.3"/></geometry></visual>
  </link>
</robot>
"#;

fn f64s(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

fn assert_close(a: &[f64], b: &[f64], tol: f64, what: &str) {
    assert_eq!(a.len(), b.len(), "{what}: {a:?} vs {b:?}");
    for (x, y) in a.iter().zip(b) {
        assert!((x - y).abs() <= tol, "{what}: {a:?} vs {b:?}");
    }
}

/// The `/scene` topic holds every visual of the URDF as Foxglove primitives in its link frame
/// (sizes, visual origins, colours, the mesh scaled and re-wound), one message at t = 0, entity
/// ids and frames equal to the `/tf` child frames and locked to them; `/inertia` holds each body's
/// equivalent ellipsoid; the URDF text is in the metadata. Read by the Python `mcap` reader with
/// protobuf decoding (nobody on the team wrote it).
#[test]
fn scene_topic_carries_the_urdf_geometry_in_link_frames() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::copy(
        common::root().join("tests/data/policy/cube_0_1m.stl"),
        d.join("cube.stl"),
    )
    .unwrap();
    std::fs::write(d.join("shapes.urdf"), SHAPES_URDF).unwrap();
    let out = tumble(
        &[
            "simulate",
            "shapes.urdf",
            "--out",
            "run",
            "--duration",
            "0.1",
            "--angvel",
            "0,0,1",
            // The model has a mesh: its ellipsoids are written only when asked.
            "--ellipsoids",
        ],
        d,
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    let py = run_py("read_scene.py", &[&d.join("run.mcap")]);
    let tf_children: Vec<&str> = py["tf_children"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    assert_eq!(tf_children, ["base", "tip"]);
    let scene = py["topics"]["/scene"].as_array().unwrap();
    assert_eq!(scene.len(), 1, "one /scene message");
    assert_eq!(scene[0]["log_time"], 0);
    let entities = scene[0]["entities"].as_array().unwrap();
    let ids: Vec<&str> = entities.iter().map(|e| e["id"].as_str().unwrap()).collect();
    assert_eq!(ids, tf_children);
    for e in entities {
        assert_eq!(e["frame_id"], e["id"]);
        assert_eq!(e["frame_locked"], true);
        assert_eq!(e["timestamp_ns"], 0);
        assert_eq!(
            e["models"], 0,
            "meshes go in as triangle lists, not model files"
        );
    }
    let (base, tip) = (&entities[0], &entities[1]);
    let h = std::f64::consts::FRAC_1_SQRT_2;
    // The box: size as written, at its origin (yaw 90°: q = (0, 0, sin 45°, cos 45°)), URDF colour
    // (stored as f32: 0.1 → 0.10000000149).
    let cube = &base["cubes"][0];
    assert_close(&f64s(&cube["size"]), &[0.3, 0.2, 0.1], 0.0, "box size");
    assert_close(
        &f64s(&cube["pose"]),
        &[0.1, 0.0, 0.05, 0.0, 0.0, h, h],
        1e-15,
        "box pose",
    );
    assert_close(
        &f64s(&cube["color"]),
        &[0.1, 0.2, 0.9, 1.0],
        1e-7,
        "box colour",
    );
    // The capsule: a cylinder of its straight part and two spheres at its ends, default grey.
    let cyl = &base["cylinders"][0];
    assert_close(
        &f64s(&cyl["size"]),
        &[0.1, 0.1, 0.2],
        0.0,
        "capsule cylinder",
    );
    assert_close(
        &f64s(&cyl["pose"])[..3],
        &[0.0, 0.0, -0.2],
        0.0,
        "capsule origin",
    );
    assert_eq!(
        (cyl["bottom_scale"].as_f64(), cyl["top_scale"].as_f64()),
        (Some(1.0), Some(1.0))
    );
    assert_close(
        &f64s(&cyl["color"]),
        &[0.8, 0.8, 0.8, 1.0],
        0.0,
        "default colour",
    );
    let ends: Vec<f64> = base["spheres"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| {
            assert_close(&f64s(&s["size"]), &[0.1; 3], 0.0, "capsule end");
            f64s(&s["pose"])[2]
        })
        .collect();
    assert_close(&ends, &[-0.3, -0.1], 1e-16, "capsule ends");
    // The sphere and the cylinder of the tip.
    assert_close(&f64s(&tip["spheres"][0]["size"]), &[0.14; 3], 0.0, "sphere");
    assert_close(
        &f64s(&tip["cylinders"][0]["size"]),
        &[0.04, 0.04, 0.3],
        0.0,
        "cylinder",
    );
    // The mesh: the STL's 8 distinct corners (0 or 0.1 m per axis) scaled by (2, 1, -1), 12
    // triangles, re-wound because the scale mirrors: the signed volume of the triangle list is
    // +|det| · 0.1³ = 2e-3 m³ (outward normals), not -2e-3 (f32 corners: 2.0000001e-3).
    let tri = &tip["triangles"][0];
    let points: Vec<Vec<f64>> = tri["points"].as_array().unwrap().iter().map(f64s).collect();
    let mut corners: Vec<Vec<f64>> = Vec::new();
    for line in std::fs::read_to_string(d.join("cube.stl")).unwrap().lines() {
        if let Some(rest) = line.trim().strip_prefix("vertex ") {
            // STL stores f32: 0.1 is 0.10000000149 m.
            let v: Vec<f64> = rest
                .split_whitespace()
                .map(|x| f64::from(x.parse::<f32>().unwrap()))
                .collect();
            let scaled = vec![2.0 * v[0], v[1], -v[2]];
            if !corners.contains(&scaled) {
                corners.push(scaled);
            }
        }
    }
    assert_eq!(points.len(), 8);
    for c in &corners {
        assert!(points.contains(c), "{c:?} not in {points:?}");
    }
    let indices: Vec<usize> = tri["indices"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| i.as_u64().unwrap() as usize)
        .collect();
    assert_eq!(indices.len(), 36);
    let signed_volume: f64 = indices
        .chunks(3)
        .map(|t| {
            let (a, b, c) = (&points[t[0]], &points[t[1]], &points[t[2]]);
            let cross = [
                b[1] * c[2] - b[2] * c[1],
                b[2] * c[0] - b[0] * c[2],
                b[0] * c[1] - b[1] * c[0],
            ];
            (a[0] * cross[0] + a[1] * cross[1] + a[2] * cross[2]) / 6.0
        })
        .sum();
    assert!((signed_volume - 2e-3).abs() < 1e-9, "{signed_volume}");

    // /inertia: the equivalent uniform ellipsoid, semi-axes a² = 5 (I2 + I3 − I1) / (2 m) etc.
    let inertia = py["topics"]["/inertia"].as_array().unwrap();
    assert_eq!(inertia.len(), 1);
    let ellipsoids = inertia[0]["entities"].as_array().unwrap();
    for (e, (link, m, i)) in ellipsoids.iter().zip([
        ("base", 2.0_f64, [0.1_f64, 0.2, 0.25]),
        ("tip", 1.0, [0.01, 0.02, 0.025]),
    ]) {
        assert_eq!(e["id"], format!("inertia/{link}"));
        assert_eq!(e["frame_id"], link);
        assert_eq!(e["frame_locked"], true);
        let k = 5.0 / (2.0 * m);
        let mut want = [
            2.0 * (k * (i[1] + i[2] - i[0])).sqrt(),
            2.0 * (k * (i[0] + i[2] - i[1])).sqrt(),
            2.0 * (k * (i[0] + i[1] - i[2])).sqrt(),
        ];
        let mut got = f64s(&e["spheres"][0]["size"]);
        want.sort_by(f64::total_cmp);
        got.sort_by(f64::total_cmp);
        assert_close(&got, &want, 1e-12, link);
    }

    // The URDF text is in the `tumble` metadata record, under `urdf/<the path given>`.
    let meta = run_py("read_mcap.py", &[&d.join("run.mcap")]);
    assert_eq!(meta["metadata"]["tumble"]["urdf/shapes.urdf"], SHAPES_URDF);

    // --no-ellipsoids leaves /inertia out.
    let out = tumble(
        &[
            "simulate",
            "shapes.urdf",
            "--out",
            "plain",
            "--duration",
            "0.01",
            "--no-ellipsoids",
        ],
        d,
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    let py = run_py("read_scene.py", &[&d.join("plain.mcap")]);
    let topics: Vec<&String> = py["topics"].as_object().unwrap().keys().collect();
    assert_eq!(topics, ["/scene"]);
}

/// `tumble trade` writes one topic group per integrator: each group's `<prefix>/scene` holds
/// exactly the frames of its own `<prefix>/tf`.
#[test]
fn grouped_recordings_have_a_scene_per_group() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = tumble(
        &[
            "trade",
            "--out",
            "t",
            "--dt",
            "0.01",
            "--duration",
            "0.2",
            "--integrators",
            "variational,rk4",
            "--repeats",
            "1",
        ],
        d,
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    let file = d.join("t/trade.mcap");
    let py = run_py("read_scene.py", &[&file]);
    let chunks = run_py("mcap_chunks.py", &[&file]);
    let channels = chunks["files"][file.display().to_string()]["channels"]
        .as_array()
        .unwrap()
        .clone();
    let prefixes: Vec<String> = channels
        .iter()
        .filter_map(|c| {
            c["topic"]
                .as_str()
                .unwrap()
                .strip_suffix("/tf")
                .map(str::to_string)
        })
        .collect();
    assert!(prefixes.len() >= 2, "{prefixes:?}");
    let tf = run_py("read_mcap.py", &[&file]);
    for prefix in &prefixes {
        let scene = &py["topics"][format!("{prefix}/scene")];
        let ids: std::collections::BTreeSet<String> = scene[0]["entities"]
            .as_array()
            .unwrap_or_else(|| panic!("no {prefix}/scene: {py}"))
            .iter()
            .map(|e| e["id"].as_str().unwrap().to_string())
            .collect();
        // The group's frames, as read back from the whole file's /tf topics by read_mcap.py.
        let frames: std::collections::BTreeSet<String> = tf["frames"]
            .as_object()
            .unwrap()
            .keys()
            .filter(|k| k.starts_with(&format!("{}/", prefix.trim_start_matches('/'))))
            .cloned()
            .collect();
        assert!(!ids.is_empty());
        assert_eq!(ids, frames, "{prefix}");
    }
}

/// The Rerun recording opens with tumble's blueprint (read back by rerun-sdk 0.36.3): the 3D view
/// gets two thirds of the width, beside a column of three time series over the whole run
/// (relative energy change, largest relative angular momentum change, energies), the side panels
/// collapsed, the time panel on `sim_time`, and the eye placed so every link frame of the run is
/// in view. The change series equal what the MCAP's `/bodies` give, computed here.
#[test]
fn rerun_recording_opens_with_the_scene_framed_and_conservation_plots() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = common::root().join("models/default.toml");
    let out = tumble(
        &[
            "simulate",
            scene.to_str().unwrap(),
            "--out",
            "run",
            "--duration",
            "2",
        ],
        d,
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    let bp = run_py("read_blueprint.py", &[&d.join("run.rrd")]);
    let (recs, bps) = (&bp["recordings"], &bp["blueprints"]);
    assert_eq!(recs.as_array().unwrap().len(), 1);
    assert_eq!(bps.as_array().unwrap().len(), 1);
    assert_eq!(bps[0]["application_id"], recs[0]["application_id"]);
    assert_eq!(
        bps[0]["recording_id"].as_str().unwrap(),
        format!("{}-blueprint", recs[0]["recording_id"].as_str().unwrap())
    );
    let e = bp["entities"].as_object().unwrap();
    let get = |path: &str, component: &str| -> serde_json::Value {
        e.get(path)
            .and_then(|c| c.get(component))
            .cloned()
            .unwrap_or_else(|| panic!("{path} {component} missing: {bp}"))
    };
    // The root container: horizontal (kind 2), [3D view, column], shares 2 : 1.
    let root_bytes: Vec<u8> = get("/viewport", "ViewportBlueprint:root_container")[0]
        .as_array()
        .unwrap()
        .iter()
        .map(|b| b.as_u64().unwrap() as u8)
        .collect();
    let root_hex: String = root_bytes.iter().map(|b| format!("{b:02x}")).collect();
    let root = e
        .keys()
        .find(|k| k.starts_with("/container/") && k.replace('-', "").ends_with(&root_hex))
        .unwrap_or_else(|| panic!("root container {root_hex} not logged"))
        .clone();
    assert_eq!(
        get(&root, "ContainerBlueprint:container_kind"),
        serde_json::json!([2])
    );
    assert_eq!(
        get(&root, "ContainerBlueprint:col_shares"),
        serde_json::json!([2.0, 1.0])
    );
    let contents = get(&root, "ContainerBlueprint:contents");
    let (view3d, column) = (
        format!("/{}", contents[0].as_str().unwrap()),
        format!("/{}", contents[1].as_str().unwrap()),
    );
    assert_eq!(
        get(&view3d, "ViewBlueprint:class_identifier"),
        serde_json::json!(["3D"])
    );
    let query = get(&format!("{view3d}/ViewContents"), "ViewContents:query");
    assert!(
        query.as_array().unwrap().contains(&"- /plots/**".into()),
        "{query}"
    );
    assert_eq!(
        get(&column, "ContainerBlueprint:container_kind"),
        serde_json::json!([3])
    );
    let plots: Vec<String> = get(&column, "ContainerBlueprint:contents")
        .as_array()
        .unwrap()
        .iter()
        .map(|v| format!("/{}", v.as_str().unwrap()))
        .collect();
    let plot_queries: Vec<serde_json::Value> = plots
        .iter()
        .map(|p| {
            assert_eq!(
                get(p, "ViewBlueprint:class_identifier"),
                serde_json::json!(["TimeSeries"])
            );
            // Whole run: both ends of the time axis unbounded (null = infinite).
            assert_eq!(
                get(&format!("{p}/TimeAxis"), "TimeAxis:view_range"),
                serde_json::json!([{"start": null, "end": null}])
            );
            get(&format!("{p}/ViewContents"), "ViewContents:query")
        })
        .collect();
    assert_eq!(
        plot_queries,
        [
            serde_json::json!(["+ /plots/scene/energy_change"]),
            serde_json::json!(["+ /plots/scene/angular_momentum_change"]),
            serde_json::json!(["+ /plots/scene/energy"]),
        ]
    );
    for panel in ["/blueprint_panel", "/selection_panel"] {
        assert_eq!(
            get(panel, "PanelBlueprint:state"),
            serde_json::json!([2]),
            "{panel} collapsed"
        );
    }
    assert_eq!(
        get("/time_panel", "TimePanelBlueprint:timeline"),
        serde_json::json!(["sim_time"])
    );

    // Framing: every recorded frame origin lies within 25° of the view axis (a 50° field of
    // view holds them all), in front of the eye. Measured: at most 13.6° for the default scene.
    let eye = f64s(&get(&format!("{view3d}/EyeControls3D"), "EyeControls3D:position")[0]);
    let target = f64s(
        &get(
            &format!("{view3d}/EyeControls3D"),
            "EyeControls3D:look_target",
        )[0],
    );
    let axis: Vec<f64> = (0..3).map(|k| target[k] - eye[k]).collect();
    let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let mcap = run_py("read_mcap.py", &[&d.join("run.mcap")]);
    let mut widest: f64 = 0.0;
    for rows in mcap["frames"].as_object().unwrap().values() {
        for row in rows.as_array().unwrap() {
            let p: Vec<f64> = (1..4)
                .map(|k| row[k].as_f64().unwrap() - eye[k - 1])
                .collect();
            let cos =
                p.iter().zip(&axis).map(|(a, b)| a * b).sum::<f64>() / (norm(&p) * norm(&axis));
            widest = widest.max(cos.clamp(-1.0, 1.0).acos().to_degrees());
        }
    }
    assert!(widest < 25.0, "a frame is {widest}° off the view axis");

    // The change series against the MCAP's energies and momenta.
    let scalars = run_py("read_scalars.py", &[&d.join("run.rrd")]);
    let bodies = mcap["bodies"].as_object().unwrap();
    let n = bodies.values().next().unwrap().as_array().unwrap().len();
    let row = |b: &serde_json::Value, i: usize, k: usize| b[i][k].as_f64().unwrap();
    let energy = |i: usize| {
        let kinetic: f64 = bodies.values().map(|b| row(b, i, 1)).sum();
        let potential: f64 = bodies.values().map(|b| row(b, i, 2)).sum();
        kinetic + potential
    };
    let e0 = energy(0);
    let energy_change = scalars["/plots/scene/energy_change"].as_array().unwrap();
    let angmom_change = scalars["/plots/scene/angular_momentum_change"]
        .as_array()
        .unwrap();
    assert_eq!((energy_change.len(), angmom_change.len()), (n, n));
    let (mut e_max, mut l_max): (f64, f64) = (0.0, 0.0);
    for i in 0..n {
        let want_e = (energy(i) - e0) / e0.abs();
        let got_e = energy_change[i][1].as_f64().unwrap();
        assert!((got_e - want_e).abs() <= 1e-15, "{i}: {got_e} vs {want_e}");
        let want_l = bodies
            .values()
            .map(|b| {
                let d: Vec<f64> = (3..6).map(|k| row(b, i, k) - row(b, 0, k)).collect();
                let l0: Vec<f64> = (3..6).map(|k| row(b, 0, k)).collect();
                norm(&d) / norm(&l0)
            })
            .fold(0.0, f64::max);
        let got_l = angmom_change[i][1].as_f64().unwrap();
        assert!((got_l - want_l).abs() <= 1e-18, "{i}: {got_l} vs {want_l}");
        e_max = e_max.max(got_e.abs());
        l_max = l_max.max(got_l);
    }
    // What the plots show for the default scene over 2 s: energy within 2.61e-7 (O(h²) at
    // h|Ω| = 0.02), angular momentum at round-off (measured 6.5e-15).
    assert!(e_max > 1e-9 && e_max < 1e-6, "{e_max}");
    assert!(l_max < 1e-13, "{l_max}");
}

/// A tetrahedron in millimetres, placed by a node 100 mm along x (what real robots' Collada
/// meshes look like to the reader: a unit and a node transform).
const TETRA_DAE: &str = r##"<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><unit name="millimetre" meter="0.001"/><up_axis>Z_UP</up_axis></asset>
  <library_geometries><geometry id="t"><mesh>
    <source id="p"><float_array id="pa" count="12">0 0 0  50 0 0  0 50 0  0 0 50</float_array>
      <technique_common><accessor source="#pa" count="4" stride="3"/></technique_common></source>
    <vertices id="v"><input semantic="POSITION" source="#p"/></vertices>
    <triangles count="4"><input semantic="VERTEX" source="#v" offset="0"/>
      <p>0 2 1  0 1 3  0 3 2  1 2 3</p></triangles>
  </mesh></geometry></library_geometries>
  <library_visual_scenes><visual_scene id="s">
    <node id="n"><translate>100 0 0</translate><instance_geometry url="#t"/></node>
  </visual_scene></library_visual_scenes>
  <scene><instance_visual_scene url="#s"/></scene>
</COLLADA>"##;

/// Collada meshes, which Rerun cannot read, reach both viewers as triangles: a `Mesh3D` in the
/// .rrd (with vertex normals) and a triangle list on `/scene`, vertices in metres with the node
/// transform applied, scaled by the URDF `scale` on the way (Rerun: the instance pose's scale).
#[test]
fn collada_meshes_reach_rerun_and_foxglove_as_triangles() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("tetra.dae"), TETRA_DAE).unwrap();
    std::fs::write(
        d.join("tetra.urdf"),
        r#"<robot name="tetra"><link name="shell">
             <inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>
             <visual><geometry><mesh filename="tetra.dae" scale="2 2 2"/></geometry></visual>
           </link></robot>"#,
    )
    .unwrap();
    let out = tumble(
        &[
            "simulate",
            "tetra.urdf",
            "--out",
            "run",
            "--duration",
            "0.01",
        ],
        d,
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(
        !text(&out.stderr).contains("warning"),
        "{}",
        text(&out.stderr)
    );
    // The file's corners in metres, node translation (0.1 m, 0, 0) applied.
    let corners = [
        [0.1, 0.0, 0.0],
        [0.15, 0.0, 0.0],
        [0.1, 0.05, 0.0],
        [0.1, 0.0, 0.05],
    ];
    let meshes = run_py("read_meshes.py", &[&d.join("run.rrd")]);
    let mesh = &meshes["/tetra/visual_geometries/shell/visual_0"];
    let positions: Vec<Vec<f64>> = mesh["positions"]
        .as_array()
        .unwrap()
        .iter()
        .map(f64s)
        .collect();
    assert_eq!(positions.len(), 4, "{meshes}");
    for c in &corners {
        // f32 storage: 0.15 is stored to 6e-9.
        assert!(
            positions
                .iter()
                .any(|p| (0..3).all(|k| (p[k] - c[k]).abs() < 1e-8)),
            "{c:?} not in {positions:?}"
        );
    }
    assert_eq!(mesh["indices"].as_array().unwrap().len(), 4);
    assert_eq!(mesh["normals"], 4);
    // Foxglove gets the scaled corners (×2) as a triangle list, each coordinate the nearest
    // float32 (written as doubles: the mesh files' precision, compressed better), so within
    // 2⁻²⁴ of it.
    let scene = run_py("read_scene.py", &[&d.join("run.mcap")]);
    let tri = &scene["topics"]["/scene"][0]["entities"][0]["triangles"][0];
    let points: Vec<Vec<f64>> = tri["points"].as_array().unwrap().iter().map(f64s).collect();
    for c in &corners {
        let scaled: Vec<f64> = c.iter().map(|x| 2.0 * x).collect();
        assert!(
            points
                .iter()
                .any(|p| (0..3).all(|k| p[k] == f64::from(scaled[k] as f32))),
            "{scaled:?} not in {points:?}"
        );
    }
}

/// The Foxglove layout shipped with tumble (docs/foxglove/tumble-layout.json, named in the run
/// summary) is a layout Foxglove imports: a 3D panel on `world` with `/scene` visible, and
/// plots whose message paths exist in the `/bodies` messages of a real recording (read by the
/// Python `mcap` reader with protobuf decoding).
#[test]
fn the_shipped_foxglove_layout_shows_the_scene_and_plots_real_fields() {
    let root = common::root();
    let json = std::fs::read_to_string(root.join("docs/foxglove/tumble-layout.json")).unwrap();
    let layout: serde_json::Value = serde_json::from_str(&json).unwrap();
    let panels = layout["configById"].as_object().unwrap();
    let three_d = &panels["3D!tumble"];
    assert_eq!(three_d["followTf"], "world");
    assert_eq!(three_d["topics"]["/scene"]["visible"], true);
    // The contact points and arrows of a run with contacts (docs/recordings.md#contacts).
    assert_eq!(three_d["topics"]["/contacts/scene"]["visible"], true);
    // Every panel the layout tree names is configured.
    let tree = layout["layout"].to_string();
    for id in panels.keys() {
        assert!(
            tree.contains(&format!("\"{id}\"")),
            "{id} not placed in {tree}"
        );
    }
    let dir = tempfile::tempdir().unwrap();
    let out = tumble(
        &["simulate", "--out", "run", "--duration", "0.05"],
        dir.path(),
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    let mcap = run_py("read_mcap.py", &[&dir.path().join("run.mcap")]);
    assert!(mcap["schemas"]["/bodies"] == "tumble.BodyStates");
    // The plotted paths: /bodies.total_energy and /bodies.bodies[0].angular_momentum.{x,y,z}, the
    // fields of tumble.BodyStates (src/record/mcap.rs), checked against the decoded message.
    let fields = run_py("bodies_fields.py", &[&dir.path().join("run.mcap")]);
    for (id, panel) in panels.iter().filter(|(id, _)| id.starts_with("Plot!")) {
        for path in panel["paths"].as_array().unwrap() {
            let path = path["value"].as_str().unwrap();
            let field = path
                .strip_prefix("/bodies.")
                .unwrap_or_else(|| panic!("{id}: {path}"));
            assert!(
                fields["paths"].as_array().unwrap().contains(&field.into()),
                "{id}: {path} is not a field of /bodies: {fields}"
            );
        }
    }
}
