"""The ``assemble`` task's physics respects the holographic tweezer's limits: the power
is shared (a bead's thermal spread in a held trap gives the trap's stiffness, which
halves when the traps double), the traps move only at the SLM's frame ticks, and a
jump beyond the trap's reach loses the bead."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from otgym.physics.constants import thermal_energy_pn_um
from otgym.tasks.assemble import core
from otgym.tasks.assemble.config import AssembleConfig, preset

pytestmark = pytest.mark.slow  # hundreds of held-trap frames: seconds of CPU each


def _measured_stiffness_pn_per_um(config: AssembleConfig, n_env: int = 256, frames: int = 4, seed: int = 0):
    """(stiffness from the beads' position variance about their held traps, samples).

    Frames are 50 ms apart, over ten times the traps' relaxation time, so the samples
    are independent. Euler-Maruyama's stationary variance of a harmonic trap is
    (kT / k) / (1 - mu k dt / 2) (mu the bead's mobility), inverted here for k."""
    params = core.make_params(config)
    _, state = jax.jit(core.reset_batch, static_argnums=2)(jax.random.PRNGKey(seed), params, n_env)
    hold = jax.jit(lambda key, s: core.step_traps(key, params, s, s.physics.trap_xy_um, s.progress, s.pace_um))
    offsets = []
    for key in jax.random.split(jax.random.PRNGKey(seed + 1), frames):
        _, state, *_ = hold(key, state)
        offsets.append(np.asarray(state.physics.pose[..., :2] - state.physics.trap_xy_um, float))
    offsets = np.stack(offsets)
    variance = float(np.mean(offsets**2))
    mobility = float(params.model.body_translational_mobility[0, 0, 0])
    dt = float(params.model.dt_s)
    kt = thermal_energy_pn_um(config.temperature_k)
    stiffness = (1 - math.sqrt(1 - 2 * mobility * dt * kt / variance)) / (mobility * dt)
    return stiffness, offsets.size


def test_stiffness_halves_when_the_traps_double():
    """Two traps of the shared power against four: the measured stiffness of each trap
    halves. Tolerance: 4 standard errors of the variances (relative SE sqrt(2 / n))."""
    few, many = AssembleConfig(n_beads=2), AssembleConfig(n_beads=4)
    k_few, n_few = _measured_stiffness_pn_per_um(few)
    k_many, n_many = _measured_stiffness_pn_per_um(many, seed=10)
    se_few, se_many = math.sqrt(2 / n_few), math.sqrt(2 / n_many)
    assert k_few == pytest.approx(few.trap_stiffness_pn_per_um, rel=4 * se_few)
    assert k_many == pytest.approx(many.trap_stiffness_pn_per_um, rel=4 * se_many)
    assert k_many / k_few == pytest.approx(0.5, rel=4 * math.hypot(se_few, se_many))


def test_traps_jump_at_the_frame_tick_and_stand_still_through_the_frame():
    """After a step the traps sit exactly where the plan puts them at the new progress
    (they did not move during the frame), and the bead of the longest way started the
    frame a whole jump from its trap (a trap sweeping through the frame would drag its
    bead within a few tens of nm). Two frames: two jumps, 2 x 50 ms."""
    params = core.make_params(preset("ring"))
    config = params.config
    _, state = jax.jit(core.reset_batch, static_argnums=2)(jax.random.PRNGKey(3), params, 16)
    step = jax.jit(core.step_batch)
    action = 3
    pace = config.pace_levels_um[action]
    start, goal = np.asarray(state.start_um), np.asarray(state.goal_um)
    way = np.linalg.norm(goal - start, axis=-1).max(axis=-1)
    for frame in (1, 2):
        _, state, _, terminated, _, info = step(jax.random.PRNGKey(frame), state, jnp.full(16, action), params)
        fraction = (frame * pace / way)[:, None, None]
        np.testing.assert_allclose(np.asarray(state.physics.trap_xy_um), start + fraction * (goal - start), atol=2e-5)
        distance = np.asarray(info["max_trap_distance_um"])
        assert np.all(distance >= pace - 0.1) and np.all(distance <= pace + 0.2), distance
        np.testing.assert_allclose(np.asarray(info["time_s"]), frame * config.frame_period_s, rtol=1e-6)
        assert not np.any(np.asarray(terminated))


def test_a_jump_beyond_the_traps_reach_loses_beads():
    """The smallest pace (0.15 um per frame, well within the 0.6 um waist) loses no bead
    in 16 episodes; the largest (1.2 um, two waists, where the Gaussian force is e^-8 of
    its peak) loses beads in most of them and ends them as failures."""
    params = core.make_params(preset("ring"))
    _, state = jax.jit(core.reset_batch, static_argnums=2)(jax.random.PRNGKey(4), params, 16)
    step = jax.jit(core.step_batch)
    _, _, _, terminated, _, info = step(jax.random.PRNGKey(5), state, jnp.zeros(16, jnp.int32), params)
    assert int(np.sum(info["beads_lost"])) == 0 and not np.any(np.asarray(terminated))
    last = params.config.n_actions - 1
    _, _, reward, terminated, _, info = step(jax.random.PRNGKey(6), state, jnp.full(16, last), params)
    lost = np.asarray(info["beads_lost"])
    assert np.mean(lost > 0) > 0.5
    assert np.all(np.asarray(terminated)[lost > 0]) and np.all(np.asarray(info["failed"])[lost > 0])
    assert np.all(np.asarray(reward)[lost > 0] < 0)
