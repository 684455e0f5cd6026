//! One recorded joint-states message decoded, whichever of the two forms a log signal reads
//! ([`super::signal_log`]):
//!
//! - ROS 2 `sensor_msgs/msg/JointState` in CDR (as tumble's ROS 2 writer,
//!   `crate::record::ros2::msgs::joint_state`, and `rosbag2` write it): an encapsulation header
//!   (`00 01` little-endian or `00 00` big-endian, two option bytes), then `header` (`int32
//!   sec`, `uint32 nanosec`, `string frame_id`), `string[] name`, `float64[] position`,
//!   `float64[] velocity`, `float64[] effort`; each primitive aligned to its size counted from
//!   the end of the encapsulation header, a string as a `uint32` length counting its NUL;
//! - tumble's protobuf `tumble.JointStates` (the `/joints` topic,
//!   `crate::record::mcap::mechanism_proto`): `repeated JointState joints = 3`, each `string
//!   name = 1; double position = 2; double velocity = 3; optional double effort = 4;` (its
//!   `target = 5` and `saturated = 6` are not needed here and skipped).
//!
//! Every length is checked against the bytes left before anything is allocated, so a damaged
//! message is an error, never a large allocation or a panic.

use anyhow::{Context, bail, ensure};

/// The quantity a signal takes from a joint's samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Quantity {
    /// rad or m (a position target).
    Position,
    /// rad/s or m/s (a velocity target).
    Velocity,
    /// N m or N (a motor's effort).
    Effort,
}

impl Quantity {
    /// The field's name in both message forms.
    pub fn name(self) -> &'static str {
        match self {
            Quantity::Position => "position",
            Quantity::Velocity => "velocity",
            Quantity::Effort => "effort",
        }
    }
}

/// What a message says about one joint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Sample {
    /// The message does not name the joint.
    Absent,
    /// The message names the joint but carries no value of the quantity (an empty array of a
    /// `JointState`, a `tumble.JointState` without `effort`).
    NoValue,
    Value(f64),
}

/// The message's encodings a log signal reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Form {
    /// `sensor_msgs/msg/JointState`, CDR.
    Ros2,
    /// `tumble.JointStates`, protobuf.
    Tumble,
}

/// `sensor_msgs/msg/JointState`'s schema name.
pub const ROS2_SCHEMA: &str = "sensor_msgs/msg/JointState";
/// `tumble.JointStates`'s schema name.
pub const TUMBLE_SCHEMA: &str = "tumble.JointStates";

impl Form {
    /// The form of a channel with schema `schema` and message encoding `encoding`, if it is
    /// one of the two.
    pub fn of(schema: &str, encoding: &str) -> Option<Self> {
        match (schema, encoding) {
            (ROS2_SCHEMA, "cdr") => Some(Form::Ros2),
            (TUMBLE_SCHEMA, "protobuf") => Some(Form::Tumble),
            _ => None,
        }
    }

    /// `joint`'s `quantity` in the message `data`, and every joint name the message holds
    /// (pushed to `names` when it has room: the error of a joint never found lists them).
    pub fn sample(
        self,
        data: &[u8],
        joint: &str,
        quantity: Quantity,
        names: &mut Vec<String>,
    ) -> anyhow::Result<Sample> {
        match self {
            Form::Ros2 => ros2_sample(data, joint, quantity, names),
            Form::Tumble => tumble_sample(data, joint, quantity, names),
        }
    }
}

/// How many joint names an error lists at most.
pub const NAMES_LISTED: usize = 32;

fn note_name(names: &mut Vec<String>, name: &str) {
    if names.len() < NAMES_LISTED && !names.iter().any(|n| n == name) {
        names.push(name.to_string());
    }
}

/// A plain-CDR (XCDR1) reader over one message.
struct Cdr<'a> {
    body: &'a [u8],
    at: usize,
    little: bool,
}

impl<'a> Cdr<'a> {
    fn new(data: &'a [u8]) -> anyhow::Result<Self> {
        ensure!(
            data.len() >= 4,
            "a CDR message of {} bytes: no encapsulation header",
            data.len()
        );
        let little = match [data[0], data[1]] {
            [0, 1] => true,
            [0, 0] => false,
            [a, b] => bail!(
                "CDR encapsulation {a:02x} {b:02x} is not plain CDR (00 00 or 00 01, as ROS 2 \
                 writes JointState)"
            ),
        };
        Ok(Self {
            body: &data[4..],
            at: 0,
            little,
        })
    }

    fn take(&mut self, align: usize, n: usize) -> anyhow::Result<&'a [u8]> {
        let start = self.at.div_ceil(align) * align;
        let end = start
            .checked_add(n)
            .filter(|&e| e <= self.body.len())
            .context("the CDR message ends early")?;
        self.at = end;
        Ok(&self.body[start..end])
    }

    fn u32(&mut self) -> anyhow::Result<u32> {
        let b: [u8; 4] = self.take(4, 4)?.try_into().expect("4 bytes");
        Ok(if self.little {
            u32::from_le_bytes(b)
        } else {
            u32::from_be_bytes(b)
        })
    }

    fn f64(&mut self) -> anyhow::Result<f64> {
        let b: [u8; 8] = self.take(8, 8)?.try_into().expect("8 bytes");
        Ok(if self.little {
            f64::from_le_bytes(b)
        } else {
            f64::from_be_bytes(b)
        })
    }

    fn string(&mut self) -> anyhow::Result<&'a str> {
        let len = self.u32()? as usize;
        ensure!(len >= 1, "a CDR string without its terminating NUL");
        let bytes = self.take(1, len)?;
        std::str::from_utf8(&bytes[..len - 1]).context("a CDR string that is not UTF-8")
    }

    /// A sequence's element count, checked against the bytes left (each element at least
    /// `min_bytes`).
    fn count(&mut self, min_bytes: usize) -> anyhow::Result<usize> {
        let n = self.u32()? as usize;
        let left = self.body.len().saturating_sub(self.at);
        ensure!(
            n.saturating_mul(min_bytes) <= left,
            "a CDR sequence of {n} elements in {left} bytes"
        );
        Ok(n)
    }

    /// Element `k` of a `float64[]` of `n` elements (the sequence skipped).
    fn f64_sequence_at(&mut self, k: Option<usize>) -> anyhow::Result<(usize, Option<f64>)> {
        let n = self.count(8)?;
        let mut found = None;
        for i in 0..n {
            let v = self.f64()?;
            if Some(i) == k {
                found = Some(v);
            }
        }
        Ok((n, found))
    }
}

fn ros2_sample(
    data: &[u8],
    joint: &str,
    quantity: Quantity,
    names: &mut Vec<String>,
) -> anyhow::Result<Sample> {
    let mut r = Cdr::new(data)?;
    r.u32()?; // header.stamp.sec
    r.u32()?; // header.stamp.nanosec
    r.string()?; // header.frame_id
    let n = r.count(5)?;
    let mut index = None;
    for i in 0..n {
        let name = r.string()?;
        note_name(names, name);
        if name == joint && index.is_none() {
            index = Some(i);
        }
    }
    let mut value = None;
    for (field, q) in [
        ("position", Quantity::Position),
        ("velocity", Quantity::Velocity),
        ("effort", Quantity::Effort),
    ] {
        let (len, v) = r.f64_sequence_at(index)?;
        ensure!(
            len == 0 || len == n,
            "JointState has {len} {field} values for {n} names"
        );
        if q == quantity {
            value = v;
        }
    }
    Ok(match (index, value) {
        (None, _) => Sample::Absent,
        (Some(_), None) => Sample::NoValue,
        (Some(_), Some(v)) => Sample::Value(v),
    })
}

/// `tumble.JointState`, the fields a signal takes (`target = 5` and `saturated = 6`, and any
/// tag a later tumble adds, are skipped as protobuf skips unknown fields).
#[derive(Clone, PartialEq, prost::Message)]
struct LoggedJoint {
    #[prost(string, tag = "1")]
    name: String,
    #[prost(double, tag = "2")]
    position: f64,
    #[prost(double, tag = "3")]
    velocity: f64,
    #[prost(double, optional, tag = "4")]
    effort: Option<f64>,
}

/// `tumble.JointStates`: only the joints (the timestamp and step are skipped).
#[derive(Clone, PartialEq, prost::Message)]
struct LoggedJoints {
    #[prost(message, repeated, tag = "3")]
    joints: Vec<LoggedJoint>,
}

fn tumble_sample(
    data: &[u8],
    joint: &str,
    quantity: Quantity,
    names: &mut Vec<String>,
) -> anyhow::Result<Sample> {
    let message = <LoggedJoints as prost::Message>::decode(data)
        .context("not a tumble.JointStates protobuf message")?;
    for j in &message.joints {
        note_name(names, &j.name);
    }
    let Some(j) = message.joints.iter().find(|j| j.name == joint) else {
        return Ok(Sample::Absent);
    };
    Ok(match quantity {
        Quantity::Position => Sample::Value(j.position),
        Quantity::Velocity => Sample::Value(j.velocity),
        Quantity::Effort => j.effort.map_or(Sample::NoValue, Sample::Value),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A JointState in CDR, built byte by byte (independently of the writer), either endianness.
    fn cdr(little: bool, names: &[&str], arrays: [&[f64]; 3]) -> Vec<u8> {
        let mut b = vec![0, u8::from(little), 0, 0];
        let pad = |b: &mut Vec<u8>, n: usize| {
            while !(b.len() - 4).is_multiple_of(n) {
                b.push(0);
            }
        };
        let u32 = |b: &mut Vec<u8>, v: u32| {
            pad(b, 4);
            b.extend(if little {
                v.to_le_bytes()
            } else {
                v.to_be_bytes()
            });
        };
        u32(&mut b, 7);
        u32(&mut b, 9);
        u32(&mut b, 1);
        b.push(0);
        u32(&mut b, names.len() as u32);
        for n in names {
            u32(&mut b, n.len() as u32 + 1);
            b.extend(n.as_bytes());
            b.push(0);
        }
        for a in arrays {
            u32(&mut b, a.len() as u32);
            for v in a {
                pad(&mut b, 8);
                b.extend(if little {
                    v.to_le_bytes()
                } else {
                    v.to_be_bytes()
                });
            }
        }
        b
    }

    #[test]
    fn cdr_joint_states_give_the_named_joints_values_in_both_byte_orders() {
        for little in [true, false] {
            let data = cdr(
                little,
                &["a", "elbow"],
                [&[1.0, 2.0], &[3.0, 4.0], &[5.0, 6.0]],
            );
            let mut names = Vec::new();
            for (q, want) in [
                (Quantity::Position, 2.0),
                (Quantity::Velocity, 4.0),
                (Quantity::Effort, 6.0),
            ] {
                assert_eq!(
                    Form::Ros2.sample(&data, "elbow", q, &mut names).unwrap(),
                    Sample::Value(want)
                );
            }
            assert_eq!(names, ["a", "elbow"]);
            assert_eq!(
                Form::Ros2
                    .sample(&data, "knee", Quantity::Position, &mut names)
                    .unwrap(),
                Sample::Absent
            );
            let no_effort = cdr(little, &["elbow"], [&[1.0], &[], &[]]);
            assert_eq!(
                Form::Ros2
                    .sample(&no_effort, "elbow", Quantity::Effort, &mut names)
                    .unwrap(),
                Sample::NoValue
            );
        }
    }

    /// What tumble's own ROS 2 writer encodes reads back.
    #[test]
    fn the_ros2_writers_bytes_read_back() {
        let mut buf = Vec::new();
        let stamp = crate::record::ros2::msgs::Stamp { sec: 3, nanosec: 1 };
        crate::record::ros2::msgs::joint_state(
            &mut buf,
            stamp,
            &["s".into(), "e".into()],
            &[0.25, -0.5],
            &[1.5, 2.5],
            &[],
        )
        .unwrap();
        let mut names = Vec::new();
        let s = |q| Form::Ros2.sample(&buf, "e", q, &mut Vec::new()).unwrap();
        assert_eq!(s(Quantity::Position), Sample::Value(-0.5));
        assert_eq!(s(Quantity::Velocity), Sample::Value(2.5));
        assert_eq!(s(Quantity::Effort), Sample::NoValue);
        Form::Ros2
            .sample(&buf, "x", Quantity::Position, &mut names)
            .unwrap();
        assert_eq!(names, ["s", "e"]);
    }

    /// Damaged messages are errors: short, a length past the end, arrays of the wrong length,
    /// another encapsulation.
    #[test]
    fn damaged_cdr_is_an_error() {
        let good = cdr(true, &["elbow"], [&[1.0], &[], &[]]);
        let mut names = Vec::new();
        let mut sample = |data: &[u8]| {
            Form::Ros2
                .sample(data, "elbow", Quantity::Position, &mut names)
                .unwrap_err()
                .to_string()
        };
        assert!(sample(&good[..good.len() - 3]).contains("ends early"));
        assert!(sample(&good[..2]).contains("no encapsulation header"));
        let mut huge = good.clone();
        huge[20..24].copy_from_slice(&u32::MAX.to_le_bytes()); // the name count
        assert!(sample(&huge).contains("sequence of 4294967295"), "{huge:?}");
        let mut xcdr2 = good.clone();
        xcdr2[1] = 7;
        assert!(sample(&xcdr2).contains("not plain CDR"));
        let wrong = cdr(true, &["elbow"], [&[1.0, 2.0], &[], &[]]);
        assert!(sample(&wrong).contains("2 position values for 1 names"));
    }

    /// `tumble.JointState` as the recordings write it since issue 30 (all six tags).
    #[derive(Clone, PartialEq, prost::Message)]
    struct Written {
        #[prost(string, tag = "1")]
        name: String,
        #[prost(double, tag = "2")]
        position: f64,
        #[prost(double, tag = "3")]
        velocity: f64,
        #[prost(double, optional, tag = "4")]
        effort: Option<f64>,
        #[prost(double, optional, tag = "5")]
        target: Option<f64>,
        #[prost(bool, tag = "6")]
        saturated: bool,
    }

    /// `tumble.JointStates` with its step (the timestamp left out).
    #[derive(Clone, PartialEq, prost::Message)]
    struct WrittenAll {
        #[prost(uint64, tag = "2")]
        step: u64,
        #[prost(message, repeated, tag = "3")]
        joints: Vec<Written>,
    }

    #[test]
    fn tumble_joint_states_give_position_velocity_and_effort_when_present() {
        use prost::Message as _;
        let message = WrittenAll {
            step: 12,
            joints: vec![
                Written {
                    name: "arm/elbow".into(),
                    position: 0.5,
                    velocity: -1.0,
                    effort: Some(2.0),
                    target: Some(0.4),
                    saturated: true,
                },
                Written {
                    name: "arm/wrist".into(),
                    position: 0.1,
                    velocity: 0.2,
                    effort: None,
                    target: None,
                    saturated: false,
                },
            ],
        }
        .encode_to_vec();
        let mut names = Vec::new();
        let mut s = |joint, q| Form::Tumble.sample(&message, joint, q, &mut names).unwrap();
        assert_eq!(s("arm/elbow", Quantity::Position), Sample::Value(0.5));
        assert_eq!(s("arm/elbow", Quantity::Velocity), Sample::Value(-1.0));
        assert_eq!(s("arm/elbow", Quantity::Effort), Sample::Value(2.0));
        assert_eq!(s("arm/wrist", Quantity::Effort), Sample::NoValue);
        assert_eq!(s("elbow", Quantity::Position), Sample::Absent);
        assert_eq!(names, ["arm/elbow", "arm/wrist"]);
        let e = Form::Tumble
            .sample(&[0xff, 0xff], "x", Quantity::Position, &mut names)
            .unwrap_err();
        assert!(e.to_string().contains("not a tumble.JointStates"), "{e}");
    }

    #[test]
    fn only_the_two_joint_state_forms_are_recognised() {
        assert_eq!(Form::of(ROS2_SCHEMA, "cdr"), Some(Form::Ros2));
        assert_eq!(Form::of(TUMBLE_SCHEMA, "protobuf"), Some(Form::Tumble));
        assert_eq!(Form::of(ROS2_SCHEMA, "json"), None);
        assert_eq!(Form::of("tumble.BodyStates", "protobuf"), None);
    }
}
