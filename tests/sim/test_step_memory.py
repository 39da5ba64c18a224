"""Scratch memory of one transport-scene control step per environment, from XLA's
memory analysis of the compiled batched step: a compile-time figure, the same on a busy
machine. The issue's limit, 0.25 MB per environment, lets one 80 GB GPU step 131,072
environments; with the noise of the step's 2000 substeps drawn up front it was 0.67 MB."""

import jax
import jax.numpy as jnp
import pytest

from otgym.sim import scene as sc

LIMIT_BYTES_PER_ENV = 250_000
N_ENV = 32
"""As tests/sim/test_scene.py's vmap test, which compiles the same batched step."""


@pytest.mark.slow
def test_transport_step_scratch_per_environment_is_under_a_quarter_megabyte(scene_of):
    scene = scene_of(sc.SceneConfig(kind="transport"))
    keys = jax.random.split(jax.random.PRNGKey(0), N_ENV)
    states = jax.eval_shape(jax.vmap(sc.reset, in_axes=(None, 0)), scene, keys)  # shapes only: nothing to run
    velocity = jnp.zeros((N_ENV, scene.n_traps, 2))
    compiled = jax.jit(sc.step_batch).lower(scene, states, velocity, jax.random.PRNGKey(1)).compile()
    per_env = compiled.memory_analysis().temp_size_in_bytes / N_ENV
    assert per_env <= LIMIT_BYTES_PER_ENV, f"{per_env:,.0f} bytes of scratch per environment"
