"""Shared test setup: JAX's persistent compilation cache, so repeated runs (and CI on
the same machine) reuse compiled XLA programs instead of compiling again; the paper
preset's task parameters, built once per session."""

import os
from pathlib import Path

import jax
import pytest

_CACHE = Path(os.environ.get("OTGYM_JAX_CACHE", Path.home() / ".cache" / "otgym" / "jax"))
_CACHE.mkdir(parents=True, exist_ok=True)
jax.config.update("jax_compilation_cache_dir", str(_CACHE))
jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.5)


@pytest.fixture(scope="session")
def paper_params():
    """The ``paper`` preset's task parameters, built once (scene, path plan) for all tests."""
    from otgym.envs import speed_control as spc

    return spc.make_params("paper")


FIXED_POLICY_HIDDEN = (16,)


@pytest.fixture(scope="session")
def fixed_action_q_params():
    """``make(action)``: Q-network parameters (hidden widths ``FIXED_POLICY_HIDDEN``)
    whose greedy action is always ``action``, so evaluations can be checked against the
    exact times of constant speeds."""
    import jax.numpy as jnp

    from otgym.envs import transport as tr
    from otgym.rl.network import QNetwork

    def make(action: int, n_actions: int = 6):
        params = QNetwork(n_actions, FIXED_POLICY_HIDDEN).init(jax.random.PRNGKey(0), jnp.zeros((1, tr.OBS_SIZE)))
        last = params["params"][f"Dense_{len(FIXED_POLICY_HIDDEN)}"]
        last["kernel"] = jnp.zeros_like(last["kernel"])
        last["bias"] = jnp.zeros(n_actions).at[action].set(1.0)
        return params

    return make
