"""The ``sort-cells`` config and what follows from it on the host: the speed at which the
manipulator may move a cell, how long it takes to take hold of one, and the light
intensity on a held cell.

Two manipulators (``mode``), one laser setting (``power_per_trap_mw`` per trap, the
Gaussian trap law with stiffness ``stiffness_per_power_pn_per_um_mw`` x power and waist
``waist_um``, as ``otgym.physics.light_dose`` relates them):

* ``robots``: two two-handle microrobots (``otgym.physics.robots``; four traps, one on
  each handle) grip the cell, as in the transport scene. The cell sees only the light of
  the handle traps that reaches it (``light_dose.cell_intensity_mw_per_um2`` at the
  scene's grip geometry for its radius). Moving the cell moves the whole assembly: its
  largest speed is the four traps' escape force over the Stokes drag of the cell and
  every robot sphere (6 pi eta r each, summed: hydrodynamic shielding between spheres
  left out, so the drag is overestimated). Taking hold (the robots travel to the cell
  and close the grip) takes ``grip_time_s`` (3 s, an assumption: the paper's robots move
  at a few um/s).
* ``direct``: one trap holds the cell itself, in its focus: the cell sees the focus
  intensity 2 P / (pi w0^2). Its largest speed is one trap's escape force over the cell's
  drag. Taking hold is moving a trap there: 0.25 s (an assumption; a spatial light
  modulator shows a new hologram at tens of Hz, Curtis, Koss & Grier, Opt. Commun. 207,
  169, 2002).

The escape force is the Gaussian law's peak force, k w exp(-1/2) / 2
(``otgym.physics.traps``). For a cell several wavelengths across, held in its focus,
this small-particle law is an approximation (a ray-optics trapping efficiency would be
the alternative, Ashkin, Biophys. J. 61, 569, 1992); the cell is moved at
``speed_fraction`` of that escape speed.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from otgym import physics as ph
from otgym.physics import light_dose as ld
from otgym.physics.constants import thermal_energy_pn_um
from otgym.physics.validation import require_positive_scalar
from otgym.sim import scene as sc

MODES = ("robots", "direct")
GRIP_TIME_S = {"robots": 3.0, "direct": 0.25}


@dataclasses.dataclass(frozen=True)
class SortReward:
    """Reward for each cell that leaves: into its own outlet, into the other one, or
    lost (refused at a full inlet or stalled in the chip)."""

    correct: float = 1.0
    wrong: float = -1.0
    lost: float = -1.0


@dataclasses.dataclass(frozen=True)
class SortConfig:
    """A sort-cells task (hashable, static under jit). ``outlets``: the outlet port of
    each kind (kind 0 is the smaller cell); ``junction_site``: the chip site where the
    inlet channel divides; cells arrive one every ``arrival_interval_s`` at the inlet
    port, each kind with probability one half, and at most ``max_cells`` are in the chip
    (an arrival beyond is lost)."""

    name: str
    mode: str = "robots"
    chip: str = "sorter"
    inlet: str = "inlet"
    outlets: tuple[str, str] = ("outlet_a", "outlet_b")
    junction_site: str = "junction"
    cell_radii_um: tuple[float, float] = (3.0, 5.0)
    flow_scale: float = 0.5
    arrival_interval_s: float = 10.0
    max_cells: int = 4
    control_period_s: float = 0.5
    substeps: int = 5
    max_steps: int = 240
    power_per_trap_mw: float = 20.0
    waist_um: float = 0.6
    stiffness_per_power_pn_per_um_mw: float = ld.STIFFNESS_PER_POWER_PN_PER_UM_MW
    speed_fraction: float = 0.5
    grip_time_s: float | None = None
    robot: str = "two-handle"
    viscosity_pa_s: float = 1.0e-3
    temperature_k: float = 293.15
    max_residence_s: float = 60.0
    exit_distance_um: float = 15.0
    min_purity: float = 0.9
    reward: SortReward = SortReward()

    def __post_init__(self):
        if self.mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {self.mode!r}")
        if len(self.outlets) != 2 or self.outlets[0] == self.outlets[1]:
            raise ValueError(f"outlets must name two different outlet ports, got {self.outlets!r}")
        radii = self.cell_radii_um
        if len(radii) != 2 or any(not (isinstance(r, (int, float)) and r > 0) for r in radii):
            raise ValueError(f"cell_radii_um must be two positive radii, got {radii!r}")
        for name in (
            "arrival_interval_s",
            "control_period_s",
            "power_per_trap_mw",
            "waist_um",
            "stiffness_per_power_pn_per_um_mw",
            "viscosity_pa_s",
            "temperature_k",
            "max_residence_s",
            "exit_distance_um",
        ):
            require_positive_scalar(name, getattr(self, name))
        if not (isinstance(self.flow_scale, (int, float)) and self.flow_scale >= 0):
            raise ValueError(f"flow_scale must be non-negative, got {self.flow_scale!r}")
        if not 0 < self.speed_fraction <= 1:
            raise ValueError(f"speed_fraction must lie in (0, 1], got {self.speed_fraction!r}")
        if self.grip_time_s is not None and not (self.grip_time_s >= 0 and math.isfinite(self.grip_time_s)):
            raise ValueError(f"grip_time_s must be a non-negative time, got {self.grip_time_s!r}")
        if not 0 <= self.min_purity <= 1:
            raise ValueError(f"min_purity must lie in [0, 1], got {self.min_purity!r}")
        for name in ("max_cells", "substeps", "max_steps"):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value!r}")

    @property
    def grip_time(self) -> float:
        return GRIP_TIME_S[self.mode] if self.grip_time_s is None else float(self.grip_time_s)

    @property
    def trap_law(self) -> ph.TrapLaw:
        stiffness = self.stiffness_per_power_pn_per_um_mw * self.power_per_trap_mw
        return ph.TrapLaw("gaussian", stiffness_pn_per_um=stiffness, waist_um=self.waist_um)

    @property
    def beam(self) -> ld.TrapBeam:
        return ld.TrapBeam(self.power_per_trap_mw, self.waist_um)

    def stokes_drag_pn_s_per_um(self, radius_um) -> np.ndarray:
        """6 pi eta r in pN s/um (eta in Pa s = pN s/um^2)."""
        return 6 * np.pi * self.viscosity_pa_s * np.asarray(radius_um, float)

    def diffusion_um2_s(self) -> np.ndarray:
        """Each kind's Stokes-Einstein diffusion coefficient kT / (6 pi eta R)."""
        return thermal_energy_pn_um(self.temperature_k) / self.stokes_drag_pn_s_per_um(self.cell_radii_um)


def manipulation(config: SortConfig) -> dict:
    """Per kind (arrays of 2): the speed (um/s) at which the manipulator moves a held
    cell, the light intensity (mW/um^2) on a held cell, and the number of traps used;
    the module docstring says how each follows from the config."""
    escape_force = config.trap_law.max_force_pn
    beam = config.beam
    speeds, intensities = [], []
    for radius in config.cell_radii_um:
        cell_drag = float(config.stokes_drag_pn_s_per_um(radius))
        if config.mode == "direct":
            n_traps, drag = 1, cell_drag
            intensity = beam.focus_intensity_mw_per_um2
        else:
            traps, robot_radii = sc.grip_geometry_um(sc.SceneConfig(robot=config.robot, cell_radius_um=radius))
            n_traps, drag = len(traps), cell_drag + float(np.sum(config.stokes_drag_pn_s_per_um(robot_radii)))
            intensity = float(ld.cell_intensity_jit(beam, traps, np.zeros(2), radius))
        speeds.append(config.speed_fraction * n_traps * escape_force / drag)
        intensities.append(intensity)
    return {"speed_um_s": np.asarray(speeds), "intensity_mw_per_um2": np.asarray(intensities), "n_traps": n_traps}
