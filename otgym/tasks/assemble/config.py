"""The ``assemble`` task's config: what a holographic optical tweezer (HOT) can do, each
limit a field with its source, and the presets.

Hardware limits of a HOT (a spatial light modulator, SLM, shapes one laser beam into
many traps by a computed hologram):

* ``slm_refresh_hz``: the trap pattern changes only when the SLM shows a new hologram.
  Liquid-crystal SLMs of holographic tweezers update at video rates, tens of Hz
  (Curtis, Koss & Grier, Opt. Commun. 207, 169, 2002; Grier, Nature 424, 810, 2003);
  between two updates every trap stands still, and at an update it jumps to its new
  place. Default 20 Hz: a 50 ms frame, one control step.
* ``max_traps``: the number of traps one hologram can form is bounded (SLM pixels,
  hologram computation, and above all the power each trap gets); a config with more
  beads than traps is refused. Default 16.
* Power sharing: the beam's power at the sample, ``laser_power_mw``, is split evenly
  between the N traps, and a trap's stiffness is proportional to its power (Neuman &
  Block, Rev. Sci. Instrum. 75, 2787, 2004, section on calibration; Curtis, Koss &
  Grier 2002 for the split), so each trap's stiffness is
  ``stiffness_per_power_pn_per_um_mw * laser_power_mw / N``: it falls as 1/N as traps
  are added. The trap is the Gaussian-beam gradient law of ``otgym.physics.traps``
  with that stiffness and ``waist_um``. The default, 0.2 pN/um per mW and 200 mW at
  the sample, is of the order reported for ~1 um polystyrene beads in water (a few to
  tens of pN/um per trap); it is an assumption of this task, not a calibration.

A trap jump larger than the trap's reach leaves its bead behind: the bead feels the
Gaussian law's force, which falls as exp(-2 r^2 / w^2), and weaker traps (more of
them) recapture from a shorter distance within one frame. A bead farther than
``lost_distance_um`` (default the waist) from its trap at the end of a frame is lost.
"""

from __future__ import annotations

import dataclasses
import math

from otgym import physics as ph
from otgym.physics.constants import ROOM_TEMPERATURE_K, WATER_VISCOSITY_PA_S
from otgym.physics.validation import require_positive_scalar

PATTERNS = ("ring", "lattice", "letter")


@dataclasses.dataclass(frozen=True)
class AssembleReward:
    """Per-step reward: a time cost, the progress of the pattern (the fraction of the
    planned move done this step, summing to ``progress`` over an episode), and terminal
    terms for a success and for a failure (a bead lost or two beads touching)."""

    time: float = -0.02
    progress: float = 1.0
    success: float = 1.0
    failure: float = -1.0


@dataclasses.dataclass(frozen=True)
class AssembleConfig:
    """Everything that defines an ``assemble`` episode (hashable, static under jit)."""

    name: str = "ring"
    pattern: str = "ring"
    n_beads: int = 8
    target_spacing_um: float = 3.0
    """Centre distance between neighbouring targets."""
    bead_radius_um: float = 0.5
    """1 um polystyrene beads, the usual HOT test particle."""
    arena_um: float = 40.0
    """The beads start in this square field of view (side, um), the pattern at its centre."""
    start_cell_um: float = 4.0
    """Beads start in distinct cells of this size, jittered within them."""
    clearance_um: float = 0.25
    """Surface clearance the plan keeps between beads (see ``min_separation_um``)."""
    slm_refresh_hz: float = 20.0
    max_traps: int = 16
    laser_power_mw: float = 200.0
    stiffness_per_power_pn_per_um_mw: float = 0.2
    waist_um: float = 0.6
    lost_distance_um: float | None = None
    """None: the waist."""
    dt_s: float = 1e-4
    temperature_k: float = ROOM_TEMPERATURE_K
    viscosity_pa_s: float = WATER_VISCOSITY_PA_S
    pace_levels_um: tuple[float, ...] = (0.15, 0.3, 0.45, 0.6, 0.75, 0.9, 1.05, 1.2)
    """The actions: how far the trap with the longest way to go jumps in one SLM frame;
    every other trap jumps the same fraction of its own way (synchronised straight
    lines, see ``otgym.tasks.assemble.plan``)."""
    placement_tolerance_um: float = 0.3
    """Success: every trap on its target with the RMS bead-target error below this."""
    max_steps: int = 200
    reward: AssembleReward = AssembleReward()

    def __post_init__(self):
        if self.pattern not in PATTERNS:
            raise ValueError(f"pattern must be one of {PATTERNS}, got {self.pattern!r}")
        if not isinstance(self.max_traps, int) or self.max_traps < 1:
            raise ValueError(f"max_traps must be a positive integer, got {self.max_traps!r}")
        if not isinstance(self.n_beads, int) or not 1 <= self.n_beads <= self.max_traps:
            raise ValueError(
                f"n_beads must be an integer within 1..max_traps={self.max_traps} (one trap per bead), "
                f"got {self.n_beads!r}"
            )
        for name in (
            "target_spacing_um",
            "bead_radius_um",
            "arena_um",
            "start_cell_um",
            "slm_refresh_hz",
            "laser_power_mw",
            "stiffness_per_power_pn_per_um_mw",
            "waist_um",
            "dt_s",
            "viscosity_pa_s",
            "placement_tolerance_um",
        ):
            require_positive_scalar(name, getattr(self, name))
        if self.lost_distance_um is not None:
            require_positive_scalar("lost_distance_um", self.lost_distance_um)
        if not (math.isfinite(self.clearance_um) and self.clearance_um >= 0):
            raise ValueError(f"clearance_um must be non-negative, got {self.clearance_um!r}")
        if self.dt_s > self.frame_period_s:
            raise ValueError(f"dt_s={self.dt_s} must not exceed the SLM frame period {self.frame_period_s:g} s")
        if not self.pace_levels_um or any(not (math.isfinite(p) and p > 0) for p in self.pace_levels_um):
            raise ValueError(f"pace_levels_um must be positive numbers, got {self.pace_levels_um!r}")
        if not isinstance(self.max_steps, int) or self.max_steps < 1:
            raise ValueError(f"max_steps must be a positive integer, got {self.max_steps!r}")
        if self.target_spacing_um < self.min_separation_um:
            raise ValueError(
                f"target_spacing_um={self.target_spacing_um} is below the collision-free separation "
                f"{self.min_separation_um:.2f} um (2 sqrt 2 (bead radius + clearance))"
            )
        if self.start_cell_um <= self.min_separation_um:
            raise ValueError(
                f"start_cell_um={self.start_cell_um} must exceed the separation {self.min_separation_um:.2f} um"
            )
        if self.cells_per_side**2 < self.n_beads:
            raise ValueError(
                f"arena_um={self.arena_um} has {self.cells_per_side**2} start cells for {self.n_beads} beads"
            )

    # -- derived ---------------------------------------------------------------------
    @property
    def frame_period_s(self) -> float:
        """One SLM frame: the control period."""
        return 1.0 / self.slm_refresh_hz

    @property
    def substeps(self) -> int:
        return max(1, int(round(self.frame_period_s / self.dt_s)))

    @property
    def n_traps(self) -> int:
        return self.n_beads

    @property
    def trap_stiffness_pn_per_um(self) -> float:
        """Each trap's stiffness: the power at the sample shared evenly by the N traps."""
        return self.stiffness_per_power_pn_per_um_mw * self.laser_power_mw / self.n_traps

    @property
    def trap_law(self) -> ph.TrapLaw:
        return ph.TrapLaw("gaussian", stiffness_pn_per_um=self.trap_stiffness_pn_per_um, waist_um=self.waist_um)

    @property
    def lost_distance(self) -> float:
        return self.waist_um if self.lost_distance_um is None else float(self.lost_distance_um)

    @property
    def min_separation_um(self) -> float:
        """Centre distance that starts and targets keep: with it, synchronised straight
        moves of a swap-stable assignment keep beads ``2 (radius + clearance)`` apart
        (Turpin, Michael & Kumar, Int. J. Robot. Res. 33, 1148, 2014)."""
        return 2 * math.sqrt(2) * (self.bead_radius_um + self.clearance_um)

    @property
    def cells_per_side(self) -> int:
        return int(self.arena_um // self.start_cell_um)

    @property
    def n_actions(self) -> int:
        return len(self.pace_levels_um)


PRESETS: dict[str, AssembleConfig] = {
    "ring": AssembleConfig(),
    "lattice": AssembleConfig(name="lattice", pattern="lattice", n_beads=9),
    "letter": AssembleConfig(name="letter", pattern="letter", n_beads=8),
    "ring-16": AssembleConfig(name="ring-16", n_beads=16),
}
"""``ring``: 8 beads on a ring (default). ``lattice``: 9 beads on a 3 x 3 square
lattice. ``letter``: 8 beads forming an L. ``ring-16``: 16 beads on a ring, each trap
with half the stiffness of ``ring``'s."""


def preset(name: str | AssembleConfig | None = None) -> AssembleConfig:
    if isinstance(name, AssembleConfig):
        return name
    if name is None:
        return PRESETS["ring"]
    if name not in PRESETS:
        raise ValueError(f"unknown assemble preset {name!r}; choose one of {list(PRESETS)}")
    return PRESETS[name]
