//! The `/tf` and `/bodies` messages encoded straight from the frame, without building the
//! `prost` structs (one `String` per transform and body per step, and their frees, cost more
//! than the encoding itself at 10 000 bodies).
//!
//! The bytes are exactly what `prost` writes for `foxglove.FrameTransforms` and
//! `tumble.BodyStates` (tested against `prost` itself below): fields in tag order, proto3 rules
//! (a scalar equal to its default, `0`, `0.0` or `-0.0`, and an empty string are left out; a
//! present sub-message is written even when empty), lengths as varints. Wire format:
//! <https://protobuf.dev/programming-guides/encoding/>.

use crate::record::BodyState;
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

/// Bytes of an encoded id field copied as one fixed-size block (the rest is slack).
const ID_BLOCK: usize = 48;

/// String fields of a message's repeated entries, encoded once per recording instead of once
/// per entry and step: the `parent_frame_id` and `child_frame_id` fields (tags 2 and 3) of each
/// transform of a `/tf` message ([`Self::frame_ids`]), or the `name` field (tag 1) of each body
/// of a `/bodies` message ([`Self::names`]). Fields that fit [`ID_BLOCK`] bytes are kept padded
/// to it and copied as one fixed-size block (a variable-length copy per string per entry cost
/// more than the rest of the encoding at 10 000 bodies); longer ones as they are.
#[derive(Debug, Clone)]
pub struct EncodedFields {
    short: Vec<([u8; ID_BLOCK], u8)>,
    /// `(index, bytes)` of the fields longer than [`ID_BLOCK`], by index; their `short` entry
    /// is unused.
    long: Vec<(usize, Vec<u8>)>,
}

impl EncodedFields {
    fn from_fields(count: usize, mut encode: impl FnMut(usize, &mut Vec<u8>)) -> Self {
        let mut short = Vec::with_capacity(count);
        let mut long = Vec::new();
        let mut field = Vec::new();
        for i in 0..count {
            field.clear();
            encode(i, &mut field);
            let mut block = [0u8; ID_BLOCK];
            if field.len() <= ID_BLOCK {
                block[..field.len()].copy_from_slice(&field);
            } else {
                long.push((i, field.clone()));
            }
            short.push((block, field.len().min(ID_BLOCK) as u8));
        }
        Self { short, long }
    }

    /// The id fields of transforms from `parent` to each of `child_ids`, in order.
    pub fn frame_ids(parent: &str, child_ids: &[String]) -> Self {
        Self::from_fields(child_ids.len(), |i, field| {
            for (tag, s) in [(2, parent), (3, child_ids[i].as_str())] {
                put_string(field, tag, s);
            }
        })
    }

    /// The name fields of bodies named `names`, in order.
    pub fn names(names: &[String]) -> Self {
        Self::from_fields(names.len(), |i, field| put_string(field, 1, &names[i]))
    }

    pub fn len(&self) -> usize {
        self.short.len()
    }

    pub fn is_empty(&self) -> bool {
        self.short.is_empty()
    }

    /// Encoded length of field `i`; `long_at` walks [`Self::long`] in index order.
    fn field_len(&self, i: usize, long_at: &mut usize) -> usize {
        match self.long.get(*long_at) {
            Some((j, bytes)) if *j == i => {
                *long_at += 1;
                bytes.len()
            }
            _ => self.short[i].1 as usize,
        }
    }

    /// Writes field `i` at `c`; `long_at` as in [`Self::field_len`].
    fn write(&self, i: usize, long_at: &mut usize, c: &mut Cursor<'_>) {
        match self.long.get(*long_at) {
            Some((j, bytes)) if *j == i => {
                c.bytes(bytes);
                *long_at += 1;
            }
            _ => {
                let (block, len) = &self.short[i];
                c.block(block, *len as usize);
            }
        }
    }
}

/// A string field `tag` (left out when empty, the proto3 rule).
fn put_string(buf: &mut Vec<u8>, tag: u8, s: &str) {
    if !s.is_empty() {
        put_message(buf, tag, s.len(), |buf| buf.extend_from_slice(s.as_bytes()));
    }
}

/// A write position in a buffer sized beforehand with at least [`ID_BLOCK`] bytes of slack
/// past the last byte written, so every copy has a fixed length.
struct Cursor<'a> {
    out: &'a mut [u8],
    at: usize,
}

impl Cursor<'_> {
    fn byte(&mut self, b: u8) {
        self.out[self.at] = b;
        self.at += 1;
    }

    fn varint(&mut self, mut v: u64) {
        while v >= 0x80 {
            self.byte((v as u8) | 0x80);
            v >>= 7;
        }
        self.byte(v as u8);
    }

    fn doubles(&mut self, values: &[f64]) {
        for (i, v) in values.iter().enumerate() {
            if *v != 0.0 {
                self.out[self.at] = (((i + 1) as u8) << 3) | 1;
                self.out[self.at + 1..self.at + 9].copy_from_slice(&v.to_le_bytes());
                self.at += 9;
            }
        }
    }

    fn block(&mut self, block: &[u8; ID_BLOCK], len: usize) {
        self.out[self.at..self.at + ID_BLOCK].copy_from_slice(block);
        self.at += len;
    }

    fn bytes(&mut self, bytes: &[u8]) {
        self.out[self.at..self.at + bytes.len()].copy_from_slice(bytes);
        self.at += bytes.len();
    }
}

/// Appends `count` repeated message fields `tag` to `buf`: entry `i` of `inner_len(i, long_at)`
/// bytes, written by `write(i, long_at, cursor)` (both walk the long fields of an
/// [`EncodedFields`] with `long_at`). The total length is computed first and `buf` sized once,
/// with [`ID_BLOCK`] bytes of slack for the fixed-size copies, then cut to size.
fn put_entries(
    buf: &mut Vec<u8>,
    tag: u8,
    count: usize,
    inner_len: impl Fn(usize, &mut usize) -> usize,
    mut write: impl FnMut(usize, &mut usize, &mut Cursor<'_>),
) {
    let mut long_at = 0;
    let total: usize = (0..count)
        .map(|i| message_field_len(inner_len(i, &mut long_at)))
        .sum();
    let start = buf.len();
    // Exactly what is needed: growing by doubling would keep up to twice the largest message
    // (at 100 000 bodies a 12.5 MB `/bodies` message left a 19.2 MB buffer).
    buf.reserve_exact((start + total + ID_BLOCK).saturating_sub(buf.len()));
    buf.resize(start + total + ID_BLOCK, 0);
    let mut c = Cursor {
        out: &mut buf[start..],
        at: 0,
    };
    let mut long_at = 0;
    for i in 0..count {
        let before = long_at;
        c.byte((tag << 3) | 2);
        c.varint(inner_len(i, &mut long_at) as u64);
        long_at = before;
        write(i, &mut long_at, &mut c);
    }
    debug_assert_eq!(c.at, total);
    buf.truncate(start + total);
}

/// Appends `foxglove.FrameTransforms { transforms }` to `buf`: one `FrameTransform` per pose,
/// stamped `time_ns`, parent `parent`, child `child_ids[i]` ([`frame_transforms_with`] with the
/// id fields encoded on the spot).
pub fn frame_transforms(
    buf: &mut Vec<u8>,
    time_ns: u64,
    parent: &str,
    poses: &[Isometry3<f64>],
    child_ids: &[String],
) {
    frame_transforms_with(
        buf,
        time_ns,
        &EncodedFields::frame_ids(parent, child_ids),
        poses,
    );
}

/// Appends `foxglove.FrameTransforms { transforms }` to `buf`: one `FrameTransform` per pose,
/// stamped `time_ns`, its frame ids from `ids` (one pair per pose, in order). The message's
/// length is computed first and `buf` sized once; the poses are then written with fixed-size
/// copies ([`EncodedFields`]).
pub fn frame_transforms_with(
    buf: &mut Vec<u8>,
    time_ns: u64,
    ids: &EncodedFields,
    poses: &[Isometry3<f64>],
) {
    assert_eq!(ids.len(), poses.len(), "one id pair per pose");
    let (sec, nsec) = (time_ns / 1_000_000_000, time_ns % 1_000_000_000);
    let stamp = time_len(sec, nsec);
    let parts = |pose: &Isometry3<f64>| {
        let t = pose.translation.vector;
        let q = pose.rotation.quaternion().coords;
        ([t.x, t.y, t.z], [q.x, q.y, q.z, q.w])
    };
    let inner_len = |i: usize, long_at: &mut usize| {
        let (t, q) = parts(&poses[i]);
        message_field_len(stamp)
            + ids.field_len(i, long_at)
            + message_field_len(doubles_len(&t))
            + message_field_len(doubles_len(&q))
    };
    put_entries(buf, 1, poses.len(), inner_len, |i, long_at, c| {
        let (t, q) = parts(&poses[i]);
        c.byte((1 << 3) | 2);
        c.varint(stamp as u64);
        if sec != 0 {
            c.byte(0x08);
            c.varint(sec);
        }
        if nsec != 0 {
            c.byte(0x10);
            c.varint(nsec);
        }
        ids.write(i, long_at, c);
        c.byte((4 << 3) | 2);
        c.varint(doubles_len(&t) as u64);
        c.doubles(&t);
        c.byte((5 << 3) | 2);
        c.varint(doubles_len(&q) as u64);
        c.doubles(&q);
    });
}

/// Appends `tumble.BodyStates` to `buf` (see [`super::proto::BodyStates`])
/// ([`body_states_with`] with the name fields encoded on the spot).
pub fn body_states(
    buf: &mut Vec<u8>,
    time_ns: u64,
    step: u64,
    states: &[BodyState],
    names: &[String],
    total_energy: f64,
) {
    body_states_with(
        buf,
        time_ns,
        step,
        states,
        &EncodedFields::names(names),
        total_energy,
    );
}

/// Appends `tumble.BodyStates` to `buf`, the bodies' name fields from `names` (one per
/// state, in order): length first, `buf` sized once, fixed-size copies (as
/// [`frame_transforms_with`]).
pub fn body_states_with(
    buf: &mut Vec<u8>,
    time_ns: u64,
    step: u64,
    states: &[BodyState],
    names: &EncodedFields,
    total_energy: f64,
) {
    assert_eq!(names.len(), states.len(), "one name per body");
    let (sec, nsec) = (time_ns / 1_000_000_000, time_ns % 1_000_000_000);
    let stamp = time_len(sec, nsec);
    put_message(buf, 1, stamp, |buf| put_time(buf, sec, nsec));
    if step != 0 {
        buf.push(0x10);
        put_varint(buf, step);
    }
    let parts = |b: &BodyState| {
        let vectors = [b.linvel_world, b.angvel_world, b.angmom_world].map(|v| [v.x, v.y, v.z]);
        (vectors, [b.kinetic_energy, b.potential_energy])
    };
    let inner_len = |i: usize, long_at: &mut usize| {
        let (vectors, energies) = parts(&states[i]);
        names.field_len(i, long_at)
            + vectors
                .iter()
                .map(|v| message_field_len(doubles_len(v)))
                .sum::<usize>()
            + doubles_len(&energies)
    };
    put_entries(buf, 3, states.len(), inner_len, |i, long_at, c| {
        let (vectors, energies) = parts(&states[i]);
        names.write(i, long_at, c);
        for (tag, v) in (2u8..).zip(&vectors) {
            c.byte((tag << 3) | 2);
            c.varint(doubles_len(v) as u64);
            c.doubles(v);
        }
        // kinetic_energy = 5, potential_energy = 6 (wire type 1).
        for (tag, v) in [(5u8, energies[0]), (6, energies[1])] {
            if v != 0.0 {
                c.byte((tag << 3) | 1);
                c.out[c.at..c.at + 8].copy_from_slice(&v.to_le_bytes());
                c.at += 8;
            }
        }
    });
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
        let mut ids: Vec<String> = (0..poses.len())
            .map(|i| format!("box_{i:04}/box"))
            .collect();
        // With the parent field "world" (7 bytes): 41 bytes of child field fill the block.
        ids[1] = "y".repeat(ID_BLOCK - 7 - 2);
        ids[6] = "y".repeat(ID_BLOCK - 7 - 1);
        let mut ids_with_empty = ids.clone();
        ids_with_empty[2].clear();
        // Longer than a fixed block, and one exactly filling it with the parent field.
        ids_with_empty[4] = "a_very_long_model_name_0123456789/a_very_long_link_name".into();
        ids_with_empty[5] = "x".repeat(ID_BLOCK - 2);
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
        // Longer than a fixed block, and exactly filling one (tag and length: 2 bytes).
        names[5] = "n".repeat(3 * ID_BLOCK);
        names[6] = "m".repeat(ID_BLOCK - 2);
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
