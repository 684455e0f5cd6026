//! The native tables read back as episodes: the runs table (`runs/part-*.parquet`: `dt`,
//! `log_every`, `status`, `model` of each run) and the joints table (`joints/part-*.parquet`,
//! one row per recorded step and joint, joints in the model's layout order), streamed one part
//! file at a time; for a floating base, the root body's rows of the trajectories part file of
//! the same name and its `link_from_body` in `bodies.parquet`.
//!
//! Checks, each refused with one message naming the spec and the key to change: every run has
//! the same joints with the same drives (else `vary.model` draws models LeRobot cannot hold in
//! one dataset); the dataset has joints at all (LeRobot holds robots); `1 / (dt · log_every)`
//! is one integer for every run (`vary.dt`, `sim.dt`, `sim.log_every`).

use super::Options;
use crate::dataset::manifest::Manifest;
use anyhow::{Context, bail};
use arrow_array::cast::AsArray;
use arrow_array::types::{Float64Type, Int64Type};
use arrow_array::{Array, RecordBatch};
use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion, Vector3};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

/// One run of the runs table.
#[derive(Debug, Clone, PartialEq)]
pub struct RunInfo {
    pub dt: f64,
    pub log_every: i64,
    pub diverged: bool,
    pub model: String,
}

/// A joint of the robot: its recorded name and drive (`position`, `velocity`, `motor`,
/// `damping`, or none).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Joint {
    pub name: String,
    pub drive: Option<String>,
}

impl Joint {
    /// Whether the joint takes an action: a position or velocity servo (its target) or a motor
    /// (its effort). Damping alone is passive.
    pub fn actuated(&self) -> bool {
        matches!(
            self.drive.as_deref(),
            Some("position" | "velocity" | "motor")
        )
    }
}

/// One run's frames: `n` joints' values per frame, frame-major.
#[derive(Debug, Clone, Default)]
pub struct Episode {
    pub run: i64,
    pub frames: usize,
    pub position: Vec<f64>,
    pub velocity: Vec<f64>,
    pub effort: Vec<f64>,
    /// NaN where the joints table has null.
    pub target: Vec<f64>,
    /// Floating base only: per frame the root link frame's pose (x y z, qx qy qz qw) and the
    /// velocity of its origin (vx vy vz, wx wy wz), world ([`BASE_VALUES`] values).
    pub base: Vec<f64>,
}

/// Values per frame in [`Episode::base`].
pub const BASE_VALUES: usize = 13;

/// A floating base: the root link, whose trajectory rows give the base features.
#[derive(Debug, Clone)]
pub struct Base {
    /// The root link's name (`bodies.parquet` `link`) of the first run's model: the features'
    /// names.
    pub link: String,
    /// For each model (URDF path as in the runs table): its root body's name in the
    /// trajectories table and its `link_from_body`.
    pub roots: BTreeMap<String, (String, Isometry3<f64>)>,
}

/// The native dataset, checked.
#[derive(Debug, Clone)]
pub struct Source {
    pub dir: PathBuf,
    pub joints: Vec<Joint>,
    pub fps: u32,
    pub runs: BTreeMap<i64, RunInfo>,
    /// The joints-table part files, in order.
    pub parts: Vec<PathBuf>,
    pub robot_type: String,
    pub task: String,
    pub spec_name: String,
    /// `Some` for a floating-base model: `observation.base_pose` and `observation.base_velocity`.
    pub base: Option<Base>,
}

fn part_files(dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("cannot read {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("part-") && n.ends_with(".parquet"))
        })
        .collect();
    files.sort();
    Ok(files)
}

/// The record batches of a Parquet file.
pub fn read_batches(path: &Path) -> anyhow::Result<Vec<RecordBatch>> {
    let file =
        std::fs::File::open(path).with_context(|| format!("cannot open {}", path.display()))?;
    let reader = ParquetRecordBatchReaderBuilder::try_new(file)
        .and_then(|b| b.with_batch_size(64 * 1024).build())
        .with_context(|| format!("{}: not a Parquet file", path.display()))?;
    reader
        .collect::<Result<Vec<_>, _>>()
        .with_context(|| format!("{}: cannot read", path.display()))
}

fn column<'a>(batch: &'a RecordBatch, path: &Path, name: &str) -> anyhow::Result<&'a dyn Array> {
    batch
        .column_by_name(name)
        .map(|c| c.as_ref())
        .with_context(|| format!("{}: no column `{name}`", path.display()))
}

fn i64s<'a>(
    batch: &'a RecordBatch,
    path: &Path,
    name: &str,
) -> anyhow::Result<&'a arrow_array::Int64Array> {
    column(batch, path, name)?
        .as_primitive_opt::<Int64Type>()
        .with_context(|| format!("{}: column `{name}` is not int64", path.display()))
}

fn f64s<'a>(
    batch: &'a RecordBatch,
    path: &Path,
    name: &str,
) -> anyhow::Result<&'a arrow_array::Float64Array> {
    column(batch, path, name)?
        .as_primitive_opt::<Float64Type>()
        .with_context(|| format!("{}: column `{name}` is not float64", path.display()))
}

fn strings<'a>(
    batch: &'a RecordBatch,
    path: &Path,
    name: &str,
) -> anyhow::Result<&'a arrow_array::StringArray> {
    column(batch, path, name)?
        .as_string_opt::<i32>()
        .with_context(|| format!("{}: column `{name}` is not a string", path.display()))
}

/// The runs table, by run.
fn read_runs(dir: &Path) -> anyhow::Result<BTreeMap<i64, RunInfo>> {
    let mut runs = BTreeMap::new();
    for path in part_files(&dir.join("runs"))? {
        for batch in read_batches(&path)? {
            let (run, dt, log_every) = (
                i64s(&batch, &path, "run")?,
                f64s(&batch, &path, "dt")?,
                i64s(&batch, &path, "log_every")?,
            );
            let (status, model) = (
                strings(&batch, &path, "status")?,
                strings(&batch, &path, "model")?,
            );
            for i in 0..batch.num_rows() {
                runs.insert(
                    run.value(i),
                    RunInfo {
                        dt: dt.value(i),
                        log_every: log_every.value(i).max(1),
                        diverged: status.value(i) == "diverged",
                        model: model.value(i).to_string(),
                    },
                );
            }
        }
    }
    Ok(runs)
}

/// The `<robot name="...">` of a URDF, if it can be read.
fn urdf_robot_name(path: &Path) -> Option<String> {
    let text = std::fs::read_to_string(path).ok()?;
    let doc = roxmltree::Document::parse(&text).ok()?;
    let root = doc.root_element();
    (root.tag_name().name() == "robot")
        .then(|| root.attribute("name").map(str::to_string))
        .flatten()
        .filter(|n| !n.is_empty())
}

impl Source {
    /// Reads the manifest and runs table, finds the joints and checks the frame rate.
    pub fn open(opts: &Options) -> anyhow::Result<Self> {
        let dir = opts.native.clone();
        let spec = &opts.spec_name;
        let manifest = Manifest::load(&dir)?.with_context(|| {
            format!(
                "{}: no manifest.json; not a tumble dataset folder",
                dir.display()
            )
        })?;
        if manifest.shard.is_some() {
            bail!(
                "{}: a shard ({}) holds only part of the runs; join the shards with `tumble \
                 dataset merge` and convert the merged folder",
                dir.display(),
                manifest.shard.map(|s| s.to_string()).unwrap_or_default()
            );
        }
        if !manifest.complete {
            bail!(
                "{}: the dataset is incomplete ({} of {} runs); finish it with `tumble dataset \
                 ... --resume` first",
                dir.display(),
                manifest.runs_done(),
                manifest.runs
            );
        }
        let runs = read_runs(&dir)?;
        let parts = part_files(&dir.join("joints"))?;
        let joints = first_joints(&parts)?;
        if joints.is_empty() {
            bail!(
                "{spec}: the dataset has no joints (free rigid bodies); LeRobot datasets hold \
                 robots: observation.state and action are joint positions and commands. Use a \
                 model with joints (bodies = \"articulated\"), or the native Parquet tables"
            );
        }
        let kept: Vec<&RunInfo> = runs.values().filter(|r| !r.diverged).collect();
        let Some(first) = kept.first() else {
            bail!("{spec}: every run diverged; no episode to write");
        };
        let period = first.dt * first.log_every as f64;
        if let Some(r) = kept.iter().find(|r| r.dt != first.dt) {
            bail!(
                "{spec}: vary.dt draws different time steps ({} s and {} s); a LeRobot dataset \
                 has one fps for every episode: remove vary.dt",
                first.dt,
                r.dt
            );
        }
        let fps = 1.0 / period;
        let rounded = fps.round();
        if !(rounded >= 1.0 && (fps - rounded).abs() <= 1e-6 * fps) {
            bail!(
                "{spec}: the frame rate 1 / (sim.dt · sim.log_every) = 1 / ({} s · {}) = {fps} \
                 Hz is not a whole number; LeRobot's fps is an integer: choose sim.dt and \
                 sim.log_every so that dt · log_every divides one second",
                first.dt,
                first.log_every
            );
        }
        let model = &first.model;
        let base = opts.base_dir.clone().unwrap_or_default();
        let robot_type = urdf_robot_name(&base.join(model))
            .or_else(|| urdf_robot_name(Path::new(model)))
            .unwrap_or_else(|| {
                Path::new(model)
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_else(|| "robot".to_string())
            });
        let task = format!(
            "tumble: {robot_type}, {} randomized runs (spec sha256 {})",
            manifest.runs,
            &manifest.spec_sha256[..manifest.spec_sha256.len().min(12)]
        );
        let base = if floating_base(&manifest.spec) {
            Some(read_base(&dir, &first.model)?)
        } else {
            None
        };
        Ok(Self {
            base,
            dir,
            joints,
            fps: rounded as u32,
            runs,
            parts,
            robot_type,
            task,
            spec_name: spec.clone(),
        })
    }

    /// The episodes of joints-table part file `path`, in run order (diverged runs left out),
    /// each with the frames on the regular grid.
    pub fn episodes(&self, path: &Path) -> anyhow::Result<Vec<Episode>> {
        let n = self.joints.len();
        let mut out: Vec<Episode> = Vec::new();
        // The run being read, its step and how many of its joints that step has given.
        let mut current: Option<(i64, i64, usize)> = None;
        let mut skip_run: Option<i64> = None;
        let spec = &self.spec_name;
        let base_rows = match &self.base {
            Some(base) => self.base_rows(base, path)?,
            None => HashMap::new(),
        };
        for batch in read_batches(path)? {
            let run = i64s(&batch, path, "run")?;
            let step = i64s(&batch, path, "step")?;
            let joint = strings(&batch, path, "joint")?;
            let drive = strings(&batch, path, "drive")?;
            let position = f64s(&batch, path, "position")?;
            let velocity = f64s(&batch, path, "velocity")?;
            let effort = f64s(&batch, path, "effort")?;
            let target = f64s(&batch, path, "target")?;
            for i in 0..batch.num_rows() {
                let (r, s) = (run.value(i), step.value(i));
                if skip_run == Some(r) {
                    continue;
                }
                let Some(info) = self.runs.get(&r) else {
                    bail!(
                        "{}: run {r} is not in the runs table ({}/runs/)",
                        path.display(),
                        self.dir.display()
                    );
                };
                if info.diverged {
                    skip_run = Some(r);
                    continue;
                }
                let k = match current {
                    Some((cr, cs, k)) if cr == r && cs == s => k,
                    Some((cr, cs, k)) if cr == r && s > cs && k == n => 0,
                    Some((cr, _, k)) if cr != r && k == n => {
                        if out.last().is_some_and(|e| e.run > r) {
                            bail!("{}: run {r} is out of order", path.display());
                        }
                        0
                    }
                    None => 0,
                    Some((cr, cs, k)) => bail!(
                        "{}: run {cr} step {cs} has {k} joint rows, other steps {n}; {spec}: \
                         every run must have the same joints (does vary.model draw models \
                         with different joints?)",
                        path.display()
                    ),
                };
                let expected = &self.joints[k.min(n - 1)];
                let drive_i = (!drive.is_null(i)).then(|| drive.value(i));
                if k >= n || joint.value(i) != expected.name || drive_i != expected.drive.as_deref()
                {
                    bail!(
                        "{spec}: run {r} has joint {:?} (drive {:?}) where run {} has {:?} \
                         (drive {:?}); a LeRobot dataset needs the same joints in every \
                         episode: vary.model must draw models with the same joints, and every \
                         run must drive them alike (the same actuator kinds)",
                        joint.value(i),
                        drive_i.unwrap_or("none"),
                        out.first().map_or(r, |e| e.run),
                        expected.name,
                        expected.drive.as_deref().unwrap_or("none")
                    );
                }
                if k == 0 && current.is_none_or(|(cr, _, _)| cr != r) {
                    out.push(Episode {
                        run: r,
                        ..Default::default()
                    });
                }
                current = Some((r, s, k + 1));
                if s % info.log_every != 0 {
                    continue; // the off-grid last row
                }
                let ep = out.last_mut().expect("pushed above");
                if k == 0 {
                    ep.frames += 1;
                    if self.base.is_some() {
                        let Some(values) = base_rows.get(&(r, s)) else {
                            bail!(
                                "{}: run {r} step {s} has joint rows but no row of its root body \
                                 in the trajectories table",
                                path.display()
                            );
                        };
                        ep.base.extend_from_slice(values);
                    }
                }
                ep.position.push(position.value(i));
                ep.velocity.push(velocity.value(i));
                ep.effort.push(effort.value(i));
                ep.target.push(if target.is_null(i) {
                    f64::NAN
                } else {
                    target.value(i)
                });
            }
        }
        if let Some((r, s, k)) = current
            && k != n
        {
            bail!(
                "{}: run {r} step {s} has {k} joint rows, other steps {n}",
                path.display()
            );
        }
        Ok(out)
    }
}

impl Source {
    /// The root body's rows of the trajectories part file beside joints part `joints_part`, on
    /// the grid, as base values ([`Episode::base`]) by (run, step).
    fn base_rows(
        &self,
        base: &Base,
        joints_part: &Path,
    ) -> anyhow::Result<HashMap<(i64, i64), [f64; BASE_VALUES]>> {
        let name = joints_part.file_name().unwrap_or_default();
        let path = self.dir.join("trajectories").join(name);
        let mut out = HashMap::new();
        for batch in read_batches(&path)? {
            let run = i64s(&batch, &path, "run")?;
            let step = i64s(&batch, &path, "step")?;
            let body = strings(&batch, &path, "body")?;
            let col = |n: &str| f64s(&batch, &path, n);
            let p = [col("position_x")?, col("position_y")?, col("position_z")?];
            let q = [
                col("orientation_x")?,
                col("orientation_y")?,
                col("orientation_z")?,
                col("orientation_w")?,
            ];
            let v = [
                col("linear_velocity_x")?,
                col("linear_velocity_y")?,
                col("linear_velocity_z")?,
            ];
            let w = [
                col("angular_velocity_x")?,
                col("angular_velocity_y")?,
                col("angular_velocity_z")?,
            ];
            for i in 0..batch.num_rows() {
                let r = run.value(i);
                let Some(info) = self.runs.get(&r) else {
                    continue;
                };
                let Some((root, link_from_body)) = base.roots.get(&info.model) else {
                    continue;
                };
                if body.value(i) != root || step.value(i) % info.log_every != 0 {
                    continue;
                }
                let get = |c: &[&arrow_array::Float64Array]| -> Vec<f64> {
                    c.iter().map(|a| a.value(i)).collect()
                };
                let (p, q, v, w) = (get(&p), get(&q), get(&v), get(&w));
                let world_from_body = Isometry3::from_parts(
                    Translation3::new(p[0], p[1], p[2]),
                    UnitQuaternion::from_quaternion(Quaternion::new(q[3], q[0], q[1], q[2])),
                );
                let link = world_from_body * link_from_body.inverse();
                let omega = Vector3::new(w[0], w[1], w[2]);
                // Velocity of the link origin: v_com + ω × (p_link − p_com).
                let v_link = Vector3::new(v[0], v[1], v[2])
                    + omega.cross(&(link.translation.vector - world_from_body.translation.vector));
                let t = link.translation.vector;
                let lq = link.rotation.quaternion();
                out.insert(
                    (r, step.value(i)),
                    [
                        t.x, t.y, t.z, lq.i, lq.j, lq.k, lq.w, v_link.x, v_link.y, v_link.z,
                        omega.x, omega.y, omega.z,
                    ],
                );
            }
        }
        Ok(out)
    }
}

/// Whether the spec's model is articulated on a floating base (`base` defaults to floating).
fn floating_base(spec: &str) -> bool {
    let Ok(value) = spec.parse::<toml::Table>() else {
        return false;
    };
    let model = value
        .get("scene")
        .and_then(|s| s.get("model"))
        .and_then(|m| m.as_array())
        .and_then(|m| m.first());
    model.is_some_and(|m| {
        m.get("bodies").and_then(|b| b.as_str()) == Some("articulated")
            && m.get("base").and_then(|b| b.as_str()) != Some("fixed")
    })
}

/// Each model's root body (`body_index` 0 in `bodies.parquet`) and the first run's model's
/// root link name.
fn read_base(dir: &Path, first_model: &str) -> anyhow::Result<Base> {
    let path = dir.join("bodies.parquet");
    let mut roots = BTreeMap::new();
    let mut link = None;
    for batch in read_batches(&path)? {
        let model = strings(&batch, &path, "model")?;
        let body = strings(&batch, &path, "body")?;
        let links = strings(&batch, &path, "link")?;
        let index = i64s(&batch, &path, "body_index")?;
        let col = |n: &str| f64s(&batch, &path, n);
        let t = [
            col("link_from_body_position_x")?,
            col("link_from_body_position_y")?,
            col("link_from_body_position_z")?,
        ];
        let q = [
            col("link_from_body_orientation_x")?,
            col("link_from_body_orientation_y")?,
            col("link_from_body_orientation_z")?,
            col("link_from_body_orientation_w")?,
        ];
        for i in 0..batch.num_rows() {
            if index.value(i) != 0 {
                continue;
            }
            let iso = Isometry3::from_parts(
                Translation3::new(t[0].value(i), t[1].value(i), t[2].value(i)),
                UnitQuaternion::from_quaternion(Quaternion::new(
                    q[3].value(i),
                    q[0].value(i),
                    q[1].value(i),
                    q[2].value(i),
                )),
            );
            if model.value(i) == first_model {
                link = Some(links.value(i).to_string());
            }
            roots.insert(model.value(i).to_string(), (body.value(i).to_string(), iso));
        }
    }
    let link = link.with_context(|| {
        format!(
            "{}: no body of model {first_model} (the first run's)",
            path.display()
        )
    })?;
    Ok(Base { link, roots })
}

/// The joints of the first run in the joints table (its first step's rows).
fn first_joints(parts: &[PathBuf]) -> anyhow::Result<Vec<Joint>> {
    for path in parts {
        for batch in read_batches(path)? {
            if batch.num_rows() == 0 {
                continue;
            }
            let run = i64s(&batch, path, "run")?;
            let step = i64s(&batch, path, "step")?;
            let joint = strings(&batch, path, "joint")?;
            let drive = strings(&batch, path, "drive")?;
            let (r0, s0) = (run.value(0), step.value(0));
            let mut joints = Vec::new();
            for i in 0..batch.num_rows() {
                if run.value(i) != r0 || step.value(i) != s0 {
                    break;
                }
                joints.push(Joint {
                    name: joint.value(i).to_string(),
                    drive: (!drive.is_null(i)).then(|| drive.value(i).to_string()),
                });
            }
            return Ok(joints);
        }
    }
    Ok(Vec::new())
}
