//! `tumble dataset --format lerobot` and `tumble convert DIR --lerobot OUT`: a LeRobot v3.0
//! folder read back by pandas and polars (`tests/py/read_lerobot.py`: the format's columns and
//! types, totals, index contiguity, timestamps, values against the native joints table, stats),
//! deterministic bytes, the same bytes from `convert`, `--force`, a floating base, diverged
//! runs, the refusals; and Rerun's LeRobot importer (`tests/py/read_lerobot_rerun.py`).
//!
//! The `lerobot` package's own `LeRobotDataset` is too heavy for the test venv (torch, about
//! 8 GB): `scripts/check_lerobot.sh` runs it (docs/datasets.md, "LeRobot v3").

use crate::common;

use common::{root, run_py, text, tumble};
use std::collections::BTreeMap;
use std::path::Path;

/// A driven-arm spec (two position servos, gravity varied) written to `dir/name`. Duration
/// 0.205 s at dt 1 ms and log_every 10: 21 frames on the grid plus an off-grid last row (step
/// 205) that the LeRobot frames leave out.
fn arm_spec(dir: &Path, name: &str, runs: u32, sim: &str, vary: &str) -> String {
    let arm = root().join("models/arm.urdf").display().to_string();
    let spec = format!(
        r#"[dataset]
runs = {runs}
seed = 3
runs_per_file = 3

[scene.sim]
{sim}
integrator = "variational"

[[scene.model]]
urdf = "{arm}"
name = "arm"
bodies = "articulated"
base = "fixed"

[[scene.model.actuator]]
joint = "shoulder"
kind = "position"
target = 0.5
kp = 400.0
kd = 8.1

[[scene.model.actuator]]
joint = "elbow"
kind = "position"
target = -0.3
kp = 800.0
kd = 11.3

[vary]
{vary}
"#
    );
    std::fs::write(dir.join(name), spec).unwrap();
    name.to_string()
}

const SIM: &str = "dt = 0.001\nduration = 0.205\nlog_every = 10";
const GRAVITY: &str = "gravity = { normal = { mean = [0, 0, -9.81], std = [1.5, 1.5, 0.5] } }";

/// The files under `dir/meta` and `dir/data` (relative path → bytes).
fn lerobot_files(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    fn walk(base: &Path, dir: &Path, out: &mut BTreeMap<String, Vec<u8>>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(base, &p, out);
            } else {
                let rel = p.strip_prefix(base).unwrap().display().to_string();
                out.insert(rel, std::fs::read(&p).unwrap());
            }
        }
    }
    let mut out = BTreeMap::new();
    for sub in ["meta", "data"] {
        walk(dir, &dir.join(sub), &mut out);
    }
    out
}

/// pandas and polars read the folder: LeRobot's columns and types, and the native tables'
/// values in them.
#[test]
fn pandas_and_polars_read_the_lerobot_dataset() {
    let tmp = tempfile::tempdir().unwrap();
    let spec = arm_spec(tmp.path(), "arm.toml", 7, SIM, GRAVITY);
    let out = tumble(
        &["dataset", &spec, "--out", "d", "-q", "--format", "lerobot"],
        tmp.path(),
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    assert!(
        stdout.contains("7 episodes, 147 frames at 100 fps"),
        "{stdout}"
    );
    let dir = tmp.path().join("d");
    assert!(!dir.join(".lerobot.part").exists());
    let r = run_py("read_lerobot.py", &[&dir]);
    let info = &r["info"];
    assert_eq!(info["codebase_version"], "v3.0");
    assert_eq!(info["robot_type"], "arm");
    assert_eq!(info["fps"], 100);
    assert_eq!(info["total_episodes"], 7);
    assert_eq!(
        info["total_frames"], 147,
        "21 frames per run: the off-grid last row dropped"
    );
    assert_eq!(info["total_tasks"], 1);
    assert_eq!(info["splits"]["train"], "0:7");
    assert_eq!(
        info["data_path"],
        "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
    );
    assert!(info["video_path"].is_null());
    let f = &info["features"];
    assert_eq!(
        f["observation.state"]["names"],
        serde_json::json!([
            "arm/shoulder.pos",
            "arm/elbow.pos",
            "arm/shoulder.vel",
            "arm/elbow.vel"
        ])
    );
    assert_eq!(f["observation.state"]["shape"], serde_json::json!([4]));
    assert_eq!(f["observation.state"]["dtype"], "float32");
    assert_eq!(
        f["action"]["names"],
        serde_json::json!(["arm/shoulder.target", "arm/elbow.target"])
    );
    assert_eq!(f["observation.effort"]["shape"], serde_json::json!([2]));
    for k in ["frame_index", "episode_index", "index", "task_index"] {
        assert_eq!(f[k]["dtype"], "int64", "{k}");
        assert_eq!(f[k]["shape"], serde_json::json!([1]), "{k}");
        assert!(f[k]["names"].is_null(), "{k}");
    }
    assert_eq!(f["timestamp"]["dtype"], "float32");
    assert_eq!(r["data_rows"], 147);
    assert_eq!(r["episodes_rows"], 7);
    assert_eq!(
        r["data_files"],
        serde_json::json!(["data/chunk-000/file-000.parquet"])
    );
    let pd = &r["pandas_dtypes"];
    assert_eq!(pd["timestamp"], "float32");
    for k in ["frame_index", "episode_index", "index", "task_index"] {
        assert_eq!(pd[k], "int64", "{k}");
    }
    for k in ["observation.state", "observation.effort", "action"] {
        assert_eq!(r["vector_dtypes"][k], "float32", "{k}");
    }
    assert_eq!(
        r["polars_schema"]["observation.state"],
        "Array(Float32, shape=(4,))"
    );
    assert_eq!(r["polars_schema"]["timestamp"], "Float32");
    assert_eq!(r["index_contiguous"], true);
    assert_eq!(r["frame_index_contiguous"], true);
    assert_eq!(r["timestamp_err_max"], 0.0);
    assert_eq!(
        r["state_err_max"], 0.0,
        "the joints table's values as float32"
    );
    assert_eq!(r["effort_err_max"], 0.0);
    assert_eq!(r["action_err_max"], 0.0);
    assert_eq!(r["polars_equals_pandas"], true);
    assert_eq!(r["stats_min_max_equal"], true);
    // Pooled mean and variance vs numpy over all frames: measured ≤ 1.1e-15 (relative to the
    // largest |value|).
    assert!(r["stats_mean_rel_err_max"].as_f64().unwrap() < 1e-12, "{r}");
    assert!(r["stats_std_rel_err_max"].as_f64().unwrap() < 1e-9, "{r}");
    assert_eq!(r["stats_count_ok"], true);
    assert_eq!(r["episode_ranges_ok"], true);
    assert_eq!(r["episode_stats_ok"], true);
    assert_eq!(r["task_index_name"], "task");
    let tasks = r["tasks"].as_object().unwrap();
    assert_eq!(tasks.len(), 1);
    assert!(
        tasks
            .keys()
            .all(|t| t.starts_with("tumble: arm, 7 randomized runs"))
    );
    assert_eq!(r["runs"], serde_json::json!([0, 1, 2, 3, 4, 5, 6]));
    for c in [
        "episode_index",
        "tasks",
        "length",
        "data/chunk_index",
        "data/file_index",
        "dataset_from_index",
        "dataset_to_index",
        "meta/episodes/chunk_index",
        "meta/episodes/file_index",
    ] {
        assert!(
            r["episode_columns"]
                .as_array()
                .unwrap()
                .iter()
                .any(|x| x == c),
            "{c}"
        );
    }
}

/// The same spec gives the same bytes; `convert DIR --lerobot OUT` gives the same files as
/// `--format lerobot`; `--force` replaces, and without it an existing LeRobot folder is kept.
#[test]
fn lerobot_bytes_are_deterministic_and_convert_gives_the_same() {
    let tmp = tempfile::tempdir().unwrap();
    let spec = arm_spec(tmp.path(), "arm.toml", 5, SIM, GRAVITY);
    let run = |args: &[&str]| tumble(args, tmp.path());
    for d in ["a", "b"] {
        let out = run(&["dataset", &spec, "--out", d, "-q", "--format", "lerobot"]);
        assert!(out.status.success(), "{}", text(&out.stderr));
    }
    let a = lerobot_files(&tmp.path().join("a"));
    assert_eq!(a.len(), 5, "{:?}", a.keys().collect::<Vec<_>>());
    assert_eq!(a, lerobot_files(&tmp.path().join("b")));
    // convert from the native tables alone.
    let out = run(&["dataset", &spec, "--out", "c", "-q"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(!tmp.path().join("c/meta").exists());
    let out = run(&["convert", "c", "--lerobot", "c_lr"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(
        text(&out.stdout).contains("5 episodes"),
        "{}",
        text(&out.stdout)
    );
    assert_eq!(a, lerobot_files(&tmp.path().join("c_lr")));
    // An existing LeRobot folder needs --force.
    let out = run(&["convert", "c", "--lerobot", "c_lr"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out.stderr).contains("--force"),
        "{}",
        text(&out.stderr)
    );
    let out = run(&["convert", "c/manifest.json", "--lerobot", "c", "--force"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert_eq!(a, lerobot_files(&tmp.path().join("c")));
    // `dataset --force` (native format) removes the LeRobot folders too.
    let out = run(&["dataset", &spec, "--out", "a", "-q", "--force"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(!tmp.path().join("a/meta").exists() && !tmp.path().join("a/data").exists());
}

/// What LeRobot cannot hold is refused with one message naming the spec and the key, exit 2,
/// and no LeRobot folder is left.
#[test]
fn lerobot_refusals_name_the_spec_and_key() {
    let tmp = tempfile::tempdir().unwrap();
    let box_urdf = root().join("models/box.urdf").display().to_string();
    let arm_urdf = root().join("models/arm.urdf").display().to_string();
    // vary.model drawing the arm and a model with other joints (or none), no actuators.
    let mix = |name: &str, other: &str, base: &str| {
        let other = root().join("models").join(other).display().to_string();
        std::fs::write(
            tmp.path().join(name),
            format!(
                "[dataset]\nruns = 6\nseed = 3\nruns_per_file = 3\n\n[scene.sim]\n{SIM}\n\n\
                 [[scene.model]]\nurdf = \"{arm_urdf}\"\nbodies = \"articulated\"\n\
                 base = \"{base}\"\n\n[vary]\nmodel = {{ choice = [\"{arm_urdf}\", \"{other}\"] }}\n"
            ),
        )
        .unwrap();
        name.to_string()
    };
    let cases = [
        (
            arm_spec(
                tmp.path(),
                "fps.toml",
                2,
                "dt = 0.003\nduration = 0.03\nlog_every = 1",
                "",
            ),
            "sim.log_every",
        ),
        (
            arm_spec(
                tmp.path(),
                "dt.toml",
                4,
                SIM,
                "dt = { choice = [0.001, 0.0005] }",
            ),
            "vary.dt",
        ),
        (
            mix("model_rigid.toml", "box.urdf", "floating"),
            "vary.model",
        ),
        (
            mix("model_joints.toml", "chain7.urdf", "fixed"),
            "vary.model",
        ),
    ];
    let rigid = "rigid.toml";
    std::fs::write(
        tmp.path().join(rigid),
        format!(
            "[dataset]\nruns = 2\nseed = 1\n\n[scene.sim]\n{SIM}\n\n[[scene.model]]\nurdf = \"{box_urdf}\"\n"
        ),
    )
    .unwrap();
    for (spec, key) in cases
        .iter()
        .map(|(s, k)| (s.as_str(), *k))
        .chain([(rigid, "hold robots")])
    {
        let out_dir = spec.replace(".toml", "");
        let out = tumble(
            &[
                "dataset", spec, "--out", &out_dir, "-q", "--format", "lerobot",
            ],
            tmp.path(),
        );
        let err = text(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{spec}: {err}");
        assert!(err.contains(key) && err.contains(spec), "{spec}: {err}");
        assert!(!err.contains("panicked"), "{spec}: {err}");
        let dir = tmp.path().join(&out_dir);
        for sub in ["meta", "data", ".lerobot.part"] {
            assert!(!dir.join(sub).exists(), "{spec}: {sub} left");
        }
    }
    // A shard holds part of the runs.
    let spec = &cases[0].0;
    let out = tumble(
        &[
            "dataset", spec, "--out", "s", "-q", "--format", "lerobot", "--shard", "1/2",
        ],
        tmp.path(),
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("merge"), "{}", text(&out.stderr));
    // Not a dataset folder.
    let out = tumble(&["convert", ".", "--lerobot", "x"], tmp.path());
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out.stderr).contains("manifest.json"),
        "{}",
        text(&out.stderr)
    );
}

/// A floating base adds `observation.base_pose` and `observation.base_velocity`: the root link
/// frame's pose and velocity, from its body's trajectory rows and `link_from_body`.
#[test]
fn a_floating_base_gives_its_pose_and_velocity() {
    let tmp = tempfile::tempdir().unwrap();
    let spec = arm_spec(tmp.path(), "float.toml", 3, SIM, GRAVITY);
    let path = tmp.path().join(&spec);
    let text_spec = std::fs::read_to_string(&path).unwrap();
    std::fs::write(
        &path,
        text_spec.replace("base = \"fixed\"", "base = \"floating\""),
    )
    .unwrap();
    let out = tumble(
        &["dataset", &spec, "--out", "d", "-q", "--format", "lerobot"],
        tmp.path(),
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    let r = run_py("read_lerobot.py", &[&tmp.path().join("d")]);
    let f = &r["info"]["features"];
    assert_eq!(
        f["observation.base_pose"]["names"],
        serde_json::json!([
            "arm/base.x",
            "arm/base.y",
            "arm/base.z",
            "arm/base.qx",
            "arm/base.qy",
            "arm/base.qz",
            "arm/base.qw"
        ])
    );
    assert_eq!(
        f["observation.base_velocity"]["shape"],
        serde_json::json!([6])
    );
    // numpy's quaternion products vs nalgebra's, both rounded to float32: measured 0.
    assert!(r["base_pose_err_max"].as_f64().unwrap() <= 1e-6, "{r}");
    assert!(r["base_velocity_err_max"].as_f64().unwrap() <= 1e-5, "{r}");
    assert_eq!(r["state_err_max"], 0.0);
    assert_eq!(r["stats_min_max_equal"], true);
    assert_eq!(r["episode_stats_ok"], true);
    assert_eq!(r["polars_equals_pandas"], true);
}

/// Runs the divergence guard stopped are left out: the episodes are renumbered and `tumble/run`
/// names each one's run. (No spec here diverges on purpose: the runs table's `status` of run 1 is
/// rewritten with pyarrow, then the folder converted.)
#[test]
fn diverged_runs_are_left_out() {
    let tmp = tempfile::tempdir().unwrap();
    let spec = arm_spec(tmp.path(), "arm.toml", 5, SIM, GRAVITY);
    let out = tumble(&["dataset", &spec, "--out", "d", "-q"], tmp.path());
    assert!(out.status.success(), "{}", text(&out.stderr));
    let runs = tmp.path().join("d/runs/part-00000.parquet");
    let py = std::process::Command::new(common::python())
        .args([
            "-c",
            "import sys, pyarrow as pa, pyarrow.parquet as pq\n\
             t = pq.read_table(sys.argv[1])\n\
             s = t.column('status').to_pylist()\n\
             s[1] = 'diverged'\n\
             i = t.schema.get_field_index('status')\n\
             pq.write_table(t.set_column(i, t.schema.field(i), pa.array(s, pa.string())), sys.argv[1], compression='zstd')\n",
        ])
        .arg(&runs)
        .output()
        .unwrap();
    assert!(py.status.success(), "{}", text(&py.stderr));
    let out = tumble(&["convert", "d", "--lerobot", "d"], tmp.path());
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(
        text(&out.stdout).contains(
            "4 episodes, 84 frames at 100 fps, 1 data file(s) (1 diverged runs left out)"
        ),
        "{}",
        text(&out.stdout)
    );
    let r = run_py("read_lerobot.py", &[&tmp.path().join("d")]);
    assert_eq!(r["runs"], serde_json::json!([0, 2, 3, 4]));
    assert_eq!(r["info"]["total_episodes"], 4);
    assert_eq!(r["info"]["splits"]["train"], "0:4");
    assert_eq!(r["state_err_max"], 0.0);
    assert_eq!(r["index_contiguous"], true);
    assert_eq!(r["episode_ranges_ok"], true);
}

/// Rerun's own LeRobot importer (rerun-sdk 0.36.3, `rr.log_file_from_path`, what `rerun DIR`
/// runs) opens the folder: one recording per episode on the `frame_index` timeline, the series
/// named by the features' names, `observation.state` equal to the data file's.
#[test]
fn rerun_opens_the_lerobot_folder() {
    let tmp = tempfile::tempdir().unwrap();
    let spec = arm_spec(tmp.path(), "arm.toml", 3, SIM, GRAVITY);
    let out = tumble(
        &["dataset", &spec, "--out", "d", "-q", "--format", "lerobot"],
        tmp.path(),
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    let rrd = tmp.path().join("d.rrd");
    let r = run_py("read_lerobot_rerun.py", &[&tmp.path().join("d"), &rrd]);
    assert_eq!(r["timelines"], serde_json::json!(["frame_index"]));
    let episodes = r["episodes"].as_object().unwrap();
    assert_eq!(
        episodes.keys().collect::<Vec<_>>(),
        ["episode_0", "episode_1", "episode_2"]
    );
    for (id, e) in episodes {
        for entity in ["/observation.state", "/observation.effort", "/action"] {
            assert_eq!(e["rows"][entity], 21, "{id} {entity}");
        }
        assert_eq!(
            e["names"]["/observation.state"],
            serde_json::json!([
                "arm/shoulder.pos",
                "arm/elbow.pos",
                "arm/shoulder.vel",
                "arm/elbow.vel"
            ]),
            "{id}"
        );
    }
    assert_eq!(r["state_err_max"], 0.0);
}
