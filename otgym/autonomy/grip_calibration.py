"""The model-predictive navigator's grip, calibrated to the real one: the model's
contact springs and traps are softer than the task's (their stiffness is tied to the
model's coarser step and softer trap law), so the model's traps squeeze the cell further
(``grip_squeeze_um``) until its gripped assembly at rest has the real contact force
(``settled_contact_force_pn``, pN). JAX for the settling, numpy around it; lengths in um."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from otgym.sim import scene as sc

GRIP_CALIBRATION_S = 0.2
"""Time the gripped assembly settles at rest before its contact force is read."""
SQUEEZE_CANDIDATES_UM = np.linspace(0.0, 2.0, 81)
"""Model squeezes tried, all in one batch of the model's settling."""


def settled_contact_force_pn(scene: sc.Scene, centre_um, heading_rad, extra_squeeze_um) -> np.ndarray:
    """Mean robot-cell contact force (one per extra squeeze, pN) of the assembly gripped
    at rest by ``reset_at`` at ``centre_um``, its traps moved ``extra_squeeze_um`` (n,)
    further towards the cell, after ``GRIP_CALIBRATION_S``. The obstacles (placed well
    away by ``reset_at``) are not propelled: they do not touch the assembly either way,
    and the step without their random walk compiles faster. Two compiled programs per
    scene and n (``_gripped``, ``_still_step``)."""
    key = jax.random.PRNGKey(0)
    state = _gripped(
        scene,
        key,
        jnp.asarray(centre_um, jnp.float32),
        jnp.asarray(heading_rad, jnp.float32),
        jnp.asarray([-np.sin(heading_rad), np.cos(heading_rad)], jnp.float32),
        jnp.asarray(extra_squeeze_um, jnp.float32),
    )
    for _ in range(max(1, int(round(GRIP_CALIBRATION_S / scene.config.control_period_s)))):
        state, force = _still_step(scene, state, key)
    return np.asarray(force)


@jax.jit
def _gripped(scene: sc.Scene, key, centre_um, heading_rad, normal, extra):
    """``reset_at`` for each extra squeeze (n,), the traps moved that much further towards the cell."""
    state = jax.vmap(lambda _: sc.reset_at(scene, key, centre_um, heading_rad))(jnp.arange(extra.shape[0]))
    towards_cell = jnp.stack([normal, normal, -normal, -normal])  # robot a's traps, then robot b's
    traps = state.physics.trap_xy_um + extra[:, None, None] * towards_cell
    return state.replace(physics=state.physics.replace(trap_xy_um=traps))


@jax.jit
def _still_step(scene: sc.Scene, state: sc.SceneState, key):
    """One control step with the traps still and the obstacles unpropelled; the state
    and the mean robot-cell contact force (n,)."""
    still = jnp.zeros_like(state.physics.trap_xy_um)
    unpropelled = jnp.zeros_like(state.obstacle_propulsion_um_s)
    state, events = sc.step_batch(scene, state, still, key, unpropelled)
    return state, jnp.mean(events.contact_force_pn, axis=1)


def grip_squeeze_um(
    real_scene: sc.Scene, model_scene: sc.Scene, centre_um, heading_rad, candidates_um=SQUEEZE_CANDIDATES_UM
) -> float:
    """Squeeze (um) of the model's traps towards the cell, beyond the real scene's,
    that gives the model's gripped assembly at rest the robot-cell contact force the
    real scene's has (``settled_contact_force_pn``; the smallest such squeeze). The
    model's contact springs and traps are both softer (their stiffness is tied to the
    step and to the law), so the real squeeze would grip the cell with a fraction of
    the real force and the model would let it slip."""
    target = float(settled_contact_force_pn(real_scene, centre_um, heading_rad, np.zeros(1))[0])
    force = settled_contact_force_pn(model_scene, centre_um, heading_rad, np.asarray(candidates_um))
    reached = np.flatnonzero(force >= target)
    if reached.size == 0 or reached[0] == 0:
        raise ValueError(
            f"no model squeeze in [{candidates_um[0]}, {candidates_um[-1]}] um gives the real grip "
            f"force {target:.2f} pN (model: {force.min():.2f}-{force.max():.2f} pN)"
        )
    i = reached[0]  # the first squeeze that grips as hard: interpolate from the one before
    return float(np.interp(target, force[i - 1 : i + 1], candidates_um[i - 1 : i + 1]))


def squeezed_offsets_um(offsets_um, extra_um: float) -> np.ndarray:
    """Formation offsets (T, 2) with each trap moved ``extra_um`` towards the formation's
    axis (the cell, between the robots on either side of it)."""
    offsets = np.asarray(offsets_um, float).copy()
    offsets[:, 1] -= np.sign(offsets[:, 1]) * extra_um
    return offsets
