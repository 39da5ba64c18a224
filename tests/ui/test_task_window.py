"""The generic task window of ``otgym play --task`` (``otgym.ui.task_window``) headless
(SDL's dummy drivers) on a toy task whose step is one jnp line, so it compiles in a
moment: the keyboard's arrows and a mouse drag become the task's actions through the
retargeting and ``device_action``, finished episodes are rows and a fresh one starts,
R and Esc do what the help says, the status shows the light dose the task's info
reports, and a task without a frame or device input is refused.
The pace's clock is the test's (``frame(now_s)``), so the steps a test sees do not
depend on the machine's speed."""

from __future__ import annotations

import os

os.environ["SDL_VIDEODRIVER"] = "dummy"
os.environ["SDL_AUDIODRIVER"] = "dummy"

import gymnasium as gym  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
import pygame  # noqa: E402
import pytest  # noqa: E402

from otgym.tasks.base import Task, TaskScene  # noqa: E402
from otgym.teleop.device import open_device  # noqa: E402
from otgym.ui.bindings import play_bindings  # noqa: E402
from otgym.ui.task_window import FRAME_SIZE, STATUS_HEIGHT, Compiled, TaskWindow, check_playable, write_episodes  # noqa: E402

MOVES = np.array([[0, 0], [1, 0], [-1, 0], [0, 1], [0, -1]], np.float32)
EPISODE_STEPS = 5
FRAME_S = 0.02  # the window's 50 Hz
PERIOD_S = 0.1


DOSE_PER_STEP = 0.25  # mJ/um^2: the toy's light dose grows this much each step


class Walker(Task):
    """A point that moves 1 um a step along MOVES[action]; an episode is 5 steps, a
    success if it ends at x >= 3 um; its info reports a light dose of DOSE_PER_STEP per step."""

    name = "walker"

    def default_config(self):
        return None

    def make_params(self, config):
        return jnp.zeros(())

    def max_steps(self, params):
        return EPISODE_STEPS

    def control_period_s(self, params):
        return PERIOD_S

    def reset(self, key, params):
        state = (jnp.zeros(2), jnp.zeros((), jnp.int32))
        return jnp.zeros(2, jnp.float32), state

    def step(self, key, state, action, params):
        xy = state[0] + jnp.asarray(MOVES)[action]
        steps = state[1] + 1
        done = steps >= EPISODE_STEPS
        info = {"success": done & (xy[0] >= 3.0), "light_dose_mj_per_um2": DOSE_PER_STEP * steps.astype(jnp.float32)}
        return xy.astype(jnp.float32), (xy, steps), jnp.float32(1.0), done, jnp.bool_(False), info

    def observation_size(self, params):
        return 2

    def action_space(self, params):
        return gym.spaces.Discrete(5)

    def frame(self, state, params, size_px=(600, 400)):
        return np.zeros((size_px[1], size_px[0], 3), np.uint8)

    def device_action(self, velocity_um_s, params):
        velocity = np.asarray(velocity_um_s, np.float32)
        if np.hypot(*velocity) < 0.5:
            return np.asarray(0, np.int32)
        return np.asarray(int(np.argmax(MOVES @ velocity)), np.int32)

    def scene(self, state, params):
        xy = np.asarray(state[0], float)[None]
        return TaskScene(xy, np.ones(1), ("bead",), xy + 0.5, targets_um=np.array([[3.0, 0.0]]))


class Frameless(Walker):
    frame = Task.frame


class Deaf(Walker):
    device_action = Task.device_action


@pytest.fixture(scope="module")
def compiled():
    return Compiled.build(Walker())


@pytest.fixture
def window(compiled):
    pygame.init()
    keyboard = open_device("keyboard", pump_events=False)
    keyboard.start()
    retarget = play_bindings([keyboard], clutch=False)[0].retarget
    window = TaskWindow(compiled, keyboard, retarget, keyboards=[keyboard])
    window.mouse.start()
    yield window
    window.mouse.stop()
    pygame.quit()


def run_frames(window, frames, start_s=0.0):
    for index in range(frames):
        window.frame(start_s + index * FRAME_S)


def test_the_task_steps_once_a_period_and_an_idle_device_holds(window):
    run_frames(window, 5 * 2 * EPISODE_STEPS + 1)  # two episodes' periods, the first frame only starts the pace
    assert window.steps == 2 * EPISODE_STEPS
    assert [row["ended_by"] for row in window.rows] == ["terminated", "terminated"]
    assert not any(row["success"] for row in window.rows)  # the point never moved
    assert np.array_equal(np.asarray(window.state[0]), [0.0, 0.0]) and window.episode_steps == 0


def test_the_arrow_key_moves_the_point_right_to_success(window):
    pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=pygame.K_RIGHT, mod=0, unicode="", scancode=0))
    run_frames(window, 5 * EPISODE_STEPS + 1)
    assert window.rows and window.rows[0]["success"] is True, window.rows
    assert window.successes == 1


def test_the_down_key_moves_it_down(window):
    pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=pygame.K_DOWN, mod=0, unicode="", scancode=0))
    run_frames(window, 5 * 3 + 1)
    x, y = np.asarray(window.state[0])
    assert x == 0.0 and y >= 2.0  # chip y points down; the first period's filter ramp may hold once


def test_a_mouse_drag_to_the_right_moves_the_point_right(window):
    pygame.event.post(pygame.event.Event(pygame.MOUSEBUTTONDOWN, button=1, pos=(300, 300)))
    pygame.event.post(pygame.event.Event(pygame.MOUSEMOTION, pos=(380, 300), rel=(80, 0), buttons=(1, 0, 0)))
    run_frames(window, 5 * 3 + 1)
    x, y = np.asarray(window.state[0])
    assert x >= 2.0 and y == 0.0


def test_r_starts_a_new_episode_and_esc_quits(window, tmp_path):
    run_frames(window, 5 * 2 + 1)  # steps at 0.1 and 0.2 s
    pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=pygame.K_r, mod=0, unicode="", scancode=0))
    window.frame(0.21)  # before the next step is due
    assert [(row["steps"], row["ended_by"]) for row in window.rows] == [(2, "reset")]
    assert window.episode_steps == 0 and window.running
    pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=pygame.K_ESCAPE, mod=0, unicode="", scancode=0))
    window.frame(0.22)
    assert not window.running
    write_episodes(tmp_path / "episodes.csv", window.rows)
    assert (tmp_path / "episodes.csv").read_text().splitlines() == [
        "episode,steps,return,success,ended_by",
        "1,2,2.0,False,reset",
    ]


def test_the_frame_is_drawn_in_the_window(window):
    window.draw()
    assert window.screen.get_size() == (FRAME_SIZE[0], FRAME_SIZE[1] + STATUS_HEIGHT)
    assert window.screen.get_at((FRAME_SIZE[0] // 2, FRAME_SIZE[1] // 2))[:3] == (0, 0, 0)  # the toy's black


class SpyFont:
    """A font that keeps every text it renders (what the window writes), in order."""

    def __init__(self, font, texts: list):
        self.font, self.texts = font, texts

    def render(self, text, *args):
        self.texts.append(text)
        return self.font.render(text, *args)


def test_the_status_shows_the_light_dose_the_task_reports(window):
    texts: list[str] = []
    window.type = {size: SpyFont(font, texts) for size, font in window.type.items()}
    window.draw()
    assert not any("light dose" in text for text in texts)  # no step yet: no info
    run_frames(window, 5 * 2 + 1)  # two steps
    texts.clear()
    window.draw()
    assert window.episode_steps == 2
    assert f"light dose {2 * DOSE_PER_STEP:.3g} mJ/um^2" in texts


@pytest.mark.parametrize("task, word", [(Frameless(), "frame"), (Deaf(), "device")])
def test_a_task_without_a_frame_or_device_input_is_refused(task, word):
    with pytest.raises(ValueError, match=word):
        check_playable(task)
    assert check_playable(Walker()).name == "walker"


def test_a_played_session_is_recorded_and_replay_summarises_it(compiled, tmp_path):
    from otgym.record.mcap_file import read_recording
    from otgym.record.replay import summary
    from otgym.ui.task_recording import TaskRecording
    from tests.otgym_cli import run_otgym

    pygame.init()
    keyboard = open_device("keyboard", pump_events=False)
    keyboard.start()
    retarget = play_bindings([keyboard], clutch=False)[0].retarget
    recording = TaskRecording(tmp_path / "session.mcap", compiled.task, compiled.params, None, 0, PERIOD_S)
    window = TaskWindow(compiled, keyboard, retarget, keyboards=[keyboard], recording=recording)
    window.mouse.start()
    try:
        run_frames(window, 5 * EPISODE_STEPS + 1)  # one idle episode: a failure
        pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=pygame.K_RIGHT, mod=0, unicode="", scancode=0))
        run_frames(window, 5 * EPISODE_STEPS + 1, start_s=1.0)  # one to the right: a success
    finally:
        window.mouse.stop()
        recording.close()
        pygame.quit()
    assert [row["success"] for row in window.rows] == [False, True]
    info = summary(read_recording(tmp_path / "session.mcap"))
    # a state per reset and per step: three resets (the third episode's only) and ten steps
    assert info["counts"]["/otgym/bodies"] == 3 + 2 * EPISODE_STEPS
    task = info["task"]
    assert (task["task"], task["episodes"], task["successes"]) == ("walker", 2, 1)
    assert task["ended_by"] == {"terminated": 2}
    assert task["mean_time_to_success_s"] == pytest.approx(EPISODE_STEPS * PERIOD_S)  # no time_s in its info
    assert task["metrics"] == {"success": 0.5, "light_dose_mj_per_um2": EPISODE_STEPS * DOSE_PER_STEP}
    printed = run_otgym(["replay", tmp_path / "session.mcap"])
    assert printed.returncode == 0, printed.stderr
    assert (
        "task walker (seed 0): 2 episode(s) (2 terminated), 1 succeeded; mean time to success 0.50 s" in printed.stdout
    )
    refused = run_otgym(["replay", tmp_path / "session.mcap", "--out", tmp_path / "frames"])
    assert refused.returncode == 2 and refused.stderr.count("error:") == 1 and "--task walker" in refused.stderr
