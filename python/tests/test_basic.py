"""The first slice of the Python package (issue 33): a scene stepped from Python matches the
library's closed forms and the CLI's numbers; errors carry the CLI's message."""

import os
import subprocess

import numpy as np
import pytest

import tumble

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def test_free_fall_is_the_closed_form_parabola():
    # A box released at rest 2 m up: z(t) = 2 - g t^2 / 2 exactly in the variational scheme
    # (free fall is integrated exactly up to round-off).
    scene = tumble.Scene.from_toml(
        '[sim]\ndt = 0.001\nduration = 0.5\ngravity = [0.0, 0.0, -9.81]\n'
        '[[model]]\nurdf = "box.urdf"\nposition = [0.0, 0.0, 2.0]\n',
        base_dir=os.path.join(ROOT, "models"),
    )
    with tumble.Simulation(scene) as sim:
        z0 = sim.state()["position"][0, 2]
        sim.step(500)
        assert sim.steps == 500
        assert abs(sim.time - 0.5) < 1e-12
        st = sim.state()
        # Round-off of 500 steps: measured below 1e-13 m and m/s.
        assert abs(st["position"][0, 2] - (z0 - 0.5 * 9.81 * 0.5**2)) < 1e-12
        assert abs(st["linear_velocity"][0, 2] + 9.81 * 0.5) < 1e-12
        assert np.all(st["position"][0, :2] == 0.0)


def test_energy_and_joints_of_an_articulated_arm():
    # The bundled arm swinging under gravity, its limits off (a stop would dissipate): energy
    # bounded with no drift, O(h^2).
    scene = tumble.Scene.from_toml(
        '[sim]\ndt = 0.001\nduration = 1.0\n[[model]]\nurdf = "arm.urdf"\nbodies = "articulated"\n'
        'base = "fixed"\njoint_limits = false\n',
        base_dir=os.path.join(ROOT, "models"),
    )
    sim = tumble.Simulation(scene)
    e0 = sim.energy()
    sim.step(1000)
    st = sim.state()
    assert st["joint_names"] == ["shoulder", "elbow"]
    assert st["joint_position"].shape == (2,)
    assert abs(st["joint_position"][1]) > 0.01  # the elbow swung (measured 0.065 rad)
    # Measured: 1.5e-8 relative.
    assert abs(sim.energy() - e0) <= 1e-6 * abs(e0)
    summary = sim.finish()
    assert summary["newton_failures"] == 0
    with pytest.raises(tumble.TumbleError, match="finished"):
        sim.step()


def test_the_end_state_equals_the_cli_run():
    # The same scene stepped from Python and by `tumble simulate` (Parquet) ends at the same bits.
    exe = os.path.join(ROOT, "target", "release", "tumble")
    if not os.path.exists(exe):
        pytest.skip("target/release/tumble not built")
    import tempfile
    import pandas as pd

    with tempfile.TemporaryDirectory() as d:
        subprocess.run([exe, "simulate", os.path.join(ROOT, "models", "default.toml"), "--duration", "0.2",
                        "--format", "parquet", "--out", os.path.join(d, "run")], check=True, capture_output=True)
        rows = pd.read_parquet(os.path.join(d, "run.trajectories.parquet"))
        last = rows[rows.step == rows.step.max()].sort_values("body")
        scene = tumble.Scene.from_file(os.path.join(ROOT, "models", "default.toml"))
        sim = tumble.Simulation(scene)
        sim.step(int(rows.step.max()))
        st = sim.state()
        order = np.argsort(st["body_names"])
        got = st["position"][order]
        want = last[["position_x", "position_y", "position_z"]].to_numpy()
        assert np.array_equal(got, want), (got, want)


def test_bad_input_raises_with_the_cli_message():
    with pytest.raises(tumble.TumbleError, match=r"sim.dt must be a positive finite number \(got -1\)"):
        tumble.Scene.from_toml("[sim]\ndt = -1\n")
    with pytest.raises(tumble.TumbleError, match="cannot read scene"):
        tumble.Scene.from_file("/nonexistent/scene.toml")
