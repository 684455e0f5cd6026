from ._tumble import Scene as Scene, Simulation as Simulation, TumbleError as TumbleError, read as read, rollout as rollout

__all__ = ["Scene", "Simulation", "TumbleError", "read", "rollout"]
