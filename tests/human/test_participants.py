"""The simulated participants (``otgym.human.participants``) on synthetic scenes: a
straight route along x, two robots of two traps each, no physics (the observation is
held or moved by hand), so each test isolates one decision of the model.

"Steady" participants have every motor error switched off (no extent, direction or
signal-dependent noise, no tremor or drift, no lapses): their motion is then the model's
intention through its delays, lags and the retargeting filter, deterministic. The tests
show them the scene directly (``percept_from_window`` of the test's observation, no
window latency), so they are built with ``display_latency_s=0``."""

import ast
import inspect

import numpy as np
import pytest

from otgym.human.avoidance import choose_velocity, miss_um
from otgym.human.params import HumanParams, sample_population
from otgym.human.participant_task import ParticipantTask
from otgym.human.participants import SimulatedParticipants
from otgym.human.percept import PERCEPT_FIELDS, ShownRoute, WindowDisplay, percept_from_window
from otgym.runtime.trials import TASK_RETARGET
from otgym.task.task import APPROACH, CARRY, FINE_TUNE_ALPHA, Observation
from otgym.teleop.feedback import FeedbackConfig
from otgym.ui import cues

TICK_S = 0.02
OFFSETS_UM = np.array([[-3.5, -6.5], [3.5, -6.5], [3.5, 6.5], [-3.5, 6.5]])  # robot 0 below the cell, robot 1 above
TRAP_ROBOT = np.array([0, 0, 1, 1])
STEADY = HumanParams(
    extent_error_fraction=0.0,
    direction_error_deg=0.0,
    signal_dependent_noise=0.0,
    tremor_rms_mm=0.0,
    drift_rms_mm=0.0,
    lapse_rate_per_h=0.0,
)
TASK = ParticipantTask()


def shown_route():
    route = np.stack([np.linspace(0.0, 300.0, 2401), np.zeros(2401)], axis=1)
    return ShownRoute(route, route[:, 0].copy(), OFFSETS_UM)


def people(params, seed=0, task=TASK, wall_distance_um=None):
    return SimulatedParticipants(
        params, TICK_S, seed, shown_route(), TASK_RETARGET, FeedbackConfig(), 0.6, task, wall_distance_um, 0.0
    )


def look(participants, obs, modes, alpha):
    """The participants' step on the scene ``obs`` as the window would show it."""
    return participants.intend(percept_from_window(obs, np.asarray(modes), alpha), TRAP_ROBOT)


def wall_below(y_um):
    """Signed distance to a straight wall filling y < ``y_um``."""
    return lambda points: np.asarray(points, float)[:, 1] - y_um


def scene(cell_xy, trap_xy, phase, obstacle_xy=((200.0, 100.0),)):
    """An observation of E environments from (E, 2) cells and (E, 4, 2) traps."""
    cell_xy = np.asarray(cell_xy, float)
    n_env = len(cell_xy)
    obstacles = np.broadcast_to(np.asarray(obstacle_xy, float), (n_env, len(obstacle_xy), 2)).copy()
    zeros = np.zeros(n_env)
    return Observation(
        time_s=zeros,
        phase=np.full(n_env, phase),
        cell_xy_um=cell_xy,
        cell_arc_um=cell_xy[:, 0],
        trap_xy_um=np.asarray(trap_xy, float),
        handle_xy_um=np.asarray(trap_xy, float),
        robot_xy_um=np.zeros((n_env, 2, 2)),
        obstacle_xy_um=obstacles,
        obstacle_gap_um=np.full((n_env, len(obstacle_xy)), 100.0),
        contact_force_pn=np.zeros((n_env, 2)),
        cell_gap_um=np.zeros((n_env, 2)),
        trap_distance_um=np.zeros((n_env, 4)),
    )


def drive(participants, obs, modes, ticks, alpha=None, autonomy=None):
    """Feed the scene for ``ticks`` ticks: the traps move by the blended command and a
    gripped cell (CARRY) with them; returns the summed hand increments (E, 2 hands, 2)."""
    n_env = len(modes)
    alpha = np.ones(n_env) if alpha is None else alpha
    autonomy = np.zeros((n_env, 4, 2)) if autonomy is None else autonomy
    total = np.zeros((n_env, 2, 2))
    for _ in range(ticks):
        hands = look(participants, obs, modes, alpha)
        command = alpha[:, None, None] * hands[:, TRAP_ROBOT] + (1 - alpha[:, None, None]) * autonomy
        obs.trap_xy_um = obs.trap_xy_um + command
        carried = (obs.phase == CARRY)[:, None]
        obs.cell_xy_um = obs.cell_xy_um + np.where(carried, command.mean(axis=1), 0.0)
        obs.cell_arc_um = obs.cell_xy_um[:, 0].copy()
        total += hands
    return total


def test_same_seed_same_participants_and_a_new_seed_differs():
    """Participants are reproducible by seed: the population's parameters and the
    motor noise. The same noisy pair fed the same scene moves identically; a different
    motor seed moves differently."""
    params = sample_population(2, seed=3)
    assert params == sample_population(2, seed=3) and params != sample_population(2, seed=4)
    gripped = np.array([[10.0, 0.0]] * 2)
    obs = lambda: scene(gripped, gripped[:, None] + OFFSETS_UM, CARRY)  # noqa: E731
    first = drive(people(params, seed=5), obs(), ["manual"] * 2, 60)
    again = drive(people(params, seed=5), obs(), ["manual"] * 2, 60)
    other = drive(people(params, seed=6), obs(), ["manual"] * 2, 60)
    np.testing.assert_array_equal(first, again)
    assert np.abs(first - other).max() > 1e-3


def test_carrying_moves_both_hands_along_the_route_at_the_carry_pace():
    """A gripped cell on a route along +x: over 4 s both steady hands move their robots
    along +x at the 2 um/s carry pace (within 25 %: reaction time, lags and filter
    delay the start) and keep the grip (the hands' y motion below 0.1 um). Fails if the
    pace, the direction or the efference copy (without it the hands overshoot and
    oscillate) were wrong."""
    cell = np.array([[10.0, 0.0]])
    obs = scene(cell, cell[:, None] + OFFSETS_UM, CARRY)
    moved = drive(people([STEADY]), obs, ["manual"], 200)[0]
    np.testing.assert_allclose(moved[:, 0], 2.0 * 200 * TICK_S, rtol=0.25)
    assert np.all(np.abs(moved[:, 1]) < 0.1), moved


def test_approach_closes_the_open_robot_onto_an_aligned_cell():
    """Robot 0 held 1.5 um out from its place below a still, aligned cell: the steady
    participant moves hand 0 up (+y, toward the cell) by about the 1.5 um gap within
    4 s (closing at most 0.75 um/s) and leaves hand 1 where it is. A flipped sign, or a
    grip about absolute places, fails."""
    cell = np.array([[10.0, 0.0]])
    traps = cell[:, None] + OFFSETS_UM
    traps[:, TRAP_ROBOT == 0, 1] -= 1.5
    moved = drive(people([STEADY]), scene(cell, traps, APPROACH), ["manual"], 200)[0]
    assert moved[0, 1] == pytest.approx(1.5, abs=0.3), moved
    assert np.abs(moved[1]).max() < 0.1 and abs(moved[0, 0]) < 0.1, moved


@pytest.mark.slow
def test_approach_closes_the_last_half_micrometre_slowly():
    """Robot 0 held 4 um out below a still, aligned cell: the participant closes it
    fast while far out but, once well within ``close_guard_um`` (1.5 um) of its grip
    place (0.5 um in, past the fast reach's momentum), at most ``close_speed_um_s``
    (0.75 um/s; it stops pressing before the trap would lose a squeezed robot), over
    every 0.5 s window. Without the guard the reach ends at 5-10 um/s."""
    cell = np.array([[10.0, 0.0]])
    traps = cell[:, None] + OFFSETS_UM
    traps[:, TRAP_ROBOT == 0, 1] -= 4.0
    obs = scene(cell, traps, APPROACH)
    participants = people([STEADY])
    heights = []
    for _ in range(300):
        drive(participants, obs, ["manual"], 1)
        heights.append(obs.trap_xy_um[0, TRAP_ROBOT == 0, 1].mean())
    heights = np.asarray(heights)[::25]
    speeds = np.diff(heights) / 0.5
    remaining = (cell[0, 1] + OFFSETS_UM[TRAP_ROBOT == 0, 1].mean()) - heights[:-1]
    near = remaining < TASK.close_guard_um - 0.5  # past the fast reach's momentum (lag and filter)
    assert near.any() and speeds.max() > 2.0, (remaining, speeds)  # it closes, fast while far
    assert speeds[near].max() <= TASK.close_speed_um_s * 1.1, (remaining, speeds)


def test_approach_lines_up_with_the_cell_before_closing():
    """The cell 2 um ahead of the formation's centre (beyond the 0.4 um alignment
    tolerance), both robots held 1.5 um open: the steady participant first moves the
    robots along +x to line up, without closing while they are more than 0.8 um out of
    line (closing then would pinch the cell between their front spheres), then
    closes (at most 0.75 um/s): by 4 s both robots are within the alignment tolerance (0.4 um) of their
    places along x and within 0.25 um across. Smaller errors stay: a correction
    slower than the retargeting's dead band (0.6 um/s at the trap, 0.24 um over a
    0.4 s sub-movement) never reaches the traps."""
    cell = np.array([[12.0, 0.0]])
    traps = np.array([[10.0, 0.0]])[:, None] + OFFSETS_UM
    traps[:, TRAP_ROBOT == 0, 1] -= 1.5
    traps[:, TRAP_ROBOT == 1, 1] += 1.5
    obs = scene(cell, traps, APPROACH)
    participants = people([STEADY])
    for _ in range(200):
        out_of_line = abs(cell[0, 0] - obs.trap_xy_um[0].mean(axis=0)[0]) > 0.8
        inward = obs.trap_xy_um[0, TRAP_ROBOT == 0, 1].mean() - (cell[0, 1] + OFFSETS_UM[0, 1] - 1.5)
        assert not (out_of_line and inward > 0.1), (obs.trap_xy_um[0], inward)
        drive(participants, obs, ["manual"], 1)
    error = obs.trap_xy_um[0] - (cell[0] + OFFSETS_UM)
    assert np.all(np.abs(error[:, 0]) < TASK.align_tolerance_um) and np.all(np.abs(error[:, 1]) < 0.25), error


@pytest.mark.slow
def test_approach_keeps_the_wall_side_robot_off_the_wall():
    """A still cell 1.5 um toward a wall at y = -9 um: robot 0's closed place below it
    (handles at y = -8.03) lies 0.97 um from the wall, inside the 2 um clearance. The
    participant who sees the wall stops robot 0 at the clearance (it would nudge the
    free cell off the wall) and closes robot 1 as before; without walls robot 0's
    handles end about 1 um from the wall (where the chip's walls held them and the
    traps lost them)."""
    cell = np.array([[10.0, -1.5]])
    start = np.array([[10.0, 0.0]])[:, None] + OFFSETS_UM
    ends = {}
    for walls in (wall_below(-9.0), None):
        obs = scene(cell, start.copy(), APPROACH)
        drive(people([STEADY], wall_distance_um=walls), obs, ["manual"], 150)
        ends[walls is None] = obs.trap_xy_um[0]
    seeing, blind = ends[False], ends[True]
    assert seeing[TRAP_ROBOT == 0, 1].min() + 9.0 == pytest.approx(TASK.wall_clearance_um, abs=0.3), seeing
    assert blind[TRAP_ROBOT == 0, 1].min() + 9.0 < 1.3, blind
    np.testing.assert_allclose(seeing[TRAP_ROBOT == 1], blind[TRAP_ROBOT == 1], atol=0.15)


def test_carrying_near_a_wall_shifts_the_whole_formation():
    """A gripped cell whose robot 0 handles sit 1.47 um from a wall (inside the 2 um
    clearance): the participant moves both robots off the wall together (the cell stays
    gripped: the robots' separation does not change by more than 0.1 um) while
    carrying along x."""
    cell = np.array([[10.0, 0.0]])
    obs = scene(cell, cell[:, None] + OFFSETS_UM, CARRY)
    wall_y = OFFSETS_UM[:, 1].min() - 1.47
    separation = lambda traps: traps[TRAP_ROBOT == 1].mean(axis=0) - traps[TRAP_ROBOT == 0].mean(axis=0)  # noqa: E731
    before = separation(obs.trap_xy_um[0])
    moved = drive(people([STEADY], wall_distance_um=wall_below(wall_y)), obs, ["manual"], 150)[0]
    assert obs.trap_xy_um[0, :, 1].min() - wall_y > TASK.wall_clearance_um - 0.3, obs.trap_xy_um[0]
    assert moved[:, 1].min() > 0.2, moved  # both hands moved off the wall
    np.testing.assert_allclose(separation(obs.trap_xy_um[0]), before, atol=0.1)
    assert moved[:, 0].min() > 2.0  # and carried along the route


def test_miss_distance_of_a_head_on_and_a_parallel_obstacle():
    """Closest approach in the horizon: an obstacle 20 um ahead coming straight at a
    still cell meets it (miss 0); one moving parallel 15 um to the side never comes
    closer than 15 um."""
    cell = np.zeros((2, 2))
    obstacles = np.array([[[20.0, 0.0]], [[0.0, 15.0]]])
    velocity = np.array([[[-5.0, 0.0]], [[5.0, 0.0]]])
    miss, away = miss_um(cell, obstacles, velocity, np.zeros((2, 2)), horizon_s=6.0)
    np.testing.assert_allclose(miss, [0.0, 15.0], atol=1e-9)
    np.testing.assert_allclose(away, [[-1.0, 0.0], [0.0, -1.0]], atol=1e-9)


def test_the_person_gives_way_to_an_obstacle_crossing_ahead():
    """Carrying along +x at 2 um/s, an obstacle 10 um ahead and 12 um to the side
    crosses the route at 2 um/s: going on would meet it, so the person chooses another
    velocity whose miss is at least the clearance. With the obstacle moving away, the
    intended velocity is kept."""
    cell = np.zeros((2, 2))
    obstacles = np.array([[[10.0, -12.0]], [[10.0, -12.0]]])
    velocity = np.array([[[0.0, 2.0]], [[0.0, -2.0]]])
    want = np.array([[2.0, 0.0], [2.0, 0.0]])
    chosen, changed = choose_velocity(cell, obstacles, velocity, want, np.array([[1.0, 0.0]] * 2), TASK)
    assert miss_um(cell[:1], obstacles[:1], velocity[:1], want[:1], TASK.horizon_s)[0][0] < TASK.clearance_um
    assert changed.tolist() == [True, False]
    np.testing.assert_array_equal(chosen[1], want[1])
    assert miss_um(cell[:1], obstacles[:1], velocity[:1], chosen[:1], TASK.horizon_s)[0][0] >= TASK.clearance_um


def test_the_person_side_steps_an_obstacle_that_stands_in_the_corridor():
    """Carrying along +x at 2 um/s past an obstacle standing still 12 um ahead and 10 um
    to the side (inside the clearance of the route): holding still would be "safe" but
    never clears the way, so the person side-steps it (forward and away from it, -y)
    with at least the still-obstacle clearance. The same obstacle crossing toward the
    route at 2 um/s is waited for instead: no forward motion."""
    cell = np.zeros((2, 2))
    obstacles = np.array([[[12.0, 10.0]], [[12.0, 10.0]]])
    velocity = np.array([[[0.0, 0.0]], [[0.0, -2.0]]])
    want = np.array([[2.0, 0.0], [2.0, 0.0]])
    chosen, changed = choose_velocity(cell, obstacles, velocity, want, np.array([[1.0, 0.0]] * 2), TASK)
    assert changed.tolist() == [True, True]
    assert chosen[0, 0] > 0.5 and chosen[0, 1] < -0.5, chosen[0]
    assert miss_um(cell[:1], obstacles[:1], velocity[:1], chosen[:1], TASK.horizon_s)[0][0] >= TASK.still_clearance_um
    assert chosen[1, 0] <= 1.0 + 1e-9, chosen[1]  # slowed, held or backed, not side-stepping past it


def crossing_threat(participants, alpha, ticks=60):
    """Shared mode, the autonomy carrying along +x at 5 um/s, an obstacle 12 um ahead
    and 12 um to the side crossing the route at 2 um/s; the traps and the gripped cell
    move by the blend at ``alpha`` (the scene the window shows). Returns the summed hand
    increments (1, 2 hands, 2)."""
    cell = np.array([[10.0, 0.0]])
    autonomy = np.full((1, 4, 2), [5.0 * TICK_S, 0.0])
    threat = scene(cell, cell[:, None] + OFFSETS_UM, CARRY, obstacle_xy=((22.0, -12.0),))
    hands = np.zeros((1, 2, 2))
    for tick in range(ticks):
        threat.obstacle_xy_um = np.array([[[22.0, -12.0 + 2.0 * TICK_S * tick]]])
        hands += drive(participants, threat, ["shared"], 1, alpha=alpha, autonomy=autonomy)
    return hands


def test_shared_mode_rests_until_the_cue_then_works_against_the_autonomy():
    """Shared mode, the autonomy carrying along +x at 5 um/s: with no obstacle the
    steady participant's hands stay still (they let the autonomy drive); with an
    obstacle about to cross ahead and alpha 0.5 (the cue shown), they push back against
    the motion they see (-x), so that the blend slows the assembly."""
    cell = np.array([[10.0, 0.0]])
    autonomy = np.full((1, 4, 2), [5.0 * TICK_S, 0.0])
    calm = scene(cell, cell[:, None] + OFFSETS_UM, CARRY)
    rest = drive(people([STEADY]), calm, ["shared"], 50, alpha=np.array([0.1]), autonomy=autonomy)
    np.testing.assert_array_equal(rest, 0.0)
    hands = crossing_threat(people([STEADY]), np.array([0.5]))
    assert np.all(hands[0, :, 0] < -0.5), hands


@pytest.mark.parametrize("below", [True, False])
def test_participants_take_over_exactly_where_the_window_cue_shows(below):
    """The obstacle crossing ahead of the shared-mode test above, with alpha just below
    the window's fine-tune threshold (``FINE_TUNE_ALPHA`` - 0.01: the cue not shown) the
    hands rest (exactly still); at the threshold (the cue shown) they push back."""
    alpha = np.array([FINE_TUNE_ALPHA - 0.01 if below else FINE_TUNE_ALPHA])
    assert cues.fine_tune_prompt(float(alpha[0]), "shared") is not below
    hands = crossing_threat(people([STEADY]), alpha)
    if below:
        np.testing.assert_array_equal(hands, 0.0)
    else:
        assert np.all(hands[0, :, 0] < -0.5), hands


@pytest.mark.slow
def test_shared_mode_at_the_cue_with_no_threat_keeps_the_pace_it_watched():
    """Shared mode, the autonomy at 5 um/s: for 3 s at alpha 0.1 (no cue) the hands rest
    and the robots carry the cell at 4.5 um/s; then at alpha 0.5 (the cue shown) with no
    obstacle near, the steady participant moves the robots on at the pace they watched:
    over the last second of 3 s the assembly keeps at least 80 % of 4.5 um/s (a resting
    hand would leave 2.5 um/s, the autonomy's half)."""
    cell = np.array([[10.0, 0.0]])
    autonomy = np.full((1, 4, 2), [5.0 * TICK_S, 0.0])
    obs = scene(cell, cell[:, None] + OFFSETS_UM, CARRY)
    participants = people([STEADY])
    drive(participants, obs, ["shared"], 150, alpha=np.array([0.1]), autonomy=autonomy)
    drive(participants, obs, ["shared"], 100, alpha=np.array([0.5]), autonomy=autonomy)
    start = obs.cell_xy_um.copy()
    drive(participants, obs, ["shared"], 50, alpha=np.array([0.5]), autonomy=autonomy)
    pace_um_s = (obs.cell_xy_um - start)[0] / (50 * TICK_S)
    assert pace_um_s[0] >= 0.8 * 4.5, pace_um_s


def test_the_participant_step_takes_only_what_the_window_shows():
    """Structure (docs/decisions/0027): the participants' step takes a ``Percept`` and
    the trap-to-hand map only; the percept's fields are the window's picture and cue
    panel, none an autonomy command; no participant module names the autonomy's
    command, imports the autonomy, or is told the traps' blended command afterwards
    (the old ``moved``). Fails for a participant that reads dP_r or the exact alpha."""
    import otgym.human.avoidance
    import otgym.human.participants
    import otgym.human.percept

    assert list(inspect.signature(SimulatedParticipants.intend).parameters) == ["self", "percept", "trap_robot"]
    assert not hasattr(SimulatedParticipants, "moved")
    assert set(PERCEPT_FIELDS) == {
        "mode",
        "phase",
        "cell_xy_um",
        "cell_arc_um",
        "trap_xy_um",
        "obstacle_xy_um",
        "alpha_shown",
        "fine_tune_shown",
        "nearest_gap_um",
    }
    banned = ("robot_increment", "autonomy", "navigator", "dp_r", "shared_um", "human_weight")
    for module in (
        otgym.human.participants,
        otgym.human.avoidance,
        otgym.human.percept,
    ):
        tree = ast.parse(inspect.getsource(module))
        for node in ast.walk(tree):
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                names = [getattr(node, "module", None) or ""] + [alias.name for alias in node.names]
                assert not any(name.startswith("otgym.autonomy") for name in names), (module.__name__, names)
            identifier = (
                node.id
                if isinstance(node, ast.Name)
                else node.attr
                if isinstance(node, ast.Attribute)
                else node.arg
                if isinstance(node, ast.arg)
                else None
            )
            if identifier is not None:
                assert not any(word in identifier.lower() for word in banned), (module.__name__, identifier)


def test_the_hands_answer_the_motion_they_see_not_the_command_behind_it():
    """Two runs of the same steady participant at the cue (alpha 0.5, an obstacle
    crossing ahead) against two different autonomy commands that the window shows
    identically (the test's scene moves by the hands' share only, as if the autonomy
    were still): their hands move identically, tick by tick. Shown the robots drifting
    forward instead, the same participant pushes back harder: the correction comes from
    the picture."""
    cell = np.array([[10.0, 0.0]])

    def run(drift_um_s):
        participants = people([STEADY])
        obs = scene(cell, cell[:, None] + OFFSETS_UM, CARRY, obstacle_xy=((22.0, -12.0),))
        steps = []
        for tick in range(60):
            obs.obstacle_xy_um = np.array([[[22.0, -12.0 + 2.0 * TICK_S * tick]]])
            hands = look(participants, obs, ["shared"], np.array([0.5]))
            shown = 0.5 * hands[:, TRAP_ROBOT] + drift_um_s * TICK_S * np.array([1.0, 0.0])
            obs.trap_xy_um = obs.trap_xy_um + shown
            obs.cell_xy_um = obs.cell_xy_um + shown.mean(axis=1)
            obs.cell_arc_um = obs.cell_xy_um[:, 0].copy()
            steps.append(hands)
        return np.asarray(steps)

    still, again = run(0.0), run(0.0)  # the autonomy's command differs; nothing shows it
    np.testing.assert_array_equal(still, again)
    drifting = run(2.5)
    assert drifting.sum(axis=0)[0, :, 0].mean() < still.sum(axis=0)[0, :, 0].mean() - 0.5


def carry_past_an_oncoming_obstacle(participants, walls_below_um, seconds=25.0):
    """A gripped cell carried along +x (manual) while an obstacle comes down the route
    at 3 um/s from 40 um ahead, 2 um to the left (+y), faster than the 2 um/s carry pace
    can back away from. Returns the closest the obstacle came to the cell (um) and the
    closest a trap came to the wall below."""
    cell = np.array([[10.0, 0.0]])
    obs = scene(cell, cell[:, None] + OFFSETS_UM, CARRY, obstacle_xy=((50.0, 2.0),))
    closest_um, wall_um = np.inf, np.inf
    for tick in range(int(seconds / TICK_S)):
        obs.obstacle_xy_um = np.array([[[50.0 - 3.0 * TICK_S * tick, 2.0]]])
        drive(participants, obs, ["manual"], 1)
        closest_um = min(closest_um, float(np.linalg.norm(obs.obstacle_xy_um[0, 0] - obs.cell_xy_um[0])))
        wall_um = min(wall_um, float(obs.trap_xy_um[0, :, 1].min() - walls_below_um))
    return closest_um, wall_um


@pytest.mark.slow
def test_the_person_steps_aside_from_an_obstacle_coming_down_the_route(monkeypatch):
    """An obstacle coming head on along the route (3 um/s, 2 um left of it; a wall 10 um
    below the route, 3.5 um from robot 0's handles): neither waiting nor backing at the
    2 um/s pace clears it, and stepping away from it (right, -y) runs into the wall. The
    steady participant steps aside to the left, the open side, past the obstacle's own
    line: the obstacle passes without touching the assembly (centres more than the
    assembly's 8.7 um radius plus the obstacle's 3 um apart) and no trap comes within
    the wall clearance. The same participant without side-steps (``SIDE_STEP_DEG``
    emptied) is hit."""
    import otgym.human.avoidance as avoidance_module

    touch_um = 8.7 + 3.0
    closest_um, wall_um = carry_past_an_oncoming_obstacle(people([STEADY], wall_distance_um=wall_below(-10.0)), -10.0)
    assert closest_um > touch_um, closest_um
    assert wall_um > TASK.wall_clearance_um - 0.3, wall_um
    monkeypatch.setattr(avoidance_module, "SIDE_STEP_DEG", ())
    closest_um, _ = carry_past_an_oncoming_obstacle(people([STEADY], wall_distance_um=wall_below(-10.0)), -10.0)
    assert closest_um < touch_um, closest_um


def test_shared_mode_intends_the_pace_it_watched_the_robots_keep(monkeypatch):
    """Shared mode: while the hands rest (no cue) the person watches the pace at which
    the robots carry the cell (3 um/s here, 8 um/s there: the autonomy's, as seen) and,
    once the cue shows, intends that pace: every option the person weighs is built on it
    (``choose_velocity``'s intended velocity). Not the autonomy's command: the pace comes
    from the picture."""
    import otgym.human.participants as participants_module

    seen = []

    def spy(cell_um, obstacle_um, obstacle_velocity_um_s, want_um_s, *rest):
        seen.append(np.linalg.norm(want_um_s, axis=-1))
        return want_um_s, np.zeros(len(want_um_s), bool)

    monkeypatch.setattr(participants_module, "choose_velocity", spy)
    cell = np.array([[10.0, 0.0], [10.0, 0.0]])
    obs = scene(cell, cell[:, None] + OFFSETS_UM, CARRY)
    autonomy = np.stack([np.full((4, 2), [3.0 * TICK_S, 0.0]), np.full((4, 2), [8.0 * TICK_S, 0.0])])
    participants = people([STEADY, STEADY])
    drive(participants, obs, ["shared"] * 2, 100, alpha=np.array([0.0, 0.0]), autonomy=autonomy)
    drive(participants, obs, ["shared"] * 2, 1, alpha=np.array([0.5, 0.5]), autonomy=autonomy)
    np.testing.assert_allclose(seen[-1], [3.0, 8.0], rtol=1e-6)


def test_a_brief_lapse_of_the_cue_does_not_reset_the_watched_pace(monkeypatch):
    """The stall of development seed 90 (scenario 900006, participant 2): the person had
    watched the robots carry at 5 um/s, then held them at an obstacle (cue on, robots
    still); the cue went off for a moment and came back. The glimpse over which the pace
    is watched then still spans the time the person held the robots, so it reads about
    0, and the person went on intending 0 for the rest of the trial. The pace is watched
    only once the hand has rested for a whole glimpse: here it stays 5 um/s. Fails for a
    participant that takes the pace from any resting tick."""
    import otgym.human.participants as participants_module

    seen = []

    def spy(cell_um, obstacle_um, obstacle_velocity_um_s, want_um_s, *rest):
        seen.append(np.linalg.norm(want_um_s, axis=-1))
        return want_um_s, np.zeros(len(want_um_s), bool)

    monkeypatch.setattr(participants_module, "choose_velocity", spy)
    cell = np.array([[10.0, 0.0]])
    obs = scene(cell, cell[:, None] + OFFSETS_UM, CARRY)
    participants = people([STEADY])
    drive(participants, obs, ["shared"], 100, alpha=np.zeros(1), autonomy=np.full((1, 4, 2), [5.0 * TICK_S, 0.0]))
    assert seen[-1] == pytest.approx([5.0], rel=1e-6)
    for alpha, ticks in ((0.5, 40), (0.0, 15), (0.5, 15)):  # held still with the cue on, off a moment, on again
        for _ in range(ticks):
            look(participants, obs, ["shared"], np.array([alpha]))
    assert seen[-1] == pytest.approx([5.0], rel=1e-6)


def test_the_person_squeezes_past_a_standing_obstacle_rather_than_wait_beside_it():
    """Carrying along +x at 2 um/s with walls that leave no room to either side, past an
    obstacle standing 6 um ahead: 11.6 um to the side (0.6 um inside the 12.2 um still
    clearance, within ``squeeze_um``; beside the assembly that leaves 0.85 um of water)
    the person goes on past it, although holding still would keep the clearance
    (waiting never clears it); 10.5 um to the side (the pass would touch) they hold
    still."""
    cell = np.zeros((2, 2))
    obstacles = np.array([[[6.0, 11.6]], [[6.0, 10.5]]])
    want = np.array([[2.0, 0.0], [2.0, 0.0]])
    chosen, _ = choose_velocity(
        cell, obstacles, np.zeros((2, 1, 2)), want, np.array([[1.0, 0.0]] * 2), TASK, np.zeros((2, 2))
    )
    assert chosen[0, 0] > 0.5, chosen[0]
    np.testing.assert_allclose(chosen[1], 0.0, atol=1e-9)


def test_grip_heading_is_the_robots_own_turn_not_the_tilt_of_a_shear_between_them():
    """Each robot's turn comes from its own two traps: a formation turned by 0.4 rad reads
    0.4 rad, and shifting robot B 1.5 um along the route (a shear, which tilts the line
    between the robots by about 0.11 rad) does not change it."""
    from otgym.human.participants import robots_heading
    from otgym.tasks.transport.route_follow import rotate
    from tests.task import shared_task

    task = shared_task()
    offsets, trap_robot = np.asarray(task.offsets_um), task.trap_robot
    turned = rotate(offsets[None], np.array([0.4]))
    np.testing.assert_allclose(robots_heading(turned, offsets, trap_robot), [0.4], atol=1e-6)  # offsets are float32
    sheared = turned.copy()
    sheared[0, trap_robot == 1] += 1.5 * np.array([np.cos(0.4), np.sin(0.4)])
    np.testing.assert_allclose(robots_heading(sheared, offsets, trap_robot), [0.4], atol=1e-6)  # offsets are float32
    across = sheared[0, trap_robot == 1].mean(axis=0) - sheared[0, trap_robot == 0].mean(axis=0)
    assert abs(np.arctan2(-across[0], across[1]) - 0.4) > 0.1  # what the line between the robots would say


@pytest.mark.slow
def test_one_batch_gives_each_environment_its_own_task_and_latency():
    """Per-environment task parameters and window latencies (what the sensitivity
    analysis varies in one batch): a list of one task for all is that one task (the same
    seed: identical hands); with two carry paces, 2 and 4 um/s, the steady participant
    with the faster pace carries about twice as far in 4 s (ratio within 1.6-2.4: the
    reaction time and lags take the same time off both). A window 0.2 s late for one
    environment only: that one sees the scene of 10 ticks ago, the other the latest, and
    that one's person perceives 0.2 s later."""
    gripped = np.array([[10.0, 0.0]] * 2)
    obs = lambda: scene(gripped, gripped[:, None] + OFFSETS_UM, CARRY)  # noqa: E731
    fast = ParticipantTask(carry_speed_um_s=4.0)

    alone = drive(people([STEADY] * 2), obs(), ["manual"] * 2, 200)
    np.testing.assert_array_equal(drive(people([STEADY] * 2, task=[TASK, TASK]), obs(), ["manual"] * 2, 200), alone)
    mixed = drive(people([STEADY] * 2, task=[TASK, fast]), obs(), ["manual"] * 2, 200)
    ratio = mixed[1, :, 0].mean() / mixed[0, :, 0].mean()
    assert 1.6 < ratio < 2.4, ratio

    display = WindowDisplay(TICK_S, np.array([0.0, 0.2]))
    for tick in range(12):
        display.show(
            scene(gripped + [tick, 0.0], gripped[:, None] + OFFSETS_UM, CARRY), np.array(["manual"] * 2), [1, 1]
        )
    np.testing.assert_array_equal(display.percept().cell_xy_um[:, 0], [10.0 + 11, 10.0 + 1])  # now; 10 ticks ago
    late = SimulatedParticipants(
        [STEADY] * 2, TICK_S, 0, shown_route(), TASK_RETARGET, FeedbackConfig(), 0.6, TASK, None, np.array([0.0, 0.2])
    )
    np.testing.assert_allclose(late.delay_s - people([STEADY] * 2).delay_s, [0.0, 0.2])


def test_the_room_beside_the_route_is_counted_in_each_persons_own_steps_for_any_reach():
    """The side room a person judges (``_side_room_um``), against counting it step by step:
    three people with side steps of 0.25, 0.5 and 1 um in a channel whose walls lie at
    y = -20 and y = 10 um, the formation centred on the route (handles at -6.5 to 6.5 um),
    asked up to 5, then 20, then 5 um again. Fails if a person's steps were another's, or
    if the steps kept from one reach answered another (the 20 um ask would stop at 5)."""
    resolutions = (0.25, 0.5, 1.0)
    tasks = [ParticipantTask(side_step_resolution_um=r) for r in resolutions]
    channel = lambda points: np.minimum(np.asarray(points, float)[:, 1] + 20.0, 10.0 - np.asarray(points, float)[:, 1])  # noqa: E731
    participants = people([STEADY] * 3, task=tasks, wall_distance_um=channel)
    traps = np.repeat(OFFSETS_UM[None], 3, axis=0)
    along_x = np.tile([1.0, 0.0], (3, 1))

    def counted(resolution, side, max_um):
        now = channel(OFFSETS_UM)
        limit = np.minimum(TASK.wall_clearance_um, now)
        room, step = 0.0, 0
        while step * resolution <= max_um + 1e-9:
            moved = OFFSETS_UM + side * step * resolution * np.array([0.0, 1.0])
            if np.any(channel(moved) < limit - 1e-6):
                break
            room, step = step * resolution, step + 1
        return room

    for max_um in (5.0, 20.0, 5.0):
        room = participants._side_room_um(traps, along_x, max_um)
        expected = [[counted(r, side, max_um) for side in (1.0, -1.0)] for r in resolutions]
        np.testing.assert_allclose(room, expected, atol=1e-9, err_msg=f"up to {max_um} um")
    assert room[0, 1] == 5.0 and participants._side_room_um(traps, along_x, 20.0)[0, 1] == 11.5
