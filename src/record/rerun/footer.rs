//! Reproducible `.rrd` footers.
//!
//! Rerun 0.36 ends a file with an RRD footer: a manifest of every chunk (offsets, time ranges per
//! column) and the "sorbet" schema of all columns, which `rerun rrd verify` requires. The
//! encoder builds that schema from a `std::collections::HashMap`, so its column order — and with
//! it the file's last few kilobytes — changes from process to process although nothing else
//! does. [`FooterWriter`] is the file writer under the encoder: while the encoder writes its
//! footer, the bytes are held back ([`FooterHold::hold`]); [`FooterWriter::finish`]
//! decodes them, sorts the per-store manifests (also a `HashMap`) by store, sorts the schema's columns by name (the order Rerun itself uses for the schema's
//! SHA-256, so the hash is unchanged), and writes the footer again with fresh length, offsets
//! and checksum. Same inputs, same bytes.

use crate::record::writeback::WritebackFile;
use anyhow::{Context, Result, anyhow};
use re_protos::external::prost::Message as _;
use rerun::external::arrow::datatypes::Schema as ArrowSchema;
use rerun::external::re_log_encoding::{
    Decodable as _, Encodable as _, MessageHeader, MessageKind, StreamFooter,
};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// The encoder's writer; see the module doc.
pub struct FooterWriter {
    inner: BufWriter<WritebackFile>,
    /// Bytes written to `inner` so far.
    written: u64,
    /// Set by [`FooterHold::hold`].
    hold: Arc<AtomicBool>,
    /// The bytes held back.
    held: Vec<u8>,
}

/// The switch that makes a [`FooterWriter`] hold bytes back (the encoder owns the writer).
#[derive(Clone)]
pub struct FooterHold(Arc<AtomicBool>);

impl FooterHold {
    /// From now on, hold the bytes back (call right before the encoder writes its footer).
    pub fn hold(&self) {
        self.0.store(true, Ordering::SeqCst);
    }
}

impl FooterWriter {
    pub fn new(file: File) -> (Self, FooterHold) {
        let hold = Arc::new(AtomicBool::new(false));
        let writer = Self {
            inner: BufWriter::new(WritebackFile::new(file)),
            written: 0,
            hold: hold.clone(),
            held: Vec::new(),
        };
        (writer, FooterHold(hold))
    }

    /// Writes the held footer in canonical form, flushes, and returns the file.
    pub fn finish(mut self) -> Result<File> {
        if !self.held.is_empty() {
            let footer = canonical_footer(&self.held, self.written)?;
            self.inner.write_all(&footer)?;
        }
        self.inner.flush()?;
        self.inner
            .into_inner()
            .map_err(|e| anyhow!("cannot flush the .rrd file: {}", e.error()))?
            .finish()
            .map_err(|e| anyhow!("cannot sync the .rrd file: {e}"))
    }
}

impl Write for FooterWriter {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if self.hold.load(Ordering::SeqCst) {
            self.held.extend_from_slice(buf);
            Ok(buf.len())
        } else {
            let n = self.inner.write(buf)?;
            self.written += n as u64;
            Ok(n)
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

/// `held` = end-of-stream message header + RRD footer payload + stream footer, as the encoder
/// wrote them starting at byte `offset` of the file. Returns the same with the footer's schema
/// columns sorted by name.
fn canonical_footer(held: &[u8], offset: u64) -> Result<Vec<u8>> {
    let stream_footer =
        StreamFooter::from_rrd_bytes(held).context("the .rrd stream footer is malformed")?;
    let entry = stream_footer
        .entries
        .first()
        .context("the .rrd stream footer has no entry")?;
    let span = entry.rrd_footer_byte_span_from_start_excluding_header;
    let start = usize::try_from(span.start.checked_sub(offset).context("footer offset")?)?;
    let end = start + usize::try_from(span.len)?;
    let payload = held
        .get(start..end)
        .context("the .rrd footer span is outside the footer bytes")?;
    let mut footer = re_protos::log_msg::v1alpha1::RrdFooter::decode(payload)
        .context("the .rrd footer does not decode")?;
    // One manifest per store (the recording, and its blueprint when there is one), taken from a
    // HashMap by the encoder: sort them by store kind and id too.
    footer.manifests.sort_by_key(|m| {
        m.store_id
            .as_ref()
            .map(|id| (id.kind, id.recording_id.clone()))
    });
    for manifest in &mut footer.manifests {
        if let Some(schema) = &manifest.sorbet_schema {
            let arrow = ArrowSchema::try_from(schema)?;
            let mut fields: Vec<_> = arrow.fields().iter().cloned().collect();
            fields.sort_by(|a, b| a.name().cmp(b.name()));
            let sorted = ArrowSchema::new_with_metadata(fields, arrow.metadata().clone());
            manifest.sorbet_schema = Some((&sorted).try_into()?);
        }
    }
    let mut payload = Vec::new();
    footer.to_rrd_bytes(&mut payload)?;
    let mut out = Vec::with_capacity(payload.len() + 64);
    MessageHeader {
        kind: MessageKind::End,
        len: payload.len() as u64,
    }
    .to_rrd_bytes(&mut out)?;
    let payload_offset = offset + out.len() as u64;
    out.extend_from_slice(&payload);
    StreamFooter::from_rrd_footer_bytes(payload_offset, &payload).to_rrd_bytes(&mut out)?;
    Ok(out)
}
