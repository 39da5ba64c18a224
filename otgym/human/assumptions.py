"""Every assumed parameter of the simulated participants with a plausible range: the one
table (``ASSUMPTIONS``) that ``otgym experiment human-sensitivity`` samples and
docs/human-model.md shows. A parameter is here unless a published measurement sets it
(``SOURCED``, with its citation): a new parameter of the model must be put in one or
the other (tests/human/test_assumptions.py fails otherwise).

Kinds: ``motor`` a ``HumanParams`` field (the population's mean), ``spread`` a
between-participant coefficient of variation (``POPULATION_CV``; the name is the
field's, the label ``cv_`` and the field), ``task`` a ``ParticipantTask`` field,
``window`` the window's latency (``otgym.human.percept.DISPLAY_LATENCY_S``).

Each range is where the value plausibly lies for the study's participants; its source
is either literature (cited) or reasoning (said). A range is not a distribution of
people: the population's spread is its own parameters (``spread``).
"""

from __future__ import annotations

import dataclasses
import math
import types

from otgym.human.params import POPULATION_CV, HumanParams
from otgym.human.participant_task import ParticipantTask
from otgym.human.percept import DISPLAY_LATENCY_S

KINDS = ("motor", "spread", "task", "window")


@dataclasses.dataclass(frozen=True)
class Assumption:
    """One assumed parameter: ``name`` as the model spells it, its ``kind`` (``KINDS``),
    its plausible range [``low``, ``high``] in the parameter's own unit, and ``source``
    ("literature: ..." or "reasoning: ...")."""

    name: str
    kind: str
    low: float
    high: float
    source: str

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"assumption {self.name}: kind must be one of {KINDS}, got {self.kind!r}")
        if not (math.isfinite(self.low) and math.isfinite(self.high) and 0 <= self.low < self.high):
            raise ValueError(f"assumption {self.name}: need 0 <= low < high, got [{self.low}, {self.high}]")
        if not self.source.startswith(("literature: ", "reasoning: ")):
            raise ValueError(f"assumption {self.name}: source must start 'literature: ' or 'reasoning: '")

    @property
    def label(self) -> str:
        """The name in outputs: ``cv_`` and the field for a spread, else the name."""
        return f"cv_{self.name}" if self.kind == "spread" else self.name

    @property
    def default(self) -> float:
        """The model's value now."""
        if self.kind == "motor":
            return float(getattr(HumanParams(), self.name))
        if self.kind == "spread":
            return float(POPULATION_CV[self.name])
        if self.kind == "task":
            return float(getattr(ParticipantTask(), self.name))
        return float(DISPLAY_LATENCY_S)


def _spread(name: str, low: float, high: float, why: str) -> Assumption:
    return Assumption(name, "spread", low, high, "reasoning: " + why)


_TYPICAL_SPREAD = "between-subject coefficients of variation of motor parameters are typically 0.1-0.5"

ASSUMPTIONS: tuple[Assumption, ...] = (
    # motor: population means without a measurement
    Assumption(
        "correction_jitter_fraction",
        "motor",
        0.1,
        0.4,
        "reasoning: intervals between corrective sub-movements vary by tens of percent (Miall, Weir & Stein "
        "1993 report 2-3 a second, not a period); a CV below 0.1 would be a clock, above 0.4 no rhythm",
    ),
    Assumption(
        "signal_dependent_noise",
        "motor",
        0.02,
        0.1,
        "reasoning: of the order of the few-percent CV of steady muscle force (Jones, Hamilton & Wolpert, "
        "J. Neurophysiol. 88, 1533, 2002), below the 0.1 extent error that holds most of a reach's variability",
    ),
    Assumption(
        "preferred_speed_mm_s",
        "motor",
        10.0,
        40.0,
        "reasoning: steering-law speed W / b' along a 2 mm path with b' 0.05-0.2 s (Accot & Zhai, CHI 1997)",
    ),
    Assumption(
        "lapse_rate_per_h",
        "motor",
        0.0,
        39.3,
        "literature: median 0 microsleeps of rested participants in a demanding dual task (Buckley et al., "
        "Conscious. Cogn. 45, 174, 2016) to 39.3 per hour in monotonous tracking (Peiris et al., J. Sleep Res. "
        "15, 291, 2006)",
    ),
    # the population's spread (the lapses' are Peiris et al.'s)
    _spread("reaction_time_s", 0.1, 0.25, "between-subject SDs of simple visual reaction time of 20-50 ms at 0.2 s"),
    _spread("correction_interval_s", 0.1, 0.4, _TYPICAL_SPREAD),
    _spread("neuromuscular_lag_s", 0.1, 0.4, _TYPICAL_SPREAD),
    _spread("extent_error_fraction", 0.15, 0.5, _TYPICAL_SPREAD),
    _spread("direction_error_deg", 0.15, 0.5, _TYPICAL_SPREAD),
    _spread("signal_dependent_noise", 0.15, 0.5, _TYPICAL_SPREAD),
    _spread(
        "tremor_rms_mm", 0.25, 0.8, "RMS tremor at an instrument tip of 50-200 um across people (Riviere et al. 1997)"
    ),
    _spread("preferred_speed_mm_s", 0.15, 0.5, _TYPICAL_SPREAD),
    _spread("fitts_b_s_per_bit", 0.1, 0.4, _TYPICAL_SPREAD),
    _spread("arm_damping_n_s_per_m", 0.15, 0.5, _TYPICAL_SPREAD),
    _spread("arm_mass_kg", 0.1, 0.4, "apparent hand mass 1-2 kg across people and postures (Tsuji et al. 1995)"),
    _spread("arm_stiffness_n_per_m", 0.15, 0.5, "hand stiffness 100-1000 N/m (Mussa-Ivaldi, Hogan & Bizzi 1985)"),
    # the task level (ParticipantTask): none has a measurement
    Assumption(
        "carry_speed_um_s",
        "task",
        1.0,
        5.0,
        "reasoning: manual optical-tweezers transport of cells is reported at a few um/s; a careful pace that "
        "keeps the grip, at most the autonomy's 5 um/s cruise",
    ),
    Assumption("lookahead_um", "task", 2.0, 10.0, "reasoning: a fraction to one of the assembly's 17 um diameter"),
    Assumption(
        "grip_tolerance_um", "task", 0.1, 0.5, "reasoning: a reach's tolerance well inside the 1 um that loses the grip"
    ),
    Assumption("open_gap_um", "task", 0.75, 3.0, "reasoning: half to twice the 1.5 um the task's approach gap allows"),
    Assumption("align_tolerance_um", "task", 0.2, 0.8, "reasoning: below the notches' depth, half to twice 0.4 um"),
    Assumption("seat_tolerance_um", "task", 0.75, 3.0, "reasoning: half to twice 1.5 um, of the order of open_gap_um"),
    Assumption(
        "clearance_um",
        "task",
        12.2,
        15.7,
        "reasoning: the assembly's and the obstacle's radii (11.7 um) plus a margin of 0.5-4 um",
    ),
    Assumption(
        "horizon_s", "task", 3.0, 10.0, "reasoning: the seconds a crossing obstacle takes to cross the assembly's path"
    ),
    Assumption(
        "glimpse_s", "task", 0.25, 1.0, "reasoning: a fixation or two (0.2-0.5 s each) to judge a motion on screen"
    ),
    Assumption("hurry_factor", "task", 1.2, 2.0, "reasoning: a noticeable hurry, within the hands' speed limits"),
    Assumption("still_speed_um_s", "task", 0.5, 2.0, "reasoning: motion a person sees as standing on the window"),
    Assumption(
        "still_clearance_um",
        "task",
        11.7,
        13.2,
        "reasoning: the radii plus 0-1.5 um; a standing obstacle parked 14 um from the route must stay passable",
    ),
    Assumption("pending_memory_s", "task", 0.25, 1.0, "reasoning: of the order of a correction interval (0.4 s)"),
    Assumption("wall_clearance_um", "task", 1.0, 4.0, "reasoning: half to twice 2 um, a handle's size"),
    Assumption("close_speed_um_s", "task", 0.4, 1.5, "reasoning: a careful close, well below the carry pace"),
    Assumption("close_guard_um", "task", 0.75, 3.0, "reasoning: half to twice 1.5 um, of the order of open_gap_um"),
    Assumption("along_angle_deg", "task", 30.0, 60.0, "reasoning: around the 45 deg that splits along from across"),
    Assumption(
        "side_step_resolution_um", "task", 0.25, 1.0, "reasoning: the smallest room a person tells apart on the window"
    ),
    Assumption(
        "squeeze_um",
        "task",
        0.5,
        1.4,
        "reasoning: of the 1.45 um of water between handle and cell beside the assembly, how much a person gives up",
    ),
    Assumption(
        "shared_lead_um", "task", 1.0, 5.0, "reasoning: of the order of the grip's tolerances, below lookahead_um"
    ),
    Assumption(
        "display_latency_s",
        "window",
        0.0,
        0.1,
        "reasoning: a frame of 16.7 ms plus a monitor's 5-50 ms (not measured on the window)",
    ),
)
"""The assumed parameters, their plausible ranges and sources: motor, spread, task, window."""

SOURCED: types.MappingProxyType = types.MappingProxyType(
    {
        "motor": {
            "reaction_time_s": "Woods et al., Front. Hum. Neurosci. 9, 131, 2015",
            "correction_interval_s": "Craik 1947; Miall, Weir & Stein 1993",
            "neuromuscular_lag_s": "McRuer & Jex, IEEE Trans. HFE 8, 231, 1967",
            "extent_error_fraction": "Gordon, Ghilardi & Ghez, Exp. Brain Res. 99, 97, 1994",
            "direction_error_deg": "Gordon, Ghilardi & Ghez 1994",
            "tremor_rms_mm": "Singh & Riviere 2002; Becker, Tummala & Riviere 2008",
            "tremor_band_hz": "McAuley & Marsden, Brain 123, 1545, 2000",
            "drift_rms_mm": "Riviere, Rader & Khosla 1997",
            "drift_cutoff_hz": "Riviere, Rader & Khosla 1997",
            "fitts_a_s": "MacKenzie, J. Motor Behav. 21, 323, 1989",
            "fitts_b_s_per_bit": "MacKenzie 1989",
            "arm_damping_n_s_per_m": "Tsuji, Morasso, Goto & Ito, Biol. Cybern. 72, 475, 1995",
            "arm_mass_kg": "Tsuji et al. 1995",
            "arm_stiffness_n_per_m": "Mussa-Ivaldi, Hogan & Bizzi, J. Neurosci. 5, 2732, 1985",
            "lapse_duration_s": "Peiris et al., J. Sleep Res. 15, 291, 2006",
        },
        "spread": {
            "lapse_rate_per_h": "Peiris et al. 2006 (SE over 15 subjects)",
            "lapse_duration_s": "Peiris et al. 2006 (SE over 15 subjects)",
        },
        "task": {"bimanual": "the paper's set-up (one stylus per robot), not a parameter"},
    }
)
"""The parameters a measurement sets, per kind, with the citation (not sampled)."""


def by_label() -> dict[str, Assumption]:
    """``ASSUMPTIONS`` keyed by ``Assumption.label``."""
    return {a.label: a for a in ASSUMPTIONS}


def unclassified(assumptions=ASSUMPTIONS, sourced=SOURCED) -> list[str]:
    """The model's parameters that are neither in ``assumptions`` nor in ``sourced``
    (as ``kind:name``), and those in both: empty when every parameter is weighed or
    cited once. The model's parameters: every ``HumanParams`` field, every
    ``POPULATION_CV`` key, every ``ParticipantTask`` field, the window's latency."""
    model = {
        "motor": [field.name for field in dataclasses.fields(HumanParams)],
        "spread": list(POPULATION_CV),
        "task": [field.name for field in dataclasses.fields(ParticipantTask)],
        "window": ["display_latency_s"],
    }
    problems = []
    for kind, names in model.items():
        assumed = {a.name for a in assumptions if a.kind == kind}
        cited = set(sourced.get(kind, {}))
        problems += [f"{kind}:{name}" for name in names if (name in assumed) == (name in cited)]
        problems += [f"{kind}:{name} (not in the model)" for name in sorted((assumed | cited) - set(names))]
    return problems
