"""The ``sort-cells`` task: the chip's sidecar read (ports, junction), bad configs and
actions refused, the pointing-device mapping and the baseline's decisions; what its
frame and scene show (the outlets in their kind's colour at the sidecar's places, the
cells coloured by kind, the robots parked, on their way and gripping, the direct trap,
from states built by hand: nothing compiled); the light a
held cell gets (linear in power and in the time held; the direct trap's far above the
robots'); both environment checkers; the batched API at 1 and 1024 environments; the
scripted baseline sorting better than random on a development seed."""

import dataclasses

import gymnasium as gym
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import otgym  # noqa: F401  (registers the Gymnasium ids)
from otgym import tasks
from otgym.physics import light_dose as ld
from otgym.physics.bodies import BodyKind
from otgym.sim import scene as sc
from otgym.tasks.sort_cells import PRESETS, baseline, core
from otgym.tasks.sort_cells.config import SortConfig, manipulation
from tests.tasks import sb3_checker_warnings, sort_state

ENV_ID = "otgym/sort-cells-v0"


@pytest.fixture(scope="module")
def params():
    task = tasks.load("sort-cells")
    return task.make_params(task.config())


def test_the_chip_sidecar_gives_the_ports_and_the_junction(params):
    from otgym.sim.chip import load_chip

    chip = load_chip("sorter")
    ports = {p.name: p for p in chip.ports}
    np.testing.assert_allclose(params.outlets_um, [ports["outlet_a"].xy_um, ports["outlet_b"].xy_um])
    np.testing.assert_allclose(params.junction_um, dict(chip.sites)["junction"])
    assert params.side_sign.tolist() == [-1.0, 1.0]  # outlet_a above the junction (y down), outlet_b below
    assert np.all(params.spawn_um[:, 0] < 10.0)  # arrivals at the inlet edge
    with pytest.raises(ValueError, match="no outlet port 'outlet_c'"):
        core.make_params(SortConfig("bad", outlets=("outlet_a", "outlet_c")))


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"mode": "tweezers"}, "mode"),
        ({"outlets": ("outlet_a", "outlet_a")}, "outlets"),
        ({"cell_radii_um": (3.0, -1.0)}, "cell_radii_um"),
        ({"speed_fraction": 1.5}, "speed_fraction"),
        ({"max_cells": 0}, "max_cells"),
        ({"power_per_trap_mw": 0.0}, "power_per_trap_mw"),
    ],
)
def test_bad_configs_are_refused(change, match):
    with pytest.raises(ValueError, match=match):
        SortConfig(**{"name": "x", **change})
    with pytest.raises(ValueError, match="no preset"):
        tasks.load("sort-cells").config("fast")


def test_bad_actions_raise():
    env = gym.make(ENV_ID).unwrapped
    env.reset(seed=3)
    for bad in (3, -1, 1.5, "up", np.array([1, 2])):
        with pytest.raises(ValueError, match="action must be an integer"):
            env.step(bad)


def test_pointing_device_up_and_down_pick_the_outlet_on_that_side(params):
    task = tasks.load("sort-cells")
    assert task.device_action(np.array([0.0, -3.0]), params) == 1  # up on screen: outlet_a's side
    assert task.device_action(np.array([5.0, 2.0]), params) == 2
    assert task.device_action(np.array([9.0, 0.1]), params) == 0  # at rest across: let go


def test_baseline_moves_a_cell_until_it_is_past_the_axis_on_its_side(params):
    half = params.half_width_um
    # kind 0 (+1) belongs above (y < junction): at 2 um below, push (1); at 8 um above, let go
    obs = np.zeros((4, core.OBS_SIZE), np.float32)
    obs[:, 0] = [1, 1, 1, 0]
    obs[:, 1] = [1, 1, -1, 1]
    obs[:, 3] = np.array([2.0, -8.0, -2.0, 0.0]) / half
    assert baseline.actions(jnp.asarray(obs), params).tolist() == [1, 0, 2, 0]


def test_light_on_a_held_cell_is_linear_in_power_and_far_higher_in_the_trap():
    robots, direct = SortConfig("r", mode="robots"), SortConfig("d", mode="direct")
    low_r, low_d = manipulation(robots), manipulation(direct)
    high_r = manipulation(dataclasses.replace(robots, power_per_trap_mw=3 * robots.power_per_trap_mw))
    np.testing.assert_allclose(high_r["intensity_mw_per_um2"], 3 * low_r["intensity_mw_per_um2"], rtol=1e-5)
    np.testing.assert_allclose(low_d["intensity_mw_per_um2"], direct.beam.focus_intensity_mw_per_um2)
    for kind, radius in enumerate(robots.cell_radii_um):
        traps, _ = sc.grip_geometry_um(sc.SceneConfig(cell_radius_um=radius))
        gap = float(np.min(np.linalg.norm(traps, axis=1))) - radius
        ratio = low_d["intensity_mw_per_um2"][kind] / low_r["intensity_mw_per_um2"][kind]
        assert ratio >= ld.dose_bound_ratio(gap, len(traps), robots.waist_um) > 10


FRAME_PX = (840, 560)


def pixel(frame, renderer, xy_um) -> np.ndarray:
    col, row = np.floor(renderer.to_px(np.asarray(xy_um, float))).astype(int)
    return frame[row, col].astype(float)


def test_the_frame_marks_each_outlet_in_its_kinds_colour_and_colours_the_cells_by_kind(params):
    from otgym.sim.render import CHANNEL_RGB
    from otgym.tasks.sort_cells import view

    task = tasks.load("sort-cells")
    frame = task.frame(sort_state(10.0), params, FRAME_PX)
    renderer = view._renderer(params.config.chip, FRAME_PX)
    exit_um = params.config.exit_distance_um
    for kind, outlet in enumerate(np.asarray(params.outlets_um, float)):
        tint = CHANNEL_RGB + view.OUTLET_OPACITY * (np.asarray(view.KIND_RGB[kind]) - CHANNEL_RGB)
        np.testing.assert_allclose(pixel(frame, renderer, outlet - [exit_um / 2, 0.0]), tint, atol=2)
        np.testing.assert_allclose(pixel(frame, renderer, outlet - [exit_um + 3.0, 0.0]), CHANNEL_RGB, atol=2)
    for cell, kind in ((0, 1), (1, 0), (3, 0)):  # each cell's centre in its kind's colour
        np.testing.assert_allclose(pixel(frame, renderer, sort_state(0.0).xy_um[cell]), view.KIND_RGB[kind])
    assert view.KIND_RGB[0] != view.KIND_RGB[1]
    labels = dict((text, xy) for xy, text in task.scene(sort_state(0.0), params).labels)  # the recording's
    for name, words, outlet in zip(params.config.outlets, ("small", "large"), np.asarray(params.outlets_um)):
        (text,) = [text for text in labels if text.startswith(f"{name}: {words} cells")]
        np.testing.assert_allclose(labels[text], outlet)


def test_the_robots_are_drawn_parked_on_their_way_and_gripping_the_held_cell(params):
    from otgym.sim.render import HANDLE_RGB
    from otgym.sim.render import KIND_RGB as BODY_RGB
    from otgym.tasks.sort_cells import view

    task = tasks.load("sort-cells")
    renderer = view._renderer(params.config.chip, FRAME_PX)
    robot_rgb = BODY_RGB[BodyKind.ROBOT]
    grip = params.config.grip_time
    cell = np.array([60.0, 60.0])  # the held cell away from where the robots park
    held = sort_state(grip + 1.0)
    held = held.replace(xy_um=np.concatenate([cell[None], held.xy_um[1:]]).astype(np.float32))
    gripping = task.frame(held, params, FRAME_PX)
    xy, _, _, handle = sc.grip_robots_um(sc.SceneConfig(cell_radius_um=params.config.cell_radii_um[1]))
    for sphere, is_handle in zip(xy + cell, handle):  # the transport scene's grip about the held (large) cell
        np.testing.assert_allclose(pixel(gripping, renderer, sphere), HANDLE_RGB if is_handle else robot_rgb)
    np.testing.assert_allclose(task.scene(held, params).traps_um, (xy + cell)[handle], atol=1e-4)

    def robot_pixels(frame, centre_um, half_um=8.0):
        (c0, r0), (c1, r1) = np.floor(
            renderer.to_px(np.array([centre_um]) + [[-half_um, -half_um], [half_um, half_um]])
        )
        window = frame[int(r0) : int(r1), int(c0) : int(c1)]
        return int(np.all(window == robot_rgb.astype(np.uint8), axis=-1).sum())

    parked = task.frame(sort_state(0.0, held=-1), params, FRAME_PX)
    junction = np.asarray(params.junction_um, float)
    for side in np.asarray(params.side_sign, float):  # against each wall, upstream of the junction
        place = junction + [-view.PARK_UPSTREAM_UM, side * (params.half_width_um - 2.0)]
        assert robot_pixels(parked, place) > 50 and robot_pixels(gripping, place) == 0
    assert robot_pixels(parked, cell) == 0 and robot_pixels(gripping, cell) > 100
    halfway = task.scene(sort_state(grip / 2), params).spheres_um[3:]
    rest, held = task.scene(sort_state(0.0, held=-1), params), task.scene(sort_state(grip + 1.0), params)
    np.testing.assert_allclose(halfway, (rest.spheres_um[3:] + held.spheres_um[3:]) / 2, atol=1e-4)


def test_direct_trapping_draws_its_trap_in_the_held_cell_and_no_robots(params):
    from otgym.sim.render import KIND_RGB as BODY_RGB
    from otgym.sim.render import TRAP_RGB
    from otgym.tasks.sort_cells import view

    task = tasks.load("sort-cells")
    direct = dataclasses.replace(params, config=dataclasses.replace(params.config, mode="direct"))
    renderer = view._renderer(params.config.chip, FRAME_PX)
    frames = {grip_s: task.frame(sort_state(grip_s), direct, FRAME_PX) for grip_s in (0.0, 1.0)}
    robot_rgb = BODY_RGB[BodyKind.ROBOT].astype(np.uint8)
    assert not any(np.all(frame == robot_rgb, axis=-1).any() for frame in frames.values())
    ring = np.asarray(sort_state(0.0).xy_um[0], float) + [view.DIRECT_RING_UM, 0.0]
    np.testing.assert_allclose(pixel(frames[1.0], renderer, ring), TRAP_RGB, atol=40)  # held: the trap's ring
    np.testing.assert_allclose(pixel(frames[0.0], renderer, ring), view.KIND_RGB[1])  # not yet held: no light
    assert "robot" not in task.scene(sort_state(1.0), direct).kinds


@pytest.mark.slow
def test_a_directly_held_cells_dose_is_its_time_held_times_the_focus_intensity():
    task = tasks.load("sort-cells")
    params = task.make_params(task.config("direct"))
    config = params.config
    obs, state = task.reset_batch(jax.random.PRNGKey(0), params, 1)
    step = jax.jit(task.step_batch)
    n_steps = 6  # 3 s: the first cell is still upstream of the junction
    for i in range(n_steps):
        obs, state, *_ = step(jax.random.PRNGKey(i), state, jnp.array([1]), params)
    held = int(state.held[0])
    assert held >= 0 and bool(state.active[0, held])
    held_s = n_steps * config.control_period_s - config.grip_time
    expected = config.beam.focus_intensity_mw_per_um2 * held_s
    assert float(state.dose_mj_per_um2[0, held]) == pytest.approx(expected, rel=1e-5)
    assert float(jnp.sum(state.dose_mj_per_um2[0])) == pytest.approx(expected, rel=1e-5)  # no other cell lit


@pytest.mark.slow
def test_gymnasium_checker_passes_and_renders():
    env = gym.make(ENV_ID, render_mode="rgb_array")
    check_env(env.unwrapped, skip_render_check=False)
    env.reset(seed=0)
    _, reward, terminated, truncated, info = env.step(1)
    assert isinstance(reward, float) and not terminated and not truncated
    assert set(info) >= {"success", "purity", "yield", "throughput_cells_per_min", "cells_lost"}
    assert "light_dose_per_cell_mj_per_um2" in info
    assert env.render().shape == (400, 600, 3)


@pytest.mark.slow
def test_sb3_checker_passes_without_warnings():
    assert sb3_checker_warnings(ENV_ID) == []


@pytest.mark.slow
@pytest.mark.parametrize("n_envs", [1024])  # one environment: the checkers' (a batch of one)
def test_batched_reset_and_step(params, n_envs):
    task = tasks.load("sort-cells")
    obs, state = task.reset_batch(jax.random.PRNGKey(1), params, n_envs)
    assert obs.shape == (n_envs, core.OBS_SIZE) and state.active.shape == (n_envs, params.config.max_cells)
    obs, state, reward, terminated, truncated, info = jax.jit(task.step_batch)(
        jax.random.PRNGKey(2), state, jnp.full(n_envs, 2, jnp.int32), params
    )
    assert obs.shape == (n_envs, core.OBS_SIZE) and reward.shape == terminated.shape == (n_envs,)
    assert all(value.shape == (n_envs,) for value in info.values())
    assert np.all(np.isfinite(np.asarray(obs)))


@pytest.mark.slow
def test_scripted_baseline_sorts_better_than_random_and_direct_trapping_doses_more():
    from otgym.experiments.sort_cells.run import rollouts

    n = 16
    out = {}
    for preset in ("robots", "direct"):
        for policy, outcome in rollouts(preset, ("baseline", "random"), n, seed=0).items():
            out[preset, policy] = outcome
    for preset in ("robots", "direct"):
        base, rand = out[preset, "baseline"]["purity"], out[preset, "random"]["purity"]
        # a two-sample z bound: the baseline's mean purity is more than 4 standard errors above random's
        error = np.sqrt(base.var(ddof=1) / n + rand.var(ddof=1) / n)
        assert base.mean() - rand.mean() > 4 * error, preset
        assert out[preset, "baseline"]["cells_sorted"].mean() > out[preset, "random"]["cells_sorted"].mean()
    robot_dose = out["robots", "baseline"]["light_dose_per_cell_mj_per_um2"]
    direct_dose = out["direct", "baseline"]["light_dose_per_cell_mj_per_um2"]
    assert np.all(direct_dose > 1e6 * np.maximum(robot_dose, 1e-30))
    assert PRESETS["direct"]().mode == "direct"
