"""The recording of ``otgym play --task`` (``otgym.ui.task_recording``): a reset state of
the ``assemble`` and ``orient`` tasks is recorded and read back as Foxglove reads it:
``/otgym/scene`` decodes with its own protobuf schema, its ``bodies`` entity has a
sphere per body where the state has it, ``traps`` a cross per trap and ``targets`` the
task's targets; the episode's end carries the task's metrics, which ``otgym replay``'s
summary gives back. Only the tasks' resets are compiled (no step); the ``sort-cells``
scene is recorded from a state built by hand (a held cell, one upstream of it, one past
the junction, one slot empty), so nothing is compiled for it: its cells, the robots
gripping the held cell or on their way to it, their traps, the outlets and the inlet. The window's path
(every step and episode recorded) is tested on a toy task in ``test_task_window``."""

from __future__ import annotations

import jax
import numpy as np
import pytest

from otgym import tasks
from otgym.record.mcap_file import read_recording
from otgym.record.replay import summary
from otgym.ui.task_recording import TaskRecording, info_metrics
from tests.tasks import sort_state

pytest.importorskip("foxglove")


def scene_class(schema_data: bytes):
    """The protobuf class of ``foxglove.SceneUpdate`` from the recorded FileDescriptorSet."""
    from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

    files = descriptor_pb2.FileDescriptorSet.FromString(schema_data)
    pool = descriptor_pool.DescriptorPool()
    for file in files.file:
        pool.Add(file)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName("foxglove.SceneUpdate"))


STAMP_S = 1_700_000_000.0


def recorded_scenes(path):
    from mcap.reader import make_reader

    with open(path, "rb") as stream:
        found = list(make_reader(stream).iter_messages(topics=["/otgym/scene"]))
    return [(message, scene_class(schema.data).FromString(message.data)) for schema, _, message in found]


@pytest.mark.slow  # builds each task's params and compiles its reset: 10-18 s on the loaded 2-core machine
@pytest.mark.parametrize("name", ["assemble", "orient"])
def test_a_recorded_episode_shows_the_task_s_scene_and_metrics(name, tmp_path):
    task = tasks.load(name)
    params = task.make_params(task.config())
    _, state = jax.jit(task.reset)(jax.random.PRNGKey(3), params)
    scene = task.scene(state, params)
    recording = TaskRecording(tmp_path / "session.mcap", task, params, None, 3, 0.05, clock_s=lambda: STAMP_S)
    recording.episode_start(1, state)
    info = {"success": np.bool_(True), "time_s": np.float32(2.5), "my_metric": np.float32(0.25), "pair": np.zeros(2)}
    recording.episode_end(1, 40, 7.5, True, "terminated", info)
    recording.close()

    (message, update), *rest = recorded_scenes(tmp_path / "session.mcap")
    assert not rest and message.log_time == int(STAMP_S * 1e9)
    entities = {entity.id: entity for entity in update.entities}
    assert set(entities) == {"bodies", "traps", "targets"}
    centres = [(s.pose.position.x, s.pose.position.y) for s in entities["bodies"].spheres]
    np.testing.assert_allclose(centres, scene.spheres_um, atol=1e-9)
    assert [s.size.x for s in entities["bodies"].spheres] == pytest.approx(2 * scene.radii_um)
    assert entities["bodies"].metadata[0].value == ",".join(scene.kinds)
    assert len(entities["traps"].lines[0].points) == 4 * len(scene.traps_um)
    if name == "assemble":
        assert set(scene.kinds) == {"bead"}
        n_beads = params.config.n_beads
        assert len(scene.spheres_um) == len(scene.traps_um) == n_beads
        targets = [(c.pose.position.x, c.pose.position.y) for c in entities["targets"].cylinders]
        np.testing.assert_allclose(targets, np.asarray(state.goal_um), atol=1e-9)
    else:
        assert set(scene.kinds) == {"robot", "cell"} and scene.kinds.count("cell") == 1 and len(scene.traps_um) == 4
        (line,) = entities["targets"].lines
        ends = np.array([(p.x, p.y) for p in line.points])
        turned = np.arctan2(*(ends[1] - ends[0])[::-1])
        expected = float(state.grip_start_rad) + float(state.target_rad)
        assert np.cos(turned - expected) == pytest.approx(1.0)  # the line lies along the target grip axis

    info_back = summary(read_recording(tmp_path / "session.mcap"))
    assert info_back["counts"]["/otgym/bodies"] == 1 and info_back["trials"] == 1
    episodes = info_back["task"]
    assert (episodes["task"], episodes["seed"], episodes["episodes"], episodes["successes"]) == (name, 3, 1, 1)
    assert episodes["mean_time_to_success_s"] == 2.5  # the info's time, not steps x period (2.0)
    assert episodes["metrics"] == {"my_metric": 0.25, "success": 1.0, "time_s": 2.5}


def test_info_metrics_keeps_scalars_only():
    info = {"success": np.bool_(False), "n": np.int32(3), "x": np.float32(0.5), "v": np.ones(2), "one": np.ones(1)}
    assert info_metrics(info) == {"success": False, "n": 3.0, "x": 0.5, "one": 1.0}


@pytest.mark.slow  # builds the task's params (the chip's fields): 3.1 s on the loaded 2-core machine
def test_a_sort_cells_recording_shows_the_cells_the_robots_their_traps_and_the_ports(tmp_path):
    import dataclasses

    from otgym.sim import scene as sc

    task = tasks.load("sort-cells")
    params = task.make_params(task.config())  # robots: four handle traps around a held cell
    direct = dataclasses.replace(params, config=dataclasses.replace(params.config, mode="direct"))
    grip = params.config.grip_time
    recording = TaskRecording(tmp_path / "session.mcap", task, params, None, 0, 0.5, clock_s=lambda: STAMP_S)
    recording.episode_start(1, sort_state(grip + 1.0))
    recording.state(sort_state(grip - 0.5))  # still taking hold: the robots on their way
    recording.close()

    (_, held), (_, taking) = recorded_scenes(tmp_path / "session.mcap")
    entities = {entity.id: entity for entity in held.entities}
    centres = np.array([(s.pose.position.x, s.pose.position.y) for s in entities["bodies"].spheres])
    np.testing.assert_allclose(centres[:3], [[100.0, 70.0], [40.0, 58.0], [180.0, 40.0]])  # the empty slot left out
    robot_xy, robot_radii, _, _ = sc.grip_robots_um(sc.SceneConfig(cell_radius_um=params.config.cell_radii_um[1]))
    np.testing.assert_allclose(centres[3:], robot_xy + [100.0, 70.0], atol=1e-4)  # gripping the held cell
    radii = np.asarray(params.radius_um, float)
    sizes = [s.size.x for s in entities["bodies"].spheres]
    assert sizes == pytest.approx(np.concatenate([2 * radii[[1, 0, 0]], 2 * robot_radii]))
    assert entities["bodies"].metadata[0].value == ",".join(["cell"] * 3 + ["robot"] * len(robot_xy))
    crosses = np.array([(p.x, p.y) for p in entities["traps"].lines[0].points]).reshape(-1, 4, 2)
    assert len(crosses) == 4  # one per handle of the two robots
    np.testing.assert_allclose(crosses.mean(axis=(0, 1)), [100.0, 70.0], atol=1e-4)  # around the held cell
    moving = np.array([(p.x, p.y) for p in {e.id: e for e in taking.entities}["traps"].lines[0].points])
    assert len(moving) == 16 and np.linalg.norm(moving.mean(axis=0) - [100.0, 70.0]) > 1.0  # not there yet
    outlets = [(c.pose.position.x, c.pose.position.y) for c in entities["targets"].cylinders]
    np.testing.assert_allclose(outlets, np.asarray(params.outlets_um, float))
    assert entities["targets"].cylinders[0].size.x == pytest.approx(2 * params.config.exit_distance_um)
    route, inlet = entities["targets"].lines  # the target (cell 0, kind 1) to the junction, then to kind 1's outlet
    np.testing.assert_allclose(
        [(p.x, p.y) for p in route.points],
        [[100.0, 70.0], np.asarray(params.junction_um), np.asarray(params.outlets_um[1])],
    )
    assert all(p.x < 5.0 for p in inlet.points)  # across the inlet's opening, on the chip's left edge
    texts = {t.text: (t.pose.position.x, t.pose.position.y) for t in entities["targets"].texts}
    assert texts.keys() == {"outlet_a: small cells (3 um)", "outlet_b: large cells (5 um)", "inlet: cells arrive"}
    np.testing.assert_allclose(texts["outlet_b: large cells (5 um)"], np.asarray(params.outlets_um[1]))
    direct_scene = task.scene(sort_state(grip + 1.0), direct)
    assert (
        direct_scene.traps_um.tolist() == [[100.0, 70.0]] and "robot" not in direct_scene.kinds
    )  # one trap in the cell
    counts = summary(read_recording(tmp_path / "session.mcap"))["counts"]
    assert counts["/otgym/bodies"] == counts["/otgym/traps"] == 2
