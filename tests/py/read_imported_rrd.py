"""Reads the transforms of an .rrd made by Rerun's own MCAP importer (`rerun mcap convert`,
rerun-sdk 0.36.3) from a tumble MCAP file, and prints them as JSON:

{"frames": {child_frame_id: [[log_time_ns, tx, ty, tz, qx, qy, qz, qw], ...]},
 "parents": {child_frame_id: parent_frame_id},
 "entities": [entity paths holding Transform3D data], "timelines": [timeline names]}

The importer turns each `foxglove.FrameTransforms` message on `/tf` into one row per transform
on the entity `/tf`, on the timelines `message_log_time`, `message_publish_time`, `timestamp`.
The chunks are read one by one (`rr.experimental.RrdReader(path).stream()`), not through a
dataframe query, because a query keeps only the last row per time.

Usage: python read_imported_rrd.py IMPORTED.rrd
"""
import json
import sys

import pyarrow as pa
import rerun as rr


def main(path):
    frames, parents, entities, timelines = {}, {}, set(), set()
    for chunk in rr.experimental.RrdReader(path).stream():
        if chunk.is_static:
            continue
        batch = chunk.to_record_batch()
        names = batch.schema.names
        timelines.update(chunk.timeline_names)
        if "Transform3D:translation" not in names:
            continue
        entities.add(str(chunk.entity_path))
        times = batch.column("message_log_time").cast(pa.int64()).to_pylist()
        child = batch.column("Transform3D:child_frame").to_pylist()
        parent = batch.column("Transform3D:parent_frame").to_pylist()
        trans = batch.column("Transform3D:translation").to_pylist()
        quat = batch.column("Transform3D:quaternion").to_pylist()
        for t, c, p, tr, q in zip(times, child, parent, trans, quat):
            if not c or not tr or not q:
                continue
            for name, par, tv, qv in zip(c, p or [None] * len(c), tr, q):
                frames.setdefault(name, []).append([t, *tv, *qv])
                parents[name] = par
    for rows in frames.values():
        rows.sort(key=lambda r: r[0])
    print(json.dumps({
        "frames": frames,
        "parents": parents,
        "entities": sorted(entities),
        "timelines": sorted(timelines),
    }))


if __name__ == "__main__":
    main(sys.argv[1])
