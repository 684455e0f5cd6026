//! `data/chunk-CCC/file-FFF.parquet`: one row per frame, the columns of [`super::info`]'s
//! features: vectors as `fixed_size_list<item: float>[n]` (what the `datasets` library makes of
//! `Sequence(length=n, feature=Value("float32"))`, the type LeRobot's loader casts to), scalars
//! as float32 / int64. Episodes are never split across files; a file takes episodes until it
//! would pass `data_files_size_in_mb` (100 MB, uncompressed), then the next file index starts
//! (a new chunk folder after `chunks_size` = 1000 files), as LeRobot's writer does.
//! Parquet compression: zstd level 1 (the dataset's other tables' writer settings,
//! [`crate::record::parquet::files::writer_properties`]).

use super::Summary;
use super::episodes::{self, EpisodeRow};
use super::info::{self, Action, Feature};
use super::source::{BASE_VALUES, Episode, Source};
use super::stats::{Aggregate, episode_stats};
use crate::record::parquet::files::writer_properties;
use anyhow::{Context, bail};
use arrow_array::{ArrayRef, FixedSizeListArray, Float32Array, Int64Array, RecordBatch};
use arrow_schema::{DataType, Field, Schema, SchemaRef};
use parquet::arrow::ArrowWriter;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The Arrow schema of the data files.
pub fn schema(features: &[Feature]) -> SchemaRef {
    let fields: Vec<Field> = features
        .iter()
        .map(|f| {
            let scalar = if f.dtype == "float32" {
                DataType::Float32
            } else {
                DataType::Int64
            };
            if f.names.is_some() {
                Field::new(
                    f.key,
                    DataType::FixedSizeList(
                        Arc::new(Field::new("item", scalar, true)),
                        f.dim as i32,
                    ),
                    false,
                )
            } else {
                Field::new(f.key, scalar, false)
            }
        })
        .collect();
    Arc::new(Schema::new(fields))
}

/// One episode's columns, in feature order, as float64 for the statistics.
struct Columns {
    values: Vec<Vec<f64>>,
}

fn columns(
    ep: &Episode,
    features: &[Feature],
    n: usize,
    actions: &[Action],
    fps: u32,
    episode_index: i64,
    first_index: i64,
) -> Columns {
    let frames = ep.frames;
    // Every value goes through f32, so the statistics are those of the stored numbers.
    let f = |x: f64| x as f32 as f64;
    let mut state = Vec::with_capacity(frames * 2 * n);
    let mut effort = Vec::with_capacity(frames * n);
    let mut action = Vec::with_capacity(frames * actions.len());
    for t in 0..frames {
        let row = t * n..(t + 1) * n;
        state.extend(ep.position[row.clone()].iter().map(|&x| f(x)));
        state.extend(ep.velocity[row.clone()].iter().map(|&x| f(x)));
        effort.extend(ep.effort[row].iter().map(|&x| f(x)));
        for a in actions {
            action.push(match *a {
                Action::Target(j) => f(ep.target[t * n + j]),
                Action::Effort(j) => f(ep.effort[t * n + j]),
            });
        }
    }
    let timestamp: Vec<f64> = (0..frames)
        .map(|t| (t as f64 / fps as f64) as f32 as f64)
        .collect();
    let ints = |g: &dyn Fn(usize) -> i64| (0..frames).map(|t| g(t) as f64).collect::<Vec<_>>();
    let base = |range: std::ops::Range<usize>| -> Vec<f64> {
        (0..frames)
            .flat_map(|t| ep.base[t * BASE_VALUES..(t + 1) * BASE_VALUES][range.clone()].to_vec())
            .map(f)
            .collect()
    };
    let values = features
        .iter()
        .map(|feature| match feature.key {
            "observation.state" => state.clone(),
            "observation.effort" => effort.clone(),
            "observation.base_pose" => base(0..7),
            "observation.base_velocity" => base(7..13),
            "action" => action.clone(),
            "timestamp" => timestamp.clone(),
            "frame_index" => ints(&|t| t as i64),
            "episode_index" => ints(&|_| episode_index),
            "index" => ints(&|t| first_index + t as i64),
            _ => ints(&|_| 0), // task_index
        })
        .collect();
    Columns { values }
}

fn batch(schema: &SchemaRef, features: &[Feature], cols: &Columns) -> anyhow::Result<RecordBatch> {
    let arrays: Vec<ArrayRef> = features
        .iter()
        .zip(&cols.values)
        .map(|(f, v)| -> anyhow::Result<ArrayRef> {
            Ok(if f.names.is_some() {
                let values = Float32Array::from_iter_values(v.iter().map(|&x| x as f32));
                Arc::new(FixedSizeListArray::try_new(
                    Arc::new(Field::new("item", DataType::Float32, true)),
                    f.dim as i32,
                    Arc::new(values),
                    None,
                )?)
            } else if f.dtype == "float32" {
                Arc::new(Float32Array::from_iter_values(v.iter().map(|&x| x as f32)))
            } else {
                Arc::new(Int64Array::from_iter_values(v.iter().map(|&x| x as i64)))
            })
        })
        .collect::<anyhow::Result<_>>()?;
    Ok(RecordBatch::try_new(schema.clone(), arrays)?)
}

/// The data file being written.
struct DataFile {
    writer: ArrowWriter<BufWriter<File>>,
    chunk: i64,
    file: i64,
    bytes: usize,
}

fn data_path(dir: &Path, chunk: i64, file: i64) -> PathBuf {
    dir.join(format!("data/chunk-{chunk:03}/file-{file:03}.parquet"))
}

fn open_data(dir: &Path, schema: &SchemaRef, chunk: i64, file: i64) -> anyhow::Result<DataFile> {
    let path = data_path(dir, chunk, file);
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent)
            .with_context(|| format!("cannot create {}", parent.display()))?;
    }
    let out = File::create(&path).with_context(|| format!("cannot create {}", path.display()))?;
    let writer = ArrowWriter::try_new(
        BufWriter::new(out),
        schema.clone(),
        Some(writer_properties(true)?),
    )?;
    Ok(DataFile {
        writer,
        chunk,
        file,
        bytes: 0,
    })
}

fn close_data(data: DataFile, dir: &Path) -> anyhow::Result<()> {
    let path = data_path(dir, data.chunk, data.file);
    data.writer
        .close()
        .with_context(|| format!("cannot write {}", path.display()))?;
    Ok(())
}

/// Writes the whole LeRobot dataset of `src` into `dir` (the staging folder).
pub fn write_all(src: &Source, dir: &Path) -> anyhow::Result<Summary> {
    let features = info::features(&src.joints, src.base.as_ref().map(|b| b.link.as_str()));
    let actions = info::actions(&src.joints);
    let schema = schema(&features);
    let n = src.joints.len();
    let limit = info::DATA_FILES_SIZE_IN_MB as usize * 1024 * 1024;
    let frame_bytes = features.iter().map(|f| f.dim * 8).sum::<usize>();
    let mut data: Option<DataFile> = None;
    let mut rows: Vec<EpisodeRow> = Vec::new();
    let mut totals: Vec<Aggregate> = vec![Aggregate::default(); features.len()];
    let mut index = 0i64;
    let mut data_files = 0u64;
    for part in &src.parts {
        for ep in src.episodes(part)? {
            let episode_index = rows.len() as i64;
            let cols = columns(&ep, &features, n, &actions, src.fps, episode_index, index);
            let bytes = ep.frames * frame_bytes;
            let next = match &data {
                None => Some((0, 0)),
                Some(d) if d.bytes > 0 && d.bytes + bytes > limit => {
                    Some(if d.file + 1 == info::CHUNKS_SIZE as i64 {
                        (d.chunk + 1, 0)
                    } else {
                        (d.chunk, d.file + 1)
                    })
                }
                Some(_) => None,
            };
            if let Some((chunk, file)) = next {
                if let Some(d) = data.take() {
                    close_data(d, dir)?;
                }
                data = Some(open_data(dir, &schema, chunk, file)?);
                data_files += 1;
            }
            let d = data.as_mut().expect("opened above");
            d.writer.write(&batch(&schema, &features, &cols)?)?;
            d.bytes += bytes;
            let stats: Vec<_> = features
                .iter()
                .zip(&cols.values)
                .map(|(f, v)| episode_stats(v, f.dim, ep.frames))
                .collect();
            for (t, s) in totals.iter_mut().zip(&stats) {
                t.add(s);
            }
            rows.push(EpisodeRow {
                episode_index,
                run: ep.run,
                length: ep.frames as i64,
                chunk: d.chunk,
                file: d.file,
                from: index,
                to: index + ep.frames as i64,
                stats,
            });
            index += ep.frames as i64;
        }
    }
    if let Some(d) = data.take() {
        close_data(d, dir)?;
    }
    let kept = src.runs.values().filter(|r| !r.diverged).count();
    if rows.len() != kept {
        let with: std::collections::HashSet<i64> = rows.iter().map(|r| r.run).collect();
        let missing = src
            .runs
            .iter()
            .find(|(r, i)| !i.diverged && !with.contains(r))
            .map(|(r, i)| format!("run {r} (model {})", i.model))
            .unwrap_or_default();
        bail!(
            "{}: {missing} has no joints in the joints table while other runs do; a LeRobot \
             dataset needs the same joints in every episode: vary.model must draw models with \
             the same joints",
            src.spec_name
        );
    }
    let meta = dir.join("meta");
    std::fs::create_dir_all(meta.join("episodes/chunk-000"))
        .with_context(|| format!("cannot create {}", meta.display()))?;
    let stats: Vec<_> = totals.iter().map(Aggregate::finish).collect();
    let episodes = rows.len() as u64;
    std::fs::write(
        meta.join("info.json"),
        info::info_json(&src.robot_type, episodes, index as u64, src.fps, &features)?,
    )?;
    std::fs::write(
        meta.join("stats.json"),
        info::stats_json(&features, &stats)?,
    )?;
    write_parquet(&meta.join("tasks.parquet"), &info::tasks_batch(&src.task)?)?;
    write_parquet(
        &dir.join(episodes::PATH),
        &episodes::batch(&rows, &features, &src.task)?,
    )?;
    Ok(Summary {
        episodes,
        frames: index as u64,
        diverged_left_out: src.runs.values().filter(|r| r.diverged).count() as u64,
        fps: src.fps,
        data_files,
    })
}

fn write_parquet(path: &Path, batch: &RecordBatch) -> anyhow::Result<()> {
    let out = File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
    let mut writer = ArrowWriter::try_new(
        BufWriter::new(out),
        batch.schema(),
        Some(writer_properties(false)?),
    )?;
    writer.write(batch)?;
    writer
        .close()
        .with_context(|| format!("cannot write {}", path.display()))?;
    Ok(())
}
