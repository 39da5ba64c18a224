"""``otgym study run`` end to end in an X window on the ``xvfb`` fixture's server
(where Xvfb is missing: ``--headless``, SDL's dummy drivers): a 2-participant protocol
of three modes with 2 s trials and scripted questionnaire answers, pressed into the
window's form (``--script``; ``tests/study/test_study_xvfb.py`` sends X events instead). The first participant's session process is killed (SIGKILL, by
the pid this test started) while a trial runs, then resumed by the same command; the
study folder is then analysed. Checked: the two orders are the Williams square's first
two rows, every planned trial is in the data exactly once, the killed trial is marked
in cut_trials.csv and ran again under its own number and scenario, the questionnaire
scores are the scripted answers' published scores, the held arrow key moved the robots
in manual trials, and the killed process left no process of its own behind."""

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
name = "end-to-end"
instructions = "scripted"
device = "keyboard"
seed_base = 3
trial_time_limit_s = 2.0
[practice]
trials = 1
mode = "autonomous"
[modes]
names = ["manual", "shared", "autonomous"]
trials_per_mode = 2
"""
ANSWERS = """
nasa_tlx = [20, 35, 50, 65, 80, 100]
ueq_s = [1, 2, 3, 4, 5, 6, 7, 6]
hold_keys = ["right"]
"""


@pytest.fixture
def display(request) -> tuple[dict, list[str]]:
    """The environment and the arguments that open the kit's window: on Xvfb where it is
    installed, else ``--headless``."""
    from tests.xserver import available

    if available():
        return request.getfixturevalue("xvfb").env(), []
    return dict(os.environ), ["--headless"]


def command(tmp_path: Path, participant: str, display: tuple[dict, list[str]]) -> list[str]:
    return [
        sys.executable,
        "-m",
        "otgym",
        "study",
        "run",
        str(tmp_path / "protocol.toml"),
        "--participant",
        participant,
        "--out",
        str(tmp_path / "study"),
        "--script",
        str(tmp_path / "answers.toml"),
        *display[1],
    ]


def run(tmp_path: Path, participant: str, display: tuple[dict, list[str]]) -> subprocess.CompletedProcess:
    return subprocess.run(
        command(tmp_path, participant, display),
        capture_output=True,
        text=True,
        timeout=600,
        env={**display[0], "PYTHONPATH": str(ROOT)},
        cwd=ROOT,
    )


def wait_gone(marker: str, timeout_s: float = 60.0) -> list[int]:
    """Live processes started with ``OTGYM_TEST_MARKER=marker`` still there after
    ``timeout_s`` (``tests.ui.test_play_distributed.marked``)."""
    from tests.ui.test_play_distributed import marked

    deadline = time.monotonic() + timeout_s
    while marked(marker) and time.monotonic() < deadline:
        time.sleep(0.1)
    return marked(marker)


def rows(path: Path) -> list[dict]:
    with path.open(newline="") as handle:
        return list(csv.DictReader(handle))


@pytest.mark.slow
def test_two_participants_one_killed_mid_trial_resumed_and_analysed(tmp_path, display):
    (tmp_path / "protocol.toml").write_text(PROTOCOL)
    (tmp_path / "answers.toml").write_text(ANSWERS)
    study = tmp_path / "study"
    marker = uuid.uuid4().hex
    # participant 1: killed once a trial of the modes' blocks is under way (the practice and
    # block 1's first trial finished: trial 3 has started)
    process = subprocess.Popen(
        command(tmp_path, "lab-a", display),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env={**display[0], "PYTHONPATH": str(ROOT), "OTGYM_TEST_MARKER": marker},
        cwd=ROOT,
    )
    started = study / "S001" / "started.csv"
    deadline = time.monotonic() + 540
    while time.monotonic() < deadline and process.poll() is None:
        if started.is_file() and any(row["trial"] == "3" for row in rows(started)):
            break
        time.sleep(0.02)
    assert process.poll() is None, process.communicate()[0][-3000:]
    os.kill(process.pid, signal.SIGKILL)
    process.wait(timeout=30)
    assert wait_gone(marker) == []  # its session process saw it die and ended too
    finished = {int(row["trial"]) for row in rows(study / "S001" / "trials.csv")}
    assert 3 not in finished and finished == {2}  # trial 3 was cut: no row of it
    resumed = run(tmp_path, "lab-a", display)
    assert resumed.returncode == 0, resumed.stdout[-2000:] + resumed.stderr[-3000:]
    assert "cut and to run again: [3]" in resumed.stdout and "the session is complete" in resumed.stdout
    second = run(tmp_path, "lab-b", display)
    assert second.returncode == 0, second.stdout[-2000:] + second.stderr[-3000:]

    # the key is kept apart; the folders carry pseudonyms only
    key = rows(tmp_path / "study.key.csv")
    assert [(r["participant_id"], r["pseudonym"]) for r in key] == [("lab-a", "S001"), ("lab-b", "S002")]
    assert "lab-a" not in "".join(p.read_text() for p in study.rglob("*.csv"))
    orders = {p: json.loads((study / p / "session.json").read_text())["mode_order"] for p in ("S001", "S002")}
    assert orders == {"S001": ["manual", "shared", "autonomous"], "S002": ["shared", "autonomous", "manual"]}
    for pseudonym, order in orders.items():
        trials = rows(study / pseudonym / "trials.csv")
        numbers = [int(r["trial"]) for r in trials]
        assert sorted(numbers) == [2, 3, 4, 5, 6, 7]  # none lost, none twice
        for r in trials:
            position = (int(r["trial"]) - 2) // 2 + 1
            assert r["mode"] == order[position - 1] and int(r["position"]) == position
            assert int(r["scenario"]) == 3 * 10_000 + int(r["trial"]) and r["ended_by"] == "time_limit"
        assert [int(r["trial"]) for r in rows(study / pseudonym / "practice.csv")] == [1]
    cut = rows(study / "S001" / "cut_trials.csv")
    assert [(r["trial"], r["mode"], r["ended_by"]) for r in cut] == [("3", "manual", "crashed")]
    assert not (study / "S002" / "cut_trials.csv").exists()
    meta = json.loads((study / "S001" / "session.json").read_text())
    assert len(meta["runs"]) == 2 and meta["runs"][0]["software"]["otgym"]
    assert sorted(p.name for p in (study / "S001").glob("session*.mcap")) == ["session-2.mcap", "session.mcap"]
    # the scripted input drove the robots: with the right arrow held, manual trials move the traps
    # along +x (with no input they stay exactly where they are)
    from otgym.record.mcap_file import read_recording
    from otgym.record.replay import ticks

    first, last = {}, {}
    for tick in ticks(read_recording(study / "S002" / "session.mcap"), 0.02):
        first.setdefault(tick.trial, (tick.mode, tick.trap_xy_um.copy()))
        last[tick.trial] = tick.trap_xy_um.copy()
    manual = [trial for trial, (mode, _) in first.items() if mode == "manual"]
    assert manual == [6, 7]
    for trial in manual:
        moved_um = (last[trial] - first[trial][1]).mean(axis=0)
        assert moved_um[0] > 0.1 and abs(moved_um[1]) < 1e-6, moved_um

    analysis = tmp_path / "analysis"
    result = subprocess.run(
        [sys.executable, "-m", "otgym", "study", "analyze", str(study), "--out", str(analysis)],
        capture_output=True,
        text=True,
        timeout=600,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        cwd=ROOT,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    scores = rows(analysis / "questionnaire_scores.csv")
    assert len(scores) == 6  # 2 participants x 3 modes, one questionnaire per mode
    for r in scores:  # raw TLX: mean of the six; UEQ-S: raw - 4, items 1-4 and 5-8
        assert float(r["raw_tlx"]) == pytest.approx(350 / 6)
        assert float(r["ueq_pragmatic"]) == -1.5 and float(r["ueq_hedonic"]) == 2.0
    report = (analysis / "report.md").read_text()
    assert "| S001 | manual, shared, autonomous |" in report and "| S002 | shared, autonomous, manual |" in report
    assert (analysis / "fig8.png").is_file() and (analysis / "order_effects.png").is_file()
    summary = json.loads((analysis / "analysis.json").read_text())
    assert summary["trials"] == 12 and summary["participants"] == 2
