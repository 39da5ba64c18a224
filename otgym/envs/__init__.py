"""Environments of the transport tasks: functional (``speed_control``,
``cell_transport``, pure JAX, jittable, batched) and Gymnasium adapters, registered
by ``import otgym`` (``otgym/__init__.py``) as ``otgym/SpeedControl-v0`` and ``otgym/CellTransport-v0``
(``gymnasium.make("otgym/SpeedControl-v0", preset="paper")``), with native vector
versions (``gymnasium.make_vec("otgym/SpeedControl-v0", num_envs=8)``,
``otgym.envs.gym_vector``)."""

from otgym.tasks.transport.presets import PRESETS, TaskConfig, preset

__all__ = ["PRESETS", "TaskConfig", "preset"]
