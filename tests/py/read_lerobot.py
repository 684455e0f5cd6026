"""Reads a tumble LeRobot v3.0 dataset folder with pandas and polars and checks it against the
LeRobot format and against the native tables written beside it.

Usage: read_lerobot.py DATASET_DIR  ->  JSON on stdout:
  info (meta/info.json as read), data_rows, episodes_rows, pandas_dtypes, polars_schema
  (column -> dtype string), index_contiguous, frame_index_contiguous, timestamp_err_max (s,
  timestamp vs frame_index / fps in float32), state_err_max / effort_err_max / action_err_max
  (largest difference from the native joints table's values cast to float32: 0 when equal),
  polars_equals_pandas, stats_min_max_equal, stats_mean_rel_err_max, stats_std_rel_err_max,
  stats_count_ok, episode_ranges_ok (from/to/length/data file of each episode), episode_stats_ok
  (per-episode stats/* min/max/mean equal a group-by), tasks (task strings by task_index),
  task_index_name, runs (the `tumble/run` of each episode).
"""

import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import polars as pl


def qmul(a, b):
    """Hamilton product of xyzw quaternions (rows)."""
    ax, ay, az, aw = a.T
    bx, by, bz, bw = b.T
    return np.stack([aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw,
                     aw * bw - ax * bx - ay * by - az * bz], axis=1)


def qrot(q, v):
    """Rotates vectors v (rows) by xyzw quaternions q (rows)."""
    qv = np.hstack([v, np.zeros((len(v), 1))])
    conj = q * np.array([-1, -1, -1, 1])
    return qmul(qmul(q, qv), conj)[:, :3]


def base_errors(root, data, arrays, episodes, runs):
    traj = pd.read_parquet(root / "trajectories")
    bodies = pd.read_parquet(root / "bodies.parquet")
    rootb = bodies[bodies["body_index"] == 0].set_index("model")
    traj = traj.merge(runs[["run", "model", "log_every"]], on="run")
    traj = traj[traj["step"] % traj["log_every"] == 0]
    traj = traj[traj["body"].to_numpy() == rootb.loc[traj["model"], "body"].to_numpy()]
    run_of = episodes.set_index("episode_index")["tumble/run"]
    pose_err = vel_err = 0.0
    for ep, g in data.groupby("episode_index", sort=True):
        t = traj[traj["run"] == run_of[ep]].sort_values("step")
        b = rootb.loc[t["model"].iloc[0]]
        p = t[["position_x", "position_y", "position_z"]].to_numpy()
        q = t[["orientation_x", "orientation_y", "orientation_z", "orientation_w"]].to_numpy()
        v = t[["linear_velocity_x", "linear_velocity_y", "linear_velocity_z"]].to_numpy()
        w = t[["angular_velocity_x", "angular_velocity_y", "angular_velocity_z"]].to_numpy()
        tlb = np.tile([b["link_from_body_position_x"], b["link_from_body_position_y"],
                       b["link_from_body_position_z"]], (len(t), 1))
        qlb = np.tile([b["link_from_body_orientation_x"], b["link_from_body_orientation_y"],
                       b["link_from_body_orientation_z"], b["link_from_body_orientation_w"]], (len(t), 1))
        qbl = qlb * np.array([-1, -1, -1, 1])
        ql = qmul(q, qbl)
        pl = p + qrot(q, -qrot(qbl, tlb))
        vl = v + np.cross(w, pl - p)
        want_pose = np.hstack([pl, ql]).astype(np.float32)
        want_vel = np.hstack([vl, w]).astype(np.float32)
        rows = g.index.to_numpy()
        pose_err = max(pose_err, float(np.max(np.abs(arrays["observation.base_pose"][rows] - want_pose))))
        vel_err = max(vel_err, float(np.max(np.abs(arrays["observation.base_velocity"][rows] - want_vel))))
    return pose_err, vel_err


def main() -> None:
    root = Path(sys.argv[1])
    info = json.loads((root / "meta/info.json").read_text())
    stats = json.loads((root / "meta/stats.json").read_text())
    fps = info["fps"]
    files = sorted((root / "data").glob("*/*.parquet"))
    data = pd.concat([pd.read_parquet(p) for p in files]).reset_index(drop=True)
    pl_data = pl.concat([pl.read_parquet(p) for p in files])
    episodes = pd.concat(
        [pd.read_parquet(p) for p in sorted((root / "meta/episodes").glob("*/*.parquet"))]
    ).reset_index(drop=True)
    tasks = pd.read_parquet(root / "meta/tasks.parquet")

    vec_keys = [k for k, f in info["features"].items() if f["names"] is not None]
    arrays = {k: np.stack(data[k].to_numpy()) for k in vec_keys}
    out = {
        "info": info,
        "data_rows": len(data),
        "episodes_rows": len(episodes),
        "data_files": [str(p.relative_to(root)) for p in files],
        "pandas_dtypes": {c: str(data[c].dtype) for c in data.columns},
        "vector_dtypes": {k: str(arrays[k].dtype) for k in vec_keys},
        "vector_shapes": {k: list(arrays[k].shape) for k in vec_keys},
        "polars_schema": {c: str(t) for c, t in pl_data.schema.items()},
    }

    idx = data["index"].to_numpy()
    out["index_contiguous"] = bool(np.array_equal(idx, np.arange(len(data))))
    ok = True
    for _, g in data.groupby("episode_index", sort=True):
        ok &= bool(np.array_equal(g["frame_index"].to_numpy(), np.arange(len(g))))
    out["frame_index_contiguous"] = ok
    expect_ts = (data["frame_index"].to_numpy() / fps).astype(np.float32)
    out["timestamp_err_max"] = float(np.max(np.abs(data["timestamp"].to_numpy() - expect_ts)))

    # The native joints table: frames on the grid, in episode order via episodes' tumble/run.
    joints = pd.read_parquet(root / "joints")
    runs = pd.read_parquet(root / "runs")
    joints = joints.merge(runs[["run", "log_every"]], on="run")
    joints = joints[joints["step"] % joints["log_every"] == 0]
    names = [n[: -len(".pos")] for n in info["features"]["observation.state"]["names"]
             if n.endswith(".pos")]
    state_err = effort_err = action_err = 0.0
    action_names = info["features"]["action"]["names"]
    run_of = episodes.set_index("episode_index")["tumble/run"]
    for ep, g in data.groupby("episode_index", sort=True):
        j = joints[joints["run"] == run_of[ep]]
        pos = j.pivot(index="step", columns="joint", values="position")[names].to_numpy()
        vel = j.pivot(index="step", columns="joint", values="velocity")[names].to_numpy()
        eff = j.pivot(index="step", columns="joint", values="effort")[names].to_numpy()
        tgt = j.pivot(index="step", columns="joint", values="target")
        want = np.hstack([pos, vel]).astype(np.float32)
        rows = g.index.to_numpy()
        state_err = max(state_err, float(np.max(np.abs(arrays["observation.state"][rows] - want))))
        effort_err = max(effort_err, float(np.max(np.abs(arrays["observation.effort"][rows] - eff.astype(np.float32)))))
        cols = []
        for a in action_names:
            joint, kind = a.rsplit(".", 1)
            src = tgt if kind == "target" else j.pivot(index="step", columns="joint", values="effort")
            cols.append(src[joint].to_numpy())
        act = np.stack(cols, axis=1).astype(np.float32)
        action_err = max(action_err, float(np.max(np.abs(arrays["action"][rows] - act))))
    out["state_err_max"] = state_err
    out["effort_err_max"] = effort_err
    out["action_err_max"] = action_err

    # Floating base: the root link frame's pose and velocity from the root body's trajectory rows
    # and its link_from_body (bodies.parquet, body_index 0).
    if "observation.base_pose" in info["features"]:
        out["base_pose_err_max"], out["base_velocity_err_max"] = base_errors(
            root, data, arrays, episodes, runs)

    # polars gives the same values (fixed-size lists as Array(Float32, n)).
    same = True
    for k in vec_keys:
        same &= bool(np.array_equal(pl_data[k].to_numpy(), arrays[k]))
    for k in ["timestamp", "frame_index", "episode_index", "index", "task_index"]:
        same &= bool(np.array_equal(pl_data[k].to_numpy(), data[k].to_numpy()))
    out["polars_equals_pandas"] = same

    # stats.json against recomputation from the data files.
    mm = True
    mean_err = std_err = 0.0
    count_ok = True
    for k, f in info["features"].items():
        v = arrays[k].astype(np.float64) if k in arrays else data[k].to_numpy().astype(np.float64)[:, None]
        s = stats[k]
        mm &= bool(np.array_equal(np.asarray(s["min"]), v.min(axis=0)))
        mm &= bool(np.array_equal(np.asarray(s["max"]), v.max(axis=0)))
        scale = np.maximum(np.abs(v).max(axis=0), 1e-30)
        mean_err = max(mean_err, float(np.max(np.abs(np.asarray(s["mean"]) - v.mean(axis=0)) / scale)))
        std_err = max(std_err, float(np.max(np.abs(np.asarray(s["std"]) - v.std(axis=0)) / scale)))
        count_ok &= s["count"] == [len(v)]
        for q in ["q01", "q10", "q50", "q90", "q99"]:
            count_ok &= len(s[q]) == f["shape"][0]
    out["stats_min_max_equal"] = mm
    out["stats_mean_rel_err_max"] = mean_err
    out["stats_std_rel_err_max"] = std_err
    out["stats_count_ok"] = bool(count_ok)

    # Episodes metadata: index ranges, lengths, data file, per-episode stats.
    ranges = True
    ep_stats = True
    start = 0
    for _, e in episodes.sort_values("episode_index").iterrows():
        g = data[data["episode_index"] == e["episode_index"]]
        ranges &= int(e["dataset_from_index"]) == start == int(g["index"].min())
        ranges &= int(e["dataset_to_index"]) == start + len(g) == int(g["index"].max()) + 1
        ranges &= int(e["length"]) == len(g)
        path = f"data/chunk-{int(e['data/chunk_index']):03d}/file-{int(e['data/file_index']):03d}.parquet"
        ranges &= (root / path).exists()
        ranges &= list(e["tasks"]) == [tasks.index[0]]
        start += len(g)
        rows = g.index.to_numpy()
        for k in vec_keys:
            v = arrays[k][rows].astype(np.float64)
            ep_stats &= bool(np.array_equal(np.asarray(e[f"stats/{k}/min"]), v.min(axis=0)))
            ep_stats &= bool(np.array_equal(np.asarray(e[f"stats/{k}/max"]), v.max(axis=0)))
            ep_stats &= bool(np.allclose(np.asarray(e[f"stats/{k}/mean"]), v.mean(axis=0), rtol=1e-9, atol=1e-9))
            ep_stats &= bool(np.allclose(np.asarray(e[f"stats/{k}/q50"]), np.quantile(v, 0.5, axis=0), rtol=1e-9, atol=1e-9))
            ep_stats &= list(e[f"stats/{k}/count"]) == [len(g)]
    out["episode_ranges_ok"] = bool(ranges)
    out["episode_stats_ok"] = bool(ep_stats)
    out["episode_columns"] = [c for c in episodes.columns if not c.startswith("stats/")]
    out["tasks"] = {str(t): int(i) for t, i in zip(tasks.index, tasks["task_index"])}
    out["task_index_name"] = tasks.index.name
    out["runs"] = [int(r) for r in episodes.sort_values("episode_index")["tumble/run"]]
    print(json.dumps(out))


if __name__ == "__main__":
    main()
