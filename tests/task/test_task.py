"""Tests of the interactive task (``otgym.task.task``): reset, the autonomous carry
with ``RouteNavigator``, held traps, obstacle tracks, metrics and input checks.

The task is built once (``tests.runtime.shared_task``) and every run ticks the same 4
environments, so the jitted step compiles once. Scenarios are seeds 7, 14, 21 and 0:
the first three each have an obstacle that departs within about 1 s (0.73, 1.06,
0.81 s), so obstacle motion is seen within the 5 s the carry test runs; all crossings
lie more than 100 um along the route, far from the assembly in those 5 s."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from otgym.autonomy.navigator import RouteNavigator
from otgym.planning import formation as fm
from otgym.sim import scene as sc
from otgym.task.task import ALPHA_BANDS, APPROACH, CARRY, DONE, TrialMetrics
from tests.task import fast_scenario, shared_task

SEEDS = (7, 14, 21, 0)
E = len(SEEDS)
CARRY_TICKS = 250  # 5 s at 50 Hz


pytestmark = pytest.mark.slow  # module fixtures that compile or solve for seconds


@pytest.fixture(scope="module")
def task():
    return shared_task()


@pytest.fixture(scope="module")
def scenarios(task):
    return [fast_scenario(seed) for seed in SEEDS]


@pytest.fixture
def fresh(task, scenarios):
    """A newly reset batch (the reset compiles once; later resets take milliseconds)."""
    return task.reset(scenarios, jax.random.PRNGKey(11))


@pytest.fixture(scope="module")
def carry_run(task, scenarios):
    """5 s of the autonomous mode: (state, observations after each tick)."""
    state = task.reset(scenarios, jax.random.PRNGKey(1))
    navigator = RouteNavigator(task.route_um, task.route_arc_um, task.offsets_um, task.config.tick_s)
    navigator.reset(E)
    obs, history = state.observation, []
    for i in range(CARRY_TICKS):
        obs = task.step(state, navigator.increments(obs), jax.random.PRNGKey(100 + i), alpha=np.zeros(E))
        history.append(obs)
    return state, history


def gripped_pose(task):
    """The scene's gripped assembly at the route's start (robots, traps, cell)."""
    heading = fm.heading_at(task.route, 0.0)
    state = sc.reset_at(task.scene, jax.random.PRNGKey(0), task.route.points_um[0], heading)
    pose = np.asarray(state.physics.pose, float)
    normal = np.array([-np.sin(float(heading)), np.cos(float(heading))])
    return pose, np.asarray(state.physics.trap_xy_um, float), normal


def test_the_shared_route_start_is_the_op_by_op_formation(task):
    """The route start every route task shares (``otgym.tasks.transport.route_start``,
    compiled whole) gives bitwise the heading and the formation that the op-by-op
    computation gives: the paper's numbers were measured on those."""
    pose, traps, _ = gripped_pose(task)
    heading = fm.heading_at(task.route, 0.0)
    offsets = fm.formation_offsets(jnp.asarray(traps, jnp.float32), task.route.points_um[0], heading)
    assert float(task.params.heading_rad) == float(heading)
    np.testing.assert_array_equal(task.offsets_um, np.asarray(offsets))


def test_reset_places_cell_robots_and_obstacles(task, scenarios, fresh):
    """Cell at the route's start; each robot (and its traps) moved exactly
    approach_gap_um (1.5 um) outward along the route's normal from its grip; the
    gripper-to-cell gap about approach_gap_um (within 0.1 um: the grippers sit off the
    normal through the cell's centre, so the 1.5 um shift opens the surface gap by
    1.40 um) and never more (a point moved 1.5 um changes its distance by at most
    1.5 um); obstacles at their tracks' starts; phase APPROACH at t = 0. Tolerances
    1e-3 um cover float32 coordinates of a few hundred um. Catches robots left gripping
    (gap 0, phase CARRY on the first tick), moved the wrong way, or the random
    obstacle spots of ``reset_at`` left in place of the tracks."""
    obs = fresh.observation
    gap = task.config.approach_gap_um
    np.testing.assert_allclose(obs.cell_xy_um, np.broadcast_to(task.route_um[0], (E, 2)), atol=1e-3)
    pose, traps, normal = gripped_pose(task)
    cell = pose[task.scene.payload, :2]
    for r, robot in enumerate(task.scene.robots):
        shift = obs.robot_xy_um[:, r] - pose[robot, :2]
        outward = np.sign((pose[robot, :2] - cell) @ normal)
        np.testing.assert_allclose(shift, np.broadcast_to(outward * gap * normal, (E, 2)), atol=1e-3)
        on_robot = task.trap_robot == robot
        np.testing.assert_allclose(
            obs.trap_xy_um[:, on_robot] - traps[on_robot],
            np.broadcast_to(outward * gap * normal, (E, on_robot.sum(), 2)),
            atol=1e-3,
        )
    assert np.all(np.abs(obs.cell_gap_um - gap) <= 0.1), obs.cell_gap_um
    assert np.all(obs.cell_gap_um <= gap + 1e-3)
    np.testing.assert_allclose(obs.obstacle_xy_um, np.stack([s.start_um for s in scenarios]), atol=1e-3)
    np.testing.assert_array_equal(obs.time_s, 0.0)
    np.testing.assert_array_equal(fresh.phase, APPROACH)
    assert not fresh.metrics.done.any() and np.isnan(fresh.metrics.grip_time_s).all()


def test_autonomous_navigator_grips_within_a_second(task, carry_run):
    """With alpha 0 and the route navigator, every environment grips (phase CARRY,
    grip time recorded) by t = 1 s and stays gripped (no detachment) through 5 s.
    Catches a grip test that never passes (the cell gap at reset is 1.4 um against a
    grip gap of 0.3 um), a phase machine that does not advance, or a carry that drops
    the cell."""
    state, history = carry_run
    at_1s = history[49]
    assert at_1s.time_s == pytest.approx(np.full(E, 1.0), abs=1e-4)
    np.testing.assert_array_equal(at_1s.phase, CARRY)
    assert np.all(state.metrics.grip_time_s <= 1.0), state.metrics.grip_time_s
    assert np.all(history[-1].phase == CARRY)
    np.testing.assert_array_equal(state.metrics.detachments, 0)
    assert np.all(history[-1].cell_gap_um < task.config.grip_gap_um)


def test_autonomous_carry_advances_at_cruise_speed(carry_run):
    """The cell's arc along the route from t = 1 s to t = 5 s grows at the navigator's
    cruise speed, 5 um/s, within 10 % (the arc is quantised to route points 0.125 um
    apart, 0.6 % of the 20 um covered). Catches a cell left behind, a navigator at its
    20 um/s speed cap, or a cell_arc_um that does not follow the cell."""
    _, history = carry_run
    start, end = history[49], history[-1]
    speed = (end.cell_arc_um - start.cell_arc_um) / (end.time_s - start.time_s)
    np.testing.assert_allclose(speed, 5.0, rtol=0.1)


def test_the_cells_light_dose_is_accounted(task, carry_run):
    """The cell's dose over the 5 s is positive (the handle traps' light reaches it) and
    below the bound for a cell whose surface stays at least a from each of the four
    traps, N P / (pi e a^2) per second (``otgym.physics.light_dose``), with a the
    smallest trap-to-surface distance seen; catches a dose never accumulated, or one
    that counts the traps' focus intensity."""
    from otgym.physics import light_dose as ld

    state, history = carry_run
    beam = ld.TrapBeam.of_trap_law(task.config.scene.trap_law)
    radius = task.config.scene.cell_radius_um
    gap = min(float(np.min(np.linalg.norm(o.trap_xy_um - o.cell_xy_um[:, None], axis=-1))) for o in history) - radius
    assert gap > 1.0
    dose = state.metrics.light_dose_mj_per_um2
    elapsed = CARRY_TICKS * task.config.tick_s
    bound = 4 * beam.power_mw / (np.pi * np.e * gap**2) * elapsed
    assert np.all(dose > 0) and np.all(dose < bound)
    assert np.all(dose < 1e-3 * beam.focus_intensity_mw_per_um2 * elapsed)


def test_alpha_band_time_is_accounted(task, carry_run):
    """alpha 0 for 5 s counts 5 s in the first band ('autonomous', alpha < 0.2) and none
    in the others; catches bands not accumulated or accumulated in the wrong column."""
    state, _ = carry_run
    assert ALPHA_BANDS[0][0] == "autonomous"
    np.testing.assert_allclose(state.metrics.band_time_s[:, 0], CARRY_TICKS * task.config.tick_s, atol=1e-9)
    np.testing.assert_array_equal(state.metrics.band_time_s[:, 1:], 0.0)


def test_obstacles_follow_their_tracks(scenarios, carry_run):
    """Every tick of the 5 s run, every obstacle (16) is within 2 um of
    Scenario.position_um(t): waiting at its start before departure (against the
    chip's ~8 um/s flow) and moving along the track after it. The largest deviation
    seen is about 1.5 um (Brownian motion of a 3 um sphere, sqrt(D / gain) ~ 0.3 um
    per axis, plus flow-compensation lag at a pull-back gain of 1 /s). Three obstacles
    have travelled about 8 um by 5 s, so an obstacle that stood still would be 8 um off;
    one swept by the flow would be tens of um off. Precondition: the assembly is more
    than 20 um from every obstacle, so nothing is in their way."""
    _, history = carry_run
    travelled = 0.0
    for obs in history:
        assert obs.nearest_obstacle_gap_um.min() > 20.0
        expected = np.stack([s.position_um(t) for s, t in zip(scenarios, obs.time_s)])
        error = np.linalg.norm(obs.obstacle_xy_um - expected, axis=-1)
        assert error.max() < 2.0, (obs.time_s[0], error)
        travelled = max(travelled, np.linalg.norm(expected - np.stack([s.start_um for s in scenarios]), axis=-1).max())
    assert travelled > 7.0  # the check covers moving obstacles, not only waiting ones


def test_zero_increments_hold_the_traps_and_the_free_cell_drifts(task, fresh):
    """A silent device: 50 ticks (1 s) of zero increments leave every trap exactly where
    it was, and the phase stays APPROACH while the free cell drifts downstream with
    the ~8 um/s flow at the route's start (more than 4 um, gap growing past the grip
    gap). Catches traps that drift (e.g. an increment applied as a velocity with an
    offset, or the navigator's command leaking in) and a grip declared without contact."""
    before = fresh.observation
    for i in range(50):
        obs = task.step(fresh, np.zeros((E, task.n_traps, 2)), jax.random.PRNGKey(200 + i), alpha=np.zeros(E))
        np.testing.assert_array_equal(obs.trap_xy_um, before.trap_xy_um)
        np.testing.assert_array_equal(obs.phase, APPROACH)
    assert np.all(np.linalg.norm(obs.cell_xy_um - before.cell_xy_um, axis=1) > 4.0)
    assert np.all(obs.cell_gap_um > before.cell_gap_um)
    assert np.isnan(fresh.metrics.grip_time_s).all()


def place_obstacle(state, task, env, k, xy):
    """Put obstacle k of env at xy and make its track hold it there."""
    body = int(np.asarray(task.scene.obstacles)[k])
    pose = state.scene.physics.pose.at[env, body, :2].set(np.asarray(xy, np.float32))
    state.scene = state.scene.replace(physics=state.scene.physics.replace(pose=pose))
    tracks = dict(state.tracks)
    tracks["start_um"] = tracks["start_um"].at[env, k].set(np.asarray(xy, np.float32))
    tracks["depart_s"] = tracks["depart_s"].at[env, k].set(1e3)
    tracks["end_s"] = tracks["end_s"].at[env, k].set(1e3)
    state.tracks = tracks


def test_touching_obstacle_counts_as_encountered_and_collided(task, fresh):
    """Env 0: obstacle 0 placed overlapping the cell by 0.2 um, obstacle 1 about 6 um from
    the assembly (less than encounter_gap_um = 20), obstacles 2 and 3 and all of envs
    1-3 far away (> 20 um). After one tick: 0 encountered and collided, 1 encountered
    and avoided, the rest neither; rows() gives 2 encountered, 1 avoided, 1 collision,
    success 0.5. Catches a collision test on the wrong sign or threshold, an encounter
    radius ignored, or metrics written to the wrong environment."""
    heading = fm.heading_at(task.route, 0.0)
    back = -np.array([np.cos(float(heading)), np.sin(float(heading))])
    cell = fresh.observation.cell_xy_um[0]
    reach = task.config.scene.cell_radius_um + task.config.scene.obstacle_radius_um
    place_obstacle(fresh, task, 0, 0, cell + (reach - 0.2) * back)
    place_obstacle(fresh, task, 0, 1, cell - (reach + 10.0) * back)
    obs = task.step(fresh, np.zeros((E, task.n_traps, 2)), jax.random.PRNGKey(3), alpha=np.zeros(E))
    gap = obs.obstacle_gap_um
    # the placement worked: obstacle 0 touched during the tick (the contact pushes it off, so
    # the end-of-tick gap is positive; collisions are counted from every physics step)
    assert obs.obstacle_touched[0, 0] and not obs.obstacle_touched[0, 1:].any() and not obs.obstacle_touched[1:].any()
    assert gap[0, 0] < 1.0 and 0.0 < gap[0, 1] < task.config.encounter_gap_um
    assert gap[0, 2:].min() > task.config.encounter_gap_um and gap[1:].min() > task.config.encounter_gap_um
    metrics = fresh.metrics
    np.testing.assert_array_equal(metrics.encountered[0], [True, True, False, False])
    np.testing.assert_array_equal(metrics.collided[0], [True, False, False, False])
    assert not metrics.encountered[1:].any() and not metrics.collided[1:].any()
    row = metrics.rows()[0]
    assert (row["obstacles_encountered"], row["obstacles_avoided"], row["collisions"]) == (2, 1, 1)
    assert row["success"] == pytest.approx(0.5)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_increments_raise(task, fresh, bad):
    """A NaN or infinite trap increment must raise ValueError, not be fed to the physics."""
    increment = np.zeros((E, task.n_traps, 2))
    increment[2, 1, 0] = bad
    with pytest.raises(ValueError, match="finite"):
        task.step(fresh, increment, jax.random.PRNGKey(0))


def test_finished_environments_hold(task, fresh):
    """An environment already DONE ignores its increments (even NaN ones) and its traps
    stay put, while the others move: catches finished trials that keep moving or an
    increment check that rejects a finished environment's stale input."""
    fresh.phase[1] = DONE
    increment = np.full((E, task.n_traps, 2), 0.1)
    increment[1] = np.nan
    before = fresh.observation.trap_xy_um
    obs = task.step(fresh, increment, jax.random.PRNGKey(4), alpha=np.zeros(E))
    np.testing.assert_array_equal(obs.trap_xy_um[1], before[1])
    np.testing.assert_allclose(obs.trap_xy_um[[0, 2, 3]] - before[[0, 2, 3]], 0.1, atol=1e-4)
    assert obs.phase[1] == DONE


def test_trial_metrics_rows_have_the_experiments_columns():
    """rows() on hand-made metrics: exactly the experiment's columns (participant, mode,
    trial and scenario are added by run_trials, not here) and the derived counts:
    avoided = encountered and not collided, success = avoided / encountered (NaN with
    no encounter), detached = any detachment. Catches a renamed or missing column or a
    wrong derived count."""
    metrics = TrialMetrics.empty(2, 3)
    metrics.encountered[0] = [True, True, True]
    metrics.collided[0] = [True, False, False]
    metrics.detachments[:] = [2, 0]
    metrics.trap_losses[:] = [1, 0]
    metrics.reached_goal[:] = [False, True]
    metrics.completion_time_s[:] = [30.0, 42.0]
    metrics.grip_time_s[:] = [0.1, 0.2]
    metrics.peak_contact_force_pn[:] = [12.0, 3.0]
    metrics.band_time_s[:] = [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]
    metrics.light_dose_mj_per_um2[:] = [1e-9, 2e-9]
    rows = metrics.rows()
    expected_columns = {
        "completion_time_s",
        "obstacles_encountered",
        "obstacles_avoided",
        "collisions",
        "success",
        "reached_goal",
        "trap_losses",
        "detached",
        "detachments",
        "peak_contact_force_pn",
        "grip_time_s",
        "time_autonomous_s",
        "time_balanced_s",
        "time_fine_tune_s",
        "light_dose_mj_per_um2",
    }
    assert len(rows) == 2 and all(set(row) == expected_columns for row in rows)
    assert not {"participant", "mode", "trial", "scenario"} & set(rows[0])
    first, second = rows
    assert (first["light_dose_mj_per_um2"], second["light_dose_mj_per_um2"]) == (1e-9, 2e-9)
    assert (first["obstacles_encountered"], first["obstacles_avoided"], first["collisions"]) == (3, 2, 1)
    assert first["success"] == pytest.approx(2 / 3)
    assert np.isnan(second["success"]) and second["obstacles_encountered"] == 0
    assert (first["detached"], first["detachments"], second["detached"]) == (True, 2, False)
    assert (first["reached_goal"], second["reached_goal"], first["trap_losses"]) == (False, True, 1)
    assert (first["completion_time_s"], first["grip_time_s"], first["peak_contact_force_pn"]) == (30.0, 0.1, 12.0)
    assert (second["time_autonomous_s"], second["time_balanced_s"], second["time_fine_tune_s"]) == (4.0, 5.0, 6.0)


def test_empty_metrics_shapes():
    """TrialMetrics.empty: nothing done, NaN times, zero counts, (E, K) obstacle flags."""
    metrics = TrialMetrics.empty(3, 4)
    assert metrics.encountered.shape == metrics.collided.shape == (3, 4)
    assert metrics.band_time_s.shape == (3, len(ALPHA_BANDS))
    assert not metrics.done.any() and np.isnan(metrics.completion_time_s).all()
    assert dataclasses.is_dataclass(metrics)
