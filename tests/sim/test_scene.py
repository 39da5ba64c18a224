"""Scenes on the default chip: placement, grip, transport, walls and obstacles."""

import dataclasses
import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from otgym import physics as ph
from otgym.physics.batching import batch_key
from otgym.physics.constants import thermal_energy_pn_um
from otgym.sim import scene as sc

PAPER_LIKE = dict(trap_law=ph.TrapLaw.paper(), dt_s=2e-3, flow_scale=0.1)
"""Weak traps of the paper's law (0.3 pN at most): a 2 ms step resolves them, so
long runs stay cheap."""


@pytest.fixture(scope="module")
def transport(scene_of):
    return scene_of(sc.SceneConfig())


@pytest.fixture(scope="module")
def transport_paper(scene_of):
    return scene_of(sc.SceneConfig(**PAPER_LIKE))


step = jax.jit(sc.step)
step_batch = jax.jit(sc.step_batch)
reset_batch = jax.jit(jax.vmap(sc.reset, in_axes=(None, 0)))


def wall_distance(scene, xy):
    distance, _ = scene.model.walls.distance_and_normal(jnp.asarray(xy))
    return np.asarray(distance)


@pytest.mark.slow
def test_reset_places_the_cell_in_both_grippers_clear_of_walls_and_obstacles(transport):
    states = reset_batch(transport, jax.random.split(jax.random.PRNGKey(0), 64))
    xy = np.asarray(ph.sphere_positions_um(transport.model, states.physics.pose))
    radius = np.asarray(transport.model.sphere_radius_um)
    assert np.all(wall_distance(transport, xy) > radius)  # every sphere clear of the walls
    cell = np.asarray(states.physics.pose[:, transport.payload, :2])
    for robot_spheres in transport.gripper_spheres:
        for sphere in robot_spheres:
            gap = np.linalg.norm(xy[:, sphere] - cell, axis=-1) - radius[sphere] - transport.config.cell_radius_um
            assert np.allclose(gap, 0.0, atol=1e-4)
    obstacles = np.asarray(states.physics.pose[:, list(transport.obstacles), :2])
    assert np.all(np.linalg.norm(obstacles - cell[:, None], axis=-1) > transport.config.min_obstacle_distance_um)
    assert len(np.unique(cell.round(1), axis=0)) > 50  # randomised from the key


@pytest.mark.slow
def test_grip_holds_the_cell_and_reports_the_grip_force(transport):
    """Traps still, flow on: over 4 s the cell stays in the grip and each robot presses
    on it with about its traps' force at the squeeze offset (two handles at 0.05 um on a
    50 pN/um Gaussian trap: 2 * 2.5 pN, less what the contact compliance takes up)."""
    state = sc.reset(transport, jax.random.PRNGKey(1))
    forces = []
    for index in range(20):
        state, events = step(transport, state, jnp.zeros((4, 2)), jax.random.PRNGKey(index))
        assert not bool(events.failed)
        forces.append(np.asarray(events.contact_force_pn))
    forces = np.array(forces)
    trap_force_at_squeeze = 2 * float(transport.model.trap_law.magnitude_pn(0.05))
    assert np.all(forces > 0.3 * trap_force_at_squeeze)
    assert np.all(forces < trap_force_at_squeeze * 1.5)


@pytest.mark.slow
def test_traps_carry_the_cell_along_the_channel(transport):
    """Start in the straight top-left branch heading +x (the flow's direction) and move
    all traps at 3 um/s for 5 s: the cell follows the traps by contact alone."""
    state = sc.reset_at(transport, jax.random.PRNGKey(2), jnp.array([20.0, 40.0]), jnp.array(0.0))
    start = np.asarray(state.physics.pose[transport.payload, :2])
    velocity = jnp.tile(jnp.array([[3.0, 0.0]]), (4, 1))
    for index in range(25):
        state, events = step(transport, state, velocity, jax.random.PRNGKey(index))
        assert not bool(events.failed)
    moved = np.asarray(state.physics.pose[transport.payload, :2]) - start
    assert moved == pytest.approx([15.0, 0.0], abs=0.5)


@functools.partial(jax.jit, static_argnames=("n_steps",))
def random_walk(scene, states, key, n_steps):
    """Random trap commands (each robot's traps together, up to 6 um/s in a random
    direction each step); returns the smallest wall clearance of any sphere centre,
    scaled by its radius, per environment and step."""
    n_env = states.time_s.shape[0]
    radius = scene.model.sphere_radius_um

    def body(carry, step_key):
        command_key, step_key = jax.random.split(step_key)
        command = jax.random.uniform(command_key, (n_env, 1, 2), minval=-6.0, maxval=6.0)
        new_states, events = sc.step_batch(scene, carry, jnp.tile(command, (1, scene.n_traps, 1)), step_key)
        xy = ph.sphere_positions_um(scene.model, new_states.physics.pose)
        distance, _ = scene.model.walls.distance_and_normal(xy)
        return new_states, jnp.min(distance / radius, axis=-1)

    return jax.lax.scan(body, states, jax.random.split(key, n_steps))


@pytest.mark.slow
def test_no_body_crosses_a_wall_over_4096_random_steps(transport_paper):
    """64 environments x 64 random control steps = 4,096 steps (4e5 physics steps):
    no sphere centre of any body (robots, cell, obstacles) ever gets within half its
    radius of a wall, let alone into it, and nothing becomes NaN (measured: 0.88 of a
    radius at the closest). Fails for a wall 20 times softer (centres cross it)."""
    states = reset_batch(transport_paper, jax.random.split(jax.random.PRNGKey(3), 64))
    final, clearance = random_walk(transport_paper, states, jax.random.PRNGKey(4), 64)
    assert np.all(np.isfinite(np.asarray(final.physics.pose)))
    assert float(np.min(np.asarray(clearance))) > 0.5


@functools.partial(jax.jit, static_argnames=("n_steps",))
def steady_drive(scene, states, velocity_um_s, key, n_steps):
    """Every trap of an environment moves at its environment's constant velocity (E, 2);
    returns the smallest wall clearance of any sphere centre, scaled by its radius, per
    environment and step."""
    radius = scene.model.sphere_radius_um
    command = jnp.tile(velocity_um_s[:, None, :], (1, scene.n_traps, 1))

    def body(carry, step_key):
        new_states, _ = sc.step_batch(scene, carry, command, step_key)
        xy = ph.sphere_positions_um(scene.model, new_states.physics.pose)
        distance, _ = scene.model.walls.distance_and_normal(xy)
        return new_states, jnp.min(distance / radius, axis=-1)

    return jax.lax.scan(body, states, jax.random.split(key, n_steps))


DRIVE_ENVS, DRIVE_STEPS = 16, 4


def drive_into_walls(scene):
    """``steady_drive`` of the assembly at 15 um/s for 4 control steps (0.8 s, 12 um)
    in 16 environments, each from a random reset towards the wall nearest its cell,
    turned by a random angle of up to 60 degrees: most runs hit a wall in their first
    step or two, many head on (a drive in a random direction spends most of its time
    away from walls), then press on it. The clearances (steps, E), checked finite."""
    states = reset_batch(scene, jax.random.split(jax.random.PRNGKey(11), DRIVE_ENVS))
    _, normal = scene.model.walls.distance_and_normal(states.physics.pose[:, scene.payload, :2])
    turn = jax.random.uniform(jax.random.PRNGKey(12), (DRIVE_ENVS,), minval=-np.pi / 3, maxval=np.pi / 3)
    angle = jnp.arctan2(-normal[:, 1], -normal[:, 0]) + turn  # the normal points into the fluid
    velocity = 15.0 * jnp.stack([jnp.cos(angle), jnp.sin(angle)], axis=-1)
    final, clearance = steady_drive(scene, states, velocity, jax.random.PRNGKey(13), DRIVE_STEPS)
    assert np.all(np.isfinite(np.asarray(final.physics.pose)))
    return np.asarray(clearance)


@pytest.mark.slow
def test_stiff_traps_do_not_push_bodies_through_walls(transport):
    """The literature traps (Gaussian, 50 pN/um, up to 9.1 pN each) drag the assembly
    into the walls (``drive_into_walls``: 16 environments, 0.8 s, 1.3e5 physics
    steps). A wall's penalty gives way by F / k_w
    with k_w = 1 / (2 dt m) (m the robot's largest point mobility): pressed by both of a
    robot's traps, 2 x 9.1 pN, that is 0.14 um, plus 3 sigma of one step's thermal
    motion, 0.02 um; a quarter more for the cell and the obstacles leaning on it. So no
    sphere centre of a robot (smallest radius 1 um) gets closer to a wall than 0.8 of
    its radius (measured: 0.88, at the impacts). Fails for a wall 20 times softer
    (centres cross)."""
    model, law = transport.model, transport.config.trap_law
    robot = transport.robots[0]
    shape = ph.two_handle_robot()  # the transport scene's robots
    mobility = ph.mobility.body_hydrodynamics(
        shape.offsets_um, shape.radii_um, transport.config.viscosity_pa_s
    ).max_point_mobility_um_per_pn_s
    dt = float(model.dt_s)
    thermal = 3 * np.sqrt(2 * thermal_energy_pn_um(transport.config.temperature_k) * mobility * dt)
    give_um = 1.25 * (2 * 2 * law.max_force_pn * dt * mobility + thermal)
    smallest = float(np.asarray(model.sphere_radius_um)[np.asarray(model.sphere_body) == robot].min())
    clearance = drive_into_walls(transport)
    assert give_um / smallest < 0.25  # the bound is a small fraction of a radius
    assert clearance.min() > 1 - give_um / smallest, (clearance.min(), give_um)
    assert np.mean(clearance.min(axis=0) < 1.2) > 0.5  # most runs pressed a sphere against a wall


@pytest.mark.slow
def test_overlap_projection_holds_bodies_off_walls_within_its_cap(scene_of):
    """The drive above (literature traps, 15 um/s into the walls, 16 environments, 0.8 s)
    in the same scene with the overlap projection on (cap 2 % of a radius): no sphere
    centre comes closer to a wall than 1 - 1.5 x 0.02 of its radius (the projection's
    slack, see tests/physics/test_contact.py). The penalty alone lets robots in to 0.88
    of their radius in this drive, so a projection that ignored the walls would fail
    (measured: 0.86 with the walls' caps lifted)."""
    cap = 0.02
    clearance = drive_into_walls(scene_of(sc.SceneConfig(contact_overlap_cap=cap)))
    assert clearance.min() > 1 - 1.5 * cap, clearance.min()
    assert np.mean(clearance.min(axis=0) < 1.2) > 0.5  # most runs pressed a sphere against a wall


@pytest.mark.slow
def test_navigation_and_bead_scenes_run(scene_of):
    for kind in ("navigation", "bead"):
        scene = scene_of(sc.SceneConfig(kind=kind, n_obstacles=2, **PAPER_LIKE))
        state = sc.reset(scene, jax.random.PRNGKey(5))
        state, events = step(scene, state, jnp.zeros((scene.n_traps, 2)), jax.random.PRNGKey(6))
        assert events.trap_lost.shape == (scene.n_traps,)
        assert not bool(events.failed)


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"kind": "juggling"}, "kind"),
        ({"n_obstacles": -1}, "n_obstacles"),
        ({"cell_radius_um": 0.0}, "cell_radius_um"),
        ({"dt_s": 1.0}, "dt_s"),
        ({"flow_scale": float("nan")}, "flow_scale"),
    ],
)
def test_bad_scene_configuration_names_the_parameter(kwargs, name):
    with pytest.raises(ValueError, match=name):
        sc.SceneConfig(**kwargs)


def test_a_chip_too_narrow_for_the_assembly_is_refused():
    from tests.sim.conftest import straight_duct

    with pytest.raises(ValueError, match="no place"):
        sc.build_scene(sc.SceneConfig(chip=straight_duct(width_um=12.0)))


@pytest.mark.slow
def test_sampling_fields_every_ten_steps_changes_nothing_that_matters(transport, scene_of):
    """At T = 0, the same control step with fields sampled every step and every 10
    steps (1 ms): the robots and the cell end within 1 nm of each other."""
    config = dataclasses.replace(transport.config, temperature_k=0.0)
    every_step = scene_of(dataclasses.replace(config, field_refresh_substeps=1))
    every_tenth = scene_of(config)
    assert every_tenth.model.field_refresh == 10 and every_step.model.field_refresh == 1
    state = sc.reset_at(every_step, jax.random.PRNGKey(7), jnp.array([60.0, 40.0]), jnp.array(0.0))
    velocity = jnp.tile(jnp.array([[3.0, 1.0]]), (4, 1))
    ends = [
        np.asarray(step(scene, state, velocity, jax.random.PRNGKey(8))[0].physics.pose[:3, :2])
        for scene in (every_step, every_tenth)
    ]
    assert np.abs(ends[0] - ends[1]).max() < 1e-3


VMAP_ENVS = 32
"""As tests/sim/test_step_memory.py's batch: the batched step compiles once for both."""


@pytest.mark.slow
def test_vmap_of_step_is_step_batch_with_the_batch_key(transport):
    """vmap(step) routes to step_batch (custom batching rule) with one key derived from
    all the batch's keys: both must agree exactly."""
    keys = jax.random.split(jax.random.PRNGKey(9), VMAP_ENVS)
    states = reset_batch(transport, keys)
    velocity = jnp.ones((VMAP_ENVS, 4, 2))
    via_vmap, events = jax.jit(jax.vmap(sc.step, in_axes=(None, 0, 0, 0)))(transport, states, velocity, keys)
    direct, _ = step_batch(transport, states, velocity, batch_key(keys))
    assert np.array_equal(np.asarray(via_vmap.physics.pose), np.asarray(direct.physics.pose))
    assert events.contact_force_pn.shape == (VMAP_ENVS, 2)


def test_re_entry_spots_are_drawn_only_when_needed_and_are_those_of_always_drawing(transport):
    """An obstacle at an outlet re-enters at the spot the batch's key gives it, as if
    every step drew spots (``_recirculate`` for each environment); a batch with no
    obstacle at an outlet is left as it is."""
    obstacles = list(transport.obstacles)
    pose = np.zeros((2, transport.model.n_bodies, 3), np.float32)
    pose[:, transport.payload, :2] = transport.start_candidates_um[0]
    pose[:, obstacles, :2] = transport.obstacle_candidates_um[: len(obstacles)]
    away = jnp.asarray(pose)
    obstacle = obstacles[0]
    pose[0, obstacle, :2] = np.asarray(transport.outlets_um[0]) - np.array([5.0, 0.0])
    at_outlet = jnp.asarray(pose)
    key = jax.random.PRNGKey(11)
    batch = jax.jit(sc._recirculate_batch)
    always = jax.jit(lambda s, k, p: jax.vmap(lambda k, q: sc._recirculate(s, k, q))(jax.random.split(k, 2), p))
    assert not np.any(np.asarray(sc._at_exit(transport, away)))
    for pose in (at_outlet, away):
        np.testing.assert_array_equal(np.asarray(batch(transport, key, pose)), np.asarray(always(transport, key, pose)))
    moved = np.asarray(batch(transport, key, at_outlet))
    assert np.min(np.linalg.norm(np.asarray(transport.inlet_spawns_um) - moved[0, obstacle, :2], axis=1)) == 0.0
    np.testing.assert_array_equal(moved[1], np.asarray(at_outlet[1]))
    np.testing.assert_array_equal(np.asarray(batch(transport, key, away)), np.asarray(away))
