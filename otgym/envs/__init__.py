"""Environments of the transport tasks: functional (``speed_control``,
``cell_transport``, pure JAX, jittable, batched) and Gymnasium adapters, registered
on import as ``otgym/SpeedControl-v0`` and ``otgym/CellTransport-v0``
(``gymnasium.make("otgym/SpeedControl-v0", preset="paper")``), with native vector
versions (``gymnasium.make_vec("otgym/SpeedControl-v0", num_envs=8)``,
``otgym.envs.gym_vector``)."""

import gymnasium as gym

from otgym.envs.presets import PRESETS, TaskConfig, preset

__all__ = ["PRESETS", "TaskConfig", "preset"]

for _id, _entry in (("otgym/SpeedControl-v0", "SpeedControl"), ("otgym/CellTransport-v0", "CellTransport")):
    if _id not in gym.registry:
        gym.register(_id, entry_point=f"otgym.envs.gym_adapter:{_entry}Env",
                     vector_entry_point=f"otgym.envs.gym_vector:{_entry}VectorEnv")
