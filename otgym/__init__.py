"""otgym: an open platform for optical-tweezer (OT) driven microrobotics.

Packages in layers, each importing only lower ones (``[tool.importlinter]`` in
pyproject.toml enforces it; docs/architecture.md explains it), high to low: ``cli``;
``experiments``; ``ui``; ``bus`` | ``record``; ``runtime``; ``autonomy`` | ``human``;
``task``; ``teleop`` | ``shared`` | ``study``; ``envs``; ``sim``; ``physics`` |
``planning`` | ``rl``.
Units everywhere: micrometre (um), second (s), piconewton (pN), kelvin (K).

``import otgym`` registers the Gymnasium environments ``otgym/SpeedControl-v0`` and
``otgym/CellTransport-v0`` (``gymnasium.make("otgym/SpeedControl-v0", preset="paper")``,
``gymnasium.make_vec(..., num_envs=8)``). The entry points are strings, so importing
otgym imports neither JAX nor the environments; ``gymnasium.make`` loads them.
"""

__version__ = "0.1.0"

GYM_IDS = ("otgym/SpeedControl-v0", "otgym/CellTransport-v0")


def _register_gym_envs() -> None:
    import gymnasium

    for env_id, name in zip(GYM_IDS, ("SpeedControl", "CellTransport")):
        if env_id not in gymnasium.registry:  # re-imports and reloads register once
            gymnasium.register(
                env_id,
                entry_point=f"otgym.envs.gym_adapter:{name}Env",
                vector_entry_point=f"otgym.envs.gym_vector:{name}VectorEnv",
            )


_register_gym_envs()
