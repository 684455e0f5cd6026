"""Decodes the `foxglove.SceneUpdate` topics (`/scene`, `/inertia`, and their group-prefixed
copies) of a tumble MCAP with the Python `mcap` reader and `mcap-protobuf-support`, and prints
them as JSON: {topic: [{"log_time", "entities": [{"id", "frame_id", "frame_locked",
"timestamp_ns", "cubes": [{"pose", "size", "color"}], "spheres": [...], "cylinders": [{...,
"bottom_scale", "top_scale"}], "triangles": [{"pose", "points": [[x, y, z]], "indices", "color"}]}]}]}
plus "tf_children": the child frame ids of the first /tf message. Poses are
[x, y, z, qx, qy, qz, qw]; sizes [x, y, z]; colours [r, g, b, a].
"""
import json
import sys

from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory


def pose(p):
    return [p.position.x, p.position.y, p.position.z,
            p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w]


def vec(v):
    return [v.x, v.y, v.z]


def color(c):
    return [c.r, c.g, c.b, c.a]


def prim(p, extra=()):
    d = {"pose": pose(p.pose), "size": vec(p.size), "color": color(p.color)}
    for k in extra:
        d[k] = getattr(p, k)
    return d


out, tf_children = {}, None
with open(sys.argv[1], "rb") as f:
    reader = make_reader(f, decoder_factories=[DecoderFactory()])
    for schema, channel, message, decoded in reader.iter_decoded_messages():
        if schema.name == "foxglove.FrameTransforms" and tf_children is None:
            tf_children = [t.child_frame_id for t in decoded.transforms]
        if schema.name != "foxglove.SceneUpdate":
            continue
        entities = []
        for e in decoded.entities:
            entities.append({
                "id": e.id,
                "frame_id": e.frame_id,
                "frame_locked": e.frame_locked,
                "timestamp_ns": e.timestamp.seconds * 10**9 + e.timestamp.nanos,
                "cubes": [prim(c) for c in e.cubes],
                "spheres": [prim(s) for s in e.spheres],
                "cylinders": [prim(c, ("bottom_scale", "top_scale")) for c in e.cylinders],
                "triangles": [{"pose": pose(t.pose), "points": [vec(p) for p in t.points],
                               "indices": list(t.indices), "color": color(t.color)}
                              for t in e.triangles],
                "models": len(e.models),
            })
        out.setdefault(channel.topic, []).append({"log_time": message.log_time, "entities": entities})
json.dump({"topics": out, "tf_children": tf_children}, sys.stdout)
