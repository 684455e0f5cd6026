//! The dataset spec (TOML): a scene template, what varies per run, and how many runs.
//!
//! ```toml
//! [dataset]
//! runs = 10000            # number of runs, >= 1
//! seed = 42               # master seed, integer >= 0; run i draws from a stream seeded by (seed, i) alone
//! runs_per_file = 100     # runs per Parquet part file (the unit of parallelism, sharding and resume) (default 100)
//! record = ["mcap"]       # optional per-run recordings: "mcap", "rrd", "ros2" (default none)
//! record_runs = 10        # how many runs, from run 0 on, get them (default 10 when `record` is set)
//!
//! [scene.sim]             # the scene template: the keys of a scene file, under [scene]
//! duration = 1.0
//! [[scene.model]]         # exactly one model; its paths are relative to the spec file
//! urdf = "box.urdf"
//!
//! [vary]                  # each key optional; anything not varied is the template's
//! model = { choice = ["box.urdf", "t_handle.urdf"] }        # URDF paths, relative to the spec
//! dt = { log_uniform = [1e-4, 1e-2] }                       # s, lower bound > 0
//! duration = { uniform = [0.5, 1.0] }                       # s, lower bound >= 0
//! integrator = { choice = ["variational", "rk4"] }
//! gravity = { normal = { mean = [0, 0, -9.81], std = [0, 0, 0.5] } }   # m/s², world
//! position = { uniform = [[-1, -1, 0], [1, 1, 1]] }         # m, world position of the root link frame
//! orientation = "uniform"                                   # uniformly random rotation (Shoemake)
//! rpy = { uniform = [[0, 0, 0], [0, 0, 6.283]] }            # or: roll, pitch, yaw (rad), R = Rz Ry Rx
//! linvel = { uniform = [[-1, -1, 0], [1, 1, 3]] }           # m/s, world, every body's centre of mass
//! angvel = { normal = { mean = [0, 0, 0], std = [5, 5, 5] } }   # rad/s, world, every body
//! joints = { uniform = [-0.5, 0.5] }                        # articulated: every moving joint (or per joint)
//! joint_velocities = { shoulder = { uniform = [-1, 1] } }   # rad/s or m/s
//! actuators = { smooth = { amplitude = 0.5, cutoff_hz = 1 } }   # the template's actuators' signals
//! ```
//!
//! The joint keys are [`super::joint_vary`]'s.
//!
//! Distributions: [`super::distribution`]. Unknown keys and bad values are errors naming the
//! spec file and the key.

use super::joint_vary::JointVary;
use crate::record::Format;
use crate::scene::Scene;
use crate::scene::placement::Orientation;
use crate::scene::placement::distribution::{Dist, parse_string_choice};
use crate::sim::IntegratorKind;
use anyhow::{Context, bail};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// The per-run recordings `dataset.record` can name, besides the Parquet rows: the
/// [`Format`]s with one file per run (`run-NNNNNN.ros2.mcap` for a ROS 2 recording,
/// [`crate::record::ros2`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
enum RecordName {
    Mcap,
    Rrd,
    Ros2,
}

impl RecordName {
    fn format(self) -> Format {
        match self {
            RecordName::Mcap => Format::Mcap,
            RecordName::Rrd => Format::Rrd,
            RecordName::Ros2 => Format::Ros2,
        }
    }
}

/// Default of `dataset.runs_per_file`.
pub const DEFAULT_RUNS_PER_FILE: u64 = 100;
/// Default of `dataset.record_runs` when `record` is set.
pub const DEFAULT_RECORD_RUNS: u64 = 10;

/// The `[dataset]` table.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
struct DatasetTable {
    runs: i64,
    seed: i64,
    #[serde(default)]
    runs_per_file: Option<i64>,
    #[serde(default)]
    record: Vec<RecordName>,
    #[serde(default)]
    record_runs: Option<i64>,
}

/// The `[vary]` table.
#[derive(Debug, Clone, PartialEq)]
pub struct Vary {
    /// URDF paths as written (relative to the spec file).
    pub model: Option<Vec<String>>,
    pub dt: Option<Dist>,
    pub duration: Option<Dist>,
    pub integrator: Option<Vec<String>>,
    pub gravity: Option<Dist>,
    pub position: Option<Dist>,
    pub orientation: Orientation,
    pub linvel: Option<Dist>,
    pub angvel: Option<Dist>,
    /// `joints`, `joint_velocities`, `actuators` ([`super::joint_vary`]).
    pub joints: JointVary,
}

/// The keys `[vary]` accepts.
pub const VARY_KEYS: &[&str] = &[
    "model",
    "dt",
    "duration",
    "integrator",
    "gravity",
    "position",
    "orientation",
    "rpy",
    "linvel",
    "angvel",
    "joints",
    "joint_velocities",
    "actuators",
];

/// A parsed, validated dataset spec.
#[derive(Debug, Clone)]
pub struct DatasetSpec {
    /// The spec file.
    pub path: PathBuf,
    /// Its text as given: written into the manifest and compared on resume and merge.
    pub text: String,
    pub runs: u64,
    pub seed: u64,
    pub runs_per_file: u64,
    pub record: Vec<Format>,
    pub record_runs: u64,
    /// The `[scene]` template, validated (relative paths anchored at the spec file). Its one
    /// `[[model]]` names the first `vary.model` choice when the template gives no `urdf`.
    pub template: Scene,
    pub vary: Vary,
    /// [`DatasetSpec::model_choices`].
    models: Vec<String>,
}

impl DatasetSpec {
    /// Reads and validates a spec file.
    pub fn load(path: &Path) -> anyhow::Result<Self> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read dataset spec {}", path.display()))?;
        Self::parse(&text, path)
    }

    /// Parses spec text; `path` names the file in errors and anchors relative paths.
    pub fn parse(text: &str, path: &Path) -> anyhow::Result<Self> {
        let file = path.display();
        let mut root: toml::Table = toml::from_str(text)
            .map_err(|e| anyhow::anyhow!("{file}: {}", e.to_string().trim_end()))?;
        if let Some(other) = root
            .keys()
            .find(|k| !["dataset", "scene", "vary"].contains(&k.as_str()))
        {
            bail!("{file}: unknown table {other:?} (expected [dataset], [scene], [vary])");
        }
        let dataset: DatasetTable = root
            .remove("dataset")
            .with_context(|| format!("{file}: missing [dataset] table (runs, seed)"))?
            .try_into()
            .map_err(|e: toml::de::Error| {
                anyhow::anyhow!("{file}: [dataset]: {}", e.to_string().trim_end())
            })?;
        let vary_table = match root.remove("vary") {
            None => toml::Table::new(),
            Some(toml::Value::Table(t)) => t,
            Some(_) => bail!("{file}: vary must be a table"),
        };
        let vary = parse_vary(&format!("{file}: vary"), &vary_table)?;
        let mut scene_table = match root.remove("scene") {
            Some(toml::Value::Table(t)) => t,
            Some(_) => bail!("{file}: scene must be a table"),
            None => bail!("{file}: missing [scene] template (at least one [[scene.model]])"),
        };
        let models = scene_table
            .get_mut("model")
            .and_then(|m| m.as_array_mut())
            .filter(|m| m.len() == 1)
            .with_context(|| {
                format!("{file}: the [scene] template must have exactly one [[scene.model]]")
            })?;
        if let (Some(table), Some(choices)) = (models[0].as_table_mut(), &vary.model) {
            table
                .entry("urdf")
                .or_insert_with(|| toml::Value::String(choices[0].clone()));
        }
        let scene_text = toml::to_string(&scene_table)
            .with_context(|| format!("{file}: cannot re-encode [scene]"))?;
        let mut template = Scene::parse(&scene_text, path).with_context(|| {
            format!("{file}: in the [scene] template (keys are relative to [scene])")
        })?;
        template.text = text.to_string();
        let entry = &template.models[0];
        if entry.copies.is_some() || entry.seed.is_some() || !entry.draws.is_empty() {
            bail!(
                "{file}: [[scene.model]]: copies, seed and distributions do not belong in a dataset \
                 template (a run is one model): put distributions in [vary], the seed in [dataset]"
            );
        }

        let positive = |key: &str, v: i64| -> anyhow::Result<u64> {
            if v < 1 {
                bail!("{file}: dataset.{key} must be at least 1 (got {v})");
            }
            Ok(v as u64)
        };
        let runs = positive("runs", dataset.runs)?;
        if dataset.seed < 0 {
            bail!("{file}: dataset.seed must be >= 0 (got {})", dataset.seed);
        }
        let runs_per_file = positive(
            "runs_per_file",
            dataset
                .runs_per_file
                .unwrap_or(DEFAULT_RUNS_PER_FILE as i64),
        )?;
        let record_runs = match dataset.record_runs {
            Some(n) if n < 0 => bail!("{file}: dataset.record_runs must be >= 0 (got {n})"),
            Some(n) => (n as u64).min(runs),
            None if dataset.record.is_empty() => 0,
            None => DEFAULT_RECORD_RUNS.min(runs),
        };
        if record_runs > 0 && dataset.record.is_empty() {
            bail!(
                "{file}: dataset.record_runs is set but dataset.record names no format (\"mcap\", \"rrd\")"
            );
        }
        let mut record: Vec<Format> = dataset.record.iter().map(|r| r.format()).collect();
        record.dedup();
        let models = match &vary.model {
            Some(choices) => choices.clone(),
            None => vec![template.models[0].urdf.display().to_string()],
        };
        Ok(Self {
            models,
            path: path.to_path_buf(),
            text: text.to_string(),
            runs,
            seed: dataset.seed as u64,
            runs_per_file,
            record,
            record_runs,
            template,
            vary,
        })
    }

    /// Number of chunks (part files): `ceil(runs / runs_per_file)`.
    pub fn chunks(&self) -> u64 {
        self.runs.div_ceil(self.runs_per_file)
    }

    /// The runs of chunk `chunk`: `[chunk · runs_per_file, min(runs, (chunk + 1) · runs_per_file))`.
    pub fn chunk_runs(&self, chunk: u64) -> std::ops::Range<u64> {
        let start = chunk * self.runs_per_file;
        start..(start + self.runs_per_file).min(self.runs)
    }

    /// The URDF paths a run may use, as written (the template's when `model` is not varied).
    pub fn model_choices(&self) -> &[String] {
        &self.models
    }
}

fn parse_vary(prefix: &str, table: &toml::Table) -> anyhow::Result<Vary> {
    if let Some(other) = table.keys().find(|k| !VARY_KEYS.contains(&k.as_str())) {
        bail!(
            "{prefix}.{other}: unknown key (expected one of: {})",
            VARY_KEYS.join(", ")
        );
    }
    let dist = |name: &str, dims: usize| -> anyhow::Result<Option<Dist>> {
        table
            .get(name)
            .map(|v| Dist::parse(&format!("{prefix}.{name}"), v, dims))
            .transpose()
    };
    let strings = |name: &str| -> anyhow::Result<Option<Vec<String>>> {
        table
            .get(name)
            .map(|v| parse_string_choice(&format!("{prefix}.{name}"), v))
            .transpose()
    };
    let dt = dist("dt", 1)?;
    if let Some(d) = &dt
        && d.lower_bound()[0] <= 0.0
    {
        bail!(
            "{prefix}.dt: every step size drawn must be positive: use log_uniform, or uniform/choice \
             with positive values (a normal can draw any value)"
        );
    }
    let duration = dist("duration", 1)?;
    if let Some(d) = &duration
        && d.lower_bound()[0] < 0.0
    {
        bail!(
            "{prefix}.duration: every duration drawn must be >= 0: use uniform, log_uniform or \
             choice with non-negative values"
        );
    }
    let integrator = strings("integrator")?;
    for (i, name) in integrator.iter().flatten().enumerate() {
        if IntegratorKind::from_name(name).is_none() {
            let known: Vec<_> = IntegratorKind::ALL.iter().map(|k| k.name()).collect();
            bail!(
                "{prefix}.integrator.choice[{i}]: unknown integrator {name:?} (expected one of: {})",
                known.join(", ")
            );
        }
    }
    let orientation =
        Orientation::parse(prefix, table.get("orientation"), table.get("rpy"), false)?;
    Ok(Vary {
        model: strings("model")?,
        dt,
        duration,
        integrator,
        gravity: dist("gravity", 3)?,
        position: dist("position", 3)?,
        orientation,
        linvel: dist("linvel", 3)?,
        angvel: dist("angvel", 3)?,
        joints: JointVary::parse(prefix, table)?,
    })
}
