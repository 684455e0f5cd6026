"""Reads a tumble dataset folder with pandas (pyarrow engine) and reports what a user would check.

Usage: read_parquet.py DATASET_DIR  ->  JSON on stdout:
  trajectory_columns, trajectory_dtypes, trajectory_rows, run_ids (distinct, sorted),
  runs_columns, runs_rows, runs_dtypes, bodies_rows, manifest_rows (sum over trajectory files),
  parabola_err_max (m): largest |p(t) - (p(0) + v(0) t + g t^2 / 2)| over every row, with g and dt from
  the runs table, t = step * dt (gravity is the only force, so every centre of mass follows the parabola),
  time_err_max: largest |time_secs - time * 1e-9| (s), time_rounding_max: largest
  |time - step * dt| (s; whole-ns rounding of dt values that are not whole ns), quat_norm_err_max: largest |‖q‖ - 1|.
"""

import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd


def main() -> None:
    root = Path(sys.argv[1])
    traj = pd.read_parquet(root / "trajectories")
    runs = pd.read_parquet(root / "runs")
    bodies = pd.read_parquet(root / "bodies.parquet")
    manifest = json.loads((root / "manifest.json").read_text())
    manifest_rows = sum(
        f["rows"]
        for c in manifest["chunks_done"]
        for f in c["files"]
        if f["name"].startswith("trajectories/")
    )

    # Parabola: join each row with its run's gravity and step size and its body's first row. Time
    # is step * dt (the `time` column is rounded to whole ns when dt is not a whole number of ns).
    t = traj.merge(runs[["run", "dt", "gravity_x", "gravity_y", "gravity_z"]], on="run")
    first = traj[traj["step"] == 0][["run", "body", "position_x", "position_y", "position_z",
                                      "linear_velocity_x", "linear_velocity_y", "linear_velocity_z"]]
    t = t.merge(first, on=["run", "body"], suffixes=("", "_0"))
    secs = t["step"].to_numpy() * t["dt"].to_numpy()
    err = 0.0
    for axis in "xyz":
        p0 = t[f"position_{axis}_0"].to_numpy()
        v0 = t[f"linear_velocity_{axis}_0"].to_numpy()
        g = t[f"gravity_{axis}"].to_numpy()
        expected = p0 + v0 * secs + 0.5 * g * secs**2
        err = max(err, float(np.max(np.abs(t[f"position_{axis}"].to_numpy() - expected))))

    q = traj[["orientation_x", "orientation_y", "orientation_z", "orientation_w"]].to_numpy()
    out = {
        "trajectory_columns": list(traj.columns),
        "trajectory_dtypes": {c: str(traj[c].dtype) for c in traj.columns},
        "trajectory_rows": len(traj),
        "run_ids": sorted(int(r) for r in traj["run"].unique()),
        "runs_columns": list(runs.columns),
        "runs_dtypes": {c: str(runs[c].dtype) for c in runs.columns},
        "runs_rows": len(runs),
        "runs_status": sorted(set(runs["status"])),
        "bodies_rows": len(bodies),
        "manifest_rows": manifest_rows,
        "parabola_err_max": err,
        "time_err_max": float(np.max(np.abs(traj["time_secs"] - traj["time"] * 1e-9))),
        "time_rounding_max": float(np.max(np.abs(t["time"].to_numpy() * 1e-9 - secs))),
        "quat_norm_err_max": float(np.max(np.abs(np.linalg.norm(q, axis=1) - 1.0))),
    }
    json.dump(out, sys.stdout)


if __name__ == "__main__":
    main()
