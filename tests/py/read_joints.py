"""Reads the articulated-model topics of a tumble MCAP file with the official Python `mcap`
reader and `mcap-protobuf-support` (readers nobody on the tumble team wrote), plus /tf and the
/bodies totals, and prints JSON:

{"joints": {name: [[log_time_ns, step, position, velocity], ...]},
 "mechanisms": {name: [[log_time_ns, step, px, py, pz, lx, ly, lz, cx, cy, cz,
                        kinetic, potential, energy, residual_m, residual_rad], ...]},
 "total_energy": [[log_time_ns, step, total_energy of /bodies], ...],
 "frames": {child_frame_id: [[log_time_ns, tx, ty, tz, qx, qy, qz, qw], ...]},
 "schemas": {topic: schema_name}, "times_agree": bool,
 "efforts": {name: [[log_time_ns, step, effort, target, saturated, has_effort], ...]},
 "joint_fields": [field names of tumble.JointState as the file's schema declares them]}

In "efforts", `target` is null where the message has none (`HasField` of the proto3 optional
field, when the schema declares it; null too when it does not), `has_effort` whether the
message carries an effort (`HasField`, false where the schema does not declare it); `effort`
0.0 and `saturated` false where absent or undeclared (the proto3 defaults).
"""
import json
import sys

from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory


def stamp_ns(ts):
    if hasattr(ts, "seconds"):
        return ts.seconds * 1_000_000_000 + ts.nanos
    return ts.sec * 1_000_000_000 + ts.nsec


def main(path):
    joints, mechanisms, total, frames, schemas = {}, {}, [], {}, {}
    efforts, joint_fields = {}, []
    times_agree = True
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for schema, channel, message, decoded in reader.iter_decoded_messages():
            schemas[channel.topic] = schema.name
            t = message.log_time
            if channel.topic.endswith("/joints"):
                times_agree &= stamp_ns(decoded.timestamp) == t
                for j in decoded.joints:
                    joints.setdefault(j.name, []).append([t, decoded.step, j.position, j.velocity])
                    fields = j.DESCRIPTOR.fields_by_name
                    joint_fields = [f.name for f in j.DESCRIPTOR.fields]
                    target = j.target if "target" in fields and j.HasField("target") else None
                    has_effort = "effort" in fields and j.HasField("effort")
                    efforts.setdefault(j.name, []).append(
                        [t, decoded.step, j.effort if "effort" in fields else 0.0, target,
                         bool(j.saturated) if "saturated" in fields else False, has_effort])
            elif channel.topic.endswith("/mechanisms"):
                times_agree &= stamp_ns(decoded.timestamp) == t
                for m in decoded.mechanisms:
                    p, l, c = m.linear_momentum, m.angular_momentum, m.com
                    mechanisms.setdefault(m.name, []).append(
                        [t, decoded.step, p.x, p.y, p.z, l.x, l.y, l.z, c.x, c.y, c.z,
                         m.kinetic_energy, m.potential_energy, m.energy, m.residual_m,
                         m.residual_rad])
            elif channel.topic.endswith("/bodies"):
                total.append([t, decoded.step, decoded.total_energy])
            elif channel.topic.endswith("/tf"):
                for tf in decoded.transforms:
                    tr, q = tf.translation, tf.rotation
                    frames.setdefault(tf.child_frame_id, []).append(
                        [t, tr.x, tr.y, tr.z, q.x, q.y, q.z, q.w])
    json.dump({"joints": joints, "mechanisms": mechanisms, "total_energy": total,
               "frames": frames, "schemas": schemas, "times_agree": bool(times_agree),
               "efforts": efforts, "joint_fields": joint_fields},
              sys.stdout)


if __name__ == "__main__":
    main(sys.argv[1])
