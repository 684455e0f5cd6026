//! ROS 2 recordings: an MCAP file that `ros2 bag play` replays and RViz2 shows
//! (`STEM.ros2.mcap`; see docs/ros2.md for replaying it).
//!
//! `ros2 bag play` refuses a file whose channels mix message encodings, so the ROS 2 recording
//! is a file of its own next to the protobuf `.mcap`: header profile `ros2`, every channel `cdr`
//! ([`cdr`]), every schema `ros2msg` ([`msgs`]), every channel with the
//! `offered_qos_profiles` metadata `rosbag2` writes (and reads back to create its publishers).
//!
//! | topic                 | type                          | QoS (durability, depth) | messages |
//! |-----------------------|-------------------------------|-------------------------|----------|
//! | `/tf`                 | `tf2_msgs/msg/TFMessage`      | volatile, 100           | one per recorded step: one `TransformStamped` per link frame, `header.frame_id = "world"`, `child_frame_id` = the frame id, the pose `world_from_link` (exactly the `/tf` of the `.mcap`) |
//! | `/robot_description`  | `std_msgs/msg/String`         | transient local, 1      | one at t = 0: the model's URDF with link names = frame ids and absolute `file://` meshes ([`crate::model::description`]) |
//! | `/bodies`             | `tumble_msgs/msg/BodyStates`  | volatile, 10            | one per recorded step: the values of the `.mcap`'s `/bodies` |
//! | `/contacts`           | `tumble_msgs/msg/Contacts`    | volatile, 10            | in runs that can have contacts ([`super::RecordingLayout::contacts`]), one per recorded step: the values of the `.mcap`'s `/contacts` (no markers: RViz2 shows neither the ground nor the arrows; the protobuf `.mcap` draws both for Foxglove) |
//!
//! All channels are reliable, keep-last, automatic liveliness. With several models each model
//! has its own description topic `/<model>/robot_description` ([`description_topics`]): RViz2's
//! RobotModel display shows one description topic, and a transient-local topic carrying several
//! messages would hand a late subscriber only the last one (depth 1). A scene of one model uses
//! `/robot_description`, the topic RViz2 and `robot_state_publisher` use by default. With
//! [`super::RecordingLayout::topic_groups`] the `/tf` and `/bodies` topics are repeated per
//! group under its prefix, as in the `.mcap`.
//!
//! Joint states of articulated models (`bodies = "articulated"`) go on `/joint_states` as
//! `sensor_msgs/msg/JointState` ([`msgs::joint_state`], QoS as `/bodies`): one
//! message per recorded step and topic group that holds joints, `name` = the joint names
//! prefixed as the frame ids are (`name/joint`, as the rewritten `/robot_description` names
//! them), `position` in rad or m, `velocity` in rad/s or m/s, and `effort`: in a recording with
//! a driven joint ([`super::RecordingLayout::drives`]) every joint's effort applied, actuator
//! plus damping, N m or N (0 for an undriven joint; the values of the `.mcap`'s `/joints`),
//! else empty (nothing applies an effort; the message is the one it was before drives
//! existed). `sensor_msgs/JointState` has no field for a target or a saturation: those are in
//! the protobuf `/joints` of the `.mcap`. Only the joints
//! the scene keeps moving are listed (fixed and locked joints are merged into bodies; mimic
//! joints follow their leader, as `robot_state_publisher` computes them). A file without
//! articulated models has no `/joint_states` channel.
//!
//! Times: `log_time` = `publish_time` = the header stamps = simulation time from 0 (1970-01-01),
//! so replay with `ros2 bag play --clock` and run RViz2 with `use_sim_time:=true`. The metadata
//! record `tumble` (scene, settings, layout) is written before any schema or channel, so every
//! chunk holds messages and lists message indexes (Foxglove refuses chunks without them). The
//! file is written under `<path>.part` and renamed onto `path` only once complete.

pub mod cdr;
pub mod cdr_read;
pub mod msgs;
pub mod sink;

pub use sink::Ros2Sink;

use super::RecordingLayout;
use super::names::ROBOT_DESCRIPTION_TOPIC;

/// File name suffix of ROS 2 recordings: `STEM.ros2.mcap`.
pub const EXTENSION: &str = "ros2.mcap";
/// Queue depth offered on `/tf` (what tf2's listener asks for).
pub const TF_DEPTH: u32 = 100;
/// Queue depth offered on `/bodies` and `/joint_states`.
pub const STATES_DEPTH: u32 = 10;

/// ROS 2 durability policy values as `rmw_qos_durability_policy_t` numbers them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Durability {
    /// A late subscriber gets the last `depth` messages (`/robot_description`).
    TransientLocal = 1,
    Volatile = 2,
}

/// The `offered_qos_profiles` channel metadata: a YAML list of one publisher's profile in the
/// form `rosbag2` writes (rosbag2_transport `qos.cpp`): policies as `rmw` enum integers
/// (history keep-last 1, reliability reliable 1, liveliness automatic 1) and durations
/// `{sec, nsec}`, here `0, 0` = unspecified (the `rmw` default, infinite).
pub fn offered_qos_profiles(durability: Durability, depth: u32) -> String {
    let zero = "\n    sec: 0\n    nsec: 0";
    format!(
        "- history: 1\n  depth: {depth}\n  reliability: 1\n  durability: {}\n  deadline:{zero}\n  \
         lifespan:{zero}\n  liveliness: 1\n  liveliness_lease_duration:{zero}\n  \
         avoid_ros_namespace_conventions: false\n",
        durability as u8
    )
}

/// The description topic of each of `layout`'s models, in order: `/robot_description` for a
/// single model; else `/<model>/robot_description`, the model's label made a valid ROS name
/// token (every character other than ASCII letters, digits and `_` replaced by `_`, a leading
/// digit or an empty label prefixed with `_`) and, when two labels map to the same token,
/// `_2`, `_3`, ... appended to the later ones.
pub fn description_topics(layout: &RecordingLayout) -> Vec<String> {
    if layout.robot_descriptions.len() == 1 {
        return vec![ROBOT_DESCRIPTION_TOPIC.to_string()];
    }
    let mut used = std::collections::HashSet::new();
    layout
        .robot_descriptions
        .iter()
        .map(|d| {
            let mut token: String = d
                .model
                .chars()
                .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
                .collect();
            if token.is_empty() || token.starts_with(|c: char| c.is_ascii_digit()) {
                token.insert(0, '_');
            }
            let mut candidate = token.clone();
            let mut n = 1;
            while !used.insert(candidate.clone()) {
                n += 1;
                candidate = format!("{token}_{n}");
            }
            format!("/{candidate}{ROBOT_DESCRIPTION_TOPIC}")
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::RobotDescription;

    fn layout_of(models: &[&str]) -> RecordingLayout {
        RecordingLayout {
            robot_descriptions: models
                .iter()
                .map(|m| RobotDescription {
                    model: m.to_string(),
                    urdf_path: "r.urdf".into(),
                    urdf: Ok(String::new()),
                })
                .collect(),
            ..Default::default()
        }
    }

    /// One model: the standard topic; several: one valid, distinct topic per model, in order.
    #[test]
    fn description_topics_are_standard_for_one_model_and_distinct_for_several() {
        assert_eq!(
            description_topics(&layout_of(&["a-b"])),
            ["/robot_description"]
        );
        assert_eq!(
            description_topics(&layout_of(&["arm", "a-b", "a.b", "2x", ""])),
            [
                "/arm/robot_description",
                "/a_b/robot_description",
                "/a_b_2/robot_description",
                "/_2x/robot_description",
                "/_/robot_description",
            ]
        );
    }

    /// A description that could not be prepared stops the sink before any file exists, with a
    /// message naming the output, the model and the URDF.
    #[test]
    fn a_failed_description_is_reported_and_writes_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.ros2.mcap");
        let mut layout = layout_of(&["m"]);
        layout.robot_descriptions[0].urdf = Err("bad xml".into());
        let e = Ros2Sink::create(&path, &layout).err().unwrap().to_string();
        assert!(
            e.contains("x.ros2.mcap") && e.contains("\"m\"") && e.contains("r.urdf"),
            "{e}"
        );
        assert!(e.contains("bad xml"), "{e}");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
}
