"""``otgym study run`` in a real X window (Xvfb, SDL's x11 driver), driven by X input
events as a person's keyboard and mouse would send them (XTEST: ``tests.xserver.XInput``),
never by pygame events posted in the window's process and without ``--script``.

One participant, a protocol of one practice trial and one mode of one trial (2 s each,
both manual), then the questionnaires. The test presses Enter (instructions, the
practice page, the block page) until the kit's own files say the next trial has
started, holds the right arrow through trial 2 only, answers NASA-TLX with keys and
UEQ-S with mouse clicks on the form's radio buttons and Finish. Checked: the session
ends complete; the practice and the trial are each one row in their file; the
questionnaire scores are those of the answers given; in the recording the robots' traps
stayed exactly in place in the practice (no key held: manual mode moves nothing) and
moved along +x in trial 2 (the X key press reached the simulation); no process started
for the session is left. The test kills the kit's process by its pid where it is still
running at the end (a failure). Slow: the session's start and compile, 4 s of trials."""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time
import uuid
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PROTOCOL = """
[study]
name = "x-events"
instructions = "Press Enter to begin."
device = "keyboard"
seed_base = 3
trial_time_limit_s = 2.0
[practice]
trials = 1
mode = "manual"
[modes]
names = ["manual"]
trials_per_mode = 1
"""
TLX = [20, 35, 50, 65, 80, 100]
UEQ = [1, 2, 3, 4, 5, 6, 7, 6]
DEADLINE_S = 480.0
"""Bounds a hang only: waits end as soon as the kit's files or the window say so."""


def rows(path: Path) -> list[dict]:
    if not path.is_file():
        return []
    with path.open(newline="") as handle:
        return list(csv.DictReader(handle))


def tlx_keys(ratings: list[int]) -> list[str]:
    """X key names that set each TLX slider (Right: to 50, then Right/Left by 5, Down: next) and Enter."""
    from otgym.study.questionnaires import TLX_STEP
    from otgym.ui.questionnaire import TLX_START

    keys = []
    for rating in ratings:
        steps = (rating - TLX_START) // TLX_STEP
        keys += ["Right"] + ["Right" if steps > 0 else "Left"] * abs(steps) + ["Down"]
    return keys + ["Return"]


@pytest.mark.slow
def test_a_session_driven_by_x_key_presses_and_clicks(xvfb, tmp_path):
    pytest.importorskip("Xlib", reason="needs python-xlib (the test extra) to send X input events")
    from otgym.record.mcap_file import read_recording
    from otgym.record.replay import ticks
    from otgym.study.questionnaires import UEQ_ITEM_NAMES, read_answers, score
    from otgym.ui.palette import WINDOW_SIZE
    from otgym.ui.questionnaire import UEQ_PAGE, QuestionnaireForm
    from tests.study.test_study_run import wait_gone
    from tests.xserver import XInput

    (tmp_path / "protocol.toml").write_text(PROTOCOL)
    study, marker = tmp_path / "study", uuid.uuid4().hex
    folder = study / "S001"
    env = xvfb.env() | {"PYTHONPATH": str(ROOT), "OTGYM_TEST_MARKER": marker}
    argv = [sys.executable, "-m", "otgym", "study", "run", str(tmp_path / "protocol.toml")]
    log = (tmp_path / "log.txt").open("w+")
    process = subprocess.Popen(
        [*argv, "--participant", "lab-x", "--out", str(study)], stdout=log, stderr=subprocess.STDOUT, env=env, cwd=ROOT
    )
    x = XInput(xvfb.display)
    deadline = time.monotonic() + DEADLINE_S

    def output() -> str:
        log.seek(0)
        return log.read()[-3000:]

    def press_until(key: str, done) -> None:
        """Press ``key`` every 0.3 s until ``done()``: a page left early takes no key
        meant for the next one, and a key that arrives late lands where it does nothing."""
        while not done():
            assert process.poll() is None and time.monotonic() < deadline, output()
            x.key(key)
            time.sleep(0.3)

    def started(trial: int) -> bool:
        return any(int(row["trial"]) == trial for row in rows(folder / "started.csv"))

    try:
        x.wait_window("otgym study: x-events", DEADLINE_S, alive=lambda: process.poll() is None)
        press_until("Return", lambda: started(1))  # the instructions, the practice's page; no key held
        press_until("Return", lambda: started(2))  # after the practice: block 1's page
        x.key_down("Right")  # held through trial 2
        while not rows(folder / "trials.csv"):
            assert process.poll() is None and time.monotonic() < deadline, output()
            time.sleep(0.05)
        x.key_up("Right")
        for key in tlx_keys(TLX):  # the questionnaire opened when trial 2's row was written
            x.key(key)
        form = QuestionnaireForm(size=WINDOW_SIZE)
        form.page = form.pages.index(UEQ_PAGE)
        for item, raw in zip(UEQ_ITEM_NAMES, UEQ):
            x.click(*form.radio_rect(item, raw).center)
        x.click(*form.next_rect.center)  # Finish
        code = process.wait(timeout=max(deadline - time.monotonic(), 1.0))
    finally:
        x.close()
        if process.poll() is None:
            os.kill(process.pid, signal.SIGKILL)  # only the process this test started
            process.wait(30)
    text = output()
    log.close()
    assert code == 0, text
    assert "the session is complete" in text, text
    assert wait_gone(marker) == []

    assert json.loads((folder / "session.json").read_text())["mode_order"] == ["manual"]
    practice, trials = rows(folder / "practice.csv"), rows(folder / "trials.csv")
    assert [(r["trial"], r["mode"], r["ended_by"]) for r in practice] == [("1", "manual", "time_limit")]
    assert [(r["trial"], r["mode"], r["ended_by"]) for r in trials] == [("2", "manual", "time_limit")]
    answers = read_answers(folder / "questionnaires.csv")
    assert list(answers["value"]) == TLX + UEQ, answers
    scores = score(answers)
    assert len(scores) == 1 and scores.iloc[0]["mode"] == "manual"
    assert scores.iloc[0]["raw_tlx"] == pytest.approx(sum(TLX) / 6)
    assert scores.iloc[0]["ueq_pragmatic"] == -1.5 and scores.iloc[0]["ueq_hedonic"] == 2.0  # raw - 4, means

    first, last = {}, {}
    for tick in ticks(read_recording(folder / "session.mcap"), 0.02):
        first.setdefault(tick.trial, tick.trap_xy_um.copy())
        last[tick.trial] = tick.trap_xy_um.copy()
    assert sorted(first) == [1, 2]
    still_um = abs(last[1] - first[1]).max()
    moved_um = (last[2] - first[2]).mean(axis=0)
    assert still_um < 1e-6, still_um  # the practice: no key, manual mode, nothing moves the traps
    assert moved_um[0] > 0.1 and abs(moved_um[1]) < 1e-6, moved_um  # trial 2: the held right arrow
