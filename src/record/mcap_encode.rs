//! The `/tf` and `/bodies` messages encoded straight from the frame, without building the
//! `prost` structs (one `String` per transform and body per step, and their frees, cost more
//! than the encoding itself at 10 000 bodies).
//!
//! The bytes are exactly what `prost` writes for `foxglove.FrameTransforms` and
//! `tumble.BodyStates` (tested against `prost` itself below): fields in tag order, proto3 rules
//! (a scalar equal to its default, `0`, `0.0` or `-0.0`, and an empty string are left out; a
//! present sub-message is written even when empty), lengths as varints. Wire format:
//! <https://protobuf.dev/programming-guides/encoding/>.

use super::BodyState;
use nalgebra::Isometry3;

fn varint_len(mut v: u64) -> usize {
    let mut n = 1;
    while v >= 0x80 {
        v >>= 7;
        n += 1;
    }
    n
}

fn put_varint(buf: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        buf.push((v as u8) | 0x80);
        v >>= 7;
    }
    buf.push(v as u8);
}

/// Size of `double` fields `values` (tags 1, 2, ...): 9 bytes each non-zero one.
fn doubles_len(values: &[f64]) -> usize {
    values.iter().filter(|v| **v != 0.0).count() * 9
}

/// `double` fields with tags 1, 2, ... (wire type 1), the zeros left out.
fn put_doubles(buf: &mut Vec<u8>, values: &[f64]) {
    for (i, v) in values.iter().enumerate() {
        if *v != 0.0 {
            buf.push((((i + 1) as u8) << 3) | 1);
            buf.extend_from_slice(&v.to_le_bytes());
        }
    }
}

/// A length-delimited field `tag` holding `len` bytes that `write` then appends.
fn put_message(buf: &mut Vec<u8>, tag: u8, len: usize, write: impl FnOnce(&mut Vec<u8>)) {
    buf.push((tag << 3) | 2);
    put_varint(buf, len as u64);
    write(buf);
}

fn message_field_len(len: usize) -> usize {
    1 + varint_len(len as u64) + len
}

/// Two varint fields 1 and 2 (left out when zero): a `foxglove.Time` (uint32 sec, nsec) or a
/// `google.protobuf.Timestamp` (int64 seconds, int32 nanos, both non-negative here).
fn time_len(a: u64, b: u64) -> usize {
    let field = |v: u64| if v == 0 { 0 } else { 1 + varint_len(v) };
    field(a) + field(b)
}

fn put_time(buf: &mut Vec<u8>, a: u64, b: u64) {
    if a != 0 {
        buf.push(0x08);
        put_varint(buf, a);
    }
    if b != 0 {
        buf.push(0x10);
        put_varint(buf, b);
    }
}

/// Appends `foxglove.FrameTransforms { transforms }` to `buf`: one `FrameTransform` per pose,
/// stamped `time_ns`, parent `parent`, child `child_ids[i]`.
pub fn frame_transforms(
    buf: &mut Vec<u8>,
    time_ns: u64,
    parent: &str,
    poses: &[Isometry3<f64>],
    child_ids: &[String],
) {
    let (sec, nsec) = (time_ns / 1_000_000_000, time_ns % 1_000_000_000);
    let stamp = time_len(sec, nsec);
    for (pose, child) in poses.iter().zip(child_ids) {
        let t = pose.translation.vector;
        let q = pose.rotation.quaternion().coords;
        let t = [t.x, t.y, t.z];
        let q = [q.x, q.y, q.z, q.w];
        let string_len = |s: &str| {
            if s.is_empty() {
                0
            } else {
                message_field_len(s.len())
            }
        };
        let len = message_field_len(stamp)
            + string_len(parent)
            + string_len(child)
            + message_field_len(doubles_len(&t))
            + message_field_len(doubles_len(&q));
        put_message(buf, 1, len, |buf| {
            put_message(buf, 1, stamp, |buf| put_time(buf, sec, nsec));
            for (tag, s) in [(2, parent), (3, child.as_str())] {
                if !s.is_empty() {
                    put_message(buf, tag, s.len(), |buf| buf.extend_from_slice(s.as_bytes()));
                }
            }
            put_message(buf, 4, doubles_len(&t), |buf| put_doubles(buf, &t));
            put_message(buf, 5, doubles_len(&q), |buf| put_doubles(buf, &q));
        });
    }
}

/// Appends `tumble.BodyStates` to `buf` (see [`super::mcap::proto::BodyStates`]).
pub fn body_states(
    buf: &mut Vec<u8>,
    time_ns: u64,
    step: u64,
    states: &[BodyState],
    names: &[String],
    total_energy: f64,
) {
    let (sec, nsec) = (time_ns / 1_000_000_000, time_ns % 1_000_000_000);
    let stamp = time_len(sec, nsec);
    put_message(buf, 1, stamp, |buf| put_time(buf, sec, nsec));
    if step != 0 {
        buf.push(0x10);
        put_varint(buf, step);
    }
    for (b, name) in states.iter().zip(names) {
        let vectors = [b.linvel_world, b.angvel_world, b.angmom_world].map(|v| [v.x, v.y, v.z]);
        let energies = [b.kinetic_energy, b.potential_energy];
        let name_len = if name.is_empty() {
            0
        } else {
            message_field_len(name.len())
        };
        let len = name_len
            + vectors
                .iter()
                .map(|v| message_field_len(doubles_len(v)))
                .sum::<usize>()
            + doubles_len(&energies);
        put_message(buf, 3, len, |buf| {
            if !name.is_empty() {
                put_message(buf, 1, name.len(), |buf| {
                    buf.extend_from_slice(name.as_bytes())
                });
            }
            for (tag, v) in (2..).zip(&vectors) {
                put_message(buf, tag, doubles_len(v), |buf| put_doubles(buf, v));
            }
            // kinetic_energy = 5, potential_energy = 6 (wire type 1).
            for (tag, v) in [(5u8, energies[0]), (6, energies[1])] {
                if v != 0.0 {
                    buf.push((tag << 3) | 1);
                    buf.extend_from_slice(&v.to_le_bytes());
                }
            }
        });
    }
    if total_energy != 0.0 {
        buf.push((4 << 3) | 1);
        buf.extend_from_slice(&total_energy.to_le_bytes());
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::mcap::proto;
    use foxglove::messages::{FrameTransform, FrameTransforms, Quaternion, Timestamp, Vector3};
    use nalgebra::{Translation3, UnitQuaternion};
    use prost::Message;

    /// Values that exercise proto3's rules: zeros of both signs (left out), NaN and infinity
    /// (kept), tiny and huge magnitudes.
    const AWKWARD: [f64; 8] = [
        0.0,
        -0.0,
        1.5,
        -2.25e-300,
        f64::NAN,
        f64::INFINITY,
        1e300,
        3.0,
    ];

    fn poses() -> Vec<Isometry3<f64>> {
        (0..AWKWARD.len())
            .map(|i| {
                let v = |k: usize| AWKWARD[(i + k) % AWKWARD.len()];
                Isometry3::from_parts(
                    Translation3::new(v(0), v(1), v(2)),
                    UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(
                        v(3),
                        v(4),
                        v(5),
                        v(6),
                    )),
                )
            })
            .collect()
    }

    /// Byte for byte what prost writes (the reference: prost's own encoder of the foxglove
    /// crate's message), for times with and without seconds and nanoseconds.
    #[test]
    fn frame_transforms_match_prost() {
        let poses = poses();
        let ids: Vec<String> = (0..poses.len())
            .map(|i| format!("box_{i:04}/box"))
            .collect();
        let mut ids_with_empty = ids.clone();
        ids_with_empty[2].clear();
        for time_ns in [0u64, 7, 1_000_000_000, 12_345_678_901] {
            for (parent, ids) in [("world", &ids), ("", &ids_with_empty)] {
                let (sec, nsec) = (time_ns / 1_000_000_000, time_ns % 1_000_000_000);
                let reference = FrameTransforms {
                    transforms: poses
                        .iter()
                        .zip(ids)
                        .map(|(p, id)| {
                            let t = p.translation.vector;
                            let q = p.rotation.quaternion().coords;
                            FrameTransform {
                                timestamp: Some(Timestamp::new(sec as u32, nsec as u32)),
                                parent_frame_id: parent.into(),
                                child_frame_id: id.clone(),
                                translation: Some(Vector3 {
                                    x: t.x,
                                    y: t.y,
                                    z: t.z,
                                }),
                                rotation: Some(Quaternion {
                                    x: q.x,
                                    y: q.y,
                                    z: q.z,
                                    w: q.w,
                                }),
                            }
                        })
                        .collect(),
                }
                .encode_to_vec();
                let mut ours = Vec::new();
                frame_transforms(&mut ours, time_ns, parent, &poses, ids);
                assert_eq!(ours, reference, "t = {time_ns} ns, parent {parent:?}");
            }
        }
    }

    #[test]
    fn body_states_match_prost() {
        let states: Vec<BodyState> = (0..AWKWARD.len())
            .map(|i| {
                let v = |k: usize| AWKWARD[(i + k) % AWKWARD.len()];
                BodyState {
                    linvel_world: nalgebra::Vector3::new(v(0), v(1), v(2)),
                    angvel_world: nalgebra::Vector3::new(v(3), v(4), v(5)),
                    angmom_world: nalgebra::Vector3::new(v(6), v(7), v(0)),
                    kinetic_energy: v(1),
                    potential_energy: v(2),
                }
            })
            .collect();
        let mut names: Vec<String> = (0..states.len()).map(|i| format!("b{i}")).collect();
        names[3].clear();
        let vec3 = |v: &nalgebra::Vector3<f64>| proto::Vector3 {
            x: v.x,
            y: v.y,
            z: v.z,
        };
        for (time_ns, step, total) in [(0u64, 0u64, 0.0), (1_500_000_000, 1500, -3.5), (9, 1, 1e9)]
        {
            let reference = proto::BodyStates {
                timestamp: Some(prost_types::Timestamp {
                    seconds: (time_ns / 1_000_000_000) as i64,
                    nanos: (time_ns % 1_000_000_000) as i32,
                }),
                step,
                bodies: states
                    .iter()
                    .zip(&names)
                    .map(|(b, name)| proto::BodyState {
                        name: name.clone(),
                        linear_velocity: Some(vec3(&b.linvel_world)),
                        angular_velocity: Some(vec3(&b.angvel_world)),
                        angular_momentum: Some(vec3(&b.angmom_world)),
                        kinetic_energy: b.kinetic_energy,
                        potential_energy: b.potential_energy,
                    })
                    .collect(),
                total_energy: total,
            }
            .encode_to_vec();
            let mut ours = Vec::new();
            body_states(&mut ours, time_ns, step, &states, &names, total);
            assert_eq!(ours, reference, "t = {time_ns} ns, step {step}");
        }
    }
}
