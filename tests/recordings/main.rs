//! Recordings out and back: MCAP, Rerun, ROS 2, Parquet datasets, readers we did not write.
//!
//! One test binary (it links the library once); each module is a former `tests/<name>.rs`, its
//! tests named `<module>::<test>` (`cargo test --release --test recordings <module>::`).

#[path = "../common/mod.rs"]
mod common;

mod contacts;
mod dataset;
mod dataset_robots;
mod drives;
mod joint_diff;
mod lerobot;
mod partial_step;
mod recordings;
mod replay;
mod rerun_sink;
mod robot_viewers;
mod ros2;
mod viewers;
