"""Reads a big tumble run (the batched Rerun layout) with readers nobody on the team wrote.

Usage: python read_scale.py RUN.mcap RUN.rrd ENTITY

Prints JSON:

    {"mcap": {"tf_messages": n, "transforms_per_message": [n, ...], "frame_ids": n distinct,
              "first_tf": {child_frame_id: [tx, ty, tz, qx, qy, qz, qw]}  (the first /tf message),
              "topics": {topic: message count}},
     "rrd":  {"entities": [paths with InstancePoses3D], "rows": n (index values of ENTITY),
              "instances_per_row": [n, ...], "first_translations": [[x, y, z], ...] (float32 values),
              "first_quaternions": [[x, y, z, w], ...]}}

MCAP: the official `mcap` reader with `mcap-protobuf-support`. RRD: rerun-sdk 0.36's dataframe API
(`RrdReader(path).stream().collect()`, `ChunkStore.reader(index="sim_time", contents=[...])`); the
columns are `<entity>:InstancePoses3D:translations` and `...:quaternions`.
"""

from __future__ import annotations

import json
import sys
from collections import Counter

import rerun as rr
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory


def read_mcap(path: str) -> dict:
    topics: Counter = Counter()
    per_message = []
    frame_ids = set()
    first = None
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _schema, channel, _message, proto in reader.iter_decoded_messages():
            topics[channel.topic] += 1
            if channel.topic != "/tf":
                continue
            per_message.append(len(proto.transforms))
            for t in proto.transforms:
                frame_ids.add(t.child_frame_id)
            if first is None:
                first = {
                    t.child_frame_id: [
                        t.translation.x, t.translation.y, t.translation.z,
                        t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w,
                    ]
                    for t in proto.transforms
                }
    return {
        "tf_messages": len(per_message),
        "transforms_per_message": per_message,
        "frame_ids": len(frame_ids),
        "first_tf": first or {},
        "topics": dict(topics),
    }


def read_rrd(path: str, entity: str) -> dict:
    store = rr.experimental.RrdReader(path).stream().collect()
    schema = store.schema()
    entities = sorted(
        {
            col.entity_path
            for col in schema.component_columns()
            if col.component == "InstancePoses3D:translations" and not col.is_static
        }
    )
    table = store.reader(index="sim_time", contents=[entity]).to_arrow_table()
    translations = table.column(f"{entity}:InstancePoses3D:translations").to_pylist()
    quaternions = table.column(f"{entity}:InstancePoses3D:quaternions").to_pylist()
    rows = [row for row in translations if row is not None]
    quats = [row for row in quaternions if row is not None]
    return {
        "entities": entities,
        "rows": len(rows),
        "instances_per_row": [len(row) for row in rows],
        "first_translations": rows[0] if rows else [],
        "first_quaternions": quats[0] if quats else [],
    }


def main() -> int:
    if len(sys.argv) != 4:
        print(__doc__, file=sys.stderr)
        return 2
    out = {"mcap": read_mcap(sys.argv[1]), "rrd": read_rrd(sys.argv[2], sys.argv[3])}
    json.dump(out, sys.stdout)
    return 0


if __name__ == "__main__":
    sys.exit(main())
