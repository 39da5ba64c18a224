"""Arbitration of shared control (paper section II-E): the traps move by

    dP_s = tau * (alpha * dP_h + (1 - alpha) * dP_r),

a blend of the human's increment dP_h and the autonomy's dP_r, weighted by the human's
share alpha, which depends on the context: the distance d from the carried assembly to
the nearest dynamic obstacle.

Units. Both increments enter in micrometres at the trap: the retargeter
(``otgym.teleop.retarget``) already applies the stylus-to-trap motion scale (the
paper's tau, in um per mm), and the navigator's increment is in um. The blend's own
``tau`` is then a dimensionless gain (1 by default); the paper's formula, with dP_r
expressed in stylus units, is the same blend.

d is the gap in um between the assembly's outline (its bounding circle) and the
nearest obstacle's surface. The paper does not give d's unit (its Fig. 6 uses d1 = 1,
d2 = 2); we read it in robot lengths: the two-handle robot is about 10 um long, so
d1 = 10 um and d2 = 20 um. At 10 um the assembly, moving at a few um/s, meets an
obstacle within a few seconds, about the time a person needs to see, decide and
correct (reaction time plus a couple of sub-movements), so the human's share is
largest there.

Laws of alpha(d):
* ``paper`` (equation 4): 0.5 for d <= d1, falling linearly to 0.1 at d2, 0.1 beyond.
* ``step``: the authors' release, three steps (0.5 below d1, 0.3 between, 0.1 beyond).
* ``smooth``: the paper's ramp made C1-smooth (a smoothstep between d1 and d2), so the
  share never jumps in slope when the gap crosses d1 or d2.
Modes: ``manual`` (alpha 1), ``shared`` (the law), ``autonomous`` (alpha 0). Every
function here is pure and works on numpy arrays (broadcasting) or scalars.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from otgym import registry

MODES = ("manual", "shared", "autonomous")
ALPHA_NEAR = 0.5
ALPHA_FAR = 0.1
ALPHA_MIDDLE_STEP = 0.3


def _ramp(distance_um, d1_um: float, d2_um: float):
    """0 at or below d1, 1 at or above d2, linear between."""
    return np.clip((np.asarray(distance_um, float) - d1_um) / (d2_um - d1_um), 0.0, 1.0)


def paper_alpha(distance_um, d1_um: float, d2_um: float):
    """Equation 4 of the paper."""
    return ALPHA_NEAR - (ALPHA_NEAR - ALPHA_FAR) * _ramp(distance_um, d1_um, d2_um)


def step_alpha(distance_um, d1_um: float, d2_um: float):
    """The release's three-step law: 0.5 below d1, 0.3 up to d2, 0.1 beyond."""
    distance = np.asarray(distance_um, float)
    return np.where(distance <= d1_um, ALPHA_NEAR, np.where(distance <= d2_um, ALPHA_MIDDLE_STEP, ALPHA_FAR))


def smooth_alpha(distance_um, d1_um: float, d2_um: float):
    """The paper's ramp through a smoothstep 3s^2 - 2s^3 (same ends, zero slope there)."""
    s = _ramp(distance_um, d1_um, d2_um)
    return ALPHA_NEAR - (ALPHA_NEAR - ALPHA_FAR) * s * s * (3.0 - 2.0 * s)


@dataclasses.dataclass(frozen=True)
class ArbitrationConfig:
    """The shared-control law: which alpha(d), its distances (um) and the blend gain."""

    law: str = "paper"
    """A registered shared-control law (``otgym list laws``): ``alpha(d_um, d1_um, d2_um)``."""
    d1_um: float = 10.0
    d2_um: float = 20.0
    tau: float = 1.0

    def __post_init__(self):
        registry.check("laws", self.law)
        for name in ("d1_um", "d2_um", "tau"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value)):
                raise ValueError(f"{name} must be a finite number, got {value!r}")
        if not 0 <= self.d1_um < self.d2_um:
            raise ValueError(f"need 0 <= d1_um < d2_um, got d1_um={self.d1_um}, d2_um={self.d2_um}")
        if self.tau <= 0:
            raise ValueError(f"tau must be positive, got {self.tau}")


def alpha_for_mode(mode: str, distance_um, config: ArbitrationConfig = ArbitrationConfig()):
    """The human's share for ``mode`` at obstacle gap ``distance_um`` (array or scalar)."""
    if mode == "manual":
        return np.ones_like(np.asarray(distance_um, float))
    if mode == "autonomous":
        return np.zeros_like(np.asarray(distance_um, float))
    if mode == "shared":
        return registry.load("laws", config.law)(distance_um, config.d1_um, config.d2_um)
    raise ValueError(f"unknown mode {mode!r}; choose one of {', '.join(MODES)}")


def blend(human_increment_um, robot_increment_um, alpha, tau: float = 1.0):
    """dP_s = tau (alpha dP_h + (1 - alpha) dP_r); alpha broadcasts over the last axis
    of the increments (shape (..., ) against (..., T, 2) needs alpha[..., None, None])."""
    return tau * (alpha * np.asarray(human_increment_um, float) + (1.0 - alpha) * np.asarray(robot_increment_um, float))
