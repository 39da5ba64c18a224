"""The study protocol (``otgym.study.protocol``), the participant folder's bookkeeping
(``otgym.study.participants``) and the mixed-effects models (``otgym.study.mixed``),
without a window."""

from __future__ import annotations

import csv
import itertools

import numpy as np
import pandas as pd
import pytest

from otgym.shared import MODES
from otgym.study.mixed import mode_model, order_effects
from otgym.study.participants import ParticipantFolder, assign, check_key, lookup, start_participant
from otgym.study.protocol import load_protocol, mode_order, trial_plan, williams_square

PROTOCOL = """
[study]
seed_base = 5
[practice]
trials = 1
mode = "shared"
[modes]
names = ["manual", "shared", "autonomous"]
trials_per_mode = 2
"""


@pytest.mark.parametrize("n", [2, 3, 4, 5, 6])
def test_the_williams_square_balances_positions_and_carry_over(n):
    rows = williams_square(n)
    assert len(rows) == (n if n % 2 == 0 else 2 * n)
    for row in rows:
        assert sorted(row) == list(range(n))
    per_position = [[sum(row[i] == c for row in rows) for c in range(n)] for i in range(n)]
    assert all(len(set(counts)) == 1 for counts in per_position)  # each condition equally often at each place
    follows = {pair: 0 for pair in itertools.permutations(range(n), 2)}
    for row in rows:
        for a, b in zip(row, row[1:]):
            follows[(a, b)] += 1
    assert len(set(follows.values())) == 1  # each ordered pair equally often: first-order carry-over balanced


def test_participant_numbers_cycle_through_the_square(tmp_path):
    path = tmp_path / "p.toml"
    path.write_text(PROTOCOL)
    protocol = load_protocol(path, MODES)
    orders = [mode_order(protocol, k) for k in range(1, 8)]
    assert len(set(orders[:6])) == 6 and orders[6] == orders[0]  # 3 modes: 6 rows, all 3! orders
    plan = trial_plan(protocol, orders[1])
    assert [(s.trial, s.mode, s.position, s.last_in_block) for s in plan] == [
        (1, "shared", 0, True),
        (2, orders[1][0], 1, False),
        (3, orders[1][0], 1, True),
        (4, orders[1][1], 2, False),
        (5, orders[1][1], 2, True),
        (6, orders[1][2], 3, False),
        (7, orders[1][2], 3, True),
    ]


def _rows(path):
    with path.open(newline="") as handle:
        return list(csv.DictReader(handle))


def test_a_resumed_folder_keeps_finished_trials_and_marks_the_cut_one(tmp_path):
    path = tmp_path / "p.toml"
    path.write_text(PROTOCOL)
    protocol = load_protocol(path, MODES)
    out, key = tmp_path / "study", tmp_path / "study.key.csv"
    folder = start_participant(protocol, "lab-1", out, key)
    assert folder.pseudonym == "S001" and assign(key, "lab-2")["pseudonym"] == "S002"
    assert lookup(key, "lab-1")["pseudonym"] == "S001"
    columns = ["participant", "mode", "trial", "scenario", "ended_by"]
    for trial in (1, 2):
        folder.started(trial)
        folder.record_trial({"participant": "S001", "mode": folder.plan[trial - 1].mode, "trial": trial,
                             "scenario": 0, "ended_by": "goal"}, columns)  # fmt: skip
    folder.started(3)  # then the process died
    again = ParticipantFolder(out, "S001", 1, protocol)
    assert again.mark_cut_trials() == [3] and again.mark_cut_trials() == []  # marked once
    assert [s.trial for s in again.remaining()] == [3, 4, 5, 6, 7]
    assert again.unanswered_blocks() == []  # block 1 (trials 2, 3) is not finished
    again.started(3)
    again.record_trial({"participant": "S001", "mode": again.plan[2].mode, "trial": 3, "scenario": 0,
                        "ended_by": "aborted"}, columns)  # fmt: skip
    assert again.mark_cut_trials() == []  # the window closed: its row is the mark
    assert [r["ended_by"] for r in _rows(folder.path / "cut_trials.csv")] == ["crashed", "aborted"]
    again.started(3)
    again.record_trial({"participant": "S001", "mode": again.plan[2].mode, "trial": 3, "scenario": 0,
                        "ended_by": "goal"}, columns)  # fmt: skip
    assert [s.trial for s in again.unanswered_blocks()] == [3]
    assert [int(r["trial"]) for r in _rows(folder.path / "trials.csv")] == [2, 3]
    other = tmp_path / "other.toml"
    other.write_text(PROTOCOL.replace("seed_base = 5", "seed_base = 6"))
    with pytest.raises(ValueError, match="another protocol"):
        start_participant(load_protocol(other, MODES), "lab-1", out, key)
    with pytest.raises(ValueError, match="does not list"):
        check_key(out, tmp_path / "lost.key.csv")


def _simulated(rng, participants: int, mode_effect: dict, position_effect: float, sd_participant=1.0, sd=0.5):
    rows = []
    for p in range(participants):
        offset = rng.normal(0, sd_participant)
        order = list(mode_effect)[p % 3 :] + list(mode_effect)[: p % 3]
        for position, mode in enumerate(order, start=1):
            for _ in range(4):
                value = mode_effect[mode] + position_effect * position + offset + rng.normal(0, sd)
                rows.append({"participant": f"S{p}", "mode": mode, "position": position, "value": value})
    return pd.DataFrame(rows)


def test_the_mixed_model_recovers_the_mode_effects_and_the_participant_variance():
    rng = np.random.default_rng(11)
    frame = _simulated(rng, 24, {"manual": 0.0, "autonomous": 2.0, "shared": -1.0}, 0.0)
    model = mode_model(frame[["participant", "mode", "value"]])
    assert model["reference"] == "manual" and model["participants"] == 24
    terms = {c["term"]: c for c in model["coefficients"]}
    for name, true in (("mode[autonomous]", 2.0), ("mode[shared]", -1.0)):
        assert terms[name]["ci_low"] < true < terms[name]["ci_high"]  # 95 % intervals: fails 1 in 20 seeds
    assert 0.3 < model["participant_variance"] < 3.0  # true 1.0, 24 participants


def test_order_effects_find_a_strong_position_effect():
    rng = np.random.default_rng(12)
    frame = _simulated(rng, 12, {"manual": 0.0, "autonomous": 0.0, "shared": 0.0}, 1.0)
    tests = order_effects(frame)
    assert tests["position"]["dof"] == 2 and tests["position"]["p"] < 1e-6  # 1 sd of noise per position step
    assert tests["mode_x_position"]["dof"] == 4
    assert "note" in order_effects(frame.drop(columns="position"))


def test_the_shipped_template_is_a_valid_protocol():
    from pathlib import Path

    template = Path(__file__).resolve().parents[2] / "docs" / "study-protocol.toml"
    protocol = load_protocol(template, MODES)
    assert protocol.modes == ("manual", "shared", "autonomous") and protocol.practice_trials == 2
    assert len(trial_plan(protocol, mode_order(protocol, 1))) == 2 + 3 * 8


def test_a_participant_variance_on_its_boundary_still_gives_the_intercept():
    """No participant effect at all (the variance's estimate is 0, on its boundary): the
    intercept is still the reference mode's mean (L-BFGS alone returned 0 with an
    infinite log-likelihood on such data)."""
    rng = np.random.default_rng(1)  # L-BFGS alone ended so on 29 of the seeds 0-39 of this design
    frame = _simulated(rng, 6, {"manual": 160.0, "autonomous": 54.0, "shared": 55.0}, 0.0, sd_participant=0.0, sd=8.0)
    model = mode_model(frame[["participant", "mode", "value"]])
    intercept = {c["term"]: c for c in model["coefficients"]}["Intercept"]
    # the reference mean of 24 trials with SD 8: SE about 1.6; within 4 SE
    assert intercept["se"] < 10.0 and abs(intercept["estimate"] - 160.0) < 4 * intercept["se"]
    assert model["participant_variance"] < 8.0**2 / 4
    tests = order_effects(frame)  # L-BFGS's Hessian is singular here: another optimiser fits it
    assert "note" not in tests["position"] and tests["position"]["dof"] == 2, tests
