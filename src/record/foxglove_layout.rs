//! The Foxglove layout of a recording that holds a robot: the shipped layout
//! (`docs/foxglove/tumble-layout.json`) with its 3D panel following the robot.
//!
//! Foxglove cannot read a layout from an MCAP file: the user imports one (Layouts → Import).
//! The shipped layout's camera looks at a fixed point of the bundled default scene; for a
//! recording with a robot ([`RecordingLayout::robot_root`]: an articulated model, or a model
//! with meshes) `tumble simulate` writes this one beside the MCAP (`STEM.foxglove.json`):
//!
//! - the 3D panel's display frame (`followTf`) is the robot's root link frame, followed in
//!   position (`followMode = "follow-position"`: the camera moves with the root link and keeps
//!   its orientation in `world`, so the robot stays in view however far it falls or walks);
//! - the camera looks at the centre of the robot's link frames at its start (`targetOffset`,
//!   from the root frame's origin, m), from `3 ×` the half diagonal of their box (grown by the
//!   frames' geometry, [`FrameLayout::reach`]), at least 0.5 m, from the robot's front side
//!   (`thetaOffset` 220°: the camera on +x, where a URDF's robot faces): the robot fills the
//!   view;
//! - the grid stays in `world` (`frameId`), the ground's plane, rather than riding on the root;
//! - the link frames' names and the lines from `world` to each of them are not drawn (a robot has
//!   dozens of links: the names would cover it), their axes are drawn small.
//!
//! Everything else (topics, plots) is the shipped layout's.

use super::{FrameLayout, RecordingLayout};
use nalgebra::{Isometry3, Vector3};
use serde_json::{Value, json};

/// The id of the 3D panel in the shipped layout's `configById`.
pub const PANEL_ID: &str = "3D!tumble";

/// What the 3D panel follows and how far the camera is.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotCamera {
    /// The frame followed: the robot's root link frame id.
    pub frame_id: String,
    /// The camera target relative to the root frame's origin (world axes), m.
    pub target_offset: Vector3<f64>,
    /// Camera distance from the target, m.
    pub distance: f64,
}

/// The camera on the robot of `layout` at its start (`world_from_link`: every frame's initial
/// pose, in layout order); `None` without a robot.
pub fn robot_camera(
    layout: &RecordingLayout,
    world_from_link: &[Isometry3<f64>],
) -> Option<RobotCamera> {
    let root = layout.robot_root()?;
    let root_pos = world_from_link.get(root)?.translation.vector;
    let model = &layout.frames[root].model;
    let (mut min, mut max) = (
        Vector3::repeat(f64::INFINITY),
        Vector3::repeat(f64::NEG_INFINITY),
    );
    for (frame, pose) in layout.frames.iter().zip(world_from_link) {
        let p = pose.translation.vector;
        if &frame.model != model || !p.iter().all(|x| x.is_finite()) {
            continue;
        }
        let r = Vector3::repeat(FrameLayout::reach(frame));
        min = min.inf(&(p - r));
        max = max.sup(&(p + r));
    }
    if min.iter().zip(max.iter()).any(|(a, b)| a > b) {
        return None;
    }
    let center = (min + max) / 2.0;
    let half_diagonal = ((max - min) / 2.0).norm();
    Some(RobotCamera {
        frame_id: layout.frames[root].frame_id.clone(),
        target_offset: center - root_pos,
        distance: (3.0 * half_diagonal).max(0.5),
    })
}

/// `base` (the shipped layout) with its 3D panel following `camera`; `None` when `base` has no
/// such panel.
pub fn robot_layout(base: &Value, camera: &RobotCamera) -> Option<Value> {
    let mut layout = base.clone();
    let panel = layout.get_mut("configById")?.get_mut(PANEL_ID)?;
    let panel = panel.as_object_mut()?;
    panel.insert("followTf".into(), json!(camera.frame_id));
    panel.insert("followMode".into(), json!("follow-position"));
    let state = panel
        .entry("cameraState")
        .or_insert_with(|| json!({}))
        .as_object_mut()?;
    let t = camera.target_offset;
    state.insert("distance".into(), json!(camera.distance));
    state.insert("thetaOffset".into(), json!(220.0));
    state.insert("target".into(), json!([0.0, 0.0, 0.0]));
    state.insert("targetOffset".into(), json!([t.x, t.y, t.z]));
    let scene = panel
        .entry("scene")
        .or_insert_with(|| json!({}))
        .as_object_mut()?;
    scene.insert(
        "transforms".into(),
        json!({"showLabel": false, "axisScale": 0.05, "lineWidth": 0.0, "lineColor": "#00000000"}),
    );
    if let Some(grid) = panel
        .get_mut("layers")
        .and_then(|l| l.get_mut("grid"))
        .and_then(Value::as_object_mut)
    {
        grid.insert("frameId".into(), json!(super::names::WORLD_FRAME));
    }
    Some(layout)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_panel_follows_the_root_frame() {
        let base = json!({"configById": {PANEL_ID: {
            "cameraState": {"distance": 1.1, "targetOffset": [0.25, 0, 1]},
            "followMode": "follow-none", "followTf": "world",
            "layers": {"grid": {"layerId": "foxglove.Grid"}}}}});
        let camera = RobotCamera {
            frame_id: "talos/base_link".into(),
            target_offset: Vector3::new(0.0, 0.0, -0.2),
            distance: 3.5,
        };
        let out = robot_layout(&base, &camera).unwrap();
        let panel = &out["configById"][PANEL_ID];
        assert_eq!(panel["followTf"], "talos/base_link");
        assert_eq!(panel["followMode"], "follow-position");
        assert_eq!(panel["cameraState"]["distance"], 3.5);
        assert_eq!(
            panel["cameraState"]["targetOffset"],
            json!([0.0, 0.0, -0.2])
        );
        assert_eq!(panel["layers"]["grid"]["frameId"], "world");
        assert_eq!(panel["scene"]["transforms"]["showLabel"], false);
        assert!(robot_layout(&json!({}), &camera).is_none());
    }
}
