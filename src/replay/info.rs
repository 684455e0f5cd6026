//! `tumble info`: what an MCAP recording holds, read in one streaming pass.

use super::stream::{Item, McapStream, StreamEnd};
use crate::record::layout_json::{LAYOUT_KEY, from_json};
use crate::record::names::{BODIES_TOPIC, METADATA_NAME, TF_TOPIC};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// One channel's messages.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct TopicInfo {
    pub topic: String,
    pub schema: String,
    pub messages: u64,
    /// First and last log time, s.
    pub time_start: f64,
    pub time_end: f64,
}

/// A simulated body of the recording.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct BodyInfo {
    pub name: String,
    /// The frame it moves.
    pub frame: String,
    pub mass: f64,
    /// kg m^2
    pub principal_moments: [f64; 3],
}

/// A recorded joint of an articulated model.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct JointInfo {
    pub name: String,
    /// `revolute`, `continuous` or `prismatic`.
    pub kind: String,
    /// The URDF range, rad or m.
    pub limits: Option<[f64; 2]>,
    /// What drives it, when something does (absent otherwise).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub drive: Option<DriveInfo>,
}

/// A joint's drive ([`crate::record::DriveLayout`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct DriveInfo {
    /// `motor`, `position`, `velocity`, or `damping` (damping alone).
    pub kind: String,
    /// N m or N.
    pub effort_limit: Option<f64>,
    /// N m s/rad or N s/m.
    pub damping: f64,
}

/// A recorded articulated model.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct MechanismInfo {
    pub name: String,
    /// `floating` or `fixed`.
    pub base: String,
    pub bodies: usize,
    pub joints: usize,
}

/// What `tumble info` reports (also its `--json` output).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RecordingInfo {
    pub path: PathBuf,
    pub bytes: u64,
    /// The MCAP header's library, e.g. "tumble 0.1.0".
    pub library: String,
    /// Written by tumble: a `tumble` metadata record is present.
    pub tumble: bool,
    pub tool_version: Option<String>,
    pub integrator: Option<String>,
    /// Step size, s (from the metadata).
    pub dt: Option<f64>,
    /// Steps the run was asked for, and every how many steps it recorded.
    pub steps: Option<u64>,
    pub log_every: Option<u64>,
    /// Recorded span, s: of the complete recorded steps (see `complete_steps`), else of all
    /// messages (last minus first log time).
    pub duration: f64,
    /// Frame ids (from the layout, else from the first `/tf` message).
    pub frames: Vec<String>,
    pub bodies: Vec<BodyInfo>,
    /// Joints and models of the articulated models (empty without them).
    pub joints: Vec<JointInfo>,
    pub mechanisms: Vec<MechanismInfo>,
    pub topics: Vec<TopicInfo>,
    pub messages: u64,
    /// Footer, summary and closing magic present.
    pub complete: bool,
    /// When not complete: what went wrong and how much was readable.
    pub truncation: Option<String>,
    /// The summary's message count agrees with the messages read (complete files only).
    pub summary_agrees: Option<bool>,
    /// The `tumble` metadata record without the scene text and layout (see `metadata_keys`).
    pub settings: BTreeMap<String, String>,
    /// Keys of the `tumble` metadata record, including the long ones left out of `settings`.
    pub metadata_keys: Vec<String>,
}

/// Metadata values too long to print: shown by key only (so are the `urdf/...` texts).
const LONG_KEYS: [&str; 3] = ["scene", "settings_json", LAYOUT_KEY];

/// Topics with one message per recorded step: every group's `/tf` and `/bodies`, and
/// `/joints`, `/mechanisms`, `/contacts` where written (a step is complete, and replayable by
/// [`super::steps::StepReader`], when all of them hold it).
fn is_step_topic(topic: &str) -> bool {
    use crate::record::names::{CONTACTS_TOPIC, JOINTS_TOPIC, MECHANISMS_TOPIC};
    topic.ends_with(TF_TOPIC)
        || topic.ends_with(BODIES_TOPIC)
        || topic.ends_with(JOINTS_TOPIC)
        || topic.ends_with(MECHANISMS_TOPIC)
        || topic.ends_with(CONTACTS_TOPIC)
}

/// Recorded steps whose messages were all read, and their time span (ns): the `/bodies`
/// message count (the last message of a step; minimum over groups), and the span from the
/// latest first time to the earliest last time of the step topics. A file cut between a step's
/// `/tf` and its `/bodies` message (a killed run) then reports the same steps and span as
/// `tumble convert`, which drops that partial step.
fn complete_steps(
    topics: &BTreeMap<String, TopicInfo>,
    step_times: &BTreeMap<String, (u64, u64)>,
) -> (u64, Option<(i64, i64)>) {
    let steps = topics
        .values()
        .filter(|t| t.topic.ends_with(BODIES_TOPIC))
        .map(|t| t.messages)
        .min()
        .unwrap_or(0);
    let start = step_times.values().map(|t| t.0).max();
    let end = step_times.values().map(|t| t.1).min();
    let span = match (start, end) {
        (Some(a), Some(b)) if a <= b => Some((a as i64, b as i64)),
        _ => None,
    };
    (steps, span)
}

/// Reads `path` once, front to back.
pub fn info(path: &Path) -> anyhow::Result<RecordingInfo> {
    let bytes = std::fs::metadata(path)
        .map_err(|e| anyhow::anyhow!("cannot read {}: {e}", path.display()))?
        .len();
    let mut stream = McapStream::open(path)?;
    let mut topics: BTreeMap<String, TopicInfo> = BTreeMap::new();
    let mut metadata: Option<BTreeMap<String, String>> = None;
    let mut tf_frames: Vec<String> = Vec::new();
    let mut messages = 0u64;
    let (mut first, mut last) = (u64::MAX, 0u64);
    // First and last log time of every step-carrying topic (`/tf`, `/bodies` of every group).
    let mut step_times: BTreeMap<String, (u64, u64)> = BTreeMap::new();
    while let Some(item) = stream.next_item() {
        match item {
            Item::Metadata(m) if m.name == METADATA_NAME => metadata = Some(m.metadata),
            Item::Metadata(_) => {}
            Item::Message {
                topic,
                schema,
                log_time,
                data,
            } => {
                messages += 1;
                first = first.min(log_time);
                last = last.max(log_time);
                let entry = topics
                    .entry(topic.to_string())
                    .or_insert_with(|| TopicInfo {
                        topic: topic.to_string(),
                        schema: schema.to_string(),
                        messages: 0,
                        time_start: log_time as f64 / 1e9,
                        time_end: 0.0,
                    });
                entry.messages += 1;
                entry.time_end = log_time as f64 / 1e9;
                if is_step_topic(&topic) {
                    let times = step_times.entry(topic.to_string()).or_insert((log_time, 0));
                    times.1 = log_time;
                }
                if tf_frames.is_empty()
                    && &*schema == "foxglove.FrameTransforms"
                    && let Ok(frames) = super::steps::decode_transforms(&data)
                {
                    tf_frames = frames.into_iter().map(|(name, _)| name).collect();
                }
            }
        }
    }
    if stream.library().is_none() {
        let why = match stream.end() {
            StreamEnd::Truncated { error, .. } => error.clone(),
            _ => "no header".into(),
        };
        anyhow::bail!("{}: not an MCAP file ({why})", path.display());
    }
    let end = stream.end().clone();
    let complete = end == StreamEnd::Complete;
    let metadata_all = metadata.clone().unwrap_or_default();
    let layout = metadata_all.get(LAYOUT_KEY).and_then(|j| from_json(j).ok());
    let (frames, bodies) = match &layout {
        Some(layout) => (
            layout.frames.iter().map(|f| f.frame_id.clone()).collect(),
            layout
                .bodies
                .iter()
                .map(|b| BodyInfo {
                    name: b.name.clone(),
                    frame: layout.frames[b.frame].frame_id.clone(),
                    mass: b.mass,
                    principal_moments: b.principal_moments.into(),
                })
                .collect(),
        ),
        None => (tf_frames, Vec::new()),
    };
    let (joints, mechanisms) = match &layout {
        Some(layout) => (
            layout
                .joints
                .iter()
                .enumerate()
                .map(|(i, j)| JointInfo {
                    name: j.name.clone(),
                    kind: j.kind.clone(),
                    limits: j.limits,
                    drive: layout.drive_of(i).map(|d| DriveInfo {
                        kind: d.kind_name().to_string(),
                        effort_limit: d.effort_limit,
                        damping: d.damping,
                    }),
                })
                .collect(),
            layout
                .mechanisms
                .iter()
                .map(|m| MechanismInfo {
                    name: m.name.clone(),
                    base: if m.floating { "floating" } else { "fixed" }.into(),
                    bodies: m.bodies.len(),
                    joints: m.joints.len(),
                })
                .collect(),
        ),
        None => (Vec::new(), Vec::new()),
    };
    let get = |key: &str| metadata_all.get(key).cloned();
    let (recovered_steps, step_span_ns) = complete_steps(&topics, &step_times);
    let truncation = super::convert::truncation_warning(
        path,
        &end,
        recovered_steps,
        step_span_ns.or((messages > 0).then_some((first as i64, last as i64))),
        super::convert::expected_recorded_steps(&metadata_all),
    );
    Ok(RecordingInfo {
        path: path.to_owned(),
        bytes,
        library: stream.library().unwrap_or_default().to_string(),
        tumble: metadata.is_some(),
        tool_version: get("tool_version"),
        integrator: get("integrator"),
        dt: get("dt").and_then(|v| v.parse().ok()),
        steps: get("steps").and_then(|v| v.parse().ok()),
        log_every: get("log_every").and_then(|v| v.parse().ok()),
        duration: match step_span_ns {
            Some((a, b)) => (b - a) as f64 / 1e9,
            None if messages > 0 => (last - first) as f64 / 1e9,
            None => 0.0,
        },
        frames,
        bodies,
        joints,
        mechanisms,
        topics: topics.into_values().collect(),
        messages,
        complete,
        truncation,
        summary_agrees: stream.statistics().map(|s| s.message_count == messages),
        settings: metadata_all
            .iter()
            .filter(|(k, _)| {
                !LONG_KEYS.contains(&k.as_str())
                    && !k.starts_with(crate::scene::URDF_METADATA_PREFIX)
            })
            .map(|(k, v)| (k.clone(), v.clone()))
            .collect(),
        metadata_keys: metadata_all.keys().cloned().collect(),
    })
}

/// Items of each list (frames, bodies, articulated models, joints) the text report shows
/// unless asked for all of them (`tumble info --all`): a 10 000-body recording would print
/// 10 000 frame ids on one line and 10 000 body lines.
pub const TEXT_LIST_LIMIT: usize = 20;

/// The first `limit` items of `items` and, when some are left out, a note saying how many.
fn shown<T>(items: &[T], limit: Option<usize>) -> (&[T], Option<String>) {
    match limit {
        Some(n) if items.len() > n => (
            &items[..n],
            Some(format!(
                "... and {} more (tumble info --all lists every one)",
                items.len() - n
            )),
        ),
        _ => (items, None),
    }
}

/// The human-readable report, every list cut at [`TEXT_LIST_LIMIT`] items.
pub fn text(info: &RecordingInfo) -> String {
    text_with(info, Some(TEXT_LIST_LIMIT))
}

/// The human-readable report, each list cut at `limit` items (`None`: all of them).
pub fn text_with(info: &RecordingInfo, limit: Option<usize>) -> String {
    let mut out = String::new();
    let status = if info.complete {
        "complete (summary and footer present)".to_string()
    } else {
        "TRUNCATED".to_string()
    };
    out.push_str(&format!(
        "{} ({} bytes, {}): {status}\n",
        info.path.display(),
        info.bytes,
        info.library
    ));
    if !info.tumble {
        out.push_str("not written by tumble (no `tumble` metadata record)\n");
    }
    let opt = |v: &Option<String>| v.clone().unwrap_or_else(|| "?".into());
    out.push_str(&format!(
        "tool version {}; integrator {}; dt {} s; steps {}; log_every {}\n",
        opt(&info.tool_version),
        opt(&info.integrator),
        info.dt.map_or("?".into(), |v| format!("{v}")),
        info.steps.map_or("?".into(), |v| v.to_string()),
        info.log_every.map_or("?".into(), |v| v.to_string()),
    ));
    out.push_str(&format!(
        "recorded span {} s, {} messages\n",
        info.duration, info.messages
    ));
    let (frames, more_frames) = shown(&info.frames, limit);
    out.push_str(&format!(
        "{} frames: {}{}\n",
        info.frames.len(),
        frames.join(", "),
        more_frames.map_or(String::new(), |m| format!(" {m}"))
    ));
    if !info.bodies.is_empty() {
        out.push_str(&format!("{} bodies:\n", info.bodies.len()));
        let (bodies, more) = shown(&info.bodies, limit);
        for b in bodies {
            out.push_str(&format!(
                "  {:<24} mass {:.6} kg, principal moments [{:.6e}, {:.6e}, {:.6e}] kg m^2 (frame {})\n",
                b.name,
                b.mass,
                b.principal_moments[0],
                b.principal_moments[1],
                b.principal_moments[2],
                b.frame
            ));
        }
        if let Some(more) = more {
            out.push_str(&format!("  {more}\n"));
        }
    }
    if !info.mechanisms.is_empty() {
        out.push_str(&format!(
            "{} articulated models, {} joints:\n",
            info.mechanisms.len(),
            info.joints.len()
        ));
        let (mechanisms, more) = shown(&info.mechanisms, limit);
        for m in mechanisms {
            out.push_str(&format!(
                "  {:<24} {} base, {} bodies, {} joints\n",
                m.name, m.base, m.bodies, m.joints
            ));
        }
        if let Some(more) = more {
            out.push_str(&format!("  {more}\n"));
        }
        let (joints, more_joints) = shown(&info.joints, limit);
        for j in joints {
            let range = j.limits.map_or(String::new(), |[lo, hi]| {
                format!(", URDF range [{lo}, {hi}]")
            });
            let drive = j.drive.as_ref().map_or(String::new(), |d| {
                let limit = d
                    .effort_limit
                    .map_or(String::new(), |l| format!(", effort limit {l}"));
                format!(", driven: {}{limit}, damping {}", d.kind, d.damping)
            });
            out.push_str(&format!(
                "  joint {:<18} {}{range}{drive}\n",
                j.name, j.kind
            ));
        }
        if let Some(more) = more_joints {
            out.push_str(&format!("  {more}\n"));
        }
    }
    out.push_str("topics:\n");
    for t in &info.topics {
        out.push_str(&format!(
            "  {:<20} {:<26} {:>8} messages, t = {} .. {} s\n",
            t.topic, t.schema, t.messages, t.time_start, t.time_end
        ));
    }
    if !info.settings.is_empty() {
        out.push_str("settings:\n");
        for (k, v) in &info.settings {
            out.push_str(&format!("  {k} = {v}\n"));
        }
    }
    match info.summary_agrees {
        Some(true) => out.push_str("summary statistics agree with the messages read\n"),
        Some(false) => {
            out.push_str("WARNING: the summary's message count differs from the messages read\n")
        }
        None => {}
    }
    out
}
