//! `meta/episodes/chunk-000/file-000.parquet`: one row per episode, the columns LeRobot's
//! `save_episode` writes
//! (<https://github.com/huggingface/lerobot/blob/main/src/lerobot/datasets/dataset_metadata.py>):
//!
//! | column | type | meaning |
//! |---|---|---|
//! | `episode_index` | int64 | 0.. in run order |
//! | `tasks` | list\<string\> | the one task |
//! | `length` | int64 | frames |
//! | `data/chunk_index`, `data/file_index` | int64 | the data file holding the episode |
//! | `dataset_from_index`, `dataset_to_index` | int64 | its global `index` range `[from, to)` |
//! | `stats/<feature>/<stat>` | list\<double\> (`count`: list\<int64\>) | the episode's statistics ([`super::stats`]) |
//! | `meta/episodes/chunk_index`, `meta/episodes/file_index` | int64 | this file (0, 0) |
//! | `tumble/run` | int64 | the tumble run (the native tables' `run`); not a LeRobot column, ignored by its readers |

use super::info::Feature;
use super::stats::Stats;
use arrow_array::builder::{Float64Builder, Int64Builder, ListBuilder, StringBuilder};
use arrow_array::{ArrayRef, Int64Array, RecordBatch};
use arrow_schema::{DataType, Field, Schema};
use std::sync::Arc;

/// The path of the episodes file.
pub const PATH: &str = "meta/episodes/chunk-000/file-000.parquet";

/// One episode's row.
#[derive(Debug, Clone)]
pub struct EpisodeRow {
    pub episode_index: i64,
    pub run: i64,
    pub length: i64,
    pub chunk: i64,
    pub file: i64,
    pub from: i64,
    pub to: i64,
    /// One per feature.
    pub stats: Vec<Stats>,
}

/// A list column of `rows` lists of `dim` values each, `values` row-major.
fn f64_lists(values: &[f64], dim: usize) -> ArrayRef {
    let mut b = ListBuilder::new(Float64Builder::new());
    for row in values.chunks(dim.max(1)) {
        b.values().append_slice(row);
        b.append(true);
    }
    Arc::new(b.finish())
}

/// The episodes table.
pub fn batch(rows: &[EpisodeRow], features: &[Feature], task: &str) -> anyhow::Result<RecordBatch> {
    let mut fields = Vec::new();
    let mut columns: Vec<ArrayRef> = Vec::new();
    let int = |name: &str,
               f: &dyn Fn(&EpisodeRow) -> i64,
               fields: &mut Vec<Field>,
               columns: &mut Vec<ArrayRef>| {
        fields.push(Field::new(name, DataType::Int64, false));
        columns.push(Arc::new(Int64Array::from_iter_values(rows.iter().map(f))));
    };
    int(
        "episode_index",
        &|r| r.episode_index,
        &mut fields,
        &mut columns,
    );
    fields.push(list_field("tasks", DataType::Utf8));
    let mut tasks = ListBuilder::new(StringBuilder::new());
    for _ in rows {
        tasks.values().append_value(task);
        tasks.append(true);
    }
    columns.push(Arc::new(tasks.finish()));
    int("length", &|r| r.length, &mut fields, &mut columns);
    int("data/chunk_index", &|r| r.chunk, &mut fields, &mut columns);
    int("data/file_index", &|r| r.file, &mut fields, &mut columns);
    int("dataset_from_index", &|r| r.from, &mut fields, &mut columns);
    int("dataset_to_index", &|r| r.to, &mut fields, &mut columns);
    for (k, feature) in features.iter().enumerate() {
        let names = rows.first().map(|r| r.stats[k].named()).unwrap_or_default();
        let stat_names: Vec<&str> = names.iter().map(|(n, _)| *n).collect();
        for (s, name) in stat_names.iter().enumerate() {
            if s == 4 {
                count_column(rows, k, feature, &mut fields, &mut columns)?;
            }
            let values: Vec<f64> = rows
                .iter()
                .flat_map(|r| r.stats[k].named()[s].1.to_vec())
                .collect();
            fields.push(list_field(
                &format!("stats/{}/{name}", feature.key),
                DataType::Float64,
            ));
            columns.push(f64_lists(&values, feature.dim));
        }
    }
    int(
        "meta/episodes/chunk_index",
        &|_| 0,
        &mut fields,
        &mut columns,
    );
    int(
        "meta/episodes/file_index",
        &|_| 0,
        &mut fields,
        &mut columns,
    );
    int("tumble/run", &|r| r.run, &mut fields, &mut columns);
    Ok(RecordBatch::try_new(
        Arc::new(Schema::new(fields)),
        columns,
    )?)
}

fn list_field(name: &str, item: DataType) -> Field {
    Field::new(
        name,
        DataType::List(Arc::new(Field::new("item", item, true))),
        false,
    )
}

fn count_column(
    rows: &[EpisodeRow],
    k: usize,
    feature: &Feature,
    fields: &mut Vec<Field>,
    columns: &mut Vec<ArrayRef>,
) -> anyhow::Result<()> {
    fields.push(list_field(
        &format!("stats/{}/count", feature.key),
        DataType::Int64,
    ));
    let mut b = ListBuilder::new(Int64Builder::new());
    for r in rows {
        b.values().append_value(r.stats[k].count as i64);
        b.append(true);
    }
    columns.push(Arc::new(b.finish()));
    Ok(())
}
