//! Names the recording formats share, defined once: the world frame id, the MCAP and ROS 2
//! topics (each repeated under a topic group's prefix, [`super::TopicGroup`]) and the name of
//! the metadata record.

/// Parent frame of every link frame: the `parent_frame_id` of the MCAP `/tf` transforms, the
/// `header.frame_id` of the ROS 2 ones, and the frame of Rerun's root entity.
pub const WORLD_FRAME: &str = "world";
/// Topic of the link transforms (MCAP and ROS 2).
pub const TF_TOPIC: &str = "/tf";
/// Topic of the per-body velocities, energies and momenta (MCAP and ROS 2).
pub const BODIES_TOPIC: &str = "/bodies";
/// MCAP topic of the geometry (`foxglove.SceneUpdate`, one message at the first recorded step).
pub const SCENE_TOPIC: &str = "/scene";
/// MCAP topic of the inertia ellipsoids (`foxglove.SceneUpdate`, one message at the first step).
pub const INERTIA_TOPIC: &str = "/inertia";
/// MCAP topic of the joint coordinates.
pub const JOINTS_TOPIC: &str = "/joints";
/// MCAP topic of the per-model totals.
pub const MECHANISMS_TOPIC: &str = "/mechanisms";
/// ROS 2 topic of the articulated models' joint positions and velocities.
pub const JOINT_STATES_TOPIC: &str = "/joint_states";
/// ROS 2 topic of a scene's single model description (per-model topics end with it).
pub const ROBOT_DESCRIPTION_TOPIC: &str = "/robot_description";
/// Name of the MCAP metadata record holding the scene and settings (MCAP and ROS 2).
pub const METADATA_NAME: &str = "tumble";
/// Name of the MCAP metadata record written at the end of a run (MCAP and ROS 2): what the
/// run did, its energy balance and its warnings
/// ([`crate::simulation::RunSummary::metadata_entries`]).
pub const SUMMARY_METADATA_NAME: &str = "tumble_summary";
/// Topic of the contacts of each recorded step (MCAP `tumble.Contacts`, ROS 2
/// `tumble_msgs/msg/Contacts`), in runs that can have contacts.
pub const CONTACTS_TOPIC: &str = "/contacts";
/// MCAP topic of the contact points and force arrows (`foxglove.SceneUpdate`, one message per
/// recorded step), in runs that can have contacts.
pub const CONTACTS_SCENE_TOPIC: &str = "/contacts/scene";
