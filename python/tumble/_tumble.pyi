"""Type stubs of the extension module `tumble._tumble` (issue 33). Units are SI, frames are the
world's; see docs/python.md."""

from os import PathLike
from typing import Any, ContextManager, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

_Path = Union[str, PathLike]
_Floats = Union[Sequence[float], npt.NDArray[np.float64]]
_Frame = Any  # a pandas.DataFrame (a dict of columns when pandas is not installed)

class TumbleError(Exception):
    """Any error of the library, with the message the CLI prints (the file, the key)."""

class Scene:
    """What is simulated: a scene TOML's `[sim]` and `[[model]]` tables."""

    @staticmethod
    def from_file(path: _Path) -> "Scene":
        """Reads a scene file (TOML); relative paths in it are relative to its folder."""
    @staticmethod
    def from_toml(text: str, base_dir: Optional[_Path] = None) -> "Scene":
        """Parses scene text; relative paths are relative to `base_dir` (default: the current
        folder), and errors name `scene.toml` there."""
    @staticmethod
    def from_urdf(path: _Path, articulated: bool = False, base: Optional[str] = None) -> "Scene":
        """The scene of one URDF: default `[sim]`, the model at the origin; `articulated` keeps
        its joints, `base` = "fixed" or "floating"."""
    @property
    def dt(self) -> float:
        """Step size, s."""
    @property
    def duration(self) -> float:
        """Duration, s."""
    @property
    def steps(self) -> int:
        """Steps in the run (duration / dt)."""
    @property
    def source(self) -> PathLike:
        """The scene's file (for `from_toml`, `scene.toml` in its `base_dir`)."""
    def inspect(self) -> Dict[str, _Frame]:
        """`{"bodies": DataFrame, "joints": DataFrame}`: each body's name, model, frame_id,
        mass (kg), principal moments moment_1..3 (kg m²), its principal frame in the link frame
        (com_link_x..z m, principal_qx..qw), initial centre of mass com_x..z (m, world);
        each recorded joint's name, model, type, lower, upper, actuator, effort_limit,
        damping, limited."""

class Simulation(ContextManager["Simulation"]):
    """A running simulation of a scene: stepped from Python, read between steps, driven by a
    controller, recorded to the files `tumble simulate` writes (the same bytes)."""

    def __init__(
        self,
        scene: Scene,
        record: Optional[Sequence[str]] = None,
        out: Optional[_Path] = None,
        threads: Optional[int] = None,
        force: bool = False,
    ) -> None:
        """`record`: any of "mcap", "rrd", "parquet", "ros2", written under the stem `out`
        (refused if they exist, unless `force`); `threads`: stepping threads (default: every
        core)."""
    def step(self, n: int = 1) -> int:
        """Steps `n` times (at most to the scene's duration), the GIL released; returns the
        steps done in all. Raises TumbleError if the guard stops the run (the files are
        finished first)."""
    @property
    def time(self) -> float:
        """Simulation time, s."""
    @property
    def steps(self) -> int:
        """Steps done."""
    @property
    def dt(self) -> float:
        """Step size, s."""
    @property
    def actuators(self) -> Dict[str, str]:
        """`{joint: "motor" | "position" | "velocity"}`."""
    @property
    def motors(self) -> List[str]:
        """Joints with a motor, in the order `set_efforts` takes a sequence in."""
    @property
    def servos(self) -> List[str]:
        """Joints with a position or velocity servo, in the order `set_targets` takes a
        sequence in."""
    def state(self) -> Dict[str, Any]:
        """`body_names`; `position` (N, 3: centres of mass), `orientation` (N, 4: x y z w,
        principal frames), `linear_velocity`, `angular_velocity` (N, 3); `joint_names`,
        `joint_position`, `joint_velocity` (J,): the numbers a recording of this step holds."""
    def joint_state(self) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """`(q, v)`: joint positions and rates (J,), as `state()` reports them, cheaper."""
    def set_efforts(self, efforts: Union[Mapping[str, float], _Floats]) -> None:
        """Motor efforts (N m or N), held from the next step on: `{joint: effort}` or a
        sequence in the order of `motors`. Bad names, counts or values raise and set nothing."""
    def set_targets(self, targets: Union[Mapping[str, float], _Floats]) -> None:
        """Servo targets (rad or m; rad/s or m/s for velocity servos), as `set_efforts`."""
    def energy(self) -> float:
        """Kinetic plus gravity's potential energy now, J."""
    def momentum(self) -> Dict[str, npt.NDArray[np.float64]]:
        """`linear` (3,) kg m/s and `angular` (3,) kg m²/s about the world origin."""
    def finish(self) -> Dict[str, Any]:
        """Ends the run, publishes its files (all or none); the summary figures, `warnings` and `written`."""
    def __enter__(self) -> "Simulation": ...
    def __exit__(self, *args: Any) -> bool: ...

def rollout(
    scene: Scene,
    initial_states: Optional[Mapping[str, npt.ArrayLike]] = None,
    steps: Optional[int] = None,
    inputs: Optional[Mapping[str, npt.ArrayLike]] = None,
    threads: Optional[int] = None,
    every: int = 1,
    rolls: Optional[int] = None,
    out: Optional[Dict[str, Any]] = None,
) -> Dict[str, Any]:
    """Many runs of `scene` on every core, the GIL released. `initial_states`: `position`
    (R, N, 3), `orientation` (R, N, 4), `linear_velocity`, `angular_velocity` (R, N, 3) for
    free bodies; `joint_position`, `joint_velocity` (R, J) for an articulated first model.
    `inputs`: `{joint: (R, steps)}` held over each step. Returns `time` (S,), `position`
    (R, S, N, 3), `orientation` (R, S, N, 4), `linear_velocity`, `angular_velocity`
    (R, S, N, 3), `joint_position`, `joint_velocity` (R, S, J), `body_names`, `joint_names`,
    `batched`; S = steps // every. `out`: a previous result whose arrays are refilled."""

def read(path: _Path) -> Dict[str, _Frame]:
    """A tumble MCAP recording as `{topic: DataFrame}`: `/tf`, `/bodies`, and when present
    `/joints`, `/mechanisms`, `/contacts`."""
