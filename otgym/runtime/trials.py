"""Batched trials of the interactive task: every environment is one trial (a simulated
participant, a mode, a scenario), all stepped together tick by tick:

    dP_r = navigator(observation)                       (the autonomy, um: the route
                                                         navigator, or in a mode named
                                                         after a registered navigator
                                                         that navigator, and in shared
                                                         mode the one ``shared_autonomy``
                                                         names)
    alpha, dP_h, dP_s = control_tick(...)               (otgym.runtime.tick: the law, the
                                                         participants' two hands, the blend)
    observation = task.step(dP_s)

Each trial's navigator is built by its registry name (``otgym.autonomy.by_name``), so a
navigator that a lab registers (tag ``trial-mode``) is a mode of these trials as the
built-in ``mpc`` and ``rl`` are; each navigator's own options (the MPC's configuration,
the learned speed's policy) reach its ``for_task`` from ``navigator_config``.

Each hand feels the feedback of its robot's handles. In batched trials the handle
forces come from the trap law at the simulator's handle offsets: rendering and sensing
a microscope frame per environment and tick would cost about 100 times the physics.
The vision sensor measures the same offsets to a few nanometres (``otgym.sim.sensor``,
tested), and the interactive loop (``otgym.runtime.loop``) feeds the real sensor.
"""

from __future__ import annotations

import dataclasses
import inspect
from collections.abc import Callable, Mapping, Sequence

import jax
import numpy as np

from otgym import registry
from otgym.autonomy.by_name import navigator_for
from otgym.autonomy.mpc_navigator import observation_rows
from otgym.autonomy.protocol import Navigator
from otgym.human.params import HumanParams
from otgym.human.participant_task import ParticipantTask
from otgym.human.participants import SimulatedParticipants
from otgym.human.percept import DISPLAY_LATENCY_S, ShownRoute, WindowDisplay
from otgym.runtime.tick import arbitration_modes, control_tick, mode_alpha
from otgym.runtime.trace import TickView
from otgym.shared import MODES, ArbitrationConfig
from otgym.task.task import InteractiveTask
from otgym.tasks.transport.scenario import Scenario
from otgym.teleop.feedback import FeedbackConfig, stable_newtons_per_pn
from otgym.teleop.retarget import RetargetConfig

TASK_RETARGET = RetargetConfig(dead_band_mm_s=0.3, max_trap_speed_um_s=20.0)
"""Stylus-to-trap mapping of the task: 2 um/mm; a 0.3 mm/s dead band (0.6 um/s at the
trap, below the 2 um/s manual pace); trap speeds up to 20 um/s, enough to chase a free
cell drifting in the chip's 8 um/s flow and far below the assembly's escape speed."""


CRUISE_SPEED_UM_S = 5.0
"""The route navigator's speed along the route in trials: the autonomous mode's pace."""

ROUTE_AUTONOMY = "route"
"""The navigator of the manual and autonomous modes (and of shared mode by default): the
route follower at ``cruise_speed_um_s``."""


_split_key = jax.jit(jax.random.split)
"""The tick's key split as one compiled call: the same keys as ``jax.random.split``,
without its eager dispatch (9 us a call against 180 us, measured on two CPU cores)."""


def trial_modes() -> tuple[str, ...]:
    """The arbitration modes, and the navigators registered now with tag ``trial-mode``:
    autonomous (alpha 0) with that navigator's dP_r instead of the route navigator's
    (built in: ``mpc``, the model-predictive navigator; ``rl``, the learned-speed one)."""
    return MODES + registry.names("navigators", "trial-mode")


PEOPLE_MODES = ("manual", "shared")
"""The arbitration modes in which a participant's dP_h counts (alpha > 0 at times)."""


def shared_autonomies() -> tuple[str, ...]:
    """Whose dP_r shared control may get: the navigators registered now with tag ``shared``."""
    return registry.names("navigators", "shared")


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
        modes = trial_modes()
        if self.mode not in modes:
            raise ValueError(f"unknown mode {self.mode!r}; choose one of {', '.join(modes)}")


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


def trial_autonomy(mode: str, shared_autonomy: str = ROUTE_AUTONOMY) -> str:
    """The navigator whose dP_r a trial of ``mode`` gets: the navigator a mode is named
    after, ``shared_autonomy`` in shared mode, else the route navigator."""
    if mode == "shared":
        return shared_autonomy
    return ROUTE_AUTONOMY if mode in MODES else mode


def build_navigator(name: str, task, max_speed_um_s: float, seed: int, config: Mapping | None = None) -> Navigator:
    """Navigator ``name`` of the registry on ``task``, as ``otgym.autonomy.by_name``
    builds it, with ``config`` (its own options) passed to its ``for_task``, and the
    trials' ``seed`` too where its ``for_task`` takes one (a navigator that draws random
    numbers, as the MPC does)."""
    options = dict(config or {})
    found = registry.load("navigators", name)
    if "seed" in inspect.signature(found.for_task).parameters:
        options.setdefault("seed", seed)
    return navigator_for(name, task, max_speed_um_s=max_speed_um_s, warm_up=False, **options)


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
    shared_autonomy: str = ROUTE_AUTONOMY,
    navigator_config: Mapping[str, Mapping] | None = None,
    navigator_stats: dict | None = None,
    navigators: Mapping[str, Navigator] | None = None,
    scenarios: list[Scenario] | None = None,
    recorder: Callable[[TickView], None] | None = None,
    participant_tasks: Sequence[ParticipantTask] | None = None,
    display_latency_s=DISPLAY_LATENCY_S,
) -> list[dict]:
    """Run ``specs`` as one batch until every trial is done; one result row per spec
    (with ``autonomy``: the name of the navigator whose dP_r the trial got,
    ``trial_autonomy``). Each navigator a trial needs is built once for the batch by its
    registry name (``build_navigator``), with its own options from ``navigator_config``
    (name -> keyword arguments of its ``for_task``, e.g. ``{"mpc": {"config":
    MPCConfig(...)}, "rl": {"policy": ...}}``), or taken ready-built from
    ``navigators`` (name -> navigator, e.g. a recording or distilled MPC,
    ``otgym.autonomy.mpc_policy``); the route navigator gives every trial its dP_r
    first, the others replace it in their trials' rows. ``navigator_stats`` (a dict)
    receives, per navigator other than the route's that offers ``stats()``, what it says (the MPC: its
    replan count and wall times). ``scenarios`` (one per spec) replaces
    ``task.scenario(spec.scenario)``, e.g. scenarios made with another
    ``ScenarioConfig``; ``recorder`` is called after every tick with a ``TickView`` of
    the batch (``otgym.runtime.trace.TraceRecorder`` copies chosen rows; it must not
    change what it sees). ``participant_tasks`` (one per spec) gives each trial's
    participant its own task parameters instead of ``participant_task``, in the same
    batch; ``display_latency_s`` is one latency or one per spec. The participants
    perceive only the window (``otgym.human.percept``): after each tick it shows the
    scene, the mode and the alpha the tick used, ``display_latency_s`` late; they never
    get the autonomy's dP_r."""
    if not specs:
        raise ValueError("no trials to run")
    autonomies = shared_autonomies()
    if shared_autonomy not in autonomies:
        raise ValueError(f"unknown shared autonomy {shared_autonomy!r}; choose one of {', '.join(autonomies)}")
    tick = task.config.tick_s
    modes = np.array([s.mode for s in specs])
    autonomy = [trial_autonomy(s.mode, shared_autonomy) for s in specs]
    others = {name: np.flatnonzero([a == name for a in autonomy]) for name in dict.fromkeys(autonomy)}
    others.pop(ROUTE_AUTONOMY, None)
    if scenarios is None:
        scenarios = [task.scenario(s.scenario) for s in specs]
    elif len(scenarios) != len(specs):
        raise ValueError(f"{len(scenarios)} scenarios for {len(specs)} trials")
    key = jax.random.PRNGKey(seed)
    key, reset_key = jax.random.split(key)
    state = task.reset(scenarios, reset_key)
    navigator_config = navigator_config or {}
    navigators = navigators or {}

    def navigator_named(name: str) -> Navigator:
        if name in navigators:
            return navigators[name]
        options = dict(navigator_config.get(name, {}))
        if name == ROUTE_AUTONOMY:
            options.setdefault("cruise_speed_um_s", cruise_speed_um_s)
        return build_navigator(name, task, retarget.max_trap_speed_um_s, seed, options)

    route = navigator_named(ROUTE_AUTONOMY)
    route.reset(len(specs))
    built = {}
    for name, rows_of in others.items():
        built[name] = navigator_named(name)
        built[name].reset(len(rows_of))
    law = task.config.scene.trap_law
    trap_force_pn = jax.jit(law.force_pn)  # each tick: one compiled call, not a dozen eager operations
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
        robot = route.increments(obs)
        for name, navigator in built.items():
            robot[others[name]] = navigator.increments(observation_rows(obs, others[name]))
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
        key, step_key = _split_key(key)
        seen = obs
        obs = task.step(state, command.shared_um, step_key, command.alpha)
        if people_act:
            display.show(obs, command.modes, command.alpha)
            people.feel(obs, np.asarray(trap_force_pn(obs.trap_xy_um - obs.handle_xy_um)), task.trap_robot)
        if recorder is not None:
            lapsed = people.motor.lapsed.reshape(len(specs), -1).any(axis=1) if people_act else no_lapses
            recorder(TickView(seen, obs, command, robot, state, lapsed))
        if progress is not None and index % 50 == 0:
            progress(float(state.metrics.done.mean()))
        if state.metrics.done.all():
            break
    if progress is not None:
        progress(1.0)
    if navigator_stats is not None:
        navigator_stats.update({name: nav.stats() for name, nav in built.items() if hasattr(nav, "stats")})
    rows = state.metrics.rows()
    for spec, row, name in zip(specs, rows, autonomy):
        row.update(
            participant=spec.participant, mode=spec.mode, trial=spec.trial, scenario=spec.scenario, autonomy=name
        )
    return rows
