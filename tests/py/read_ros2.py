"""Reads a tumble ROS 2 recording (STEM.ros2.mcap) with two decoders nobody on the tumble team
wrote, and prints what each decoded as JSON:

- `mcap` + `mcap-ros2-support` (mcap_ros2.decoder): decodes CDR with the file's own ros2msg
  schemas;
- `rosbags` (rosbags.rosbag2.Reader on the .mcap file): its own ROS 2 Humble typestore for the
  standard types (tf2_msgs, std_msgs, geometry_msgs, builtin_interfaces), plus tumble_msgs
  registered from the msg text the file carries; it also parses the channels'
  offered_qos_profiles.

Output:
{"profile": str, "library": str,
 "statistics": {"message_count": n, "channel_message_counts": {topic: n}} or null,
 "chunks": [number of message indexes of each chunk index],
 "channels": {topic: {"message_encoding", "schema", "schema_encoding", "qos_raw"}},
 "metadata": {name: {key: value}},
 "mcap_ros2": DECODED, "rosbags": DECODED,
 "rosbags_qos": {topic: [{"history", "depth", "reliability", "durability", "liveliness"}]},
 "descriptions": {topic: {"links": [names], "joints": [[name, parent, child]], "meshes": [uri],
                           "missing_meshes": [uri], "pinocchio_nq": n, "pinocchio_frames": [..]}}}
DECODED = {"frames": {child_frame_id: [[log_time, stamp_ns, tx, ty, tz, qx, qy, qz, qw]]},
           "tf_parents": [distinct header.frame_id],
           "bodies": {name: [[log_time, stamp_ns, step, ke, pe, Lx, Ly, Lz, wx, wy, wz, vx, vy, vz]]},
           "total_energy": [[log_time, total_energy]],
           "descriptions": {topic: [[log_time, urdf text]]},
           "joints": {name: [[log_time, stamp_ns, position, velocity, len(effort), frame_id,
                              effort (null when the message's effort is empty)]]},
           "counts": {topic: n}}
"""
import json
import os
import sys
import urllib.parse
import xml.etree.ElementTree as ET

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore, get_types_from_msg


def stamp_ns(t):
    return t.sec * 1_000_000_000 + t.nanosec


def new_decoded():
    return {"frames": {}, "tf_parents": [], "bodies": {}, "total_energy": [],
            "descriptions": {}, "counts": {}, "joints": {}}


def add(out, topic, log_time, msg):
    out["counts"][topic] = out["counts"].get(topic, 0) + 1
    if topic.endswith("/tf"):
        for tf in msg.transforms:
            if tf.header.frame_id not in out["tf_parents"]:
                out["tf_parents"].append(tf.header.frame_id)
            t, q = tf.transform.translation, tf.transform.rotation
            out["frames"].setdefault(tf.child_frame_id, []).append(
                [log_time, stamp_ns(tf.header.stamp), t.x, t.y, t.z, q.x, q.y, q.z, q.w])
    elif topic.endswith("/bodies"):
        out["total_energy"].append([log_time, msg.total_energy])
        for b in msg.bodies:
            L, w, v = b.angular_momentum, b.angular_velocity, b.linear_velocity
            out["bodies"].setdefault(b.name, []).append(
                [log_time, stamp_ns(msg.timestamp), msg.step, b.kinetic_energy,
                 b.potential_energy, L.x, L.y, L.z, w.x, w.y, w.z, v.x, v.y, v.z])
    elif topic.endswith("/joint_states"):
        if len(msg.position) != len(msg.name) or len(msg.velocity) != len(msg.name):
            raise SystemExit(f"{topic}: {len(msg.name)} names, {len(msg.position)} positions, "
                             f"{len(msg.velocity)} velocities")
        if len(msg.effort) not in (0, len(msg.name)):
            raise SystemExit(f"{topic}: {len(msg.name)} names, {len(msg.effort)} efforts")
        efforts = list(msg.effort) if len(msg.effort) else [None] * len(msg.name)
        for name, p, v, e in zip(msg.name, msg.position, msg.velocity, efforts):
            out["joints"].setdefault(name, []).append(
                [log_time, stamp_ns(msg.header.stamp), p, v, len(msg.effort),
                 msg.header.frame_id, None if e is None else float(e)])
    elif topic.endswith("/robot_description"):
        out["descriptions"].setdefault(topic, []).append([log_time, msg.data])


def describe(urdf):
    root = ET.fromstring(urdf)
    links = [l.get("name") for l in root.findall("link")]
    joints = [[j.get("name"), j.find("parent").get("link"), j.find("child").get("link")]
              for j in root.findall("joint")]
    meshes = [m.get("filename") for m in root.iter("mesh")]
    missing = []
    for uri in meshes:
        parsed = urllib.parse.urlparse(uri)
        if parsed.scheme != "file" or not os.path.isfile(urllib.parse.unquote(parsed.path)):
            missing.append(uri)
    # urdfdom (through Pinocchio) as the URDF validator: it refuses a file that is not one tree.
    import pinocchio as pin
    model = pin.buildModelFromXML(urdf)
    return {"links": links, "joints": joints, "meshes": meshes, "missing_meshes": missing,
            "pinocchio_nq": model.nq, "pinocchio_frames": [f.name for f in model.frames]}


def main(path):
    result = {"channels": {}, "metadata": {}}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        header = reader.get_header()
        result["profile"], result["library"] = header.profile, header.library
        summary = reader.get_summary()
        stats = summary.statistics
        result["statistics"] = None if stats is None else {
            "message_count": stats.message_count,
            "channel_message_counts": {summary.channels[c].topic: n
                                       for c, n in stats.channel_message_counts.items()},
        }
        result["chunks"] = [len(ci.message_index_offsets) for ci in summary.chunk_indexes]
        for ch in summary.channels.values():
            schema = summary.schemas[ch.schema_id]
            result["channels"][ch.topic] = {
                "message_encoding": ch.message_encoding, "schema": schema.name,
                "schema_encoding": schema.encoding,
                "qos_raw": ch.metadata.get("offered_qos_profiles")}
        for record in reader.iter_metadata():
            result["metadata"][record.name] = dict(record.metadata)
        decoded = new_decoded()
        for schema, channel, message, msg in reader.iter_decoded_messages():
            add(decoded, channel.topic, message.log_time, msg)
            if message.log_time != message.publish_time:
                decoded.setdefault("time_mismatch", []).append(channel.topic)
        result["mcap_ros2"] = decoded

    typestore = get_typestore(Stores.ROS2_HUMBLE)
    decoded, qos = new_decoded(), {}
    with Reader(path) as bag:
        for c in bag.connections:
            if c.msgtype.startswith("tumble_msgs/"):
                typestore.register(get_types_from_msg(c.msgdef.data, c.msgtype))
            qos[c.topic] = [{"history": q.history.value, "depth": q.depth,
                             "reliability": q.reliability.value, "durability": q.durability.value,
                             "liveliness": q.liveliness.value}
                            for q in c.ext.offered_qos_profiles]
        for c, timestamp, raw in bag.messages():
            add(decoded, c.topic, timestamp, typestore.deserialize_cdr(raw, c.msgtype))
    result["rosbags"], result["rosbags_qos"] = decoded, qos
    result["descriptions"] = {topic: describe(msgs[0][1])
                              for topic, msgs in result["mcap_ros2"]["descriptions"].items()}
    json.dump(result, sys.stdout)


if __name__ == "__main__":
    main(sys.argv[1])
