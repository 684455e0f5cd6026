//! The `.rrd` file writer: a [`LogSink`] that renumbers the ids (TUIDs) with a counter, then
//! encodes ([`RrdFileSink`], for what the recording stream sends), and [`ChunkWriter`], which
//! writes the sink's chunks the same way on the calling thread.

use super::footer::FooterWriter;
use anyhow::{Context, Result, anyhow, bail};
use rerun::external::re_log_encoding::Encoder;
use rerun::external::re_log_types::StoreId;
use rerun::log::{Chunk, ChunkComponents, ChunkId, LogMsg, RowId};
use rerun::sink::{LogSink, SinkFlushError};
use rerun::{EntityPath, SerializedComponentColumn, TimeColumn};
use std::path::Path;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

/// Where the encoded stream goes; shared between the [`super::RerunSink`] and the [`RrdFileSink`] that
/// the recording stream's forwarding thread owns.
pub(super) struct FileState {
    pub(super) encoder: Option<Encoder<FooterWriter>>,
    /// Last TUID handed out (counter part; the time part is 0).
    pub(super) last_id: u64,
    /// First error met by the forwarding thread (it cannot return errors).
    pub(super) error: Option<String>,
}

impl FileState {
    fn next_id(&mut self) -> u128 {
        self.last_id += 1;
        u128::from(self.last_id)
    }

    pub(super) fn write(&mut self, msg: LogMsg) -> Result<()> {
        let msg = match msg {
            LogMsg::SetStoreInfo(mut info) => {
                info.row_id = *RowId::from_u128(self.next_id());
                LogMsg::SetStoreInfo(info)
            }
            LogMsg::ArrowMsg(store_id, arrow_msg) => {
                let chunk = Chunk::from_arrow_msg(&arrow_msg)?;
                let (timelines, components) =
                    (chunk.timelines().clone(), chunk.components().clone());
                return self.write_chunk(
                    &store_id,
                    chunk.entity_path().clone(),
                    timelines,
                    components,
                );
            }
            other => other,
        };
        self.append(&msg)
    }

    /// Writes a chunk of these columns, its ids renumbered (chunk id first, then one row id
    /// per row, from the counter). A chunk without components is dropped, as Rerun's batcher
    /// drops it.
    fn write_chunk(
        &mut self,
        store_id: &StoreId,
        entity: EntityPath,
        timelines: rerun::external::nohash_hasher::IntMap<rerun::time::TimelineName, TimeColumn>,
        components: ChunkComponents,
    ) -> Result<()> {
        if components.0.is_empty() {
            return Ok(());
        }
        let rows = components
            .list_arrays()
            .next()
            .map_or(0, arrow_array::Array::len);
        let chunk_id = ChunkId::from_u128(self.next_id());
        let row_ids: Vec<RowId> = (0..rows)
            .map(|_| RowId::from_u128(self.next_id()))
            .collect();
        let chunk =
            Chunk::from_native_row_ids(chunk_id, entity, None, &row_ids, timelines, components)?;
        self.append(&LogMsg::ArrowMsg(store_id.clone(), chunk.to_arrow_msg()?))
    }

    fn append(&mut self, msg: &LogMsg) -> Result<()> {
        let encoder = self
            .encoder
            .as_mut()
            .ok_or_else(|| anyhow!("message after the recording was closed"))?;
        encoder.append(msg)?;
        Ok(())
    }
}

/// Writes chunks into the file on the calling thread ([`FileState::write_chunk`]): after the
/// recording stream has written its store info and properties, every chunk goes this way,
/// not through the stream's batcher and forwarding thread, which turned each chunk into an
/// Arrow message that [`RrdFileSink`] had to turn back into a chunk to renumber its ids (the
/// same bytes; two threads and an Arrow round trip per chunk less).
pub(super) struct ChunkWriter<'a> {
    pub(super) state: &'a Mutex<FileState>,
    pub(super) store_id: &'a StoreId,
    pub(super) path: &'a Path,
}

impl ChunkWriter<'_> {
    /// A chunk of `columns` on `entity` at the times of `indexes` (what
    /// `RecordingStream::send_columns` sends).
    pub(super) fn send_columns(
        &self,
        entity: EntityPath,
        indexes: impl IntoIterator<Item = TimeColumn>,
        columns: impl IntoIterator<Item = SerializedComponentColumn>,
    ) -> Result<()> {
        let timelines = indexes
            .into_iter()
            .map(|column| (*column.timeline().name(), column))
            .collect();
        let components: ChunkComponents = columns
            .into_iter()
            .map(|column| (column.descriptor, column.list_array))
            .collect();
        self.write(entity, timelines, components)
    }

    pub(super) fn send(&self, chunk: Chunk) -> Result<()> {
        let (timelines, components) = (chunk.timelines().clone(), chunk.components().clone());
        self.write(chunk.entity_path().clone(), timelines, components)
    }

    fn write(
        &self,
        entity: EntityPath,
        timelines: rerun::external::nohash_hasher::IntMap<rerun::time::TimelineName, TimeColumn>,
        components: ChunkComponents,
    ) -> Result<()> {
        let mut state = lock(self.state);
        if let Some(err) = &state.error {
            bail!("writing {}: {err}", self.path.display());
        }
        state
            .write_chunk(self.store_id, entity, timelines, components)
            .with_context(|| format!("writing {}", self.path.display()))
    }
}

pub(super) fn lock(state: &Mutex<FileState>) -> MutexGuard<'_, FileState> {
    state
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// [`LogSink`] writing a reproducible `.rrd` (see the module doc).
pub(super) struct RrdFileSink {
    pub(super) state: Arc<Mutex<FileState>>,
}

impl LogSink for RrdFileSink {
    fn send(&self, msg: LogMsg) {
        let mut state = lock(&self.state);
        if state.error.is_none()
            && let Err(err) = state.write(msg)
        {
            state.error = Some(format!("{err:#}"));
        }
    }

    fn flush_blocking(&self, _timeout: Duration) -> Result<(), SinkFlushError> {
        let mut state = lock(&self.state);
        if let Some(err) = &state.error {
            return Err(SinkFlushError::failed(err.clone()));
        }
        if let Some(encoder) = state.encoder.as_mut() {
            encoder
                .flush_blocking()
                .map_err(|err| SinkFlushError::failed(err.to_string()))?;
        }
        Ok(())
    }

    fn defers_finalization_to_shutdown(&self) -> bool {
        true
    }
}
