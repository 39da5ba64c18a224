"""otgym: an open platform for optical-tweezer (OT) driven microrobotics.

Packages in layers, each importing only lower ones (``[tool.importlinter]`` in
pyproject.toml enforces it; docs/architecture.md explains it), high to low: ``cli``;
``experiments``; ``ui``; ``bus`` | ``record``; ``runtime``; ``autonomy`` | ``human``;
``task``; ``teleop`` | ``shared`` | ``study``; ``envs``; ``sim``; ``physics`` |
``planning`` | ``rl``.
Units everywhere: micrometre (um), second (s), piconewton (pN), kelvin (K).

``import otgym`` registers a Gymnasium environment for every registered task with a
Gymnasium id (``otgym list tasks``), e.g. ``otgym/SpeedControl-v0`` and
``otgym/CellTransport-v0`` (``gymnasium.make("otgym/SpeedControl-v0", preset="paper")``,
``gymnasium.make_vec(..., num_envs=8)``). The entry points are strings, so importing
otgym imports neither JAX nor the environments; ``gymnasium.make`` loads them.
"""

__version__ = "0.1.0"


def _register_gym_envs() -> None:
    """Every registered task (``otgym.registry``: otgym's own and installed packages'
    ``otgym.tasks`` entry points) becomes a Gymnasium environment, under its entry's
    ``gym_id`` or else ``otgym/<name>-v0``."""
    import gymnasium

    from otgym import registry

    for task in registry.entries("tasks"):
        env_id = task.extras.get("gym_id") or f"otgym/{task.name}-v0"
        if env_id not in gymnasium.registry:  # re-imports and reloads register once
            gymnasium.register(
                env_id,
                entry_point="otgym.envs.gym_adapter:TaskEnv",
                vector_entry_point="otgym.envs.gym_vector:TaskVectorEnv",
                kwargs={"task": task.name},
            )


_register_gym_envs()
