"""Synthetic calibration traces of a bead in an optical trap.

OT labs calibrate traps from the thermal motion of a trapped bead (equipartition,
power spectrum; Berg-Sorensen & Flyvbjerg, Rev. Sci. Instrum. 75, 594, 2004). This
module produces such traces with otgym's own physics core (a one-bead model with a
harmonic trap, integrated by Euler-Maruyama), so labs can test their pipelines and we
can validate the physics against the analytic results.

Accuracy: Euler-Maruyama inflates the stationary variance of an Ornstein-Uhlenbeck
process by 1 / (1 - lambda/2), lambda = k dt / gamma; the internal step is chosen so
that lambda <= 0.01 (bias <= 0.5 %), with a whole number of steps per sample.
"""

from __future__ import annotations

import functools
import math

import jax
import jax.numpy as jnp
import numpy as np

from otgym.physics.bodies import bead
from otgym.physics.integrator import Controls, control_step
from otgym.physics.model import PhysicsConfig, build_model, initial_state, max_stable_dt_s
from otgym.physics.traps import TrapLaw
from otgym.physics.validation import require_non_negative, require_positive_scalar

MAX_RELAXATION_PER_STEP = 0.01
SAMPLES_PER_CHUNK = 8192


@functools.partial(jax.jit, static_argnames=("n_samples",))
def _sample_chunk(model, state, controls, key, n_samples: int):
    def body(carry, step_key):
        new_state, _ = control_step(model, carry, controls, step_key)
        origin = new_state.trap_xy_um[0] if model.n_traps else jnp.zeros(2, new_state.pose.dtype)
        return new_state, new_state.pose[0, :2] - origin

    return jax.lax.scan(body, state, jax.random.split(key, n_samples))


def _substeps_per_sample(sample_dt_s, stiffness, radius_um, config_without_trap, bodies):
    drag = 6 * math.pi * config_without_trap.viscosity_pa_s * radius_um
    by_relaxation = math.ceil(stiffness * sample_dt_s / drag / MAX_RELAXATION_PER_STEP)
    by_tunnelling = math.ceil(sample_dt_s / max_stable_dt_s(bodies, config_without_trap, traps=[]))
    return max(1, by_relaxation, by_tunnelling)


def simulate_trapped_bead(
    diameter_um: float,
    stiffness_pn_per_um: float,
    *,
    temperature_k: float = 298.15,
    viscosity_pa_s: float = 8.9e-4,
    sample_rate_hz: float = 50_000.0,
    duration_s: float = 10.0,
    seed: int = 0,
) -> np.ndarray:
    """Positions (n_samples, 2) in um of a bead relative to a fixed trap centre,
    sampled at ``sample_rate_hz`` for ``duration_s``. ``stiffness_pn_per_um=0`` gives a
    free bead (then positions are relative to its start). The bead starts at the trap
    centre; discard the first few relaxation times gamma/k if you need stationarity."""
    diameter = require_positive_scalar("diameter_um", diameter_um)
    stiffness = float(require_non_negative("stiffness_pn_per_um", stiffness_pn_per_um))
    require_non_negative("temperature_k", temperature_k)
    require_positive_scalar("viscosity_pa_s", viscosity_pa_s)
    rate = require_positive_scalar("sample_rate_hz", sample_rate_hz)
    duration = require_positive_scalar("duration_s", duration_s)
    if not isinstance(seed, (int, np.integer)) or isinstance(seed, bool):
        raise ValueError(f"seed must be an integer, got {seed!r}")
    n_samples = int(round(duration * rate))
    if n_samples < 2:
        raise ValueError(f"duration_s * sample_rate_hz gives {n_samples} samples; need at least 2")

    bodies = [bead("bead", radius_um=diameter / 2)]
    law = TrapLaw(name="harmonic", stiffness_pn_per_um=max(stiffness, 1e-12))
    base = PhysicsConfig(
        dt_s=1.0 / rate, temperature_k=float(temperature_k), viscosity_pa_s=float(viscosity_pa_s), trap_law=law
    )
    substeps = _substeps_per_sample(1.0 / rate, stiffness, diameter / 2, base, bodies)
    config = PhysicsConfig(
        dt_s=1.0 / rate / substeps,
        substeps=substeps,
        temperature_k=float(temperature_k),
        viscosity_pa_s=float(viscosity_pa_s),
        trap_law=law,
    )
    model = build_model(bodies, config, traps=[(0, 0)] if stiffness > 0 else [])
    state = initial_state(model, np.zeros((1, 3)), np.zeros((model.n_traps, 2)))
    controls = Controls.zeros(model)
    key = jax.random.PRNGKey(seed)
    chunks = []
    for _ in range(0, n_samples, SAMPLES_PER_CHUNK):
        key, chunk_key = jax.random.split(key)
        state, samples = _sample_chunk(model, state, controls, chunk_key, SAMPLES_PER_CHUNK)
        chunks.append(np.asarray(samples))
    return np.concatenate(chunks)[:n_samples].astype(float)
