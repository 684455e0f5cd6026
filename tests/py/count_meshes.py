"""Counts the mesh payloads of a tumble recording, to check each is written once.

Usage: python count_meshes.py RUN.mcap RUN.rrd

Prints JSON: {"mcap": {"messages": {topic: n}, "triangle_lists": n, "points": n,
"f32_exact": bool, "topics": [...]}, "rrd": {"asset3d_blobs": n, "mesh3d_meshes": n,
"entities": [...]}}: over every `foxglove.SceneUpdate` message of the MCAP (read with the
Python `mcap` reader and `mcap-protobuf-support`), the number of `TriangleListPrimitive`s and
of their points, and whether every point coordinate is a float32 value; over every chunk of
the .rrd's recording store (rerun-sdk 0.36.3 `RrdReader`), the number of rows holding an
`Asset3D` blob or `Mesh3D` vertex positions, and every entity path.
"""
import json
import sys

import numpy as np
import rerun as rr
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory

mcap = {"messages": {}, "triangle_lists": 0, "points": 0, "f32_exact": True}
with open(sys.argv[1], "rb") as f:
    reader = make_reader(f, decoder_factories=[DecoderFactory()])
    mcap["topics"] = sorted(c.topic for c in reader.get_summary().channels.values())
    for schema, channel, message, decoded in reader.iter_decoded_messages():
        if schema.name != "foxglove.SceneUpdate":
            continue
        mcap["messages"][channel.topic] = mcap["messages"].get(channel.topic, 0) + 1
        for e in decoded.entities:
            for t in e.triangles:
                mcap["triangle_lists"] += 1
                mcap["points"] += len(t.points)
                xyz = np.array([[p.x, p.y, p.z] for p in t.points], dtype=np.float64)
                if not np.array_equal(xyz.astype(np.float32).astype(np.float64), xyz):
                    mcap["f32_exact"] = False

rrd = {"asset3d_blobs": 0, "mesh3d_meshes": 0, "entities": set()}
reader = rr.experimental.RrdReader(sys.argv[2])
for chunk in reader.stream(store=reader.recordings()[0]):
    rrd["entities"].add(str(chunk.entity_path))
    batch = chunk.to_record_batch()
    for name in batch.schema.names:
        rows = sum(1 for v in batch.column(name).to_pylist() if v is not None)
        if name == "Asset3D:blob":
            rrd["asset3d_blobs"] += rows
        elif name == "Mesh3D:vertex_positions":
            rrd["mesh3d_meshes"] += rows
rrd["entities"] = sorted(rrd["entities"])
json.dump({"mcap": mcap, "rrd": rrd}, sys.stdout)
