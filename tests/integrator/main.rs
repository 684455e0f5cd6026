//! The integrators: closed forms, orders, the stress matrix, accuracy on demand, stability map, guards and `tumble trade`.
//!
//! One test binary (it links the library once); each module is a former `tests/<name>.rs`, its
//! tests named `<module>::<test>` (`cargo test --release --test integrator <module>::`).

#[path = "../common/mod.rs"]
mod common;

mod accuracy;
mod guard_check;
mod guards;
mod integrator;
mod integrator_family;
mod stability;
mod stress;
mod trade;
