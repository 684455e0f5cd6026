"""Reads the Parquet tables of `tumble simulate --format parquet` with pandas (pyarrow engine).

Usage: read_parquet_run.py STEM.trajectories.parquet STEM.bodies.parquet  ->  JSON on stdout:
  trajectory_rows, trajectory_columns, bodies_rows, bodies (distinct body names, sorted),
  steps (distinct steps, sorted), quat_norm_err_max (largest |‖q‖ - 1|).
"""

import json
import sys

import numpy as np
import pandas as pd


def main() -> None:
    traj = pd.read_parquet(sys.argv[1])
    bodies = pd.read_parquet(sys.argv[2])
    q = traj[["orientation_x", "orientation_y", "orientation_z", "orientation_w"]].to_numpy()
    json.dump(
        {
            "trajectory_rows": len(traj),
            "trajectory_columns": list(traj.columns),
            "bodies_rows": len(bodies),
            "bodies": sorted(traj["body"].unique().tolist()),
            "steps": sorted(int(s) for s in traj["step"].unique()),
            "quat_norm_err_max": float(np.abs(np.linalg.norm(q, axis=1) - 1.0).max()),
        },
        sys.stdout,
    )


if __name__ == "__main__":
    main()
