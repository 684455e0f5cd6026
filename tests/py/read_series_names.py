"""Reads the static series names (`SeriesLines:names`, what the viewer's legend shows) of every
entity of an .rrd with rerun-sdk 0.36.3 and prints JSON: {entity_path: [name, ...]}.

Usage: python read_series_names.py RECORDING.rrd
"""
import json
import sys

import rerun as rr


def main(path):
    names = {}
    for chunk in rr.experimental.RrdReader(path).stream():
        if not chunk.is_static:
            continue
        batch = chunk.to_record_batch()
        if "SeriesLines:names" not in batch.schema.names:
            continue
        for row in batch.column("SeriesLines:names").to_pylist():
            if row is not None:
                names[str(chunk.entity_path)] = row
    print(json.dumps(names))


if __name__ == "__main__":
    main(sys.argv[1])
