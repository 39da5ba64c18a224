"""Batched trials of the interactive task: every environment is one trial (a simulated
participant, a mode, a scenario), all stepped together tick by tick:

    dP_r = navigator(observation)                       (the autonomy, um: the route
                                                         navigator, or the model-predictive
                                                         one in mode ``mpc`` and, with
                                                         ``shared_autonomy="mpc"``, in shared mode;
                                                         the learned-speed one in mode ``rl``
                                                         and with ``shared_autonomy="rl"``)
    alpha, dP_h, dP_s = control_tick(...)               (otgym.runtime.tick: the law, the
                                                         participants' two hands, the blend)
    observation = task.step(dP_s)

Each hand feels the feedback of its robot's handles. In batched trials the handle
forces come from the trap law at the simulator's handle offsets: rendering and sensing
a microscope frame per environment and tick would cost about 100 times the physics.
The vision sensor measures the same offsets to a few nanometres (``otgym.sim.sensor``,
tested), and the interactive loop (``otgym.runtime.loop``) feeds the real sensor.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence

import jax
import numpy as np

from otgym import registry
from otgym.autonomy.mpc import MPCConfig, MPCCosts
from otgym.autonomy.mpc_navigator import MPCNavigator, observation_rows
from otgym.autonomy.navigator import RouteNavigator
from otgym.autonomy.protocol import Navigator
from otgym.autonomy.rl_navigator import RLNavigator
from otgym.human.params import HumanParams
from otgym.human.participant_task import ParticipantTask
from otgym.human.participants import SimulatedParticipants
from otgym.human.percept import DISPLAY_LATENCY_S, ShownRoute, WindowDisplay
from otgym.runtime.tick import arbitration_modes, control_tick, mode_alpha
from otgym.runtime.trace import TickView
from otgym.shared import MODES, ArbitrationConfig
from otgym.task.scenario import Scenario
from otgym.task.task import InteractiveTask
from otgym.teleop.feedback import FeedbackConfig, stable_newtons_per_pn
from otgym.teleop.retarget import RetargetConfig

TASK_RETARGET = RetargetConfig(dead_band_mm_s=0.3, max_trap_speed_um_s=20.0)
"""Stylus-to-trap mapping of the task: 2 um/mm; a 0.3 mm/s dead band (0.6 um/s at the
trap, below the 2 um/s manual pace); trap speeds up to 20 um/s, enough to chase a free
cell drifting in the chip's 8 um/s flow and far below the assembly's escape speed."""


CRUISE_SPEED_UM_S = 5.0
"""The route navigator's speed along the route in trials: the autonomous mode's pace."""

TRIAL_MODES = MODES + registry.names("navigators", "trial-mode")
"""The arbitration modes, and the navigators tagged ``trial-mode``: autonomous (alpha 0)
with that navigator's dP_r instead of the route navigator's (``mpc``: the
model-predictive navigator; ``rl``: the learned-speed one)."""
PEOPLE_MODES = ("manual", "shared")
"""The arbitration modes in which a participant's dP_h counts (alpha > 0 at times)."""
AUTONOMIES = registry.names("navigators", "shared")
"""Whose dP_r shared control may get: the navigators tagged ``shared``."""


TRIAL_COLUMNS = [
    "participant",
    "mode",
    "trial",
    "scenario",
    "completion_time_s",
    "obstacles_encountered",
    "obstacles_avoided",
    "success",
    "reached_goal",
    "trap_losses",
    "detached",
    "peak_contact_force_pn",
]
"""The columns of trials.csv, first in this order, for simulated participants
(``otgym experiment shared-control``) and people (``otgym play``) alike."""


@dataclasses.dataclass(frozen=True)
class TrialSpec:
    participant: int
    mode: str
    trial: int
    scenario: int

    def __post_init__(self):
        if self.mode not in TRIAL_MODES:
            raise ValueError(f"unknown mode {self.mode!r}; choose one of {', '.join(TRIAL_MODES)}")


def task_feedback(trap_law, retarget: RetargetConfig, handles_per_robot: int) -> FeedbackConfig:
    """Feedback of the task's styluses: one scale (N per pN) for the trap forces and
    the contact cue, the largest at which the hand-trap loop is stable
    (``stable_newtons_per_pn``; the 0.6 N full scale of ``newtons_per_pn_for`` made the
    simulated hands oscillate against the 50 pN/um literature traps)."""
    scale = stable_newtons_per_pn(
        trap_law.centre_stiffness_pn_per_um, handles_per_robot, retarget.motion_scale_um_per_mm
    )
    contact_limit_pn = FeedbackConfig().contact_limit_pn
    return FeedbackConfig(newtons_per_pn=scale, contact_gain_n=scale * contact_limit_pn)


def stylus_feedback(task) -> FeedbackConfig:
    """``task_feedback`` for a person's styluses on ``task`` (``TASK_RETARGET``, the
    task's handles per robot): what ``otgym play`` and the sim node give each device."""
    return task_feedback(task.config.scene.trap_law, TASK_RETARGET, int(np.sum(task.trap_robot == task.trap_robot[0])))


def run_trials(
    task: InteractiveTask,
    specs: list[TrialSpec],
    participants: dict[int, HumanParams],
    seed: int,
    arbitration: ArbitrationConfig = ArbitrationConfig(),
    retarget: RetargetConfig = TASK_RETARGET,
    participant_task: ParticipantTask = ParticipantTask(),
    cruise_speed_um_s: float = CRUISE_SPEED_UM_S,
    progress: Callable[[float], None] | None = None,
    shared_autonomy: str = "route",
    mpc_config: MPCConfig = MPCConfig(),
    mpc_costs: MPCCosts = MPCCosts(),
    mpc_stats: dict | None = None,
    mpc_navigator: Callable[..., Navigator] | None = None,
    scenarios: list[Scenario] | None = None,
    recorder: Callable[[TickView], None] | None = None,
    participant_tasks: Sequence[ParticipantTask] | None = None,
    speed_policy=None,
    display_latency_s=DISPLAY_LATENCY_S,
) -> list[dict]:
    """Run ``specs`` as one batch until every trial is done; one result row per spec
    (with ``autonomy``: whose dP_r the trial got, ``route``, ``mpc`` or ``rl``). The
    model-predictive navigator gives dP_r to ``mpc`` trials and, with
    ``shared_autonomy="mpc"``, to shared ones; ``mpc_stats`` (a dict) receives its
    replan count and wall times; ``mpc_navigator`` (default ``MPCNavigator``) builds
    the navigator from ``(task, config, costs, seed=...)``, e.g. a recording or
    distilled one (``otgym.autonomy.mpc_policy``). ``scenarios`` (one per spec) replaces
    ``task.scenario(spec.scenario)``, e.g. scenarios made with another
    ``ScenarioConfig``; ``recorder`` is called after every tick with a ``TickView`` of
    the batch (``otgym.runtime.trace.TraceRecorder`` copies chosen rows; it must not
    change what it sees). ``participant_tasks`` (one per spec) gives each trial's
    participant its own task parameters instead of ``participant_task``, in the same
    batch; ``display_latency_s`` is one latency or one per spec. ``rl`` trials and, with
    ``shared_autonomy="rl"``, shared ones get the learned-speed navigator's dP_r
    (``speed_policy``, default the shipped ``SPEED_POLICY``). The participants perceive
    only the window (``otgym.human.percept``): after each tick it shows the scene, the
    mode and the alpha the tick used, ``display_latency_s`` late; they never get the
    autonomy's dP_r."""
    if not specs:
        raise ValueError("no trials to run")
    if shared_autonomy not in AUTONOMIES:
        raise ValueError(f"unknown shared autonomy {shared_autonomy!r}; choose one of {', '.join(AUTONOMIES)}")
    tick = task.config.tick_s
    modes = np.array([s.mode for s in specs])
    uses_mpc = (modes == "mpc") | ((modes == "shared") & (shared_autonomy == "mpc"))
    mpc_rows = np.flatnonzero(uses_mpc)
    uses_rl = (modes == "rl") | ((modes == "shared") & (shared_autonomy == "rl"))
    rl_rows = np.flatnonzero(uses_rl)
    if scenarios is None:
        scenarios = [task.scenario(s.scenario) for s in specs]
    elif len(scenarios) != len(specs):
        raise ValueError(f"{len(scenarios)} scenarios for {len(specs)} trials")
    key = jax.random.PRNGKey(seed)
    key, reset_key = jax.random.split(key)
    state = task.reset(scenarios, reset_key)
    navigator = RouteNavigator(
        task.route_um,
        task.route_arc_um,
        task.offsets_um,
        tick,
        cruise_speed_um_s,
        max_speed_um_s=retarget.max_trap_speed_um_s,
    )
    navigator.reset(len(specs))
    mpc = (mpc_navigator or MPCNavigator)(task, mpc_config, mpc_costs, seed=seed) if len(mpc_rows) else None
    if mpc is not None:
        mpc.reset(len(mpc_rows))
    learned = (
        RLNavigator.for_task(task, speed_policy, max_speed_um_s=retarget.max_trap_speed_um_s) if len(rl_rows) else None
    )
    if learned is not None:
        learned.reset(len(rl_rows))
    law = task.config.scene.trap_law
    feedback = task_feedback(law, retarget, int(np.sum(task.trap_robot == 0)))
    people = SimulatedParticipants(
        [participants[s.participant] for s in specs],
        tick,
        seed,
        ShownRoute(np.asarray(task.route_um), np.asarray(task.route_arc_um), np.asarray(task.offsets_um)),
        retarget,
        feedback,
        law.escape_distance,
        participant_task if participant_tasks is None else list(participant_tasks),
        task.wall_distance_um,
        display_latency_s,
    )
    max_step = retarget.max_trap_speed_um_s * tick
    obs = state.observation
    # a batch in which nobody's hands count (every trial autonomous: alpha 0) skips the simulated people,
    # whose dP_h would be blended with weight 0: the same commands, bit for bit, for less work
    people_act = bool(np.isin(arbitration_modes(modes), PEOPLE_MODES).any())
    idle_hands = np.zeros((len(specs), task.n_traps, 2))
    no_lapses = np.zeros(len(specs), bool)
    display = WindowDisplay(tick, display_latency_s)  # what the participants see: the window, late
    if people_act:
        display.show(obs, arbitration_modes(modes), mode_alpha(modes, obs.nearest_obstacle_gap_um, arbitration))
    total_ticks = int(np.ceil(task.config.time_limit_s / tick))
    for index in range(total_ticks):
        robot = navigator.increments(obs)
        if mpc is not None:
            robot[mpc_rows] = mpc.increments(observation_rows(obs, mpc_rows))
        if learned is not None:
            robot[rl_rows] = learned.increments(observation_rows(obs, rl_rows))
        command = control_tick(
            obs,
            modes,
            robot,
            (lambda modes, alpha: people.intend(display.percept(), task.trap_robot)[:, task.trap_robot])
            if people_act
            else (lambda modes, alpha: idle_hands),
            arbitration,
            max_step,
        )
        key, step_key = jax.random.split(key)
        seen = obs
        obs = task.step(state, command.shared_um, step_key, command.alpha)
        if people_act:
            display.show(obs, command.modes, command.alpha)
            people.feel(obs, np.asarray(law.force_pn(obs.trap_xy_um - obs.handle_xy_um)), task.trap_robot)
        if recorder is not None:
            lapsed = people.motor.lapsed.reshape(len(specs), -1).any(axis=1) if people_act else no_lapses
            recorder(TickView(seen, obs, command, robot, state, lapsed))
        if progress is not None and index % 50 == 0:
            progress(float(state.metrics.done.mean()))
        if state.metrics.done.all():
            break
    if progress is not None:
        progress(1.0)
    if mpc is not None and mpc_stats is not None:
        mpc_stats.update(
            replans=len(mpc.replan_seconds),
            replan_seconds=list(mpc.replan_seconds),
            environments_planned=list(mpc.replan_sizes),
        )
    rows = state.metrics.rows()
    for spec, row, planned, speed_learned in zip(specs, rows, uses_mpc, uses_rl):
        row.update(
            participant=spec.participant,
            mode=spec.mode,
            trial=spec.trial,
            scenario=spec.scenario,
            autonomy="mpc" if planned else "rl" if speed_learned else "route",
        )
    return rows
