"""Reads the static series names (`SeriesLines:names`, what the viewer's legend shows) of every
entity of an .rrd with rerun-sdk 0.36.3 and prints JSON: {entity_path: [name, ...]}.
With --style: {entity_path: {"names": [...], "colors": [0xRRGGBBAA, ...] or null,
"widths": [...] or null}}.

Usage: python read_series_names.py RECORDING.rrd [--style]
"""
import json
import sys

import rerun as rr


def main(path, style):
    names = {}
    for chunk in rr.experimental.RrdReader(path).stream():
        if not chunk.is_static:
            continue
        batch = chunk.to_record_batch()
        if "SeriesLines:names" not in batch.schema.names:
            continue
        column = lambda c: batch.column(c).to_pylist() if c in batch.schema.names else None
        rows, colors, widths = (column("SeriesLines:" + c) for c in ("names", "colors", "widths"))
        for k, row in enumerate(rows):
            if row is None:
                continue
            entity = str(chunk.entity_path)
            if style:
                names[entity] = {"names": row, "colors": colors[k] if colors else None,
                                 "widths": widths[k] if widths else None}
            else:
                names[entity] = row
    print(json.dumps(names))


if __name__ == "__main__":
    main(sys.argv[1], "--style" in sys.argv[2:])
