//! Protobuf messages of the MCAP `/bodies` topic (`package tumble`) and their self-contained
//! descriptor, which the `/joints` and `/mechanisms` schemas ([`super::mechanism_proto`]) build
//! on.

use prost::Message;

/// Schema name of the `/bodies` messages.
pub const BODY_STATES_SCHEMA: &str = "tumble.BodyStates";

/// `tumble.Vector3`
#[derive(Clone, PartialEq, prost::Message)]
pub struct Vector3 {
    #[prost(double, tag = "1")]
    pub x: f64,
    #[prost(double, tag = "2")]
    pub y: f64,
    #[prost(double, tag = "3")]
    pub z: f64,
}

/// `tumble.BodyState`: one body at one instant, world frame, SI units.
#[derive(Clone, PartialEq, prost::Message)]
pub struct BodyState {
    /// The body's frame id (as in `/tf`).
    #[prost(string, tag = "1")]
    pub name: String,
    /// Velocity of the centre of mass, m/s.
    #[prost(message, optional, tag = "2")]
    pub linear_velocity: Option<Vector3>,
    /// Angular velocity, rad/s.
    #[prost(message, optional, tag = "3")]
    pub angular_velocity: Option<Vector3>,
    /// Angular momentum about the centre of mass, kg m^2/s.
    #[prost(message, optional, tag = "4")]
    pub angular_momentum: Option<Vector3>,
    /// J
    #[prost(double, tag = "5")]
    pub kinetic_energy: f64,
    /// J, zero at the world origin.
    #[prost(double, tag = "6")]
    pub potential_energy: f64,
}

/// `tumble.BodyStates`: every body at one recorded step.
#[derive(Clone, PartialEq, prost::Message)]
pub struct BodyStates {
    #[prost(message, optional, tag = "1")]
    pub timestamp: Option<prost_types::Timestamp>,
    /// Integrator step index.
    #[prost(uint64, tag = "2")]
    pub step: u64,
    #[prost(message, repeated, tag = "3")]
    pub bodies: Vec<BodyState>,
    /// Sum of kinetic and potential energy over all bodies, J.
    #[prost(double, tag = "4")]
    pub total_energy: f64,
}

/// The `FileDescriptorSet` describing [`BodyStates`], built from the message definitions
/// above (kept in one place: the field numbers here must match the `prost` tags).
pub fn body_states_descriptor() -> Vec<u8> {
    use prost_types::FileDescriptorSet;
    FileDescriptorSet {
        file: body_states_files().to_vec(),
    }
    .encode_to_vec()
}

/// The files of [`body_states_descriptor`]: `google/protobuf/timestamp.proto` and
/// `tumble/BodyStates.proto` (which defines `tumble.Vector3`; other tumble schemas depend on
/// it rather than define it again, so one descriptor pool can hold them all).
pub fn body_states_files() -> [prost_types::FileDescriptorProto; 2] {
    use prost_types::field_descriptor_proto::{Label, Type};
    use prost_types::{DescriptorProto, FieldDescriptorProto, FileDescriptorProto};

    fn field(
        name: &str,
        number: i32,
        ty: Type,
        label: Label,
        type_name: Option<&str>,
    ) -> FieldDescriptorProto {
        FieldDescriptorProto {
            name: Some(name.into()),
            number: Some(number),
            label: Some(label as i32),
            r#type: Some(ty as i32),
            type_name: type_name.map(str::to_string),
            json_name: None,
            ..Default::default()
        }
    }
    fn message(name: &str, fields: Vec<FieldDescriptorProto>) -> DescriptorProto {
        DescriptorProto {
            name: Some(name.into()),
            field: fields,
            ..Default::default()
        }
    }
    let one = Label::Optional;
    let timestamp_file = FileDescriptorProto {
        name: Some("google/protobuf/timestamp.proto".into()),
        package: Some("google.protobuf".into()),
        message_type: vec![message(
            "Timestamp",
            vec![
                field("seconds", 1, Type::Int64, one, None),
                field("nanos", 2, Type::Int32, one, None),
            ],
        )],
        syntax: Some("proto3".into()),
        ..Default::default()
    };
    let vec3 = |name: &str, n| field(name, n, Type::Message, one, Some(".tumble.Vector3"));
    let tumble_file = FileDescriptorProto {
        name: Some("tumble/BodyStates.proto".into()),
        package: Some("tumble".into()),
        dependency: vec!["google/protobuf/timestamp.proto".into()],
        message_type: vec![
            message(
                "Vector3",
                vec![
                    field("x", 1, Type::Double, one, None),
                    field("y", 2, Type::Double, one, None),
                    field("z", 3, Type::Double, one, None),
                ],
            ),
            message(
                "BodyState",
                vec![
                    field("name", 1, Type::String, one, None),
                    vec3("linear_velocity", 2),
                    vec3("angular_velocity", 3),
                    vec3("angular_momentum", 4),
                    field("kinetic_energy", 5, Type::Double, one, None),
                    field("potential_energy", 6, Type::Double, one, None),
                ],
            ),
            message(
                "BodyStates",
                vec![
                    field(
                        "timestamp",
                        1,
                        Type::Message,
                        one,
                        Some(".google.protobuf.Timestamp"),
                    ),
                    field("step", 2, Type::Uint64, one, None),
                    field(
                        "bodies",
                        3,
                        Type::Message,
                        Label::Repeated,
                        Some(".tumble.BodyState"),
                    ),
                    field("total_energy", 4, Type::Double, one, None),
                ],
            ),
        ],
        syntax: Some("proto3".into()),
        ..Default::default()
    };
    [timestamp_file, tumble_file]
}
