//! `tumble diff`: two recordings' frame poses compared over time.
//!
//! # What is compared
//!
//! The `foxglove.FrameTransforms` messages of one topic (`/tf` by default) in both files. Frames
//! are matched by frame id (`child_frame_id`); frames in only one file are listed and make the
//! runs differ. Per matched frame, at every comparison time:
//!
//! - position error `|p_A - p_B|`, metres (the frame origin in the world);
//! - orientation error: the angle of `R_A^T R_B`, radians ([`rotation_between`]: exactly 0 for
//!   equal orientations, accurate to round-off at every angle).
//!
//! Reported per frame: the maximum (and when it happened), the RMS over the comparison times and
//! the value at the last common time; overall: the maxima over frames.
//!
//! # Aligning time
//!
//! Comparison happens inside the time span both recordings cover. When the two share timestamps
//! (integer ns, e.g. `dt` 1 ms vs 2 ms with the same `log_every`) at no fewer than half the
//! samples of the coarser one, only the shared timestamps are compared: no interpolation at all.
//! Otherwise the comparison times are the coarser recording's, and the other recording is
//! interpolated between its two neighbouring samples: position linearly, orientation by slerp.
//! Interpolation adds an error of order `|a| Δ²/8` (Δ its sample spacing, `a` the acceleration of
//! the quantity), so the report says how many values were interpolated; record both runs at
//! shared times when the figure matters.
//!
//! # Bounded memory
//!
//! Two passes over each file, both streaming ([`super::stream`]): the first collects the
//! timestamps (8 bytes per sample), the second walks both files in step holding two samples of
//! each. Errors are accumulated as they are computed.

use super::joint_diff::{JointAccumulator, JointCursor, JointDiff, JointScan};
use super::stream::{Item, McapStream, Message, StreamEnd};
use crate::record::layout_json::{LAYOUT_KEY, from_json};
use crate::record::names::METADATA_NAME;
use crate::record::rerun::blueprint::PlotView;
use crate::record::rerun::{RerunOptions, RerunSink};
use crate::record::{Frame, FrameLayout, RecordingLayout, Sink};
use anyhow::{Context, bail};
use nalgebra::{Isometry3, Translation3, UnitQuaternion};
use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

/// What `tumble diff` is asked to do.
#[derive(Debug, Clone, PartialEq)]
pub struct DiffSettings {
    /// The transforms topic of both files.
    pub topic: String,
    /// Largest position error (m) still counted as "same".
    pub pos_tolerance_m: f64,
    /// Largest orientation error (rad) still counted as "same".
    pub rot_tolerance_rad: f64,
    /// The joints topic of both files; `None`: each file's first of
    /// [`super::joint_diff::DEFAULT_JOINT_TOPICS`].
    pub joint_topic: Option<String>,
    /// Largest joint position difference (rad or m) still counted as "same". `None`: the
    /// joints are reported but judged only when no frames are compared (then against 0).
    pub joint_tolerance: Option<f64>,
    /// Joint times from each file's first joints message ([`JointScan::start_at_zero`]).
    pub joint_zero_start: bool,
}

/// Errors of one frame (named `bodies` in the JSON: the frames that bodies move).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct BodyDiff {
    /// Frame id.
    pub name: String,
    pub pos_err_max: f64,
    pub rot_err_max: f64,
    pub pos_err_rms: f64,
    pub rot_err_rms: f64,
    /// At the last comparison time.
    pub pos_err_end: f64,
    pub rot_err_end: f64,
    /// When the maxima happened, s.
    pub pos_err_max_time: f64,
    pub rot_err_max_time: f64,
}

/// One input file as the diff saw it.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RunSide {
    pub path: PathBuf,
    /// Samples on the topic.
    pub samples: usize,
    /// First and last sample time, s.
    pub time_start: f64,
    pub time_end: f64,
    /// `dt` and `integrator` from the tumble metadata, when present.
    pub dt: Option<String>,
    pub integrator: Option<String>,
    /// Whether the file was read to its end (summary and footer present).
    pub complete: bool,
}

/// The result of a diff.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct DiffReport {
    /// Largest position error of any frame, m.
    pub pos_err_max: f64,
    /// Largest orientation error of any frame, rad.
    pub rot_err_max: f64,
    /// Per matched frame, in the order of the first file.
    pub bodies: Vec<BodyDiff>,
    pub a: RunSide,
    pub b: RunSide,
    /// Comparison times used.
    pub samples_compared: usize,
    /// `"common timestamps"`, `"a"` or `"b"` (whose times were used; the other interpolated).
    pub aligned_on: String,
    /// Pose values obtained by interpolation (0 when aligned on common timestamps).
    pub interpolated: usize,
    /// The compared span, s.
    pub time_start: f64,
    pub time_end: f64,
    /// Frames found in only one file.
    pub unmatched_a: Vec<String>,
    pub unmatched_b: Vec<String>,
    pub pos_tolerance: f64,
    pub rot_tolerance: f64,
    /// Errors within the tolerances, same frames, same time span (and the joints within
    /// theirs when judged, [`JointsReport::within_tolerance`]): the exit status.
    pub within_tolerance: bool,
    /// Truncated inputs, different spans, ...
    pub warnings: Vec<String>,
    /// Whether the frames alone are within the tolerances (same frames, same span; true when
    /// no frames are compared). `within_tolerance` is this and the joints' verdict, if judged.
    pub frames_within_tolerance: bool,
    /// Whether frames were compared (both files have the frames topic, in protobuf); when not,
    /// the frame fields above are empty and `a`, `b` and the span describe the joints topic.
    pub frames_compared: bool,
    /// The joint comparison, when both files have joint states naming a common joint.
    pub joints: Option<JointsReport>,
}

/// The joint comparison of a diff ([`super::joint_diff`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct JointsReport {
    /// The joints topic read in each file.
    pub topic_a: String,
    pub topic_b: String,
    /// Messages on each.
    pub samples_a: usize,
    pub samples_b: usize,
    /// Largest difference of any compared joint, rad or m.
    pub err_max: f64,
    /// Per joint in both files, in the order of the first file.
    pub joints: Vec<JointDiff>,
    pub samples_compared: usize,
    /// As for frames: `"common timestamps"`, `"a"` or `"b"`.
    pub aligned_on: String,
    /// Positions obtained by interpolation.
    pub interpolated: usize,
    /// The compared span, s.
    pub time_start: f64,
    pub time_end: f64,
    /// Joints in only one file (not compared).
    pub unmatched_a: Vec<String>,
    pub unmatched_b: Vec<String>,
    /// Subtracted from each file's joint times, s (`--zero-start`: its first message's time;
    /// else 0).
    pub offset_a: f64,
    pub offset_b: f64,
    /// The tolerance the joints were judged against (null: not judged).
    pub tolerance: Option<f64>,
    /// Whether every compared joint is within it (null: not judged).
    pub within_tolerance: Option<bool>,
}

/// Angle of the rotation taking `a` to `b`, rad, in `[0, π]`:
/// `4 atan2(|a - s b|, |a + s b|)` with `s = sign(a · b)` (the two quaternions of a rotation).
/// Exactly 0 for equal orientations and accurate to round-off at every angle, unlike
/// `2 acos(w)` of the relative quaternion (no digits left below 1e-8 rad).
pub fn rotation_between(a: &UnitQuaternion<f64>, b: &UnitQuaternion<f64>) -> f64 {
    let (a, b) = (a.quaternion().coords, b.quaternion().coords);
    let b = if a.dot(&b) < 0.0 { -b } else { b };
    4.0 * (a - b).norm().atan2((a + b).norm())
}

/// Pose at fraction `s` in `[0, 1]` from `a` to `b`: position lerp, orientation slerp (shortest).
pub fn interpolate(a: &Isometry3<f64>, b: &Isometry3<f64>, s: f64) -> Isometry3<f64> {
    let p = a.translation.vector.lerp(&b.translation.vector, s);
    let r = a
        .rotation
        .try_slerp(&b.rotation, s, 1e-12)
        .unwrap_or(if s < 0.5 { a.rotation } else { b.rotation });
    Isometry3::from_parts(Translation3::from(p), r)
}

/// `value > max`, or `value` is NaN (so a NaN error is never hidden by a maximum).
fn exceeds(value: f64, max: f64) -> bool {
    value > max || value.is_nan()
}

/// First pass over one file.
struct Scan {
    times: Vec<u64>,
    frames: Vec<String>,
    end: StreamEnd,
    layout: Option<RecordingLayout>,
    metadata: BTreeMap<String, String>,
    /// Why the frames of this file cannot be compared (no messages on the frames topic, a ROS 2
    /// recording): the error `diff` gives when the joints cannot be compared either.
    frames_error: Option<anyhow::Error>,
    /// The joints topic, when the file has one.
    joints: Option<JointScan>,
}

fn scan(path: &Path, settings: &DiffSettings) -> anyhow::Result<Scan> {
    let topic = settings.topic.as_str();
    let mut stream = McapStream::open(path)?;
    let mut times = Vec::new();
    let mut frames = Vec::new();
    let mut layout = None;
    let mut metadata = BTreeMap::new();
    let mut topics = std::collections::BTreeSet::new();
    let mut frames_error = None;
    let mut joints = None;
    while let Some(item) = stream.next_item() {
        match item {
            Item::Metadata(m) if m.name == METADATA_NAME => {
                metadata = m.metadata;
                if let Some(json) = metadata.remove(LAYOUT_KEY) {
                    layout = from_json(&json).ok();
                }
            }
            Item::Message {
                topic: t,
                schema,
                log_time,
                data,
            } => {
                JointScan::offer(
                    &mut joints,
                    settings.joint_topic.as_deref(),
                    path,
                    (&t, &schema, log_time, &data),
                )?;
                if &*t != topic {
                    topics.insert(t.to_string());
                    continue;
                }
                if frames_error.is_some() {
                    continue;
                }
                if let Some(&last) = times.last()
                    && log_time <= last
                {
                    bail!(
                        "{}: {topic} message at {log_time} ns follows one at {last} ns (times \
                         must increase)",
                        path.display()
                    );
                }
                if times.is_empty() {
                    if let Err(e) = super::steps::refuse_ros2(&stream, path) {
                        frames_error = Some(e);
                        continue;
                    }
                    frames = super::steps::decode_transforms(&data)
                        .with_context(|| format!("{}", path.display()))?
                        .into_iter()
                        .map(|(name, _)| name)
                        .collect();
                }
                times.push(log_time);
            }
            _ => {}
        }
    }
    if times.is_empty() && frames_error.is_none() {
        let end = match stream.end() {
            StreamEnd::Truncated { error, .. } => format!(" (reading stopped: {error})"),
            _ => String::new(),
        };
        frames_error = Some(anyhow::anyhow!(
            "{}: no {topic} messages{end}; topics present: {}",
            path.display(),
            if topics.is_empty() {
                "none".to_string()
            } else {
                topics.into_iter().collect::<Vec<_>>().join(", ")
            }
        ));
    }
    if frames_error.is_some() {
        times.clear();
        frames.clear();
    }
    Ok(Scan {
        times,
        frames,
        end: stream.end().clone(),
        layout,
        metadata,
        frames_error,
        joints,
    })
}

/// [`scan`], failing at once (as `diff` did before joints were compared) when the file's
/// frames cannot be compared and it has no joints topic either.
fn scan_or_fail(path: &Path, settings: &DiffSettings) -> anyhow::Result<Scan> {
    let mut scan = scan(path, settings)?;
    if scan.joints.is_none()
        && let Some(e) = scan.frames_error.take()
    {
        return Err(e);
    }
    Ok(scan)
}

/// Which times to compare at, and whose they are.
fn comparison_times(a: &[u64], b: &[u64]) -> anyhow::Result<(Vec<u64>, &'static str)> {
    let lo = a[0].max(b[0]);
    let hi = a[a.len() - 1].min(b[b.len() - 1]);
    if lo > hi {
        bail!(
            "the recordings do not overlap in time (a: {} .. {} s, b: {} .. {} s)",
            a[0] as f64 / 1e9,
            a[a.len() - 1] as f64 / 1e9,
            b[0] as f64 / 1e9,
            b[b.len() - 1] as f64 / 1e9
        );
    }
    let inside = |t: &&u64| (lo..=hi).contains(*t);
    let a_in: Vec<u64> = a.iter().filter(inside).copied().collect();
    let b_in: Vec<u64> = b.iter().filter(inside).copied().collect();
    let mut common = Vec::new();
    let (mut i, mut j) = (0, 0);
    while i < a_in.len() && j < b_in.len() {
        match a_in[i].cmp(&b_in[j]) {
            std::cmp::Ordering::Less => i += 1,
            std::cmp::Ordering::Greater => j += 1,
            std::cmp::Ordering::Equal => {
                common.push(a_in[i]);
                i += 1;
                j += 1;
            }
        }
    }
    let (coarser, name) = if b_in.len() < a_in.len() {
        (b_in, "b")
    } else {
        (a_in, "a")
    };
    if !common.is_empty() && common.len() * 2 >= coarser.len() {
        Ok((common, "common timestamps"))
    } else {
        Ok((coarser, name))
    }
}

/// One sample of the matched frames.
struct Sample {
    t: u64,
    poses: Vec<Option<Isometry3<f64>>>,
}

/// Second pass over one file: poses of the matched frames at requested times.
struct Cursor {
    path: PathBuf,
    stream: McapStream<BufReader<File>>,
    topic: String,
    /// frame id -> slot among the matched frames
    slots: HashMap<String, usize>,
    names: Vec<String>,
    prev: Option<Sample>,
    next: Option<Sample>,
    interpolated: usize,
}

impl Cursor {
    fn open(path: &Path, topic: &str, matched: &[String]) -> anyhow::Result<Self> {
        Ok(Self {
            path: path.to_owned(),
            stream: McapStream::open(path)?,
            topic: topic.to_owned(),
            slots: matched
                .iter()
                .enumerate()
                .map(|(i, n)| (n.clone(), i))
                .collect(),
            names: matched.to_vec(),
            prev: None,
            next: None,
            interpolated: 0,
        })
    }

    fn read(&mut self) -> anyhow::Result<Option<Sample>> {
        while let Some(Message {
            topic,
            log_time,
            data,
        }) = self.stream.next_message()
        {
            if *topic != *self.topic {
                continue;
            }
            let mut poses = vec![None; self.slots.len()];
            for (name, pose) in super::steps::decode_transforms(&data)
                .with_context(|| format!("{}", self.path.display()))?
            {
                if let Some(&slot) = self.slots.get(&name) {
                    poses[slot] = Some(pose);
                }
            }
            return Ok(Some(Sample { t: log_time, poses }));
        }
        Ok(None)
    }

    fn poses(&self, sample: &Sample) -> anyhow::Result<Vec<Isometry3<f64>>> {
        sample
            .poses
            .iter()
            .zip(&self.names)
            .map(|(p, name)| {
                p.with_context(|| {
                    format!(
                        "{}: frame {name:?} is missing at t = {} s",
                        self.path.display(),
                        sample.t as f64 / 1e9
                    )
                })
            })
            .collect()
    }

    /// The matched frames' poses at `t`: the sample at `t`, or interpolated between the two
    /// samples around it.
    fn at(&mut self, t: u64) -> anyhow::Result<Vec<Isometry3<f64>>> {
        if self.next.is_none() {
            self.next = self.read()?;
        }
        while self.next.as_ref().is_some_and(|n| n.t < t) {
            self.prev = self.next.take();
            self.next = self.read()?;
        }
        let next = self.next.as_ref().with_context(|| {
            format!(
                "{}: no sample at or after t = {} s (file ended)",
                self.path.display(),
                t as f64 / 1e9
            )
        })?;
        if next.t == t {
            return self.poses(next);
        }
        let prev = self.prev.as_ref().with_context(|| {
            format!(
                "{}: no sample before t = {} s",
                self.path.display(),
                t as f64 / 1e9
            )
        })?;
        let s = (t - prev.t) as f64 / (next.t - prev.t) as f64;
        let (a, b) = (self.poses(prev)?, self.poses(next)?);
        self.interpolated += a.len();
        Ok(a.iter()
            .zip(&b)
            .map(|(a, b)| interpolate(a, b, s))
            .collect())
    }
}

/// Running error statistics of one frame.
#[derive(Default, Clone)]
struct Accumulator {
    pos_max: f64,
    pos_max_t: u64,
    rot_max: f64,
    rot_max_t: u64,
    pos_sq: f64,
    rot_sq: f64,
    pos_end: f64,
    rot_end: f64,
}

/// The file as the diff saw it: on its frames topic, or on `times` (its joints topic's) when
/// no frames are compared.
fn side(path: &Path, scan: &Scan, times: &[u64]) -> RunSide {
    RunSide {
        path: path.to_owned(),
        samples: times.len(),
        time_start: times[0] as f64 / 1e9,
        time_end: times[times.len() - 1] as f64 / 1e9,
        dt: scan.metadata.get("dt").cloned(),
        integrator: scan.metadata.get("integrator").cloned(),
        complete: scan.end == StreamEnd::Complete,
    }
}

/// Entities of the error series in the `--rrd` recording.
pub fn error_entities(frame_id: &str) -> [rerun::EntityPath; 2] {
    let path = |kind: &str| {
        let mut parts = vec![
            rerun::EntityPathPart::new("plots"),
            rerun::EntityPathPart::new("diff"),
            rerun::EntityPathPart::new(kind),
        ];
        parts.extend(
            frame_id
                .split('/')
                .filter(|p| !p.is_empty())
                .map(rerun::EntityPathPart::new),
        );
        rerun::EntityPath::new(parts)
    };
    [path("position_error"), path("rotation_error")]
}

/// Colours of the two runs' visuals in the `--rrd` overlay (linear RGBA): a blue, b orange and
/// translucent, so both stay visible where they overlap.
pub const OVERLAY_RGBA: [[f32; 4]; 2] = [[0.2, 0.45, 1.0, 1.0], [1.0, 0.45, 0.1, 0.6]];

/// The overlay layout: the matched frames of each run as `a/<frame id>` and `b/<frame id>`,
/// models `a` and `b`, with the visuals each file's layout has for the frame.
fn overlay_layout(
    matched: &[String],
    scans: [&Scan; 2],
    metadata: BTreeMap<String, String>,
) -> RecordingLayout {
    let mut layout = RecordingLayout {
        name: "tumble_diff".into(),
        metadata,
        ..Default::default()
    };
    for (k, (scan, prefix)) in scans.into_iter().zip(["a", "b"]).enumerate() {
        let visuals: HashMap<&str, &FrameLayout> = scan
            .layout
            .iter()
            .flat_map(|l| l.frames.iter())
            .map(|f| (f.frame_id.as_str(), f))
            .collect();
        for name in matched {
            let mut frame_visuals = visuals
                .get(name.as_str())
                .map(|f| f.visuals.to_vec())
                .unwrap_or_default();
            for v in &mut frame_visuals {
                v.rgba = Some(OVERLAY_RGBA[k]);
            }
            layout.frames.push(FrameLayout {
                frame_id: format!("{prefix}/{name}"),
                model: prefix.into(),
                link: name.clone(),
                visuals: frame_visuals.into(),
            });
        }
    }
    layout
}

/// Frames collected before the error series are sent to the `--rrd` recording.
const SERIES_BATCH: usize = 1000;

/// Compares `a` and `b`: their frames (module doc) and, when both have joint states naming a
/// common joint, their joints ([`super::joint_diff`]); a file whose frames cannot be compared
/// (no frames topic, a ROS 2 recording) is compared on its joints alone. With `rrd`, also
/// writes both runs overlaid plus the error series (see [`error_entities`],
/// [`joint_error_entity`], [`overlay_layout`]) to that `.rrd` (via `<rrd>.part`).
pub fn diff(
    a: &Path,
    b: &Path,
    settings: &DiffSettings,
    rrd: Option<&Path>,
) -> anyhow::Result<DiffReport> {
    let mut scans = [scan_or_fail(a, settings)?, scan_or_fail(b, settings)?];
    if settings.joint_zero_start {
        for joints in scans.iter_mut().filter_map(|s| s.joints.as_mut()) {
            joints.start_at_zero();
        }
    }
    let joint_pair = match (&scans[0].joints, &scans[1].joints) {
        (Some(x), Some(y)) => Some(match_names(&x.names, &y.names)),
        _ => None,
    };
    let frames_compared = scans.iter().all(|s| s.frames_error.is_none());
    let joints_compared = joint_pair.as_ref().is_some_and(|m| !m.0.is_empty());
    let mut warnings = Vec::new();
    if !frames_compared {
        if !joints_compared {
            if let Some((_, only_a, only_b)) = &joint_pair {
                bail!(
                    "no joint is in both recordings (a: {}; b: {})",
                    only_a.join(", "),
                    only_b.join(", ")
                );
            }
            let e = scans.iter_mut().find_map(|s| s.frames_error.take());
            return Err(e.expect("a file whose frames cannot be compared"));
        }
        for s in &scans {
            if let Some(e) = &s.frames_error {
                warnings.push(format!("frames not compared, joints only: {e}"));
            }
        }
    }
    // What each file is judged on: its frames topic, else its joints topic.
    let sampled = |s: &Scan| -> Vec<u64> {
        if frames_compared {
            s.times.clone()
        } else {
            s.joints
                .as_ref()
                .map(|j| j.times.clone())
                .unwrap_or_default()
        }
    };
    let sides_times = [sampled(&scans[0]), sampled(&scans[1])];
    for ((path, scan), times) in [a, b].iter().zip(&scans).zip(&sides_times) {
        let expected = super::convert::expected_recorded_steps(&scan.metadata);
        if let Some(w) = super::convert::truncation_warning(
            path,
            &scan.end,
            times.len() as u64,
            Some((times[0] as i64, times[times.len() - 1] as i64)),
            expected,
        ) {
            warnings.push(w);
        }
    }
    let (matched, unmatched_a, unmatched_b) = match_names(&scans[0].frames, &scans[1].frames);
    if frames_compared && matched.is_empty() {
        bail!(
            "no frame id is in both recordings (a: {}; b: {})",
            scans[0].frames.join(", "),
            scans[1].frames.join(", ")
        );
    }
    let frame_times = if frames_compared {
        Some(comparison_times(&scans[0].times, &scans[1].times)?)
    } else {
        None
    };
    let joint_times = match (&scans[0].joints, &scans[1].joints) {
        (Some(x), Some(y)) if joints_compared => {
            Some(comparison_times(&x.times, &y.times).map_err(|e| {
                if settings.joint_zero_start {
                    e
                } else {
                    e.context(
                        "comparing the joints (a log on another clock: --zero-start takes \
                             each file's times from its first joints message)",
                    )
                }
            })?)
        }
        _ => None,
    };
    let span = |t: &[u64]| (t[0], t[t.len() - 1]);
    let same_span = span(&sides_times[0]) == span(&sides_times[1]);
    let compared = frame_times
        .as_ref()
        .or(joint_times.as_ref())
        .map(|(t, _)| t.as_slice())
        .expect("frames or joints are compared");
    if !same_span {
        warnings.push(format!(
            "the recordings cover different spans (a: {} .. {} s, b: {} .. {} s); compared on \
             {} .. {} s",
            span(&sides_times[0]).0 as f64 / 1e9,
            span(&sides_times[0]).1 as f64 / 1e9,
            span(&sides_times[1]).0 as f64 / 1e9,
            span(&sides_times[1]).1 as f64 / 1e9,
            compared[0] as f64 / 1e9,
            compared[compared.len() - 1] as f64 / 1e9,
        ));
    }

    let mut sink = match rrd {
        Some(path) => {
            let mut metadata = BTreeMap::new();
            metadata.insert("a".to_string(), a.display().to_string());
            metadata.insert("b".to_string(), b.display().to_string());
            metadata.insert("topic".to_string(), settings.topic.clone());
            metadata.insert("tool_version".to_string(), crate::VERSION.to_string());
            let layout = overlay_layout(&matched, [&scans[0], &scans[1]], metadata);
            let mut sink = RerunSink::create(path, &layout, &RerunOptions { ellipsoids: false })?;
            let mut views = Vec::new();
            if frames_compared {
                views.push(PlotView::new(
                    "position error (m)",
                    &["+ /plots/diff/position_error/**"],
                ));
                views.push(PlotView::new(
                    "rotation error (rad)",
                    &["+ /plots/diff/rotation_error/**"],
                ));
            }
            if joints_compared {
                views.push(PlotView::new(
                    "joint position difference |θ_A − θ_B| (rad, m)",
                    &["+ /plots/diff/joint_error/**"],
                ));
            }
            sink.set_plot_views(views);
            Some(sink)
        }
        None => None,
    };
    let mut frames_result = None;
    let mut joints_result = None;
    let result = (|| -> anyhow::Result<()> {
        if let Some((times, _)) = &frame_times {
            frames_result = Some(compare_frames(a, b, settings, &matched, times, &mut sink)?);
        }
        if let (Some((times, _)), Some((names, _, _))) = (&joint_times, &joint_pair) {
            let joints = [&scans[0], &scans[1]].map(|s| s.joints.as_ref().expect("joints"));
            joints_result = Some(compare_joints([a, b], joints, names, times, &mut sink)?);
        }
        Ok(())
    })();
    if let Some(sink) = sink {
        let sinks: Vec<Box<dyn Sink>> = vec![Box::new(sink)];
        crate::record::finish_all(sinks, result, &rrd.into_iter().collect::<Vec<_>>())?;
    } else {
        result?;
    }

    let (bodies, interpolated) = frames_result.unwrap_or_default();
    let worst = |f: fn(&BodyDiff) -> f64| {
        bodies
            .iter()
            .map(f)
            .fold(0.0, |m: f64, v| if exceeds(v, m) { v } else { m })
    };
    let pos_err_max = worst(|b| b.pos_err_max);
    let rot_err_max = worst(|b| b.rot_err_max);
    let frames_within = !frames_compared
        || (pos_err_max <= settings.pos_tolerance_m
            && rot_err_max <= settings.rot_tolerance_rad
            && unmatched_a.is_empty()
            && unmatched_b.is_empty()
            && same_span);
    let joints = match (joints_result, &joint_times, joint_pair) {
        (Some((joints, interpolated)), Some((times, aligned_on)), Some((_, only_a, only_b))) => {
            let err_max = joints
                .iter()
                .map(|j| j.err_max)
                .fold(0.0, |m: f64, v| if exceeds(v, m) { v } else { m });
            let tolerance = match settings.joint_tolerance {
                Some(t) => Some(t),
                None if !frames_compared => Some(0.0),
                None => None,
            };
            let [x, y] = [&scans[0], &scans[1]].map(|s| s.joints.as_ref().expect("joints"));
            Some(JointsReport {
                topic_a: x.topic.clone(),
                topic_b: y.topic.clone(),
                samples_a: x.times.len(),
                samples_b: y.times.len(),
                err_max,
                joints,
                samples_compared: times.len(),
                aligned_on: aligned_on.to_string(),
                interpolated,
                time_start: times[0] as f64 / 1e9,
                time_end: times[times.len() - 1] as f64 / 1e9,
                unmatched_a: only_a,
                unmatched_b: only_b,
                offset_a: x.offset_ns as f64 / 1e9,
                offset_b: y.offset_ns as f64 / 1e9,
                tolerance,
                within_tolerance: tolerance.map(|t| err_max <= t),
            })
        }
        _ => None,
    };
    let joints_within = joints
        .as_ref()
        .and_then(|j| j.within_tolerance)
        .unwrap_or(true);
    let (samples_compared, aligned_on, time_start, time_end) = match &frame_times {
        Some((times, on)) => (
            times.len(),
            on.to_string(),
            times[0] as f64 / 1e9,
            times[times.len() - 1] as f64 / 1e9,
        ),
        None => (
            0,
            "none".to_string(),
            compared[0] as f64 / 1e9,
            compared[compared.len() - 1] as f64 / 1e9,
        ),
    };
    Ok(DiffReport {
        pos_err_max,
        rot_err_max,
        bodies,
        a: side(a, &scans[0], &sides_times[0]),
        b: side(b, &scans[1], &sides_times[1]),
        samples_compared,
        aligned_on,
        interpolated,
        time_start,
        time_end,
        unmatched_a,
        unmatched_b,
        pos_tolerance: settings.pos_tolerance_m,
        rot_tolerance: settings.rot_tolerance_rad,
        within_tolerance: frames_within && joints_within,
        frames_within_tolerance: frames_within,
        warnings,
        frames_compared,
        joints,
    })
}

/// The names of `a` also in `b` (in `a`'s order), those only in `a`, those only in `b`.
fn match_names(a: &[String], b: &[String]) -> (Vec<String>, Vec<String>, Vec<String>) {
    let in_a: std::collections::HashSet<&String> = a.iter().collect();
    let in_b: std::collections::HashSet<&String> = b.iter().collect();
    (
        a.iter().filter(|n| in_b.contains(n)).cloned().collect(),
        a.iter().filter(|n| !in_b.contains(n)).cloned().collect(),
        b.iter().filter(|n| !in_a.contains(n)).cloned().collect(),
    )
}

/// The frames pass: per matched frame its errors at `times`, and the poses interpolated;
/// with a sink, the overlay and the error series.
fn compare_frames(
    a: &Path,
    b: &Path,
    settings: &DiffSettings,
    matched: &[String],
    times: &[u64],
    sink: &mut Option<RerunSink>,
) -> anyhow::Result<(Vec<BodyDiff>, usize)> {
    let mut cursors = [
        Cursor::open(a, &settings.topic, matched)?,
        Cursor::open(b, &settings.topic, matched)?,
    ];
    let entities: Vec<[rerun::EntityPath; 2]> = matched.iter().map(|f| error_entities(f)).collect();
    let mut acc = vec![Accumulator::default(); matched.len()];
    let mut batch_t: Vec<i64> = Vec::new();
    let mut batch_step: Vec<i64> = Vec::new();
    let mut batch_err: Vec<Vec<[f64; 2]>> = vec![Vec::new(); matched.len()];
    let mut overlay: Vec<Isometry3<f64>> = Vec::with_capacity(2 * matched.len());
    for (index, &t) in times.iter().enumerate() {
        let pa = cursors[0].at(t)?;
        let pb = cursors[1].at(t)?;
        for (i, (x, y)) in pa.iter().zip(&pb).enumerate() {
            let pos = (x.translation.vector - y.translation.vector).norm();
            let rot = rotation_between(&x.rotation, &y.rotation);
            let s = &mut acc[i];
            // A NaN error becomes the maximum (and then fails any tolerance).
            if exceeds(pos, s.pos_max) {
                s.pos_max = pos;
                s.pos_max_t = t;
            }
            if exceeds(rot, s.rot_max) {
                s.rot_max = rot;
                s.rot_max_t = t;
            }
            s.pos_sq += pos * pos;
            s.rot_sq += rot * rot;
            s.pos_end = pos;
            s.rot_end = rot;
            if sink.is_some() {
                batch_err[i].push([pos, rot]);
            }
        }
        if let Some(sink) = sink.as_mut() {
            overlay.clear();
            overlay.extend(pa.iter().chain(&pb));
            let time_ns = i64::try_from(t).context("time beyond i64 ns")?;
            sink.write(&Frame {
                step: index as u64,
                time_ns,
                world_from_link: &overlay,
                bodies: &[],
                joints: &[],
                mechanisms: &[],
                contacts: &[],
            })?;
            batch_t.push(time_ns);
            batch_step.push(index as i64);
            if batch_t.len() >= SERIES_BATCH || index + 1 == times.len() {
                for (i, [pos_entity, rot_entity]) in entities.iter().enumerate() {
                    let pos: Vec<f64> = batch_err[i].iter().map(|e| e[0]).collect();
                    let rot: Vec<f64> = batch_err[i].iter().map(|e| e[1]).collect();
                    sink.write_series(pos_entity, &["m"], &batch_t, &batch_step, &pos)?;
                    sink.write_series(rot_entity, &["rad"], &batch_t, &batch_step, &rot)?;
                    batch_err[i].clear();
                }
                batch_t.clear();
                batch_step.clear();
            }
        }
    }
    let n = times.len() as f64;
    let bodies = matched
        .iter()
        .zip(&acc)
        .map(|(name, s)| BodyDiff {
            name: name.clone(),
            pos_err_max: s.pos_max,
            rot_err_max: s.rot_max,
            pos_err_rms: (s.pos_sq / n).sqrt(),
            rot_err_rms: (s.rot_sq / n).sqrt(),
            pos_err_end: s.pos_end,
            rot_err_end: s.rot_end,
            pos_err_max_time: s.pos_max_t as f64 / 1e9,
            rot_err_max_time: s.rot_max_t as f64 / 1e9,
        })
        .collect();
    Ok((bodies, cursors[0].interpolated + cursors[1].interpolated))
}

/// Entity of a joint's difference series in the `--rrd` recording:
/// `/plots/diff/joint_error/<joint split at '/'>`.
pub fn joint_error_entity(joint: &str) -> rerun::EntityPath {
    let mut parts = vec![
        rerun::EntityPathPart::new("plots"),
        rerun::EntityPathPart::new("diff"),
        rerun::EntityPathPart::new("joint_error"),
    ];
    parts.extend(
        joint
            .split('/')
            .filter(|p| !p.is_empty())
            .map(rerun::EntityPathPart::new),
    );
    rerun::EntityPath::new(parts)
}

/// The joints pass ([`super::joint_diff`]): per compared joint its differences at `times`,
/// and the positions interpolated; with a sink, the difference series.
fn compare_joints(
    paths: [&Path; 2],
    scans: [&JointScan; 2],
    names: &[String],
    times: &[u64],
    sink: &mut Option<RerunSink>,
) -> anyhow::Result<(Vec<JointDiff>, usize)> {
    let mut cursors = [
        JointCursor::open(paths[0], scans[0], names)?,
        JointCursor::open(paths[1], scans[1], names)?,
    ];
    let entities: Vec<rerun::EntityPath> = names.iter().map(|n| joint_error_entity(n)).collect();
    let mut acc = vec![JointAccumulator::default(); names.len()];
    let (mut batch_t, mut batch_step) = (Vec::new(), Vec::new());
    let mut batch_err: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
    for (index, &t) in times.iter().enumerate() {
        let pa = cursors[0].at(t)?;
        let pb = cursors[1].at(t)?;
        for (i, (x, y)) in pa.iter().zip(&pb).enumerate() {
            let err = (x - y).abs();
            acc[i].add(t, err);
            if sink.is_some() {
                batch_err[i].push(err);
            }
        }
        if let Some(sink) = sink.as_mut() {
            batch_t.push(i64::try_from(t).context("time beyond i64 ns")?);
            batch_step.push(index as i64);
            if batch_t.len() >= SERIES_BATCH || index + 1 == times.len() {
                for (entity, errs) in entities.iter().zip(&mut batch_err) {
                    sink.write_series(entity, &["|θ_A − θ_B|"], &batch_t, &batch_step, errs)?;
                    errs.clear();
                }
                batch_t.clear();
                batch_step.clear();
            }
        }
    }
    let joints = names
        .iter()
        .zip(&acc)
        .map(|(name, s)| s.report(name, times.len()))
        .collect();
    Ok((joints, cursors[0].interpolated + cursors[1].interpolated))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    /// The atan2 form agrees with the axis-angle construction across the range, including
    /// angles far below where `2 acos(w)` loses all digits, and is exactly 0 for equal or
    /// sign-flipped quaternions.
    #[test]
    fn rotation_between_is_accurate_from_tiny_to_pi() {
        let base = UnitQuaternion::from_euler_angles(0.3, -1.2, 2.5);
        assert_eq!(rotation_between(&base, &base), 0.0);
        let flipped = UnitQuaternion::new_unchecked(-base.into_inner());
        assert_eq!(rotation_between(&base, &flipped), 0.0);
        for angle in [1e-15, 1e-9, 1e-3, 0.5, 3.0, std::f64::consts::PI] {
            let q = base * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), angle);
            let got = rotation_between(&base, &q);
            // measured: |error| <= 1.3e-16 rad at every angle (round-off of composing `q`)
            assert!(
                (got - angle).abs() <= 2e-15 * angle.max(1.0),
                "{angle}: {got}"
            );
        }
    }

    /// Interpolating a uniform rotation and a uniform translation is exact.
    #[test]
    fn interpolation_is_exact_for_uniform_motion() {
        let axis = Vector3::new(1.0, 2.0, -0.5).normalize();
        let pose = |t: f64| {
            Isometry3::from_parts(
                Translation3::new(t, -2.0 * t, 3.0),
                UnitQuaternion::from_scaled_axis(axis * (0.7 * t)),
            )
        };
        let mid = interpolate(&pose(1.0), &pose(2.0), 0.25);
        let exact = pose(1.25);
        let pos = (mid.translation.vector - exact.translation.vector).norm();
        let rot = rotation_between(&mid.rotation, &exact.rotation);
        // measured: 0 m and 2.6e-16 rad
        assert!(pos <= 1e-15 && rot <= 1e-15, "{pos} {rot}");
    }

    #[test]
    fn shared_timestamps_are_preferred_over_interpolation() {
        let a: Vec<u64> = (0..=100).map(|k| k * 10).collect();
        let b: Vec<u64> = (0..=50).map(|k| k * 20).collect();
        let (times, on) = comparison_times(&a, &b).unwrap();
        assert_eq!(on, "common timestamps");
        assert_eq!(times, b);
        // No shared timestamps but the first: compare on the coarser one's times.
        let c: Vec<u64> = (0..=30).map(|k| k * 33).collect();
        let (times, on) = comparison_times(&a, &c).unwrap();
        assert_eq!(on, "b");
        assert_eq!(times, c);
        let late: Vec<u64> = vec![5000, 6000];
        assert!(comparison_times(&a, &late).is_err());
    }
}
