"""The one control tick of the interactive task (paper section II-E, Fig. 2), shared by
the batched trials of simulated participants (``otgym.runtime.trials``) and the
real-time loop of a person with devices (``otgym.runtime.loop``):

    modes  = each environment's arbitration mode (``mpc``: autonomous; ``shared``
             without the autonomy's dP_r this tick: manual)
    alpha  = alpha_for_mode(mode, gap to the nearest obstacle)          (otgym.shared)
    dP_h   = human(modes, alpha)                    (simulated hands, or the devices)
    dP_s   = cap_speed(blend(dP_h, dP_r, alpha, tau), max step)     (trap-speed clamp)

All arrays carry a leading environment axis E (the loop has E = 1); increments are
(E, T, 2) um at the trap per tick. The physics step that follows is the caller's: the
trials step every environment at once, the loop overlaps it with the microscope.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from otgym import registry
from otgym.autonomy.navigator import cap_speed
from otgym.shared import MODES, ArbitrationConfig, alpha_for_mode, blend
from otgym.task.task import Observation


@dataclasses.dataclass(frozen=True)
class TickCommand:
    """What the tick commands (E environments, T traps; um at the trap)."""

    modes: np.ndarray  # (E,) str: the arbitration mode each environment ran in
    alpha: np.ndarray  # (E,) the human's share
    human_um: np.ndarray  # (E, T, 2) dP_h
    shared_um: np.ndarray  # (E, T, 2) dP_s, what the traps move by


def arbitration_modes(modes, autonomy_live=True) -> np.ndarray:
    """Each environment's arbitration mode (E,): trials of a navigator's mode (``mpc``,
    ``rl``: navigators tagged ``trial-mode``) are autonomous, and
    shared control without the autonomy's dP_r (``autonomy_live`` False) is manual."""
    modes = np.asarray(modes)
    modes = np.where(np.isin(modes, registry.names("navigators", "trial-mode")), "autonomous", modes)
    return np.where((modes == "shared") & ~np.asarray(autonomy_live, bool), "manual", modes)


def mode_alpha(modes, gap_um: np.ndarray, config: ArbitrationConfig) -> np.ndarray:
    """alpha (E,) for each environment's mode at its obstacle gap ``gap_um`` (E,) um
    (``mpc``, ``rl``: autonomous)."""
    modes = arbitration_modes(modes)
    alpha = np.zeros(len(modes))
    for mode in MODES:
        chosen = modes == mode
        if chosen.any():
            alpha[chosen] = alpha_for_mode(mode, gap_um[chosen], config)
    return alpha


def control_tick(
    obs: Observation,
    modes,
    robot_um: np.ndarray,
    human: Callable[[np.ndarray, np.ndarray], np.ndarray],
    arbitration: ArbitrationConfig,
    max_step_um: float,
    autonomy_live=True,
) -> TickCommand:
    """The tick's command from what it sees (``obs``), each environment's mode
    (``modes`` (E,): ``otgym.runtime.trials.trial_modes()``), the autonomy's dP_r
    (``robot_um`` (E, T, 2); zeros where ``autonomy_live`` (E,) is False) and the
    human's dP_h, ``human(modes, alpha) -> (E, T, 2)`` (called once, after alpha:
    a simulated person reacts to the share it gets). Each trap's dP_s is capped at
    ``max_step_um``."""
    modes = arbitration_modes(modes, autonomy_live)
    alpha = mode_alpha(modes, obs.nearest_obstacle_gap_um, arbitration)
    human_um = human(modes, alpha)
    shared_um = cap_speed(blend(human_um, robot_um, alpha[:, None, None], arbitration.tau), max_step_um)
    return TickCommand(modes, alpha, human_um, shared_um)
