"""Task presets: the scene, the route and the speed levels of the transport tasks.

``paper``: the paper's trap law (equation 3, at most 0.30 pN per handle) and its six
constant-speed groups, 0.27 to 0.51 um/s (Table II), in water at 20 C (1.0 mPa s), a
medium chosen from physics, not tuned (docs/decisions/0005-paper-preset-medium.md). In
it the paper's speeds are mostly safe, so the speed trade-off of the paper's Table II is
much weaker here than published.
The cell is carried upstream (outlet to inlet) against a weak flow (4 % of the chip's
nominal flow, 0.2-0.3 um/s), which varies along the path. Episodes are 15 um segments
of the planned path (about 200 control steps, as in the paper) at random places;
obstacles drift slowly (0.2 um/s) and start at least 80 um away.

``realistic``: literature traps (Gaussian beam, 50 pN/um, 0.6 um waist), water, the
chip's full flow and 2 um/s obstacles; the cell is carried downstream (as the
``otgym demo``) over 40 um segments with speeds of 2 to 12 um/s, where obstacles,
not the traps, are the danger. About 40 times costlier per step than ``paper``.
"""

from __future__ import annotations

import dataclasses

from otgym import physics as ph
from otgym.physics.validation import require_positive_scalar
from otgym.sim.obstacles import ObstacleMotion
from otgym.sim.scene import SceneConfig

PAPER_SPEEDS_UM_S = (0.27, 0.318, 0.366, 0.414, 0.462, 0.51)
"""The six constant-speed groups of the paper's Table II (0.27 to 0.51 um/s, evenly
spaced; the paper gives only the ends)."""


@dataclasses.dataclass(frozen=True)
class RewardWeights:
    """Per-step reward terms (paper section II-C, original release): a time cost, a
    speed bonus, a safe contact-force band, handle deviation, and terminal terms.

    ``trap_margin`` (shaping, ours): per handle, ``trap_margin`` per tenth of the escape
    distance by which the handle-to-trap distance d exceeds ``trap_margin_fraction`` of
    it. At 0.45 the penalty starts at 0.40 um for ``paper``, just before the bend of its
    law (0.446 um): beyond the bend the restoring force falls, and once a handle is
    0.5-0.6 um out even the slowest speed cannot bring it back. Such near-losses are far
    more frequent than losses, so they teach the risk faster. The failure penalty alone
    cannot: the DQN's Huber loss clips the error of its rare large targets, so a failure
    pulls the Q-values down by the same gradient whatever its size. The fraction and
    weight were chosen among five variants (docs/decisions/0025-reward-shaping.md).

    ``cell_margin`` (shaping, ours): ``cell_margin`` per 0.1 um by which the cell sits
    more than ``cell_margin_um`` behind the formation's centre along the path (the
    observation's entry 2, which the policy sees). In water at 20 C most failures are
    detachments: drag and the opposing flow push the cell backwards out of the robots'
    notches over a few seconds (it is more than 2 um back about 3 s before it detaches,
    and seldom comes back from there), while in completed episodes it stays within about
    1.2 um (99th percentile). The slide is the precursor the policy can act on by slowing
    down, and it is far more frequent than the detachment itself.

    ``priced(penalty)``: the same reward with failure penalty ``-penalty`` and both
    precursor shapings scaled in proportion, so that a near-loss keeps its price relative
    to a loss (the failure penalty alone changes little, see above)."""

    time: float = -0.05
    speed: float = 0.05
    force_in_band: float = 0.01
    force_out_of_band: float = -0.05
    handle_deviation: float = -0.02
    trap_margin: float = -0.1
    trap_margin_fraction: float = 0.45
    cell_margin: float = -0.1
    cell_margin_um: float = 0.8
    failure: float = -100.0
    goal: float = 10.0

    def priced(self, penalty: float) -> RewardWeights:
        """Failure penalty ``-penalty``; ``trap_margin`` and ``cell_margin`` scaled by
        ``penalty / -failure``."""
        require_positive_scalar("penalty", penalty)
        scale = penalty / -self.failure
        return dataclasses.replace(
            self, failure=-float(penalty), trap_margin=self.trap_margin * scale, cell_margin=self.cell_margin * scale
        )


@dataclasses.dataclass(frozen=True)
class TaskConfig:
    """A transport task: scene, route (start and goal of the planned path: sites of the
    chip, by name, or points in um),
    episode segment length, speed levels and limits, reward weights."""

    name: str
    scene: SceneConfig
    start_um: str | tuple[float, float]  # a site of the chip's sidecar, or (x, y) um
    goal_um: str | tuple[float, float]
    segment_um: float
    speed_levels_um_s: tuple[float, ...]
    max_steps: int
    max_robot_speed_um_s: float
    force_band_pn: tuple[float, float] = (0.05, 10.0)
    deviation_limit_um: float = 0.2
    reward: RewardWeights = RewardWeights()

    def __post_init__(self):
        require_positive_scalar("segment_um", self.segment_um)
        require_positive_scalar("max_robot_speed_um_s", self.max_robot_speed_um_s)
        require_positive_scalar("deviation_limit_um", self.deviation_limit_um)
        if not self.speed_levels_um_s or any(not (v > 0) for v in self.speed_levels_um_s):
            raise ValueError(f"speed_levels_um_s must be positive speeds, got {self.speed_levels_um_s}")
        if not isinstance(self.max_steps, int) or self.max_steps < 1:
            raise ValueError(f"max_steps must be a positive integer, got {self.max_steps!r}")
        low, high = self.force_band_pn
        if not 0 <= low < high:
            raise ValueError(f"force_band_pn must be (low, high) with 0 <= low < high, got {self.force_band_pn}")

    @property
    def n_actions(self) -> int:
        return len(self.speed_levels_um_s)


def paper() -> TaskConfig:
    scene = SceneConfig(
        trap_law=ph.TrapLaw.paper(),
        dt_s=4e-3,
        viscosity_pa_s=1.0e-3,
        flow_scale=0.04,
        obstacle_motion=ObstacleMotion(speed_um_s=0.2),
        min_obstacle_distance_um=80.0,
    )
    return TaskConfig(
        name="paper",
        scene=scene,
        start_um="goal",  # the paper's learning task runs the chip's route backwards
        goal_um="start",
        segment_um=15.0,
        speed_levels_um_s=PAPER_SPEEDS_UM_S,
        max_steps=300,
        max_robot_speed_um_s=1.0,
    )


def realistic() -> TaskConfig:
    return TaskConfig(
        name="realistic",
        scene=SceneConfig(),
        start_um="start",
        goal_um="goal",
        segment_um=40.0,
        speed_levels_um_s=(2.0, 4.0, 6.0, 8.0, 10.0, 12.0),
        max_steps=100,
        max_robot_speed_um_s=15.0,
    )


PRESETS = {"paper": paper, "realistic": realistic}


def preset(name: str) -> TaskConfig:
    if name not in PRESETS:
        raise ValueError(f"unknown preset {name!r}; choose one of {sorted(PRESETS)}")
    return PRESETS[name]()
