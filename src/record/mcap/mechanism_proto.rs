//! The MCAP topics of articulated models: `/joints` (`tumble.JointStates`) and `/mechanisms`
//! (`tumble.MechanismStates`), one message per recorded step each, written only when the
//! recording has articulated models (per topic group, under its prefix like `/tf`).
//!
//! ```text
//! message JointState      { string name = 1; double position = 2; double velocity = 3;
//!                           optional double effort = 4; optional double target = 5;
//!                           bool saturated = 6; bool at_limit = 7; }
//! message JointStates     { google.protobuf.Timestamp timestamp = 1; uint64 step = 2;
//!                           repeated JointState joints = 3; }
//! message MechanismState  { string name = 1; Vector3 linear_momentum = 2;
//!                           Vector3 angular_momentum = 3; Vector3 com = 4;
//!                           double kinetic_energy = 5; double potential_energy = 6;
//!                           double energy = 7; double residual_m = 8; double residual_rad = 9; }
//! message MechanismStates { google.protobuf.Timestamp timestamp = 1; uint64 step = 2;
//!                           repeated MechanismState mechanisms = 3; }
//! ```
//!
//! `name` is the joint's recorded name (the URDF joint name, `name/`-prefixed like frame ids)
//! or the model's; positions in rad (continuous joints unwrapped) or m, rates in rad/s or m/s;
//! momenta and energies from the momenta projected onto the velocity constraints, world frame,
//! SI units; `angular_momentum` is about the model's centre of mass `com`; `residual_m` the
//! largest anchor gap of any joint (m), `residual_rad` the largest axis misalignment (rad).
//!
//! `effort`, `target` and `saturated` are a driven joint's ([`crate::record::JointState`]):
//! the effort applied, actuator plus damping (N m or N; the continuous-time law at the
//! recorded time, position and velocity), present for every driven joint even when it is 0
//! (proto3 `optional`: a log read back tells "no effort" from "an effort of 0"); the commanded
//! target (a position servo's position, a velocity servo's velocity; absent for a motor,
//! damping alone or an undriven joint); and whether the effort limit clamped it. An undriven
//! joint carries none of the three (effort and target absent, reading as 0, not saturated), so
//! its message is the one it was before drives existed; and the schema lists the three fields
//! only in recordings with a driven joint ([`joint_states_descriptor`]), so a recording without
//! drives is byte for byte the one it was. A reader decodes both with either schema (fields it
//! does not know are skipped).
//! `at_limit` ([`crate::record::JointState::at_limit`]): the joint is at a bound of its range,
//! its limit on. Listed in the schema only in recordings with an enforced limit, and (proto3)
//! encoded only when true, so a recording without limits is byte for byte the one it was.
//! Each schema is a self-contained `FileDescriptorSet` (`tumble.Vector3` from
//! `tumble/BodyStates.proto`, which it includes, as `/bodies` does).

use prost::Message as _;
use prost_types::field_descriptor_proto::{Label, Type};
use prost_types::{
    DescriptorProto, FieldDescriptorProto, FileDescriptorProto, FileDescriptorSet,
    OneofDescriptorProto,
};

/// Schema names.
pub const JOINT_STATES_SCHEMA: &str = "tumble.JointStates";
pub const MECHANISM_STATES_SCHEMA: &str = "tumble.MechanismStates";

/// `tumble.JointState`
#[derive(Clone, PartialEq, prost::Message)]
pub struct JointState {
    #[prost(string, tag = "1")]
    pub name: String,
    #[prost(double, tag = "2")]
    pub position: f64,
    #[prost(double, tag = "3")]
    pub velocity: f64,
    #[prost(double, optional, tag = "4")]
    pub effort: Option<f64>,
    #[prost(double, optional, tag = "5")]
    pub target: Option<f64>,
    #[prost(bool, tag = "6")]
    pub saturated: bool,
    #[prost(bool, tag = "7")]
    pub at_limit: bool,
}

/// `tumble.JointStates`
#[derive(Clone, PartialEq, prost::Message)]
pub struct JointStates {
    #[prost(message, optional, tag = "1")]
    pub timestamp: Option<prost_types::Timestamp>,
    #[prost(uint64, tag = "2")]
    pub step: u64,
    #[prost(message, repeated, tag = "3")]
    pub joints: Vec<JointState>,
}

/// `tumble.MechanismState`
#[derive(Clone, PartialEq, prost::Message)]
pub struct MechanismState {
    #[prost(string, tag = "1")]
    pub name: String,
    #[prost(message, optional, tag = "2")]
    pub linear_momentum: Option<super::proto::Vector3>,
    #[prost(message, optional, tag = "3")]
    pub angular_momentum: Option<super::proto::Vector3>,
    #[prost(message, optional, tag = "4")]
    pub com: Option<super::proto::Vector3>,
    #[prost(double, tag = "5")]
    pub kinetic_energy: f64,
    #[prost(double, tag = "6")]
    pub potential_energy: f64,
    #[prost(double, tag = "7")]
    pub energy: f64,
    #[prost(double, tag = "8")]
    pub residual_m: f64,
    #[prost(double, tag = "9")]
    pub residual_rad: f64,
}

/// `tumble.MechanismStates`
#[derive(Clone, PartialEq, prost::Message)]
pub struct MechanismStates {
    #[prost(message, optional, tag = "1")]
    pub timestamp: Option<prost_types::Timestamp>,
    #[prost(uint64, tag = "2")]
    pub step: u64,
    #[prost(message, repeated, tag = "3")]
    pub mechanisms: Vec<MechanismState>,
}

pub(super) fn field(
    name: &str,
    number: i32,
    ty: Type,
    type_name: Option<&str>,
) -> FieldDescriptorProto {
    FieldDescriptorProto {
        name: Some(name.into()),
        number: Some(number),
        label: Some(Label::Optional as i32),
        r#type: Some(ty as i32),
        type_name: type_name.map(str::to_string),
        ..Default::default()
    }
}

pub(super) fn repeated(name: &str, number: i32, type_name: &str) -> FieldDescriptorProto {
    FieldDescriptorProto {
        label: Some(Label::Repeated as i32),
        ..field(name, number, Type::Message, Some(type_name))
    }
}

pub(super) fn message(name: &str, fields: Vec<FieldDescriptorProto>) -> DescriptorProto {
    DescriptorProto {
        name: Some(name.into()),
        field: fields,
        ..Default::default()
    }
}

/// A self-contained `FileDescriptorSet`: the timestamp and `tumble/BodyStates.proto` files,
/// then `file` (package `tumble`) holding `messages`.
pub(super) fn descriptor(file: &str, messages: Vec<DescriptorProto>) -> Vec<u8> {
    let [timestamp, body_states] = super::proto::body_states_files();
    let own = FileDescriptorProto {
        name: Some(file.into()),
        package: Some("tumble".into()),
        dependency: vec![
            "google/protobuf/timestamp.proto".into(),
            "tumble/BodyStates.proto".into(),
        ],
        message_type: messages,
        syntax: Some("proto3".into()),
        ..Default::default()
    };
    FileDescriptorSet {
        file: vec![timestamp, body_states, own],
    }
    .encode_to_vec()
}

/// The `timestamp = 1` and `step = 2` fields every per-step message starts with.
pub(super) fn stamp_and_step() -> [FieldDescriptorProto; 2] {
    [
        field(
            "timestamp",
            1,
            Type::Message,
            Some(".google.protobuf.Timestamp"),
        ),
        field("step", 2, Type::Uint64, None),
    ]
}

/// The `FileDescriptorSet` of [`JointStates`] (field numbers as the `prost` tags above). With
/// `limited` (the recording has an enforced joint limit) it lists `at_limit`. With
/// `driven` (the recording has a driven joint) `JointState` lists `effort` and `target` (each
/// proto3 `optional`: a synthetic oneof `_effort`, `_target`, as `protoc` describes them) and
/// `saturated`; without, the three are left out and the schema is the one recordings had
/// before drives.
pub fn joint_states_descriptor(driven: bool, limited: bool) -> Vec<u8> {
    let [ts, step] = stamp_and_step();
    let mut joint_state = message(
        "JointState",
        vec![
            field("name", 1, Type::String, None),
            field("position", 2, Type::Double, None),
            field("velocity", 3, Type::Double, None),
        ],
    );
    if driven {
        let optional = |name: &str, number, oneof| FieldDescriptorProto {
            oneof_index: Some(oneof),
            proto3_optional: Some(true),
            ..field(name, number, Type::Double, None)
        };
        joint_state.field.extend([
            optional("effort", 4, 0),
            optional("target", 5, 1),
            field("saturated", 6, Type::Bool, None),
        ]);
        for name in ["_effort", "_target"] {
            joint_state.oneof_decl.push(OneofDescriptorProto {
                name: Some(name.into()),
                ..Default::default()
            });
        }
    }
    if limited {
        joint_state
            .field
            .push(field("at_limit", 7, Type::Bool, None));
    }
    descriptor(
        "tumble/JointStates.proto",
        vec![
            joint_state,
            message(
                "JointStates",
                vec![ts, step, repeated("joints", 3, ".tumble.JointState")],
            ),
        ],
    )
}

/// The `FileDescriptorSet` of [`MechanismStates`].
pub fn mechanism_states_descriptor() -> Vec<u8> {
    let [ts, step] = stamp_and_step();
    let v3 = |name: &str, n| field(name, n, Type::Message, Some(".tumble.Vector3"));
    let f64_field = |name: &str, n| field(name, n, Type::Double, None);
    descriptor(
        "tumble/MechanismStates.proto",
        vec![
            message(
                "MechanismState",
                vec![
                    field("name", 1, Type::String, None),
                    v3("linear_momentum", 2),
                    v3("angular_momentum", 3),
                    v3("com", 4),
                    f64_field("kinetic_energy", 5),
                    f64_field("potential_energy", 6),
                    f64_field("energy", 7),
                    f64_field("residual_m", 8),
                    f64_field("residual_rad", 9),
                ],
            ),
            message(
                "MechanismStates",
                vec![
                    ts,
                    step,
                    repeated("mechanisms", 3, ".tumble.MechanismState"),
                ],
            ),
        ],
    )
}

/// The protobuf `Timestamp` of a simulation time in ns.
pub fn timestamp(time_ns: u64) -> prost_types::Timestamp {
    prost_types::Timestamp {
        seconds: (time_ns / 1_000_000_000) as i64,
        nanos: (time_ns % 1_000_000_000) as i32,
    }
}

pub(super) fn vec3(v: &nalgebra::Vector3<f64>) -> Option<super::proto::Vector3> {
    Some(super::proto::Vector3 {
        x: v.x,
        y: v.y,
        z: v.z,
    })
}

/// The `/joints` message of a group's joints; `driven[i]`: whether joint `i` is driven (empty:
/// none is). An undriven joint's drive fields are left out, so a recording without drives (whose
/// schema declares no drive field, [`joint_states_descriptor`]) never carries one.
pub fn joint_states(
    time_ns: u64,
    step: u64,
    names: &[String],
    states: &[crate::record::JointState],
    driven: &[bool],
) -> JointStates {
    JointStates {
        timestamp: Some(timestamp(time_ns)),
        step,
        joints: names
            .iter()
            .zip(states)
            .enumerate()
            .map(|(i, (name, s))| {
                let driven = driven.get(i).copied().unwrap_or(false);
                JointState {
                    name: name.clone(),
                    position: s.position,
                    velocity: s.velocity,
                    effort: driven.then_some(s.effort),
                    target: s.target.filter(|_| driven),
                    saturated: s.saturated && driven,
                    at_limit: s.at_limit,
                }
            })
            .collect(),
    }
}

/// The `/mechanisms` message of a group's models.
pub fn mechanism_states(
    time_ns: u64,
    step: u64,
    names: &[String],
    states: &[crate::record::MechanismState],
) -> MechanismStates {
    MechanismStates {
        timestamp: Some(timestamp(time_ns)),
        step,
        mechanisms: names
            .iter()
            .zip(states)
            .map(|(name, s)| MechanismState {
                name: name.clone(),
                linear_momentum: vec3(&s.linear_momentum),
                angular_momentum: vec3(&s.angular_momentum),
                com: vec3(&s.com),
                kinetic_energy: s.kinetic_energy,
                potential_energy: s.potential_energy,
                energy: s.kinetic_energy + s.potential_energy,
                residual_m: s.residual_m,
                residual_rad: s.residual_rad,
            })
            .collect(),
    }
}

/// Back from a decoded message to the recorded state.
pub fn from_proto(m: &MechanismState) -> crate::record::MechanismState {
    let v = |v: &Option<super::proto::Vector3>| {
        v.as_ref().map_or_else(nalgebra::Vector3::zeros, |v| {
            nalgebra::Vector3::new(v.x, v.y, v.z)
        })
    };
    crate::record::MechanismState {
        linear_momentum: v(&m.linear_momentum),
        angular_momentum: v(&m.angular_momentum),
        com: v(&m.com),
        kinetic_energy: m.kinetic_energy,
        potential_energy: m.potential_energy,
        residual_m: m.residual_m,
        residual_rad: m.residual_rad,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A recording without drives writes the bytes it wrote before drives existed, whatever
    /// the frame holds; with drives, the three fields are encoded (the target only when set).
    #[test]
    fn drive_fields_are_written_only_in_driven_recordings() {
        let names = ["j".to_string()];
        let plain = crate::record::JointState {
            position: 0.5,
            velocity: -1.0,
            ..Default::default()
        };
        let driven_state = crate::record::JointState {
            effort: 2.0,
            target: Some(0.25),
            saturated: true,
            ..plain
        };
        let bytes = |s, driven: &[bool]| joint_states(7, 1, &names, &[s], driven).encode_to_vec();
        assert_eq!(bytes(driven_state, &[]), bytes(plain, &[]));
        assert_eq!(bytes(driven_state, &[false]), bytes(plain, &[]));
        let decoded = JointStates::decode(&*bytes(driven_state, &[true])).unwrap();
        let j = &decoded.joints[0];
        assert_eq!(
            (j.effort, j.target, j.saturated),
            (Some(2.0), Some(0.25), true)
        );
        // An effort and a target of 0 are still present (proto3 `optional` keeps them).
        let zero = crate::record::JointState {
            target: Some(0.0),
            ..plain
        };
        let decoded = JointStates::decode(&*bytes(zero, &[true])).unwrap();
        assert_eq!(
            (decoded.joints[0].effort, decoded.joints[0].target),
            (Some(0.0), Some(0.0))
        );
    }
}
