//! Outputs that survive and the binary's contract: reliability, file ownership, the CLI, big scenes.
//!
//! One test binary (it links the library once); each module is a former `tests/<name>.rs`, its
//! tests named `<module>::<test>` (`cargo test --release --test reliability <module>::`).

#[path = "../common/mod.rs"]
mod common;

mod cli;
mod ownership;
mod reliability;
mod robot_cli;
mod scale;
