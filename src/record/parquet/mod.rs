//! Parquet: the tables of recorded steps and bodies ([`tables`]), the part files they are
//! written to so that the same rows always give the same bytes ([`files`]), and the sinks of
//! `simulate --format parquet` ([`sink`], [`joints`] the articulated models' joints, and
//! [`contacts`] the contacts of runs that can have them). The
//! dataset writes its tables with these too.

pub mod contacts;
pub mod files;
pub mod joints;
pub mod sink;
pub mod tables;

pub use contacts::ContactsSink;
pub use joints::JointsSink;
pub use sink::{BodiesSink, TrajectorySink};

/// `STEM.trajectories.parquet` and `STEM.bodies.parquet` (`simulate --format parquet`).
pub const TRAJECTORIES_EXTENSION: &str = "trajectories.parquet";
pub const BODIES_EXTENSION: &str = "bodies.parquet";
/// `STEM.joints.parquet` ([`joints`]).
pub const JOINTS_EXTENSION: &str = "joints.parquet";
/// `STEM.contacts.parquet` ([`contacts`]), only for runs that can have contacts.
pub const CONTACTS_EXTENSION: &str = "contacts.parquet";
