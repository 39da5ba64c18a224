"""The window of ``otgym play`` (``otgym.ui.app``) headless (SDL's dummy drivers), on
the interactive task built once per test process (``tests.runtime.shared_task``):
the mode keys change the loop's alpha, space stops simulated time and zeros the
devices' force, R starts the next trial, Esc ends the session and the devices are
sent zero force; the CLI runs a short session with the simulated stylus and writes
trials.csv and a screenshot with the route drawn; bad arguments are one error line,
exit 2, nothing written. In-process sessions run on a stepped clock that each frame
advances (``SteppedClock``), so the ticks a test sees do not depend on the machine's
speed; a session in its own process is waited for through its snapshots, with a
deadline that only bounds a hang."""

from __future__ import annotations

import csv
import os
import time

os.environ["SDL_VIDEODRIVER"] = "dummy"
os.environ["SDL_AUDIODRIVER"] = "dummy"

import numpy as np  # noqa: E402
import pygame  # noqa: E402
import pytest  # noqa: E402

from otgym.runtime.session import Session  # noqa: E402
from otgym.runtime.trials import TRIAL_COLUMNS  # noqa: E402
from otgym.teleop.device import Device, DeviceCaps, Sample  # noqa: E402
from otgym.ui.app import PlayApp  # noqa: E402
from otgym.ui.bindings import play_bindings  # noqa: E402
from otgym.ui.views import ROUTE_RGB  # noqa: E402
from tests.task import shared_task  # noqa: E402


class SpyStylus(Device):
    """A haptic device holding still with its clutch pressed; records every force and stop."""

    def __init__(self):
        self.caps = DeviceCaps("spy stylus", 3, 0.88, (160.0, 120.0, 70.0), 1000.0)
        self.forces, self.stops, self.sequence = [], 0, 0

    def start(self):
        pass

    def stop(self):
        self.stops += 1

    def read(self):
        self.sequence += 1
        return Sample(time.monotonic(), self.sequence, np.zeros(3), np.zeros(3), 1)

    def set_force(self, force_n):
        self.forces.append(np.array(force_n, float))


class SteppedClock:
    """A session's wall clock that only the test moves (``advance``), so that a frame
    runs the ticks due by the time the test says has passed, however fast the machine
    is. Devices keep the real clock: their samples are always fresh."""

    def __init__(self):
        self.now_s = 1000.0

    def __call__(self) -> float:
        return self.now_s

    def advance(self, seconds: float) -> None:
        self.now_s += seconds


@pytest.fixture(scope="module")
def task():
    return shared_task()


@pytest.fixture
def session(task, tmp_path):
    """A started session in this process (shared mode) with a spy stylus on robot 0, on
    a stepped clock, under a headless window whose frames also run the ticks (the test
    steps frames, each advancing the clock: 60 ms, three ticks, by default)."""
    pygame.init()
    spy = SpyStylus()
    simulation = Session(task, play_bindings([spy, None], clutch=True), "T1", "shared", seed=3, clock=SteppedClock())
    simulation.start()
    app = PlayApp(simulation, tmp_path, questionnaire=False, step=True)
    yield app, simulation, spy
    simulation.close()
    pygame.quit()


class EventSink:
    """A session's sink that keeps the names of its events and counts its ticks."""

    def __init__(self):
        self.events: list[str] = []
        self.ticks = 0

    def describe(self, task) -> None:
        self.events.append("describe")

    def tick(self, record, sphere_xy_um, mode) -> None:
        self.ticks += 1

    def event(self, name: str, **fields) -> None:
        self.events.append(name)

    def close(self) -> None:
        pass


def test_a_session_holding_its_first_trial_ticks_nothing_until_next_trial(task):
    """``hold_first_trial`` (the sim of ``otgym play --distributed``, ``--wait-for-start``):
    after ``start`` the chip is described but trial 1 does not start, and no tick runs
    however much wall time passes, until ``next_trial`` is posted; then trial 1 runs
    from its start and, without ``hold_between_trials``, trial 2 follows it at once."""
    clock, sink = SteppedClock(), EventSink()
    simulation = Session(
        task, play_bindings([SpyStylus(), None], clutch=True), "H1", "manual", seed=3, clock=clock, sink=sink,
        hold_between_trials=False, hold_first_trial=True,
    )  # fmt: skip
    simulation.start()
    try:
        for _ in range(5):
            clock.advance(1.0)
            assert simulation.advance() == 0
        assert (simulation.trial, simulation.ticks, sink.ticks, sink.events) == (0, 0, 0, ["describe"])
        simulation.next_trial()
        clock.advance(1.0)
        assert simulation.advance() == 1 and simulation.trial == 1  # its first tick, at the command
        clock.advance(0.04)
        assert simulation.advance() == 2 and sink.ticks == 3
        assert sink.events[:2] == ["describe", "trial_start"] and simulation.loop.time_s == pytest.approx(0.06)
    finally:
        simulation.close()


def press(app, key, frames=1, step_s=0.06):
    pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=key, mod=0, unicode="", scancode=0))
    run_frames(app, frames, step_s)


def run_frames(app, frames, step_s=0.06):
    """``frames`` frames, the session's stepped clock advanced by ``step_s`` before each."""
    for _ in range(frames):
        app.session.clock.advance(step_s)
        app.frame()


def frames_until(app, condition, timeout_s: float = 120.0) -> None:
    """Frames (about 100 a second) until ``condition()`` holds, for a session in another
    process on the real clock; the deadline only bounds a hang."""
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, f"not within {timeout_s} s"
        app.frame()
        time.sleep(0.01)


@pytest.mark.slow
def test_mode_keys_switch_the_loops_mode_and_alpha(session):
    app, simulation, _ = session
    run_frames(app, 3)
    assert simulation.loop.mode == "shared" and simulation.snapshot.alpha == pytest.approx(0.1)  # far from obstacles
    press(app, pygame.K_1, frames=3)
    assert simulation.loop.mode == "manual" and simulation.snapshot.alpha == 1.0
    press(app, pygame.K_3, frames=3)
    assert simulation.loop.mode == "autonomous" and simulation.snapshot.alpha == 0.0
    press(app, pygame.K_2, frames=3)
    assert simulation.loop.mode == "shared" and simulation.snapshot.alpha == pytest.approx(0.1)


class RecordingSurface(pygame.Surface):
    """A surface that keeps the rectangle of every blit (the texts drawn on it), in order."""

    def __init__(self, size):
        super().__init__(size)
        self.blitted: list[pygame.Rect] = []

    def blit(self, source, dest, *args, **kwargs):
        rect = super().blit(source, dest, *args, **kwargs)
        self.blitted.append(rect)
        return rect


def test_the_cue_panels_mode_and_alpha_never_overlap(session):
    """The panel's first line: the mode's name in the title font, then alpha, clear of
    even the longest name (AUTONOMOUS, which a fixed column for alpha would overlap)."""
    app, simulation, _ = session
    for key, mode in ((pygame.K_1, "manual"), (pygame.K_2, "shared"), (pygame.K_3, "autonomous")):
        press(app, key, frames=3)
        surface = RecordingSurface(app.screen.get_size())
        app.cue_panel.draw(surface, simulation.snapshot, app.type)
        assert simulation.snapshot.mode == mode
        title, alpha = surface.blitted[:2]
        assert title.width > 0 and alpha.width > 0 and not title.colliderect(alpha), mode


class SpyFont:
    """A font that keeps every text it renders (what the panel writes), in order."""

    def __init__(self, font, texts: list):
        self.font, self.texts = font, texts

    def render(self, text, *args):
        self.texts.append(text)
        return self.font.render(text, *args)


@pytest.mark.slow
def test_the_cue_panel_shows_the_trial_s_light_dose(session):
    """The panel writes the cell's light dose so far: the trial metric the session holds."""
    app, simulation, _ = session
    run_frames(app, 3)
    dose = float(simulation.loop.state.metrics.light_dose_mj_per_um2[0])
    assert simulation.snapshot.light_dose_mj_per_um2 == dose and dose > 0.0  # the cell starts gripped, in light
    texts: list[str] = []
    app.cue_panel.draw(app.screen, simulation.snapshot, {size: SpyFont(font, texts) for size, font in app.type.items()})
    assert "cell light dose" in texts and f"{dose:.3g} mJ/um^2" in texts


def test_space_pauses_simulated_time_and_zeros_the_force(session):
    app, simulation, spy = session
    run_frames(app, 3)
    before = simulation.loop.time_s
    run_frames(app, 3)
    assert simulation.loop.time_s > before  # running: time advances
    press(app, pygame.K_SPACE)
    paused_at = simulation.loop.time_s
    assert simulation.paused and np.all(spy.forces[-1] == 0.0)
    run_frames(app, 6)
    assert simulation.loop.time_s == paused_at and simulation.snapshot.paused
    press(app, pygame.K_SPACE, frames=4)
    assert simulation.loop.time_s > paused_at


def test_r_starts_trial_2_from_the_start(session):
    app, simulation, _ = session
    run_frames(app, 4)
    assert simulation.trial == 1 and simulation.loop.time_s > 0
    press(app, pygame.K_r, frames=1, step_s=0.0)
    assert simulation.trial == 2 and simulation.snapshot.trial == 2
    assert simulation.participant == "T1" and simulation.loop.time_s < 0.2
    assert simulation.take_finished() is None  # an abandoned trial writes no row


def test_escape_ends_the_session_and_the_devices_get_zero_force(session):
    app, simulation, spy = session
    run_frames(app, 2)
    pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=pygame.K_ESCAPE, mod=0, unicode="", scancode=0))
    app.run()  # returns after the frame that sees Esc
    assert not app.running
    simulation.close()
    assert spy.stops == 1 and np.all(spy.forces[-1] == 0.0)


def test_closing_the_window_mid_trial_saves_it_as_aborted(session, tmp_path):
    """The window closed mid-trial: the trial's row is written with ended_by aborted,
    its completion time the simulated time it ran, not a goal."""
    app, simulation, _ = session
    run_frames(app, 4)
    pygame.event.post(pygame.event.Event(pygame.QUIT))
    app.run()
    ran_s = simulation.loop.time_s
    with open(tmp_path / "trials.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert ran_s > 0 and len(rows) == 1 and rows[0]["ended_by"] == "aborted" and rows[0]["trial"] == "1"
    assert float(rows[0]["completion_time_s"]) == pytest.approx(ran_s) and rows[0]["reached_goal"] == "False"


def test_mouse_drag_moves_the_robots_traps_toward_the_pointer(session, task):
    app, simulation, _ = session
    press(app, pygame.K_1, frames=2)  # manual: only the person moves the traps
    view = app.global_view
    traps = view.trap_centre_um(simulation.snapshot, 1)
    start_px = view.to_px(traps)
    target_um = traps + np.array([0.0, 4.0])
    pygame.event.post(pygame.event.Event(pygame.MOUSEBUTTONDOWN, pos=tuple(start_px), button=1))
    pygame.event.post(
        pygame.event.Event(pygame.MOUSEMOTION, pos=tuple(view.to_px(target_um)), rel=(0, 0), buttons=(1, 0, 0))
    )
    run_frames(app, 15)
    moved = view.trap_centre_um(simulation.snapshot, 1) - traps
    assert moved[1] > 1.0 and abs(moved[0]) < 0.5 * moved[1]
    robot0 = view.trap_centre_um(simulation.snapshot, 0)
    pygame.event.post(pygame.event.Event(pygame.MOUSEBUTTONUP, pos=tuple(view.to_px(target_um)), button=1))
    run_frames(app, 5)
    assert np.linalg.norm(view.trap_centre_um(simulation.snapshot, 0) - robot0) < 0.2  # robot 0 held still


@pytest.mark.slow
def test_cli_session_writes_trials_and_a_screenshot(tmp_path, capsys):
    from otgym.cli.app import main

    out = tmp_path / "out"
    shot = out / "play.png"  # into --out, which the command creates
    with pytest.raises(SystemExit) as exit_info:
        main(
            [
                "play",
                "--headless",
                "--device",
                "simulated",
                "--duration",
                "2",
                "--no-questionnaire",
                "--participant",
                "P7",
                "--seed",
                "2",
                "--screenshot",
                str(shot),
                "--out",
                str(out),
            ]
        )
    assert exit_info.value.code == 0
    with open(out / "trials.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert list(rows[0])[: len(TRIAL_COLUMNS)] == TRIAL_COLUMNS
    assert len(rows) == 1 and rows[0]["participant"] == "P7" and rows[0]["trial"] == "1"
    assert rows[0]["scenario"] == "20001" and rows[0]["ended_by"] == "duration"
    # cut off by --duration: the time it ran, not an empty cell, and not a goal
    assert float(rows[0]["completion_time_s"]) == pytest.approx(2.0, abs=0.011)
    assert rows[0]["reached_goal"] == "False"
    from otgym.record.mcap_file import read_recording
    from otgym.record.replay import summary

    recorded = summary(read_recording(out / "session.mcap"))  # every tick of the session, its events
    assert recorded["complete"] and recorded["trials"] == 1 and recorded["ended_by"] == ["duration"]
    counts = recorded["counts"]
    assert counts["/otgym/traps"] == counts["/otgym/bodies"] == counts["/otgym/shared/alpha"] == 100
    # a new stylus sample is recorded once, on the tick that read it: at most one a tick (how many ticks
    # found a new one is the servo process's pace, measured in benchmarks/interactive.py)
    assert 0 < counts["/otgym/device/device0/twist"] <= 100 and counts["/otgym/feedback/device0"] == 100
    # the global view's scene, once, and the mode at the trial's start only (issue 12: replay draws the chip)
    assert counts["/otgym/session"] == counts["/otgym/chip"] == counts["/otgym/route"] == counts["/otgym/mode"] == 1
    from otgym.record.replay import session_scene
    from otgym.sim.chip import load_chip

    scene = session_scene(read_recording(out / "session.mcap"))
    assert scene.chip_note is None and scene.chip.content_hash == load_chip("default").content_hash
    assert list(scene.sphere_kind).count(1) == 1 and len(scene.handle_spheres) == 4 and len(scene.route_um) > 100
    image = pygame.surfarray.array3d(pygame.image.load(str(shot)))
    assert image.shape[:2] == (1280, 720)
    colours = np.unique(image.reshape(-1, 3) // 16, axis=0)
    assert len(colours) > 50  # views, text and cues, not a blank frame
    route_pixels = np.all(np.abs(image.astype(int) - ROUTE_RGB) <= 8, axis=-1).sum()
    assert route_pixels > 1000
    # the study's analysis reads the session and counts the cut trial as one that did not reach the goal
    from otgym.study.analyze import load_study
    from otgym.study.summary import summarize

    shared = summarize(load_study([out])[0]).set_index("mode").loc["shared"]
    assert shared["trials"] == 1 and shared["goals_reached"] == 0 and np.isnan(shared["completion_time_mean_s"])


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["--device", "joystick"], "unknown device 'joystick'"),
        (["--mode", "telepathic"], "--mode must be one of manual, shared, autonomous, not 'telepathic'"),
        (["--device", "touch"], "Geomagic Touch"),
        (["--chip", "no_such_chip"], "no chip file"),
        (["--device", "gamepad"], "no gamepad"),  # none plugged in on a test machine
        (["--navigator", "mpc"], "needs --distributed"),
        (["--navigator", "oracle"], "--navigator: unknown navigator 'oracle'; choose one of route, mpc, rl"),
    ],
)
def test_cli_refuses_bad_arguments_with_one_line_and_writes_nothing(tmp_path, capsys, arguments, message):
    from otgym.cli.app import main

    out = tmp_path / "out"
    with pytest.raises(SystemExit) as exit_info:
        main(["play", "--headless", *arguments, "--out", str(out)])
    assert exit_info.value.code == 2
    error = capsys.readouterr().err.strip().splitlines()
    assert len(error) == 1 and error[0].startswith("error: ") and message in error[0]
    assert not out.exists()


def test_cli_refuses_an_out_that_is_a_file(tmp_path, capsys):
    from otgym.cli.app import main

    out = tmp_path / "file.txt"
    out.write_text("keep me")
    with pytest.raises(SystemExit) as exit_info:
        main(["play", "--headless", "--device", "simulated", "--out", str(out)])
    assert exit_info.value.code == 2 and "is a file" in capsys.readouterr().err
    assert out.read_text() == "keep me"


def test_a_finished_trial_asks_the_questionnaires_and_saves_the_answers(task, tmp_path):
    """The session's duration spent, the trial's row goes to trials.csv and the window
    shows the questionnaires; answered by keys (every NASA-TLX subscale 50, every UEQ-S
    item 6), the answers go to questionnaires.csv under the trial's participant, mode
    and trial."""
    from otgym.study.questionnaires import read_answers, score

    pygame.init()
    clock = SteppedClock()
    simulation = Session(
        task, play_bindings([SpyStylus(), None], clutch=True), "Q1", "manual", seed=3, duration_s=0.2, clock=clock
    )
    simulation.start()
    try:
        app = PlayApp(simulation, tmp_path, questionnaire=True, step=True)
        for _ in range(11):  # 0.2 s of ticks is due by the 10th step of 30 ms; one to spare
            if simulation.over:
                break
            clock.advance(0.03)
            simulation.advance()
        assert simulation.over
        pygame.event.clear()
        keys = [pygame.K_RIGHT, pygame.K_DOWN] * 6 + [pygame.K_RETURN] + [pygame.K_6] * 8 + [pygame.K_RETURN]
        for key in keys:
            pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=key, mod=0, unicode="", scancode=0))
        app._finish_trials()
    finally:
        simulation.close()
        pygame.quit()
    with open(tmp_path / "trials.csv") as handle:
        trial = next(csv.DictReader(handle))
    answers = read_answers(tmp_path / "questionnaires.csv")
    assert len(answers) == 14
    assert set(zip(answers.participant.astype(str), answers["mode"], answers.trial.astype(str))) == {
        (trial["participant"], trial["mode"], trial["trial"])
    }
    scores = score(answers).iloc[0]
    assert scores["raw_tlx"] == 50 and scores["ueq_overall"] == 2


def test_the_keyboard_moves_both_robots_as_a_formation(task):
    """--device keyboard: holding the right arrow for 30 ticks (0.6 s of the session's
    stepped clock) moves both robots' traps along +x by the same amount (one keyboard
    shared by both bindings); with the keyboard on robot 0 alone, robot 1's traps would
    not move."""
    from otgym.ui.bindings import primary_devices

    pygame.init()
    primaries = primary_devices("keyboard")
    clock = SteppedClock()
    simulation = Session(task, play_bindings(primaries, clutch=False), "K1", "manual", seed=3, clock=clock)
    simulation.start()
    try:
        simulation.advance()
        before = np.array(simulation.loop.observation.trap_xy_um[0])
        primaries[0].handle_event(pygame.event.Event(pygame.KEYDOWN, key=pygame.K_RIGHT, mod=0, unicode="", scancode=0))
        for _ in range(12):  # 0.6 s of the session's clock: 30 ticks
            clock.advance(0.05)
            simulation.advance()
        moved = np.array(simulation.loop.observation.trap_xy_um[0]) - before
    finally:
        simulation.close()
        pygame.quit()
    robot = task.trap_robot
    first, second = moved[robot == robot[0]].mean(axis=0), moved[robot != robot[0]].mean(axis=0)
    assert first[0] > 0.5 and second[0] > 0.5, moved
    assert abs(first[0] - second[0]) < 0.1 * first[0] and abs(first[1]) < 0.1 * first[0], moved


@pytest.mark.slow
def test_the_window_drives_a_session_in_its_own_process_with_the_keyboard(tmp_path):
    """``otgym play``'s arrangement: the session in a worker process, the keyboard read
    by the window and its samples forwarded. Holding the right arrow moves both robots'
    traps along +x (manual mode: nothing else moves them; the window draws frames until
    every trap has moved 1 um, 120 s at most, then the motion must point along x);
    closing the window mid-trial saves the trial as aborted, and its recording ends with
    it, holding the forwarded key samples (the keyboard's 2 mm/s along x). While it
    starts, the worker reports its stages in order (what the start-up screen shows)."""
    import functools

    from otgym.bus import messages as msg
    from otgym.record.mcap_file import read_recording
    from otgym.record.replay import summary
    from otgym.runtime.worker import STATUS_COMPILING, SessionProcess, WorkerSpec
    from otgym.teleop.device import start_devices
    from otgym.ui.bindings import window_devices
    from otgym.ui.play_worker import play_setup

    pygame.init()
    windowed = window_devices("keyboard")
    start_devices(windowed)
    statuses = []
    session = SessionProcess(
        WorkerSpec(
            functools.partial(play_setup, "default", "keyboard", tmp_path / "session.mcap"),
            "K2",
            "manual",
            3,
            forwarded_caps=tuple(d.caps for d in windowed),
        ),
        on_status=statuses.append,
    )
    session.start()
    # what the start-up screen showed: each stage of the worker, before the session ran
    assert statuses == ["building the task: chip, route, robots and cell", STATUS_COMPILING], statuses
    try:
        app = PlayApp(session, tmp_path, window_devices=windowed, questionnaire=False)
        frames_until(app, lambda: session.snapshot is not None and session.snapshot.observation.time_s[0] > 0)
        before = np.array(session.snapshot.observation.trap_xy_um[0])
        pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=pygame.K_RIGHT, mod=0, unicode="", scancode=0))

        def moved_um():
            return np.array(session.snapshot.observation.trap_xy_um[0]) - before

        frames_until(app, lambda: np.all(moved_um()[:, 0] > 1.0))
        moved = moved_um()
        pygame.event.post(pygame.event.Event(pygame.QUIT))
        app.run()
    finally:
        session.finish()
        pygame.quit()
    assert np.all(np.abs(moved[:, 1]) < 0.1 * moved[:, 0]), moved
    with open(tmp_path / "trials.csv", newline="") as handle:
        assert [row["ended_by"] for row in csv.DictReader(handle)] == ["aborted"]
    recording = read_recording(tmp_path / "session.mcap")
    recorded = summary(recording)
    assert recorded["complete"] and recorded["ended_by"] == ["aborted"]
    twists = [msg.velocity_mm_s(msg.decode(m.topic, m.data)) for m in recording.topic(msg.twist_topic("device0"))]
    assert any(np.allclose(v, [2.0, 0.0, 0.0]) for v in twists)  # the forwarded key samples are recorded
