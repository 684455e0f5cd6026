//! The features of a tumble LeRobot dataset and its small metadata files: `meta/info.json`,
//! `meta/stats.json`, `meta/tasks.parquet`.
//!
//! Features (`info.json` `features`, each `{"dtype", "shape", "names"}`), n joints in the
//! model's layout order, m of them actuated:
//!
//! | key | dtype, shape | names / meaning |
//! |---|---|---|
//! | `observation.state` | float32 [2n] | `<joint>.pos` ×n then `<joint>.vel` ×n (rad, m; rad/s, m/s) |
//! | `observation.effort` | float32 [n] | `<joint>.effort`: the effort applied (N m, N) |
//! | `observation.base_pose` | float32 [7] | floating base only: the root link frame's pose, world: `<link>.x/.y/.z` (m), `<link>.qx/.qy/.qz/.qw` (unit quaternion, scalar last) |
//! | `observation.base_velocity` | float32 [6] | floating base only: the root link frame origin's velocity `<link>.vx/.vy/.vz` (m/s) and its angular velocity `<link>.wx/.wy/.wz` (rad/s), world |
//! | `action` | float32 [m] | `<joint>.target` (position / velocity servo) or `<joint>.effort` (motor); with no actuated joint, every joint's applied effort |
//! | `timestamp` | float32 [1] | `frame_index / fps`, s |
//! | `frame_index`, `episode_index`, `index`, `task_index` | int64 [1] | LeRobot's `DEFAULT_FEATURES` |
//!
//! Joint names are the joints table's (`<model name>/<URDF joint name>`).
//! `info.json` keys follow `create_empty_dataset_info` and `save_episode`
//! (<https://github.com/huggingface/lerobot/blob/main/src/lerobot/datasets/feature_utils.py>,
//! `dataset_metadata.py`): `video_path` is null (no video), `splits` is `{"train": "0:N"}`.

use super::source::Joint;
use super::stats::Stats;
use arrow_array::{ArrayRef, Int64Array, RecordBatch, StringArray};
use arrow_schema::{DataType, Field, Schema};
use serde::Serialize;
use serde::ser::{SerializeMap, Serializer};
use std::collections::HashMap;
use std::sync::Arc;

/// `codebase_version` of the format written.
pub const CODEBASE_VERSION: &str = "v3.0";
/// LeRobot's defaults (`lerobot.datasets.utils`).
pub const CHUNKS_SIZE: u64 = 1000;
pub const DATA_FILES_SIZE_IN_MB: u64 = 100;
pub const VIDEO_FILES_SIZE_IN_MB: u64 = 200;
pub const DATA_PATH: &str = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet";

/// One feature.
#[derive(Debug, Clone, PartialEq)]
pub struct Feature {
    pub key: &'static str,
    pub dtype: &'static str,
    pub dim: usize,
    pub names: Option<Vec<String>>,
}

/// Where each action component comes from: a joint's target, or its applied effort.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Action {
    Target(usize),
    Effort(usize),
}

/// The action components of `joints` (module doc).
pub fn actions(joints: &[Joint]) -> Vec<Action> {
    let actuated: Vec<Action> = joints
        .iter()
        .enumerate()
        .filter(|(_, j)| j.actuated())
        .map(|(i, j)| match j.drive.as_deref() {
            Some("motor") => Action::Effort(i),
            _ => Action::Target(i),
        })
        .collect();
    if actuated.is_empty() {
        (0..joints.len()).map(Action::Effort).collect()
    } else {
        actuated
    }
}

/// The features, in the order of `info.json` and of the data files' columns; `base_link`: a
/// floating base's root link (its pose and velocity features).
pub fn features(joints: &[Joint], base_link: Option<&str>) -> Vec<Feature> {
    let named = |suffix: &str| -> Vec<String> {
        joints
            .iter()
            .map(|j| format!("{}.{suffix}", j.name))
            .collect()
    };
    let mut state = named("pos");
    state.extend(named("vel"));
    let action = actions(joints)
        .iter()
        .map(|a| match a {
            Action::Target(i) => format!("{}.target", joints[*i].name),
            Action::Effort(i) => format!("{}.effort", joints[*i].name),
        })
        .collect::<Vec<_>>();
    let scalar = |key, dtype| Feature {
        key,
        dtype,
        dim: 1,
        names: None,
    };
    let mut features = vec![
        Feature {
            key: "observation.state",
            dtype: "float32",
            dim: 2 * joints.len(),
            names: Some(state),
        },
        Feature {
            key: "observation.effort",
            dtype: "float32",
            dim: joints.len(),
            names: Some(named("effort")),
        },
    ];
    if let Some(link) = base_link {
        let names = |s: &[&str]| Some(s.iter().map(|c| format!("{link}.{c}")).collect());
        features.push(Feature {
            key: "observation.base_pose",
            dtype: "float32",
            dim: 7,
            names: names(&["x", "y", "z", "qx", "qy", "qz", "qw"]),
        });
        features.push(Feature {
            key: "observation.base_velocity",
            dtype: "float32",
            dim: 6,
            names: names(&["vx", "vy", "vz", "wx", "wy", "wz"]),
        });
    }
    features.extend([
        Feature {
            key: "action",
            dtype: "float32",
            dim: action.len(),
            names: Some(action),
        },
        scalar("timestamp", "float32"),
        scalar("frame_index", "int64"),
        scalar("episode_index", "int64"),
        scalar("index", "int64"),
        scalar("task_index", "int64"),
    ]);
    features
}

/// `features` as a JSON object in order.
struct Features<'a>(&'a [Feature]);

impl Serialize for Features<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        #[derive(Serialize)]
        struct One<'a> {
            dtype: &'a str,
            shape: [usize; 1],
            names: &'a Option<Vec<String>>,
        }
        let mut map = s.serialize_map(Some(self.0.len()))?;
        for f in self.0 {
            map.serialize_entry(
                f.key,
                &One {
                    dtype: f.dtype,
                    shape: [f.dim],
                    names: &f.names,
                },
            )?;
        }
        map.end()
    }
}

/// `meta/info.json`.
pub fn info_json(
    robot_type: &str,
    episodes: u64,
    frames: u64,
    fps: u32,
    features: &[Feature],
) -> anyhow::Result<String> {
    #[derive(Serialize)]
    struct Splits {
        train: String,
    }
    #[derive(Serialize)]
    struct Info<'a> {
        codebase_version: &'a str,
        robot_type: &'a str,
        total_episodes: u64,
        total_frames: u64,
        total_tasks: u64,
        chunks_size: u64,
        data_files_size_in_mb: u64,
        video_files_size_in_mb: u64,
        fps: u32,
        splits: Splits,
        data_path: &'a str,
        video_path: Option<&'a str>,
        features: Features<'a>,
    }
    let mut text = serde_json::to_string_pretty(&Info {
        codebase_version: CODEBASE_VERSION,
        robot_type,
        total_episodes: episodes,
        total_frames: frames,
        total_tasks: 1,
        chunks_size: CHUNKS_SIZE,
        data_files_size_in_mb: DATA_FILES_SIZE_IN_MB,
        video_files_size_in_mb: VIDEO_FILES_SIZE_IN_MB,
        fps,
        splits: Splits {
            train: format!("0:{episodes}"),
        },
        data_path: DATA_PATH,
        video_path: None,
        features: Features(features),
    })?;
    text.push('\n');
    Ok(text)
}

/// `meta/stats.json`: for each feature, `min`, `max`, `mean`, `std`, `count`, `q01`..`q99`,
/// each a list.
pub fn stats_json(features: &[Feature], stats: &[Stats]) -> anyhow::Result<String> {
    struct One<'a>(&'a Stats);
    impl Serialize for One<'_> {
        fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
            let named = self.0.named();
            let mut map = s.serialize_map(Some(named.len() + 1))?;
            for (name, values) in &named[..4] {
                map.serialize_entry(name, values)?;
            }
            map.serialize_entry("count", &[self.0.count])?;
            for (name, values) in &named[4..] {
                map.serialize_entry(name, values)?;
            }
            map.end()
        }
    }
    struct All<'a>(&'a [Feature], &'a [Stats]);
    impl Serialize for All<'_> {
        fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
            let mut map = s.serialize_map(Some(self.0.len()))?;
            for (f, st) in self.0.iter().zip(self.1) {
                map.serialize_entry(f.key, &One(st))?;
            }
            map.end()
        }
    }
    let mut text = serde_json::to_string_pretty(&All(features, stats))?;
    text.push('\n');
    Ok(text)
}

/// The pandas metadata that makes `pd.read_parquet` give the index `task` (LeRobot's
/// `load_tasks` looks tasks up by that index).
const PANDAS_TASKS: &str = r#"{"index_columns": ["task"], "column_indexes": [{"name": null, "field_name": null, "pandas_type": "unicode", "numpy_type": "object", "metadata": {"encoding": "UTF-8"}}], "columns": [{"name": "task_index", "field_name": "task_index", "pandas_type": "int64", "numpy_type": "int64", "metadata": null}, {"name": "task", "field_name": "task", "pandas_type": "unicode", "numpy_type": "object", "metadata": null}], "creator": {"library": "pyarrow", "version": "19.0.0"}, "pandas_version": "2.2.3"}"#;

/// `meta/tasks.parquet`: columns `task_index` (int64) and `task` (string, the pandas index).
pub fn tasks_batch(task: &str) -> anyhow::Result<RecordBatch> {
    let schema = Schema::new(vec![
        Field::new("task_index", DataType::Int64, false),
        Field::new("task", DataType::Utf8, false),
    ])
    .with_metadata(HashMap::from([(
        "pandas".to_string(),
        PANDAS_TASKS.to_string(),
    )]));
    Ok(RecordBatch::try_new(
        Arc::new(schema),
        vec![
            Arc::new(Int64Array::from(vec![0i64])) as ArrayRef,
            Arc::new(StringArray::from(vec![task])),
        ],
    )?)
}
