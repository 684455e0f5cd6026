"""Loads a LeRobot v3 folder with Rerun's own LeRobot importer (rerun-sdk 0.36.3) and reads it back.

Usage: read_lerobot_rerun.py DATASET_DIR OUT.rrd  ->  JSON on stdout:
  episodes: {recording_id: {"rows": {entity: frames with a value}, "names": {entity: series names}}},
  timelines (of the first episode), state_err_max: largest |Rerun's observation.state scalars - the data
  Parquet's| over every episode and frame (Rerun stores float64 from the float32 column: 0 when equal).

`rr.log_file_from_path(DIR)` runs the importer in-process (what `rerun DIR` does, without a port); the
stream is saved to OUT.rrd and read back with `rr.experimental.RrdReader`.
"""

import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import rerun as rr


def main() -> None:
    root, out = Path(sys.argv[1]), sys.argv[2]
    rr.init("tumble_lerobot", spawn=False)
    rr.save(out)
    rr.log_file_from_path(root)
    rr.disconnect()

    data = pd.concat(pd.read_parquet(p) for p in sorted((root / "data").glob("*/*.parquet")))
    reader = rr.experimental.RrdReader(out)
    episodes = {}
    timelines = None
    err = 0.0
    for entry in reader.recordings():
        if not entry.recording_id.startswith("episode_"):
            continue
        ep = int(entry.recording_id.removeprefix("episode_"))
        store = reader.stream(store=entry).collect()
        schema = store.schema()
        if timelines is None:
            timelines = sorted(c.name for c in schema.index_columns())
        entities = sorted(e for e in schema.entity_paths() if not e.startswith("/__"))
        rows, names = {}, {}
        for entity in entities:
            t = store.reader(index="frame_index", contents=[entity]).to_arrow_table()
            scalars = t.column(f"{entity}:Scalars:scalars").to_pylist()
            rows[entity] = sum(1 for s in scalars if s is not None)
            col = f"{entity}:SeriesLines:names"
            if col in t.column_names:
                names[entity] = next((n for n in t.column(col).to_pylist() if n), None)
            if entity == "/observation.state":
                frames = t.column("frame_index").to_pylist()
                got = {int(f): s for f, s in zip(frames, scalars) if s is not None}
                g = data[data["episode_index"] == ep].set_index("frame_index")
                for f, s in got.items():
                    want = np.asarray(g.loc[f, "observation.state"], dtype=np.float64)
                    err = max(err, float(np.max(np.abs(np.asarray(s) - want))))
        episodes[entry.recording_id] = {"rows": rows, "names": names}
    print(json.dumps({"episodes": episodes, "timelines": timelines, "state_err_max": err}))


if __name__ == "__main__":
    main()
