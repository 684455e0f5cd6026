//! `tumble convert`: a tumble MCAP recording replayed into a Rerun `.rrd`.
//!
//! The layout stored in the MCAP ([`crate::record::layout_json`]) and every recorded step go
//! through the same [`RerunSink`] a fresh run uses, so the converted recording has the same
//! entities, timelines, recording id and values as the `.rrd` that `tumble simulate` wrote beside
//! the MCAP (poses and energies are stored as f64 in MCAP, so nothing is lost on the way).
//! A truncated MCAP gives every complete step of every complete chunk and a warning saying what
//! was lost ([`truncation_warning`]).

use super::steps::StepReader;
use super::stream::StreamEnd;
use crate::record::rerun::{RerunOptions, RerunSink};
use crate::record::{Frame, Sink, finish_all};
use std::path::Path;

/// What a conversion did.
#[derive(Debug, Clone, PartialEq)]
pub struct ConvertReport {
    pub steps: u64,
    /// Simulation time of the first and last converted step, ns.
    pub time_range_ns: (i64, i64),
    /// Steps dropped because their messages were cut apart.
    pub incomplete_steps: u64,
    /// `Some(warning)` when the MCAP was truncated or damaged.
    pub truncation: Option<String>,
    /// Meshes the Rerun sink skipped, one line each.
    pub sink_warnings: Vec<String>,
}

/// Recorded steps the metadata promises: steps `0, L, 2L, ..` and always the last one.
pub fn expected_recorded_steps(
    metadata: &std::collections::BTreeMap<String, String>,
) -> Option<u64> {
    let steps: u64 = metadata.get("steps")?.parse().ok()?;
    let every: u64 = metadata.get("log_every")?.parse().ok()?;
    if every == 0 {
        return None;
    }
    Some(steps / every + 1 + u64::from(!steps.is_multiple_of(every)))
}

/// The warning for a stream that did not end cleanly (`None` when it did).
pub fn truncation_warning(
    path: &Path,
    end: &StreamEnd,
    recovered_steps: u64,
    time_range_ns: Option<(i64, i64)>,
    expected_steps: Option<u64>,
) -> Option<String> {
    let StreamEnd::Truncated {
        bytes_read,
        data_complete,
        error,
    } = end
    else {
        return None;
    };
    let size = std::fs::metadata(path).map(|m| m.len()).ok();
    let place = match size {
        Some(size) => format!("reading stopped at byte {bytes_read} of {size}"),
        None => format!("reading stopped at byte {bytes_read}"),
    };
    if *data_complete {
        return Some(format!(
            "{} is damaged after its data ({place}: {error}); all {recovered_steps} recorded steps \
             were read, only the summary/index is lost",
            path.display()
        ));
    }
    let span = match time_range_ns {
        Some((a, b)) => format!(" (t = {} .. {} s)", a as f64 / 1e9, b as f64 / 1e9),
        None => String::new(),
    };
    let lost = match expected_steps {
        Some(expected) if expected >= recovered_steps => format!(
            "; its metadata promises {expected} recorded steps, so {} were lost",
            expected - recovered_steps
        ),
        _ => String::new(),
    };
    Some(format!(
        "{} is truncated or damaged ({place}: {error}): recovered {recovered_steps} complete steps{span} \
         from its complete chunks; everything after the last complete chunk is lost{lost}",
        path.display()
    ))
}

/// Converts `mcap` into `rrd` (written as `<rrd>.part`, renamed when complete).
pub fn convert(mcap: &Path, rrd: &Path, options: &RerunOptions) -> anyhow::Result<ConvertReport> {
    convert_with(mcap, rrd, |_| *options)
}

/// [`convert`] with the options chosen from the recording's layout (`tumble convert`: the
/// inertia ellipsoids off by default when a model has meshes, as `simulate` does).
pub fn convert_with(
    mcap: &Path,
    rrd: &Path,
    options: impl FnOnce(&crate::record::RecordingLayout) -> RerunOptions,
) -> anyhow::Result<ConvertReport> {
    let mut reader = StepReader::open(mcap)?;
    let layout = reader.layout().clone();
    let expected = super::convert::expected_recorded_steps(&layout.metadata);
    let options = options(&layout);
    let sink = RerunSink::create(rrd, &layout, &options)?;
    let sink_warnings = sink.warnings().to_vec();
    let mut sinks: Vec<Box<dyn Sink>> = vec![Box::new(sink)];
    let result = (|| -> anyhow::Result<()> {
        while let Some(step) = reader.next_step()? {
            let frame = Frame {
                step: step.step,
                time_ns: step.time_ns,
                world_from_link: &step.world_from_link,
                bodies: &step.bodies,
                joints: &step.joints,
                mechanisms: &step.mechanisms,
                contacts: &step.contacts,
            };
            for sink in sinks.iter_mut() {
                sink.write(&frame)?;
            }
        }
        if reader.steps_read() == 0 {
            anyhow::bail!(
                "{}: no complete recorded step could be read{}",
                mcap.display(),
                match reader.end() {
                    StreamEnd::Truncated { error, .. } => format!(" ({error})"),
                    _ => String::new(),
                }
            );
        }
        Ok(())
    })();
    finish_all(sinks, result, &[rrd])?;
    let truncation = truncation_warning(
        mcap,
        reader.end(),
        reader.steps_read(),
        reader.time_range_ns(),
        expected,
    );
    Ok(ConvertReport {
        steps: reader.steps_read(),
        time_range_ns: reader.time_range_ns().unwrap_or_default(),
        incomplete_steps: reader.incomplete_steps(),
        truncation,
        sink_warnings,
    })
}
