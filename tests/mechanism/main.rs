//! Articulated mechanisms.
//!
//! One test binary (it links the library once); each module is a former `tests/<name>.rs`, its
//! tests named `<module>::<test>` (`cargo test --release --test mechanism <module>::`).

#[path = "../common/mod.rs"]
mod common;

mod arm_servo;
mod balance;
mod contact_hostile;
mod contact_robots;
mod copies;
mod corpus;
mod driven;
mod driven_hostile;
mod forces;
mod hostile;
mod joint_space;
mod limits;
mod mechanism;
mod pinocchio_driven;
mod recordings;
mod robot;
mod threads;
mod trade;
