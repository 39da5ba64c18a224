"""``otgym replay`` (``otgym.record.replay``, ``frames``, ``video``): a recording that
holds its session's description, chip and route draws the global view (walls, route,
destination, each sphere by kind, traps) with colours where the recorded positions
put them; a recording made before chips were recorded still replays, with a one-line
note; a missing chip image falls back to the shipped chip only when its content hash
agrees; the MP4 decodes with the expected frame count and size."""

from __future__ import annotations

import json
import math
import types

import av
import numpy as np
import pytest
from PIL import Image

from otgym.bus import messages as m
from otgym.bus import schemas, task_messages
from otgym.physics.bodies import BodyKind
from otgym.record.frames import STRIP_PX, FrameRenderer, label, render_frames
from otgym.record.mcap_file import McapRecorder, read_recording
from otgym.record.replay import session_scene, summary, ticks
from otgym.record.video import frame_ticks, write_video
from otgym.sim.chip import load_chip
from otgym.sim.render import CHANNEL_RGB, HANDLE_RGB, KIND_RGB, PATH_RGB, SOLID_RGB, TRAP_RGB, UNKNOWN_KIND_RGB

TICK_S = 0.02
ROUTE_UM = np.array([[15.0, 40.0], [60.0, 40.0]])
# spheres: robot (handle), robot, cell, obstacle; every one in a channel of the default chip
SPHERES_UM = np.array([[40.0, 160.0], [46.0, 160.0], [150.0, 100.0], [250.0, 160.0]])
RADII_UM = [2.0, 2.0, 5.0, 3.0]
TRAP_UM = [40.0, 165.0]


def stand_in_task(chip):
    """What ``task_messages.session_messages`` reads of a task, for four spheres on ``chip``."""
    model = types.SimpleNamespace(
        sphere_body=[0, 0, 1, 2],
        body_kinds=[BodyKind.ROBOT, BodyKind.CELL, BodyKind.OBSTACLE],
        sphere_radius_um=RADII_UM,
    )
    return types.SimpleNamespace(
        chip=chip,
        scene=types.SimpleNamespace(model=model),
        trap_sphere=np.array([0]),
        config=types.SimpleNamespace(goal_tolerance_um=3.0, tick_s=TICK_S),
        route_um=ROUTE_UM,
    )


def write(recorder: McapRecorder, topic: str, data: bytes, t_ns: int) -> None:
    type_name = m.topic_type(topic)
    recorder.write(topic, type_name, schemas.SCHEMAS[type_name], data, log_time_ns=t_ns)


def record(path, n_ticks: int, described=("session", "chip", "route"), chip=None, mode_every_tick=False) -> None:
    """A one-trial session of ``n_ticks`` ticks; the spheres drift +0.1 um in x per tick.
    ``described``: which of the latched description messages it starts with (none: a
    recording made before they existed, which sent the mode every tick)."""
    topics = {"session": m.SESSION, "chip": m.CHIP, "route": m.ROUTE}
    with McapRecorder(path) as recorder:
        wanted = [topics[name] for name in described]
        for topic, data in task_messages.session_messages(
            stand_in_task(chip or load_chip("default")), ["device0"], 1.0
        ):
            if topic in wanted:
                write(recorder, topic, data, 10**9)
        write(
            recorder,
            m.EVENTS,
            m.event("trial_start", trial=1, scenario=10001, mode="manual", sphere_radius_um=RADII_UM),
            10**9,
        )
        for i in range(n_ticks):
            t_ns = 10**9 + (i + 1) * int(TICK_S * 1e9)
            write(recorder, m.TRAPS, m.pose_array([TRAP_UM], t_ns * 1e-9), t_ns)
            write(recorder, m.ALPHA, m.float64(0.3), t_ns)
            if i == 0 or mode_every_tick:
                write(recorder, m.MODE, m.string("manual"), t_ns)
            write(recorder, m.BODIES, m.pose_array(SPHERES_UM + [0.1 * i, 0.0], t_ns * 1e-9), t_ns)
        write(recorder, m.EVENTS, m.event("trial_end", trial=1, ended_by="goal"), 10**9 + (n_ticks + 1) * 20_000_000)


def colour_near(frame, renderer: FrameRenderer, xy_um, rgb, atol: float = 10) -> bool:
    """Whether a pixel within one of ``xy_um``'s pixel has colour ``rgb``."""
    x, y = renderer.view.to_px(xy_um)
    patch = frame[int(y) + STRIP_PX - 1 : int(y) + STRIP_PX + 2, int(x) - 1 : int(x) + 2].reshape(-1, 3).astype(float)
    return bool(np.min(np.abs(patch - np.asarray(rgb, float)).max(axis=1)) <= atol)


def test_a_recorded_session_draws_chip_route_destination_bodies_and_traps(tmp_path):
    path = tmp_path / "s.mcap"
    record(path, 3)
    recording = read_recording(path)
    scene = session_scene(recording)
    assert scene.chip_note is None and scene.chip.content_hash == load_chip("default").content_hash
    np.testing.assert_array_equal(scene.route_um, ROUTE_UM)
    assert list(scene.sphere_kind) == [BodyKind.ROBOT, BodyKind.ROBOT, BodyKind.CELL, BodyKind.OBSTACLE]
    renderer = FrameRenderer(recording, scene, width_px=960)
    assert renderer.width_px == 960 and renderer.height_px == 640 + STRIP_PX  # the chip is 300 x 200 um
    tick = next(ticks(recording, scene.tick_s))
    frame = renderer.draw(tick)
    assert frame.shape == (renderer.height_px, 960, 3)
    assert colour_near(frame, renderer, (20.0, 100.0), SOLID_RGB)  # a wall
    assert colour_near(frame, renderer, (150.0, 60.0), CHANNEL_RGB)  # a channel
    assert colour_near(frame, renderer, (30.0, 40.0), PATH_RGB)  # the route
    assert colour_near(frame, renderer, (60.0 + 3.0, 40.0), PATH_RGB, atol=40)  # the destination's ring
    assert not colour_near(frame, renderer, (60.0, 40.0 + 1.5), PATH_RGB, atol=40)  # a ring, not a disc
    assert colour_near(frame, renderer, SPHERES_UM[0], HANDLE_RGB)
    assert colour_near(frame, renderer, SPHERES_UM[1], KIND_RGB[BodyKind.ROBOT])
    assert colour_near(frame, renderer, SPHERES_UM[2], KIND_RGB[BodyKind.CELL])
    assert colour_near(frame, renderer, SPHERES_UM[3], KIND_RGB[BodyKind.OBSTACLE])
    trap_ring = np.add(TRAP_UM, [max(3.0, 0.6 * renderer.view.scale) / renderer.view.scale, 0.0])
    assert colour_near(frame, renderer, trap_ring, TRAP_RGB, atol=40)
    assert label(tick) == "trial 1    t   0.02 s    mode manual    alpha 0.30"
    strip = frame[:STRIP_PX].reshape(-1, 3).astype(int)
    assert (strip.min(axis=1) > 200).sum() > 100  # the label's light text on the dark strip


def test_the_time_counts_ticks_in_the_trial_and_the_mode_stays_latched(tmp_path):
    path = tmp_path / "s.mcap"
    record(path, 30)
    recording = read_recording(path)
    seen = list(ticks(recording, TICK_S, lambda index: index in (0, 29)))
    assert [t.index for t in seen] == [0, 29]
    assert seen[1].time_s == pytest.approx(30 * TICK_S) and seen[1].mode == "manual"  # one mode message, at tick 1
    np.testing.assert_allclose(seen[1].sphere_xy_um, SPHERES_UM + [2.9, 0.0])


def test_a_recording_without_its_chip_still_replays_with_a_one_line_note(tmp_path, capsys):
    from otgym.cli.app import main

    path = tmp_path / "old.mcap"
    record(path, 60, described=(), mode_every_tick=True)
    recording = read_recording(path)
    scene = session_scene(recording)
    assert scene.chip is None and scene.route_um is None and "holds no chip" in scene.chip_note
    assert scene.tick_s == pytest.approx(TICK_S)  # measured from the bodies messages
    frames = render_frames(recording, tmp_path, every=25)
    assert [f.name for f in frames] == ["frame_00000.png", "frame_00001.png", "frame_00002.png"]
    first = np.asarray(Image.open(frames[0]).convert("RGB")).astype(float)
    renderer = FrameRenderer(recording)
    assert colour_near(first, renderer, SPHERES_UM[2], UNKNOWN_KIND_RGB, atol=3)  # kinds unknown: grey
    assert colour_near(first, renderer, (SPHERES_UM[2] + SPHERES_UM[3]) / 2, CHANNEL_RGB, atol=3)  # no walls
    with pytest.raises(SystemExit) as exit_info:
        main(["replay", str(path), "--out", str(tmp_path / "cli"), "--every", "30"])
    assert exit_info.value.code in (0, None)
    printed = capsys.readouterr().out
    assert "over 1.22 s, complete" in printed and "1 started, 1 finished (goal)" in printed
    notes = [line for line in printed.splitlines() if line.startswith("note:")]
    assert len(notes) == 1 and "holds no chip" in notes[0] and "wrote 2 frame(s)" in printed
    with pytest.raises(SystemExit) as exit_info:
        main(["replay", str(tmp_path / "missing.mcap")])
    assert exit_info.value.code == 2 and "missing.mcap does not exist" in capsys.readouterr().err


def test_a_missing_chip_image_is_the_shipped_chip_only_if_its_hash_agrees(tmp_path):
    record(tmp_path / "named.mcap", 2, described=("session", "route"))
    scene = session_scene(read_recording(tmp_path / "named.mcap"))
    assert scene.chip_note is None and scene.chip.content_hash == load_chip("default").content_hash
    default = load_chip("default")
    other = type(default)("default", default.image[::-1], default.pixel_size_um, default.channel_height_um)
    record(tmp_path / "other.mcap", 2, described=("session", "route"), chip=other)
    scene = session_scene(read_recording(tmp_path / "other.mcap"))
    assert scene.chip is None and "differs" in scene.chip_note
    record(tmp_path / "own.mcap", 2, chip=other)  # its own image recorded: drawn from it
    scene = session_scene(read_recording(tmp_path / "own.mcap"))
    assert scene.chip_note is None and scene.chip.content_hash == other.content_hash


def test_frame_ticks_play_simulated_time_in_real_time():
    np.testing.assert_array_equal(frame_ticks(7, 0.02, 25.0), [0, 2, 4, 6])
    np.testing.assert_array_equal(frame_ticks(6, 0.02, 25.0, speed=2.0), [0, 4])
    shown = frame_ticks(50, 0.02, 60.0)  # more frames than ticks: some ticks shown twice
    assert len(shown) == 60 and shown[-1] == 49 and np.all(np.diff(shown) >= 0)
    with pytest.raises(ValueError, match="fps"):
        frame_ticks(5, 0.02, 0.0)


def test_the_video_decodes_with_the_expected_frames_and_size(tmp_path):
    path = tmp_path / "s.mcap"
    n_ticks = 51
    record(path, n_ticks)
    calls = []
    made = write_video(
        read_recording(path),
        tmp_path / "s.mp4",
        fps=25.0,
        width_px=480,
        progress=lambda done, total: calls.append((done, total)),
    )
    expected = math.ceil(n_ticks * TICK_S * 25.0)
    assert made["frames"] == expected and calls[-1] == (expected, expected) and len(calls) == expected
    assert not list(tmp_path.glob(".*part"))
    with av.open(str(tmp_path / "s.mp4")) as container:
        stream = container.streams.video[0]
        assert stream.codec_context.name == "h264" and stream.average_rate == 25
        decoded = [frame.to_ndarray(format="rgb24") for frame in container.decode(video=0)]
    assert len(decoded) == expected and decoded[0].shape == (320 + STRIP_PX, 480, 3)
    # the cell drifts 0.1 um per tick: the last frame shows it 2.5 um (tick 50) further along x
    renderer = FrameRenderer(read_recording(path), width_px=480)
    cell_end = SPHERES_UM[2] + [0.1 * 50, 0.0]
    assert colour_near(decoded[-1], renderer, cell_end + [4.0, 0.0], KIND_RGB[BodyKind.CELL], atol=30)
    assert not colour_near(decoded[0], renderer, cell_end + [4.0, 0.0], KIND_RGB[BodyKind.CELL], atol=30)


def test_video_from_the_command_line_beside_the_recording(tmp_path, capsys):
    from otgym.cli.app import main

    path = tmp_path / "session.mcap"
    record(path, 10)
    with pytest.raises(SystemExit) as exit_info:
        main(["replay", str(path), "--video", "--width", "320"])
    assert exit_info.value.code in (0, None)
    assert "H.264 at 25 fps" in capsys.readouterr().out
    with av.open(str(tmp_path / "session.mp4")) as container:
        assert sum(1 for _ in container.decode(video=0)) == 5
    with pytest.raises(SystemExit) as exit_info:
        main(["replay", str(path), "--video", "--fps", "0"])
    assert exit_info.value.code == 2 and capsys.readouterr().err.startswith("error: --fps must lie in")


def test_summary_counts_the_description_once(tmp_path):
    path = tmp_path / "s.mcap"
    record(path, 4)
    counts = summary(read_recording(path))["counts"]
    assert counts[m.SESSION] == counts[m.CHIP] == counts[m.ROUTE] == counts[m.MODE] == 1
    assert json.loads(m.decode(m.SESSION, read_recording(path).topic(m.SESSION)[0].data).data)["tick_s"] == TICK_S
