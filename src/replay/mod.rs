//! Recordings read back: `tumble info`, `tumble diff`, `tumble convert`.
//!
//! Everything reads MCAP files front to back with bounded memory ([`stream`]); a file cut short
//! (a killed run, a full disk, a partial copy) gives every complete chunk and a warning saying
//! what was lost. [`steps`] rebuilds the recorded steps of a tumble recording from its `/tf` and
//! `/bodies` messages and the layout stored in its metadata; [`convert`] replays them into a
//! Rerun `.rrd` with the same entities as a fresh run; [`diff`] compares two recordings' frame
//! poses over time, and their joint positions ([`joint_diff`], also against a ROS 2 log's
//! `/joint_states`); [`info`] summarises one file.

pub mod convert;
pub mod diff;
pub mod info;
pub mod joint_diff;
pub mod steps;
pub mod stream;
