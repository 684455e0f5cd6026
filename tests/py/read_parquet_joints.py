"""Reads the joints table of `tumble simulate --format parquet` (STEM.joints.parquet) with two
dataframe libraries nobody on the tumble team wrote, pandas (pyarrow engine) and polars, and
prints JSON:

{"pandas": TABLE, "polars": TABLE,
 "units": {column: the field's `unit` metadata, as pyarrow reads the file's schema}}
TABLE = {"rows": n, "columns": [name, ...], "dtypes": {column: dtype name},
         "joints": {joint: [[step, time, time_secs, position, velocity, effort, target,
                             saturated, drive], ...]}}   (rows in file order; null as null)

Usage: read_parquet_joints.py STEM.joints.parquet
"""

import json
import math
import sys

import pandas as pd
import polars as pl
import pyarrow.parquet as pq

COLUMNS = ["step", "time", "time_secs", "position", "velocity", "effort", "target",
           "saturated", "drive"]


def plain(v):
    """A JSON value: numpy scalars to Python, NaN/None/NA to null."""
    if v is None or v is pd.NA:
        return None
    if hasattr(v, "item"):
        v = v.item()
    if isinstance(v, float) and math.isnan(v):
        return None
    return v


def table(records, columns, dtypes):
    joints = {}
    for r in records:
        joints.setdefault(r["joint"], []).append([plain(r[c]) for c in COLUMNS])
    return {"rows": len(records), "columns": columns, "dtypes": dtypes, "joints": joints}


def main(path):
    df = pd.read_parquet(path)
    pandas = table(df.to_dict("records"), list(df.columns),
                   {c: str(t) for c, t in df.dtypes.items()})
    pf = pl.read_parquet(path)
    polars = table(pf.to_dicts(), pf.columns, {c: str(t) for c, t in pf.schema.items()})
    schema = pq.read_schema(path)
    units = {f.name: (f.metadata or {}).get(b"unit", b"").decode() for f in schema}
    json.dump({"pandas": pandas, "polars": polars, "units": units}, sys.stdout)


if __name__ == "__main__":
    main(sys.argv[1])
