"""tumble from Python (issue 33, a first slice): scenes from files, TOML text or a URDF, stepped
by the library's `Simulation`, the state read back as numpy arrays. No physics here: every call
goes to the Rust library. Errors raise `tumble.TumbleError` with the CLI's message."""

from ._tumble import Scene, Simulation, TumbleError

__all__ = ["Scene", "Simulation", "TumbleError"]
