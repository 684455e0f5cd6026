//! The MCAP `/contacts` topic (`tumble.Contacts`): one message per recorded step, written only
//! when the run can have contacts ([`crate::record::RecordingLayout::contacts`]; per topic
//! group, under its prefix like `/tf`, holding the contacts whose body `a` is the group's).
//!
//! ```text
//! message Contact  { string body_a = 1; string body_b = 2; bool ground = 3;
//!                    Vector3 point = 4; Vector3 normal = 5; Vector3 force = 6;
//!                    Vector3 impulse = 7; double gap_m = 8; }
//! message Contacts { google.protobuf.Timestamp timestamp = 1; uint64 step = 2;
//!                    repeated Contact contacts = 3; }
//! ```
//!
//! The contacts of the step that ended at the recorded time ([`crate::record::ContactState`]):
//! `body_a` the name of the body the impulse acts on (as in `/bodies`), `body_b` the other
//! body's, or `ground` with `ground = true` for the ground (`ground` tells the ground from a
//! body that happens to be named so); `point` the contact point on `b`'s surface (m), `normal`
//! the unit normal from `b` toward `a`, `impulse` the impulse on `a` over the step (N s),
//! `force` the mean force over the step, `impulse / dt` (N), `gap_m` the signed gap at the start
//! of the step (m, negative: penetration); world frame. A step without contacts has an empty
//! list. The schema is a self-contained `FileDescriptorSet` (`tumble.Vector3` from
//! `tumble/BodyStates.proto`, which it includes, as `/bodies` does).

use super::mechanism_proto::{
    descriptor, field, message, repeated, stamp_and_step, timestamp, vec3,
};
use crate::record::ContactState;
use crate::record::contacts::body_b_name;
use prost_types::field_descriptor_proto::Type;

/// Schema name of the `/contacts` messages.
pub const CONTACTS_SCHEMA: &str = "tumble.Contacts";

/// `tumble.Contact`
#[derive(Clone, PartialEq, prost::Message)]
pub struct Contact {
    #[prost(string, tag = "1")]
    pub body_a: String,
    #[prost(string, tag = "2")]
    pub body_b: String,
    #[prost(bool, tag = "3")]
    pub ground: bool,
    #[prost(message, optional, tag = "4")]
    pub point: Option<super::proto::Vector3>,
    #[prost(message, optional, tag = "5")]
    pub normal: Option<super::proto::Vector3>,
    #[prost(message, optional, tag = "6")]
    pub force: Option<super::proto::Vector3>,
    #[prost(message, optional, tag = "7")]
    pub impulse: Option<super::proto::Vector3>,
    #[prost(double, tag = "8")]
    pub gap_m: f64,
}

/// `tumble.Contacts`
#[derive(Clone, PartialEq, prost::Message)]
pub struct Contacts {
    #[prost(message, optional, tag = "1")]
    pub timestamp: Option<prost_types::Timestamp>,
    #[prost(uint64, tag = "2")]
    pub step: u64,
    #[prost(message, repeated, tag = "3")]
    pub contacts: Vec<Contact>,
}

/// The `FileDescriptorSet` of [`Contacts`] (field numbers as the `prost` tags above).
pub fn contacts_descriptor() -> Vec<u8> {
    let [ts, step] = stamp_and_step();
    let v3 = |name: &str, n| field(name, n, Type::Message, Some(".tumble.Vector3"));
    descriptor(
        "tumble/Contacts.proto",
        vec![
            message(
                "Contact",
                vec![
                    field("body_a", 1, Type::String, None),
                    field("body_b", 2, Type::String, None),
                    field("ground", 3, Type::Bool, None),
                    v3("point", 4),
                    v3("normal", 5),
                    v3("force", 6),
                    v3("impulse", 7),
                    field("gap_m", 8, Type::Double, None),
                ],
            ),
            message(
                "Contacts",
                vec![ts, step, repeated("contacts", 3, ".tumble.Contact")],
            ),
        ],
    )
}

/// The `/contacts` message of `contacts`; `names` the layout's body names.
pub fn contacts<'a>(
    time_ns: u64,
    step: u64,
    names: &[String],
    contacts: impl Iterator<Item = &'a ContactState>,
) -> Contacts {
    Contacts {
        timestamp: Some(timestamp(time_ns)),
        step,
        contacts: contacts
            .map(|c| Contact {
                body_a: names[c.body_a].clone(),
                body_b: body_b_name(names, c).to_string(),
                ground: c.body_b.is_none(),
                point: vec3(&c.point_world),
                normal: vec3(&c.normal_world),
                force: vec3(&c.force_world),
                impulse: vec3(&c.impulse_world),
                gap_m: c.gap_m,
            })
            .collect(),
    }
}

/// Back from a decoded message to the recorded contact; `index` finds a body by name (`None`:
/// the layout has no such body).
pub fn from_proto(
    c: &Contact,
    index: impl Fn(&str) -> Option<usize>,
) -> Result<ContactState, String> {
    let body = |name: &str| index(name).ok_or_else(|| format!("body {name:?}"));
    let v = |v: &Option<super::proto::Vector3>| {
        v.as_ref().map_or_else(nalgebra::Vector3::zeros, |v| {
            nalgebra::Vector3::new(v.x, v.y, v.z)
        })
    };
    Ok(ContactState {
        body_a: body(&c.body_a)?,
        body_b: if c.ground {
            None
        } else {
            Some(body(&c.body_b)?)
        },
        point_world: v(&c.point),
        normal_world: v(&c.normal),
        force_world: v(&c.force),
        impulse_world: v(&c.impulse),
        gap_m: c.gap_m,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use prost::Message as _;

    /// A contact with the ground and one between bodies encode and decode back to the same
    /// states; the ground is told from a body named `ground` by the flag.
    #[test]
    fn contacts_round_trip_and_the_ground_flag_decides() {
        let names = ["ground".to_string(), "b".into()];
        let states = [
            ContactState {
                body_a: 1,
                body_b: None,
                point_world: nalgebra::Vector3::new(0.5, -0.25, 0.0),
                normal_world: nalgebra::Vector3::z(),
                force_world: nalgebra::Vector3::new(0.5, 0.0, 19.6),
                impulse_world: nalgebra::Vector3::new(5e-4, 0.0, 0.0196),
                gap_m: -2e-7,
            },
            ContactState {
                body_a: 1,
                body_b: Some(0),
                point_world: nalgebra::Vector3::new(1.0, 2.0, 3.0),
                normal_world: -nalgebra::Vector3::x(),
                force_world: nalgebra::Vector3::new(-3.0, 0.0, 0.0),
                impulse_world: nalgebra::Vector3::new(-0.003, 0.0, 0.0),
                gap_m: 1e-9,
            },
        ];
        let bytes = contacts(1_500_000_000, 1500, &names, states.iter()).encode_to_vec();
        let decoded = Contacts::decode(&*bytes).unwrap();
        assert_eq!(decoded.step, 1500);
        let ts = decoded.timestamp.unwrap();
        assert_eq!((ts.seconds, ts.nanos), (1, 500_000_000));
        let c = &decoded.contacts;
        assert_eq!(
            (
                c[0].body_b.as_str(),
                c[0].ground,
                c[1].body_b.as_str(),
                c[1].ground
            ),
            ("ground", true, "ground", false)
        );
        let index = |n: &str| names.iter().position(|m| m == n);
        let back: Vec<ContactState> = c.iter().map(|c| from_proto(c, index).unwrap()).collect();
        assert_eq!(back, states);
        let unknown = from_proto(&c[0], |_| None).unwrap_err();
        assert_eq!(unknown, "body \"b\"");
    }
}
