"""Reads the contacts and the ground of tumble recordings with readers nobody on the tumble team
wrote, and prints JSON. Each argument is a file, or `-` to skip that format:

    read_contacts.py STEM.mcap STEM.ros2.mcap STEM.rrd STEM.contacts.parquet

{"mcap": {"schemas": {topic: schema name},
          "contact_fields": [field names of tumble.Contact as the file's schema declares them],
          "contacts": {topic: [[log_time, stamp_ns, step, [CONTACT, ...]], ...]},
          "scene": {topic: [[log_time, [ENTITY, ...]], ...]}},
 "ros2": {"mcap_ros2": {topic: [[log_time, stamp_ns, step, [CONTACT, ...]], ...]},
          "rosbags": {topic: [...]}, "channels": {topic: [schema, encoding]}},
 "rrd": {"static": {entity: {column: value}}, "rows": {entity: [[sim_time_ns, {column: value}]]}},
 "parquet": {"pandas": TABLE, "polars": TABLE, "units": {column: unit}}}

CONTACT = [body_a, body_b, ground, px, py, pz, nx, ny, nz, fx, fy, fz, ix, iy, iz, gap_m]
ENTITY = {"id", "frame_id", "frame_locked", "timestamp_ns", "metadata": {key: value},
          "cubes": [[pose7, size3, rgba]], "spheres": [[pose7, size3, rgba]],
          "arrows": [[pose7, shaft_length, shaft_diameter, head_length, head_diameter, rgba]]}
pose7 = [x, y, z, qx, qy, qz, qw]
TABLE = {"rows": n, "columns": [...], "dtypes": {column: dtype}, "records": [[step, time,
         time_secs, body_a, body_b, ground, px, py, pz, nx, ny, nz, fx, fy, fz, ix, iy, iz,
         gap_m], ...]}   (file order)
In "rrd", each column is the chunk's cell for that row as a Python list (Arrow lists of
float32 are printed exactly: a JSON double holds any float32); static cells likewise.
"""
import json
import sys


def vec(v):
    return [v.x, v.y, v.z]


def pose(p):
    return [p.position.x, p.position.y, p.position.z,
            p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w]


def color(c):
    return [c.r, c.g, c.b, c.a]


def contact(c):
    return [c.body_a, c.body_b, bool(c.ground), *vec(c.point), *vec(c.normal), *vec(c.force),
            *vec(c.impulse), c.gap_m]


def stamp_ns(ts):
    if hasattr(ts, "seconds"):
        return ts.seconds * 1_000_000_000 + ts.nanos
    return ts.sec * 1_000_000_000 + ts.nanosec


def entity(e):
    return {
        "id": e.id, "frame_id": e.frame_id, "frame_locked": e.frame_locked,
        "timestamp_ns": e.timestamp.seconds * 10**9 + e.timestamp.nanos,
        "metadata": {kv.key: kv.value for kv in e.metadata},
        "cubes": [[pose(c.pose), vec(c.size), color(c.color)] for c in e.cubes],
        "spheres": [[pose(s.pose), vec(s.size), color(s.color)] for s in e.spheres],
        "arrows": [[pose(a.pose), a.shaft_length, a.shaft_diameter, a.head_length,
                    a.head_diameter, color(a.color)] for a in e.arrows],
    }


def read_mcap(path):
    from mcap.reader import make_reader
    from mcap_protobuf.decoder import DecoderFactory

    out = {"schemas": {}, "contact_fields": [], "contacts": {}, "scene": {}}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for schema, channel, message, decoded in reader.iter_decoded_messages():
            out["schemas"][channel.topic] = schema.name
            t = message.log_time
            if schema.name == "tumble.Contacts":
                for c in decoded.contacts:
                    out["contact_fields"] = [f.name for f in c.DESCRIPTOR.fields]
                out["contacts"].setdefault(channel.topic, []).append(
                    [t, stamp_ns(decoded.timestamp), decoded.step,
                     [contact(c) for c in decoded.contacts]])
            elif schema.name == "foxglove.SceneUpdate":
                out["scene"].setdefault(channel.topic, []).append(
                    [t, [entity(e) for e in decoded.entities]])
    return out


def ros2_contacts(out, topic, log_time, msg):
    if topic.endswith("/contacts"):
        out.setdefault(topic, []).append(
            [log_time, stamp_ns(msg.timestamp), msg.step, [contact(c) for c in msg.contacts]])


def read_ros2(path):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_typestore, get_types_from_msg

    result = {"mcap_ros2": {}, "rosbags": {}, "channels": {}}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        for ch in summary.channels.values():
            result["channels"][ch.topic] = [summary.schemas[ch.schema_id].name,
                                            ch.message_encoding]
        for schema, channel, message, msg in reader.iter_decoded_messages():
            ros2_contacts(result["mcap_ros2"], channel.topic, message.log_time, msg)
    typestore = get_typestore(Stores.ROS2_HUMBLE)
    with Reader(path) as bag:
        for c in bag.connections:
            if c.msgtype.startswith("tumble_msgs/"):
                typestore.register(get_types_from_msg(c.msgdef.data, c.msgtype))
        for c, timestamp, raw in bag.messages():
            ros2_contacts(result["rosbags"], c.topic, timestamp,
                          typestore.deserialize_cdr(raw, c.msgtype))
    return result


def read_rrd(path):
    import pyarrow as pa
    import rerun as rr

    out = {"static": {}, "rows": {}}
    for chunk in rr.experimental.RrdReader(path).stream():
        name = str(chunk.entity_path)
        if not name.startswith("/world/"):
            continue
        batch = chunk.to_record_batch()
        columns = [c for c in batch.schema.names if ":" in c]
        if chunk.is_static:
            cells = out["static"].setdefault(name, {})
            for c in columns:
                cells[c] = batch.column(c).to_pylist()[0]
            continue
        times = batch.column("sim_time").cast(pa.int64()).to_pylist()
        values = {c: batch.column(c).to_pylist() for c in columns}
        rows = out["rows"].setdefault(name, [])
        for i, t in enumerate(times):
            rows.append([t, {c: values[c][i] for c in columns}])
    for rows in out["rows"].values():
        rows.sort(key=lambda r: r[0])
    return out


COLUMNS = ["step", "time", "time_secs", "body_a", "body_b", "ground",
           "point_x", "point_y", "point_z", "normal_x", "normal_y", "normal_z",
           "force_x", "force_y", "force_z", "impulse_x", "impulse_y", "impulse_z", "gap_m"]


def plain(v):
    if hasattr(v, "item"):
        v = v.item()
    return v


def read_parquet(path):
    import pandas as pd
    import polars as pl
    import pyarrow.parquet as pq

    df = pd.read_parquet(path)
    pandas = {"rows": len(df), "columns": list(df.columns),
              "dtypes": {c: str(t) for c, t in df.dtypes.items()},
              "records": [[plain(r[c]) for c in COLUMNS] for r in df.to_dict("records")]}
    pf = pl.read_parquet(path)
    polars = {"rows": pf.height, "columns": pf.columns,
              "dtypes": {c: str(t) for c, t in pf.schema.items()},
              "records": [[r[c] for c in COLUMNS] for r in pf.to_dicts()]}
    units = {f.name: (f.metadata or {}).get(b"unit", b"").decode()
             for f in pq.read_schema(path)}
    return {"pandas": pandas, "polars": polars, "units": units}


def main(mcap, ros2, rrd, parquet):
    out = {}
    for key, path, read in (("mcap", mcap, read_mcap), ("ros2", ros2, read_ros2),
                            ("rrd", rrd, read_rrd), ("parquet", parquet, read_parquet)):
        if path != "-":
            out[key] = read(path)
    json.dump(out, sys.stdout)


if __name__ == "__main__":
    main(*sys.argv[1:5])
