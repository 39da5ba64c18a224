"""Pure-JAX overdamped physics of multi-sphere microrobots in optical traps.

Quick use::

    from otgym import physics as ph
    bodies = [ph.two_handle_robot("robot"), ph.cell("cell")]
    model = ph.build_model(bodies, ph.PhysicsConfig(substeps=100))
    state = ph.initial_state(model, [[0, 0, 0], [0, 7.5, 0]])
    state, report = jax.jit(ph.control_step)(model, state, ph.Controls.zeros(model), key)
"""

from otgym.physics.adhesion import MATERIALS, Adhesion
from otgym.physics.bodies import (
    ROBOT_DESIGNS,
    TWO_HANDLE_GRIPPER_SPHERES,
    BodyKind,
    BodySpec,
    bead,
    cell,
    custom_body,
    four_arm_robot,
    obstacle,
    two_handle_robot,
)
from otgym.physics.calibration import simulate_trapped_bead
from otgym.physics.fields import NoWalls, UniformFlow
from otgym.physics.hydrodynamics import resistance_matrix
from otgym.physics.integrator import Controls, StepReport, control_step, control_step_batch, rollout
from otgym.physics.model import (
    Model,
    PhysicsConfig,
    PhysicsState,
    build_model,
    drag_force_pn,
    initial_state,
    max_stable_dt_s,
    sphere_positions_um,
)
from otgym.physics.traps import TrapLaw

__all__ = [
    "MATERIALS",
    "Adhesion",
    "ROBOT_DESIGNS",
    "TWO_HANDLE_GRIPPER_SPHERES",
    "BodyKind",
    "BodySpec",
    "bead",
    "cell",
    "custom_body",
    "four_arm_robot",
    "obstacle",
    "two_handle_robot",
    "simulate_trapped_bead",
    "NoWalls",
    "UniformFlow",
    "resistance_matrix",
    "Controls",
    "StepReport",
    "control_step",
    "control_step_batch",
    "rollout",
    "Model",
    "PhysicsConfig",
    "PhysicsState",
    "build_model",
    "drag_force_pn",
    "initial_state",
    "max_stable_dt_s",
    "sphere_positions_um",
    "TrapLaw",
]
