"""Loads a tumble LeRobot v3.0 dataset with the `lerobot` package's own reader.

Usage: python load_lerobot_dataset.py DATASET_DIR

Run by scripts/check_lerobot.sh in a venv that has `lerobot` (too heavy for the test venv:
torch and CUDA wheels, about 8 GB). Offline: HF_HUB_OFFLINE=1, `root=` the folder, so nothing
is downloaded. Checks len(ds) == total_frames, the episode count, a few frames' values against
the data Parquet read with pandas, and the per-episode index ranges.
"""

import json
import os
import sys
from pathlib import Path

os.environ.setdefault("HF_HUB_OFFLINE", "1")

import numpy as np
import pandas as pd
import lerobot
from lerobot.datasets.lerobot_dataset import LeRobotDataset, LeRobotDatasetMetadata

root = Path(sys.argv[1])
info = json.loads((root / "meta/info.json").read_text())
meta = LeRobotDatasetMetadata(repo_id="local/tumble", root=root)
ds = LeRobotDataset(repo_id="local/tumble", root=root)
print(f"lerobot {getattr(lerobot, '__version__', '?')}: LeRobotDataset({root})")
print(f"  fps={ds.fps} robot_type={meta.robot_type} num_episodes={ds.num_episodes} "
      f"num_frames={ds.num_frames} len={len(ds)} features={list(ds.features)}")
assert len(ds) == info["total_frames"] == ds.num_frames, (len(ds), info["total_frames"])
assert ds.num_episodes == meta.total_episodes == info["total_episodes"]
assert ds.fps == info["fps"]
assert meta.total_tasks == 1 and meta.tasks.index[0].startswith("tumble: ")

data = pd.concat(pd.read_parquet(p) for p in sorted((root / "data").glob("*/*.parquet")))
data = data.reset_index(drop=True)
checked = 0
for i in sorted({0, 1, len(ds) // 2, len(ds) - 1}):
    item = ds[i]
    row = data.iloc[i]
    state = item["observation.state"].numpy()
    assert state.dtype == np.float32 and state.shape == (info["features"]["observation.state"]["shape"][0],)
    assert np.array_equal(state, np.asarray(row["observation.state"], dtype=np.float32)), (i, state)
    assert np.array_equal(item["action"].numpy(), np.asarray(row["action"], dtype=np.float32))
    assert int(item["index"]) == i and int(item["episode_index"]) == int(row["episode_index"])
    assert abs(float(item["timestamp"]) - int(item["frame_index"]) / ds.fps) < 1e-6
    assert item["task"] == meta.tasks.index[0], item["task"]
    checked += 1
print(f"  frame 0: observation.state={ds[0]['observation.state'].tolist()} action={ds[0]['action'].tolist()} task={ds[0]['task']!r}")

# Episode ranges as LeRobot sees them.
eps = meta.episodes
for e in [0, meta.total_episodes - 1]:
    ep = eps[e]
    lo, hi = ep["dataset_from_index"], ep["dataset_to_index"]
    assert int(ds[lo]["episode_index"]) == e and int(ds[hi - 1]["episode_index"]) == e
    assert int(ds[lo]["frame_index"]) == 0 and int(ds[hi - 1]["frame_index"]) == ep["length"] - 1

# A window with delta_timestamps (LeRobot's timestamp-sync checks at 1/fps ± tolerance).
dt = 1.0 / info["fps"]
win = LeRobotDataset(repo_id="local/tumble", root=root, episodes=[0, 1],
                     delta_timestamps={"observation.state": [-dt, 0.0], "action": [0.0, dt, 2 * dt]})
w = win[0]
print(f"  episodes=[0, 1], delta_timestamps: len={len(win)} observation.state window {tuple(w['observation.state'].shape)} "
      f"action window {tuple(w['action'].shape)} pad={w['observation.state_is_pad'].tolist()}")
assert tuple(w["observation.state"].shape) == (2, info["features"]["observation.state"]["shape"][0])

stats = meta.stats
print(f"  stats observation.state mean={np.round(stats['observation.state']['mean'], 4).tolist()} count={stats['observation.state']['count'].tolist()}")
print(f"OK: LeRobotDataset loaded {len(ds)} frames of {ds.num_episodes} episodes; {checked} frames equal the Parquet rows")
