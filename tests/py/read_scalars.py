"""Reads every scalar series of an .rrd with rerun-sdk 0.36.3 and prints JSON:

{entity_path: [[sim_time_ns, value, ...], ...]}   (rows sorted by time)

Chunks are read one by one (`rr.experimental.RrdReader(path).stream()`); a row's values are the
`Scalars:scalars` batch of that row.

Usage: python read_scalars.py RECORDING.rrd
"""
import json
import sys

import pyarrow as pa
import rerun as rr


def main(path):
    series = {}
    for chunk in rr.experimental.RrdReader(path).stream():
        if chunk.is_static:
            continue
        batch = chunk.to_record_batch()
        if "Scalars:scalars" not in batch.schema.names:
            continue
        times = batch.column("sim_time").cast(pa.int64()).to_pylist()
        values = batch.column("Scalars:scalars").to_pylist()
        rows = series.setdefault(str(chunk.entity_path), [])
        for t, v in zip(times, values):
            if v is not None:
                rows.append([t, *v])
    for rows in series.values():
        rows.sort(key=lambda r: r[0])
    print(json.dumps(series))


if __name__ == "__main__":
    main(sys.argv[1])
