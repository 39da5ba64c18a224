"""Policy files: a trained Q-network's weights and what they were trained for, in
one ``.npz`` (arrays named by their path in the parameter tree, plus a JSON
``__meta__`` with the preset, observation size, number of actions and layer widths).
Loading checks the file against the environment and raises a clear error."""

from __future__ import annotations

import json
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
from flax import traverse_util

from otgym.rl.network import QNetwork

PRETRAINED_POLICY = Path(__file__).resolve().parent.parent / "data" / "policies" / "speed_control_paper.npz"
"""The small policy shipped with the package: DQN speed control on the ``paper``
preset, trained by ``otgym experiment pretrain`` (see that module for how)."""


def resolve_policy(name_or_path) -> Path:
    """``"pretrained"`` -> the shipped policy file; anything else is a path."""
    return PRETRAINED_POLICY if str(name_or_path) == "pretrained" else Path(name_or_path)


def save_policy(path, q_params, meta: dict) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    flat = traverse_util.flatten_dict(q_params, sep="/")
    arrays = {name: np.asarray(value) for name, value in flat.items()}
    with open(path, "wb") as handle:  # np.savez would append .npz to other names
        np.savez(handle, __meta__=np.array(json.dumps(meta)), **arrays)
    return path


def policy_meta(path) -> dict:
    """The ``__meta__`` of a policy file (raises FileNotFoundError, IsADirectoryError or
    ValueError)."""
    path = Path(path)
    if path.is_dir():
        raise IsADirectoryError(f"{path} is a folder; give a policy file (policy.npz from otgym train)")
    if not path.is_file():
        raise FileNotFoundError(f"policy file {path} does not exist")
    try:
        with np.load(path, allow_pickle=False) as data:
            return json.loads(str(data["__meta__"]))
    except (OSError, KeyError, ValueError) as error:
        raise ValueError(f"{path} is not an otgym policy file ({error})") from None


def load_policy(path, obs_size: int, n_actions: int):
    """Returns (q_params, meta); raises FileNotFoundError or ValueError naming the problem."""
    path = Path(path)
    meta = policy_meta(path)
    try:
        with np.load(path, allow_pickle=False) as data:
            flat = {name: jnp.asarray(data[name]) for name in data.files if name != "__meta__"}
    except (OSError, KeyError, ValueError) as error:
        raise ValueError(f"{path} is not an otgym policy file ({error})") from None
    hidden = tuple(meta.get("hidden", ()))
    network = QNetwork(n_actions, hidden)  # only the shapes: traced, neither compiled nor run
    expected = jax.eval_shape(network.init, jax.random.PRNGKey(0), jnp.zeros((1, obs_size)))
    expected_flat = traverse_util.flatten_dict(expected, sep="/")
    shapes = {name: tuple(value.shape) for name, value in flat.items()}
    wanted = {name: tuple(value.shape) for name, value in expected_flat.items()}
    if shapes != wanted:
        raise ValueError(
            f"policy {path} does not fit this environment (observation size {obs_size}, "
            f"{n_actions} actions): its layers are {shapes}, expected {wanted}"
        )
    return traverse_util.unflatten_dict(flat, sep="/"), meta
