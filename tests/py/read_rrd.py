"""Read every transform of a tumble .rrd back with rerun-sdk 0.36's dataframe API.

Usage: python read_rrd.py RECORDING.rrd [INDEX]

Prints JSON to stdout:

    {"frames":    {child_frame_id: [[time_ns, tx, ty, tz, qx, qy, qz, qw], ...]},
     "parents":   {child_frame_id: parent_frame_id},
     "timelines": [names of all index columns, sorted],
     "entities":  [all entity paths except properties, sorted]}

Transforms are identified by their `Transform3D:child_frame` component, not by entity path.
Times are the integer nanoseconds of the INDEX timeline (default `sim_time`); values are the
stored float32 numbers, printed exactly (a JSON double holds any float32).

API used (rerun-sdk 0.36.3, needs its `datafusion` extra): `rr.experimental.RrdReader(path)
.stream().collect()` gives a `ChunkStore`, whose `reader(index=..., contents=[...])` is a
DataFusion DataFrame with one row per index value and one column per
`<entity>:<Archetype>:<field>`.
"""

from __future__ import annotations

import json
import sys

import pyarrow as pa
import rerun as rr

CHILD = "Transform3D:child_frame"
PARENT = "Transform3D:parent_frame"
TRANSLATION = "Transform3D:translation"
QUATERNION = "Transform3D:quaternion"


def single(cell: list | None) -> object | None:
    """A unit batch's only value (None for a null cell or an empty batch)."""
    if cell is None or len(cell) == 0:
        return None
    if len(cell) != 1:
        raise ValueError(f"expected one transform per row, got {len(cell)}")
    return cell[0]


def main() -> int:
    if len(sys.argv) not in (2, 3):
        print(__doc__, file=sys.stderr)
        return 2
    path = sys.argv[1]
    index = sys.argv[2] if len(sys.argv) == 3 else "sim_time"

    store = rr.experimental.RrdReader(path).stream().collect()
    schema = store.schema()
    timelines = sorted(col.name for col in schema.index_columns())
    if index not in timelines:
        raise SystemExit(f"{path}: no timeline {index!r} (timelines: {timelines})")

    entities = sorted(
        {col.entity_path for col in schema.component_columns() if col.component == CHILD and not col.is_static}
    )
    frames: dict[str, list[list[float]]] = {}
    parents: dict[str, str] = {}
    if entities:
        table = store.reader(index=index, contents=entities).to_arrow_table()
        times = table.column(index).cast(pa.int64()).to_pylist()
        for entity in entities:
            columns = {
                field: table.column(f"{entity}:{field}").to_pylist()
                if f"{entity}:{field}" in table.column_names
                else [None] * table.num_rows
                for field in (CHILD, PARENT, TRANSLATION, QUATERNION)
            }
            for row, time_ns in enumerate(times):
                child = single(columns[CHILD][row])
                if child is None:
                    continue  # no transform of this entity at this time
                translation = single(columns[TRANSLATION][row]) or [0.0, 0.0, 0.0]
                quaternion = single(columns[QUATERNION][row]) or [0.0, 0.0, 0.0, 1.0]
                frames.setdefault(child, []).append([time_ns, *translation, *quaternion])
                parent = single(columns[PARENT][row])
                if parent is not None:
                    if parents.setdefault(child, parent) != parent:
                        raise SystemExit(f"{path}: frame {child!r} has parents {parents[child]!r} and {parent!r}")

    for rows in frames.values():
        rows.sort(key=lambda r: r[0])
    entity_paths = sorted(schema.entity_paths())
    json.dump(
        {"frames": frames, "parents": parents, "timelines": timelines, "entities": entity_paths},
        sys.stdout,
    )
    print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
