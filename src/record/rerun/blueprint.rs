//! The Rerun blueprint a tumble recording opens with: what a user sees first in the viewer.
//!
//! ```text
//! ┌──────────────────────────────┬──────────────────────────┐
//! │                              │ energy change            │
//! │  3D view (the scene, framed) ├──────────────────────────┤
//! │  two thirds of the width     │ angular momentum change  │
//! │                              ├──────────────────────────┤
//! │                              │ energy (J)               │
//! └──────────────────────────────┴──────────────────────────┘
//! ```
//!
//! The 3D view shows everything but the plots, its eye placed so that every link frame's
//! positions over the whole run (the box [`SceneBounds`] collects), grown by the size of its
//! geometry, fit in view; in a recording with a robot, the robot's link frames at its first
//! recorded step, with the eye tracking its root link's visual (`tracking_entity`, set by the
//! sink: [`super::sink`]). The plots show the relative change of the conserved quantities (what
//! the integrators are judged by; a raw |L| plot only shows round-off noise at full scale) and
//! the scene's energies, each over the whole run (time axis from −∞ to +∞) on `sim_time`.
//! A recording of fixed-base models only has no conserved angular momentum (the weld exchanges
//! it with the world): its blueprint omits the angular momentum change plot, which would be a
//! flat line at 0 (the series is still written). Other recordings
//! ([`super::RerunSink::set_plot_views`]) replace the plots.
//!
//! Rerun's own blueprint API (`re_sdk::blueprint`) gives every view and container a random
//! UUID and logs through a recording stream with a random store id, so two runs would write
//! different bytes. Here the same archetypes (`ViewportBlueprint`, `ContainerBlueprint`,
//! `ViewBlueprint`, `ViewContents`, and the views' properties `EyeControls3D`, `TimeAxis`,
//! `PanelBlueprint`, `TimePanelBlueprint`) are logged at the entity paths the viewer reads (`viewport`,
//! `container/<uuid>`, `view/<uuid>`, `view/<uuid>/<property>`, `blueprint_panel`,
//! `selection_panel`, `time_panel`; the side panels start collapsed) on the `blueprint`
//! timeline at 0, in a blueprint store whose id derives from the recording's, with UUIDs derived
//! from a counter: same recording, same bytes. The store is activated and made the default.

use anyhow::Result;
use nalgebra::Vector3;
use rerun::external::re_log_types::{
    BlueprintActivationCommand, SetStoreInfo, StoreId, StoreInfo, StoreKind,
};
use rerun::external::re_sdk_types::blueprint::archetypes::{
    ContainerBlueprint, EyeControls3D, PanelBlueprint, TimeAxis, TimePanelBlueprint, ViewBlueprint,
    ViewContents, ViewportBlueprint,
};
use rerun::external::re_sdk_types::blueprint::components::{
    AutoLayout, AutoViews, ColumnShare, ContainerKind, Eye3DKind, IncludedContent, PanelState,
    QueryExpression, RootContainer, RowShare, TimeRange, ViewClass,
};
use rerun::external::re_sdk_types::datatypes::{self, TimeRangeBoundary};
use rerun::log::{Chunk, LogMsg, RowId};
use rerun::{AsComponents, EntityPath, TimePoint};

/// A time series view of the right-hand column.
#[derive(Debug, Clone, PartialEq)]
pub struct PlotView {
    pub title: String,
    /// Entity query expressions (`+ /plots/scene/energy`, `/plots/diff/**`, ...).
    pub contents: Vec<String>,
}

impl PlotView {
    pub fn new(title: &str, contents: &[&str]) -> Self {
        Self {
            title: title.into(),
            contents: contents.iter().map(|s| s.to_string()).collect(),
        }
    }
}

/// The plots of a simulation recording.
pub fn default_plot_views() -> Vec<PlotView> {
    vec![
        PlotView::new(
            "energy change (E − E₀)/|E₀|",
            &["+ /plots/scene/energy_change"],
        ),
        PlotView::new(
            "angular momentum change, max over bodies |L − L₀|/|L₀|",
            &["+ /plots/scene/angular_momentum_change"],
        ),
        PlotView::new("energy (J)", &["+ /plots/scene/energy"]),
    ]
}

/// The axis-aligned box around every recorded link frame origin, with a margin per frame for
/// its geometry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SceneBounds {
    pub min: Vector3<f64>,
    pub max: Vector3<f64>,
}

impl Default for SceneBounds {
    fn default() -> Self {
        Self {
            min: Vector3::repeat(f64::INFINITY),
            max: Vector3::repeat(f64::NEG_INFINITY),
        }
    }
}

impl SceneBounds {
    /// Grows the box to hold a ball of `radius` around `point` (non-finite points are ignored).
    pub fn add(&mut self, point: &Vector3<f64>, radius: f64) {
        if point.iter().all(|x| x.is_finite()) {
            let r = Vector3::repeat(radius.max(0.0));
            self.min = self.min.inf(&(point - r));
            self.max = self.max.sup(&(point + r));
        }
    }

    pub fn is_empty(&self) -> bool {
        self.min.iter().zip(self.max.iter()).any(|(a, b)| a > b)
    }

    /// Eye position and look target that frame the box: the eye looks at the box's centre from
    /// above and to the side (direction (1, −1.6, 0.9)), at 2.2 times the box's half diagonal,
    /// at least 0.3 m (a 50° field of view then holds the whole box).
    pub fn eye(&self) -> ([f32; 3], [f32; 3]) {
        let (center, radius) = if self.is_empty() {
            (Vector3::new(0.0, 0.0, 0.0), 1.0)
        } else {
            (
                (self.min + self.max) / 2.0,
                ((self.max - self.min) / 2.0).norm(),
            )
        };
        let direction = Vector3::new(1.0, -1.6, 0.9).normalize();
        let eye = center + direction * (2.2 * radius).max(0.3);
        let f = |v: Vector3<f64>| [v.x as f32, v.y as f32, v.z as f32];
        (f(eye), f(center))
    }
}

/// Deterministic UUIDs: a counter in a fixed prefix, formatted like `uuid::Uuid`'s hyphenated form.
struct Ids {
    seed: u64,
    next: u64,
}

impl Ids {
    fn next(&mut self) -> ([u8; 16], String) {
        self.next += 1;
        let value = (u128::from(self.seed) << 64) | u128::from(self.next);
        let bytes = value.to_be_bytes();
        let hex: String = bytes.iter().map(|b| format!("{b:02x}")).collect();
        let text = format!(
            "{}-{}-{}-{}-{}",
            &hex[0..8],
            &hex[8..12],
            &hex[12..16],
            &hex[16..20],
            &hex[20..32]
        );
        (bytes, text)
    }
}

fn blueprint_chunk(entity: impl Into<EntityPath>, archetype: &dyn AsComponents) -> Result<Chunk> {
    let time = TimePoint::default().with(rerun::Timeline::new_sequence("blueprint"), 0);
    Ok(Chunk::builder(entity.into())
        .with_archetype(RowId::new(), time, archetype)
        .build()?)
}

/// Everything the blueprint store holds, in logging order (the caller wraps the chunks in
/// `ArrowMsg`s of the blueprint store).
/// `tracked`: the entity the 3D view's eye follows (a robot's root link visual), if any; the
/// eye then starts where `bounds` (the robot at its start) put it and keeps its offset from the
/// entity as the entity moves.
pub fn blueprint_chunks(
    recording_seed: u64,
    bounds: &SceneBounds,
    tracked: Option<&EntityPath>,
    plots: &[PlotView],
) -> Result<Vec<Chunk>> {
    let mut ids = Ids {
        seed: recording_seed,
        next: 0,
    };
    let mut chunks = Vec::new();

    // The 3D view.
    let (_, view3d) = ids.next();
    let view3d_path = format!("view/{view3d}");
    chunks.push(blueprint_chunk(
        format!("{view3d_path}/ViewContents"),
        &ViewContents::new([
            QueryExpression("+ /**".into()),
            QueryExpression("- /plots/**".into()),
            QueryExpression("- /metadata".into()),
        ]),
    )?);
    chunks.push(blueprint_chunk(
        view3d_path.as_str(),
        &ViewBlueprint::new(ViewClass("3D".into()))
            .with_display_name("scene")
            .with_space_origin("/"),
    )?);
    let (position, target) = bounds.eye();
    let mut eye = EyeControls3D::new()
        .with_kind(Eye3DKind::Orbital)
        .with_position(position)
        .with_look_target(target)
        .with_eye_up([0.0, 0.0, 1.0]);
    if let Some(tracked) = tracked {
        eye = eye.with_tracking_entity(tracked.to_string());
    }
    chunks.push(blueprint_chunk(
        format!("{view3d_path}/EyeControls3D"),
        &eye,
    )?);

    // The plots.
    let mut plot_paths = Vec::new();
    for plot in plots {
        let (_, id) = ids.next();
        let path = format!("view/{id}");
        chunks.push(blueprint_chunk(
            format!("{path}/ViewContents"),
            &ViewContents::new(
                plot.contents
                    .iter()
                    .map(|q| QueryExpression(q.as_str().into())),
            ),
        )?);
        chunks.push(blueprint_chunk(
            path.as_str(),
            &ViewBlueprint::new(ViewClass("TimeSeries".into()))
                .with_display_name(plot.title.as_str())
                .with_space_origin("/"),
        )?);
        chunks.push(blueprint_chunk(
            format!("{path}/TimeAxis"),
            &TimeAxis::new().with_view_range(TimeRange(datatypes::TimeRange {
                start: TimeRangeBoundary::Infinite,
                end: TimeRangeBoundary::Infinite,
            })),
        )?);
        plot_paths.push(path);
    }

    // Containers: the plots in a column, beside the 3D view.
    let mut root_contents = vec![IncludedContent(view3d_path.as_str().into())];
    let mut shares = vec![ColumnShare(2.0.into())];
    if !plot_paths.is_empty() {
        let (_, column) = ids.next();
        let column_path = format!("container/{column}");
        chunks.push(blueprint_chunk(
            column_path.as_str(),
            &ContainerBlueprint::new(ContainerKind::Vertical)
                .with_contents(
                    plot_paths
                        .iter()
                        .map(|p| IncludedContent(p.as_str().into())),
                )
                .with_row_shares(plot_paths.iter().map(|_| RowShare(1.0.into()))),
        )?);
        root_contents.push(IncludedContent(column_path.as_str().into()));
        shares.push(ColumnShare(1.0.into()));
    }
    let (root_bytes, root) = ids.next();
    chunks.push(blueprint_chunk(
        format!("container/{root}"),
        &ContainerBlueprint::new(ContainerKind::Horizontal)
            .with_contents(root_contents)
            .with_col_shares(shares),
    )?);
    chunks.push(blueprint_chunk(
        "viewport",
        &ViewportBlueprint::new()
            .with_root_container(RootContainer(datatypes::Uuid::from(root_bytes)))
            .with_auto_layout(AutoLayout(false.into()))
            .with_auto_views(AutoViews(false.into())),
    )?);
    // The side panels collapsed, so the views get the window; the time panel on `sim_time`,
    // collapsed to its playback bar.
    for panel in ["blueprint_panel", "selection_panel"] {
        chunks.push(blueprint_chunk(
            panel,
            &PanelBlueprint::new().with_state(PanelState::Collapsed),
        )?);
    }
    chunks.push(blueprint_chunk(
        "time_panel",
        &TimePanelBlueprint::new()
            .with_timeline(super::paths::SIM_TIME_TIMELINE)
            .with_state(PanelState::Collapsed),
    )?);
    Ok(chunks)
}

/// The blueprint store's messages: its store info (derived from the recording's: same
/// application, kind blueprint, recording id `<recording id>-blueprint`), the chunks, and the
/// command that makes it the active and default blueprint. Row ids are renumbered by the writer.
pub fn blueprint_messages(recording: &StoreInfo, chunks: Vec<Chunk>) -> Result<Vec<LogMsg>> {
    let store_id = StoreId::new(
        StoreKind::Blueprint,
        recording.store_id.application_id().clone(),
        format!("{}-blueprint", recording.store_id.recording_id()),
    );
    let mut info = recording.clone();
    info.store_id = store_id.clone();
    let mut messages = vec![LogMsg::SetStoreInfo(SetStoreInfo {
        row_id: *RowId::new(),
        info,
    })];
    for chunk in chunks {
        messages.push(LogMsg::ArrowMsg(store_id.clone(), chunk.to_arrow_msg()?));
    }
    messages.push(LogMsg::BlueprintActivationCommand(
        BlueprintActivationCommand {
            blueprint_id: store_id,
            make_active: true,
            make_default: true,
        },
    ));
    Ok(messages)
}
