"""Pure-JAX overdamped physics of multi-sphere microrobots in optical traps.

Quick use::

    from otgym import physics as ph
    bodies = [ph.two_handle_robot("robot"), ph.cell("cell")]
    model = ph.build_model(bodies, ph.PhysicsConfig(substeps=100))
    state = ph.initial_state(model, [[0, 0, 0], [0, 7.5, 0]])
    state, report = jax.jit(ph.control_step)(model, state, ph.Controls.zeros(model), key)
"""

import importlib

_EXPORTS = {
    "MATERIALS": "adhesion",
    "Adhesion": "adhesion",
    "TWO_HANDLE_GRIPPER_SPHERES": "bodies",
    "BodyKind": "bodies",
    "BodySpec": "bodies",
    "bead": "bodies",
    "cell": "bodies",
    "custom_body": "bodies",
    "four_arm_robot": "bodies",
    "obstacle": "bodies",
    "two_handle_robot": "bodies",
    "simulate_trapped_bead": "calibration",
    "NoWalls": "fields",
    "UniformFlow": "fields",
    "resistance_matrix": "hydrodynamics",
    "Controls": "integrator",
    "StepReport": "integrator",
    "control_step": "integrator",
    "control_step_batch": "integrator",
    "rollout": "integrator",
    "Model": "model",
    "PhysicsConfig": "model",
    "PhysicsState": "model",
    "build_model": "model",
    "drag_force_pn": "model",
    "initial_state": "model",
    "max_stable_dt_s": "model",
    "sphere_positions_um": "model",
    "TrapLaw": "traps",
}
"""Each public name and the submodule that defines it: loaded on first use (PEP 562), so
that a light user (``physics.validation``, ``physics.constants``) does not import JAX."""

__all__ = list(_EXPORTS)


def __getattr__(name: str):
    if name in _EXPORTS:
        value = getattr(importlib.import_module(f"otgym.physics.{_EXPORTS[name]}"), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'otgym.physics' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*globals(), *_EXPORTS])
