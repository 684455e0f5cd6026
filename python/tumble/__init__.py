"""tumble from Python (issue 33): URDF robots and rigid bodies simulated by the tumble library's
variational integrator. No physics here: every call goes to the Rust library.

- ``Scene.from_file(path)``, ``Scene.from_toml(text, base_dir)``, ``Scene.from_urdf(path,
  articulated, base)``; ``scene.inspect()`` (bodies and joints as DataFrames);
- ``Simulation(scene, record=["mcap", "rrd"], out="logs/run")``: ``step(n)``, ``time``,
  ``state()``, ``set_efforts({...})``, ``set_targets({...})``, ``energy()``, ``momentum()``,
  ``finish()``; a context manager;
- ``rollout(scene, initial_states, steps, inputs, threads)``: many runs on every core, the GIL
  released;
- ``read(path)``: a tumble MCAP recording as one DataFrame per topic.

Errors raise ``TumbleError`` with the CLI's message (the file, the key). See docs/python.md."""

from ._tumble import Scene, Simulation, TumbleError, read, rollout

__all__ = ["Scene", "Simulation", "TumbleError", "read", "rollout"]
