"""Reads a tumble MCAP file with the official Python `mcap` reader and `mcap-protobuf-support`
(readers nobody on the tumble team wrote) and prints what it decoded as JSON:

{"frames": {child_frame_id: [[log_time_ns, tx, ty, tz, qx, qy, qz, qw], ...]},
 "bodies": {name: [[log_time_ns, kinetic_energy, potential_energy, Lx, Ly, Lz, wx, wy, wz, vx, vy, vz], ...]},
 "times_agree": bool,   # every message: log_time == publish_time == its own timestamp
 "schemas": {topic: schema_name}, "metadata": {name: {key: value}}, "message_count": n}
"""
import json
import sys

from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory


def stamp_ns(ts):
    # foxglove.Timestamp / google.protobuf.Timestamp both have (seconds|sec, nanos|nsec)
    if hasattr(ts, "seconds"):
        return ts.seconds * 1_000_000_000 + ts.nanos
    return ts.sec * 1_000_000_000 + ts.nsec


def main(path):
    frames, bodies, schemas, metadata = {}, {}, {}, {}
    times_agree = True
    count = 0
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for record in reader.iter_metadata():
            metadata[record.name] = dict(record.metadata)
        for schema, channel, message, decoded in reader.iter_decoded_messages():
            count += 1
            schemas[channel.topic] = schema.name
            times_agree &= message.log_time == message.publish_time
            if channel.topic.endswith("/tf"):
                for tf in decoded.transforms:
                    times_agree &= stamp_ns(tf.timestamp) == message.log_time
                    times_agree &= tf.parent_frame_id == "world"
                    t, q = tf.translation, tf.rotation
                    frames.setdefault(tf.child_frame_id, []).append(
                        [message.log_time, t.x, t.y, t.z, q.x, q.y, q.z, q.w])
            elif channel.topic.endswith("/bodies"):
                times_agree &= stamp_ns(decoded.timestamp) == message.log_time
                for b in decoded.bodies:
                    L, w, v = b.angular_momentum, b.angular_velocity, b.linear_velocity
                    bodies.setdefault(b.name, []).append(
                        [message.log_time, b.kinetic_energy, b.potential_energy,
                         L.x, L.y, L.z, w.x, w.y, w.z, v.x, v.y, v.z])
    json.dump({"frames": frames, "bodies": bodies, "times_agree": bool(times_agree),
               "schemas": schemas, "metadata": metadata, "message_count": count}, sys.stdout)


if __name__ == "__main__":
    main(sys.argv[1])
