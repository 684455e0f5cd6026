//! tumble: URDF rigid bodies simulated as free bodies with a variational integrator,
//! recorded as MCAP (Foxglove protobuf schemas) and Rerun `.rrd` files.
//!
//! Data flows one way: scene → model → bodies → stepper → recorders. The integrator knows no
//! URDF; a recorder knows no integrator.

pub mod bench;
pub mod budget;
pub mod cli;
pub mod commands;
pub mod dataset;
pub mod fsutil;
pub mod input;
pub mod interrupt;
pub mod message;
pub mod model;
pub mod plot;
pub mod record;
pub mod replay;
pub mod scene;
pub mod sim;
pub mod simulation;
pub mod stability;
pub mod survey;
pub mod trade;
pub mod world;

/// The tool's version, written into every recording's metadata.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");
