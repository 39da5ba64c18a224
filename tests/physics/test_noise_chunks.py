"""Large batches draw a control step's noise in chunks inside the loop
(``Model.noise_chunk_bytes``); the dynamics must go on across chunks as in one draw.
(That the chunks' noise is fresh is tested with the diffusion coefficients in
test_diffusion.py.)"""

import jax
import jax.numpy as jnp
import numpy as np

from otgym import physics as ph
from otgym.physics.integrator import _noise_chunk_substeps
from tests.physics.helpers import batch_state, step_batch

N_ENV = 4
TRAP_SPEED_UM_S = 20.0


def test_chunks_carry_the_trap_motion_and_the_field_blocks_on():
    """At T = 0 (no noise) two robots pulled by traps moving at 20 um/s through 20
    substeps in field-refresh blocks of 5: drawn in chunks of one block (the trap
    positions and the blocks' field samples must continue from the chunk before), the
    step ends where the single draw's does. Were each chunk to restart the trap motion
    from the step's start, the traps would end 20 um/s x 15 substeps x 0.1 ms = 30 nm
    short."""
    config = ph.PhysicsConfig(dt_s=1e-4, substeps=20, temperature_k=0.0, field_refresh_substeps=5)
    model = ph.build_model([ph.two_handle_robot("a"), ph.two_handle_robot("b")], config)
    state = batch_state(model, np.array([[0.0, -6.0, 0.0], [0.0, 6.0, 0.3]]), N_ENV)
    controls = ph.Controls.zeros(model, N_ENV).replace(
        trap_velocity_um_s=jnp.full((N_ENV, model.n_traps, 2), TRAP_SPEED_UM_S / np.sqrt(2)))
    one_block = 5 * 3 * model.n_bodies * N_ENV * 4
    chunked_model = model.replace(noise_chunk_bytes=one_block)
    assert _noise_chunk_substeps(chunked_model, N_ENV, 4) == 5
    assert _noise_chunk_substeps(model, N_ENV, 4) == 20
    whole, whole_report = step_batch(model, state, controls, jax.random.PRNGKey(0))
    chunked, chunked_report = step_batch(chunked_model, state, controls, jax.random.PRNGKey(0))
    np.testing.assert_allclose(np.asarray(chunked.trap_xy_um), np.asarray(whole.trap_xy_um), atol=1e-6)
    np.testing.assert_allclose(np.asarray(chunked.pose), np.asarray(whole.pose), atol=1e-6)
    np.testing.assert_allclose(np.asarray(chunked_report.trap_distance_max_um),
                               np.asarray(whole_report.trap_distance_max_um), atol=1e-6)
    moved = np.linalg.norm(np.asarray(whole.trap_xy_um) - np.asarray(state.trap_xy_um), axis=-1)
    np.testing.assert_allclose(moved, TRAP_SPEED_UM_S * 20 * 1e-4, rtol=1e-3)


def test_chunk_sizes_are_whole_blocks_that_divide_the_step():
    """2000 substeps in blocks of 10 (the transport scene's): a limit that fits 450
    substeps gives chunks of 400 (the largest whole number of blocks dividing 200
    blocks that fits); one that fits less than a block gives one block."""
    model = ph.build_model([ph.bead()], ph.PhysicsConfig(substeps=2000, field_refresh_substeps=10))
    per_substep = 3 * model.n_bodies * 1024 * 4
    assert _noise_chunk_substeps(model.replace(noise_chunk_bytes=450 * per_substep), 1024, 4) == 400
    assert _noise_chunk_substeps(model.replace(noise_chunk_bytes=3 * per_substep), 1024, 4) == 10
    assert _noise_chunk_substeps(model.replace(noise_chunk_bytes=2000 * per_substep), 1024, 4) == 2000
