//! Static chunks: one row at no time, holding archetypes or component batches (the layout, the
//! series names).

use anyhow::Result;
use rerun::log::{Chunk, RowId};
use rerun::{AsComponents, EntityPath, SerializedComponentBatch, TimePoint};

/// A static chunk with one row holding all the given archetypes.
pub fn static_chunk(entity: EntityPath, archetypes: &[&dyn AsComponents]) -> Result<Chunk> {
    let batches: Vec<SerializedComponentBatch> = archetypes
        .iter()
        .flat_map(|a| a.as_serialized_batches())
        .collect();
    static_batches_chunk(entity, batches)
}

/// A static chunk with one row holding the given component batches.
pub fn static_batches_chunk(
    entity: EntityPath,
    batches: Vec<SerializedComponentBatch>,
) -> Result<Chunk> {
    Ok(Chunk::builder(entity)
        .with_serialized_batches(RowId::new(), TimePoint::default(), batches)
        .build()?)
}
