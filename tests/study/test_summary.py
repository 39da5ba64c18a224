"""otgym.study.summary: the per-mode table (our numbers recomputed here from the trials,
the paper's beside them) and the files write_summary leaves, degenerate data included."""

import json
import math

import numpy as np
import pandas as pd
import pytest

from otgym.study.paper_fig8 import PAPER_FIG8
from otgym.study.summary import SUMMARY_COLUMNS, summarize, write_summary
from tests.study import make_trials

MODES = ("manual", "autonomous", "shared", "mpc")


def _trials(seed: int = 0) -> pd.DataFrame:
    """8 participants x 4 modes x 3 trials, with varied obstacles, misses, losses and detachments."""
    rng = np.random.default_rng(seed)
    frames = []
    for trial in range(3):
        times = {m: rng.normal(mu, 2.0, 8) for m, mu in zip(MODES, (160, 54, 54, 60))}
        avoided = {m: rng.binomial(5, p, 8) for m, p in zip(MODES, (0.9, 0.6, 1.0, 0.8))}
        frame = make_trials(times, avoided, encountered=5).assign(trial=trial)
        frame["reached_goal"] = rng.random(len(frame)) < 0.8
        frame["trap_losses"] = rng.integers(0, 3, len(frame))
        frame["detached"] = rng.random(len(frame)) < 0.1
        frames.append(frame)
    return pd.concat(frames, ignore_index=True).sample(frac=1.0, random_state=seed)  # row order must not matter


def test_summarize_columns_modes_and_values():
    trials = _trials()
    table = summarize(trials.drop(columns=["success", "scenario", "peak_contact_force_pn"]))
    assert list(table.columns) == list(SUMMARY_COLUMNS)
    assert list(table["mode"]) == list(MODES)
    for row in table.itertuples():
        t = trials[trials["mode"] == row.mode]
        by_participant = t.groupby("participant")
        success = by_participant["obstacles_avoided"].sum() / by_participant["obstacles_encountered"].sum()
        times = t[t["reached_goal"]].groupby("participant")["completion_time_s"].mean()
        assert (row.trials, row.participants) == (24, 8)
        assert row.success_mean == pytest.approx(success.mean()) and row.success_sd == pytest.approx(success.std())
        assert row.completion_time_mean_s == pytest.approx(times.mean())
        assert row.completion_time_sd_s == pytest.approx(times.std())
        assert row.avoided_rate == pytest.approx(t["obstacles_avoided"].sum() / t["obstacles_encountered"].sum())
        assert row.avoided_rate_ci_low <= row.avoided_rate <= row.avoided_rate_ci_high
        assert row.goal_rate == pytest.approx(t["reached_goal"].mean())
        assert row.goal_rate_ci_low <= row.goal_rate <= row.goal_rate_ci_high
        assert (row.trap_losses, row.detachments) == (t["trap_losses"].sum(), t["detached"].sum())
        paper = PAPER_FIG8.get(row.mode)
        got = (row.paper_success_mean, row.paper_success_sd, row.paper_time_mean_s, row.paper_time_sd_s)
        if paper is None:
            assert all(math.isnan(v) for v in got)
        else:
            assert got == (paper["success_mean"], paper["success_sd"], paper["time_mean_s"], paper["time_sd_s"])


def test_summarize_rejects_a_table_without_a_needed_column():
    with pytest.raises(ValueError, match="detached"):
        summarize(_trials().drop(columns="detached"))


def _strict_json(text: str):
    def reject(constant):
        raise AssertionError(f"stats.json is not strict JSON: {constant}")

    return json.loads(text, parse_constant=reject)


def test_write_summary_writes_the_table_the_markdown_and_the_stats(tmp_path):
    trials = _trials()
    stats = write_summary(trials, tmp_path / "out")
    assert set(stats) == {"success", "time"}
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["stats.json", "summary.csv", "summary.md"]
    table = pd.read_csv(tmp_path / "out" / "summary.csv")
    assert list(table.columns) == list(SUMMARY_COLUMNS) and list(table["mode"]) == list(MODES)
    saved = _strict_json((tmp_path / "out" / "stats.json").read_text())
    assert saved["time"]["anova"]["F"] == pytest.approx(stats["time"]["anova"]["F"])
    assert [p["stars"] for p in saved["success"]["posthoc"]] == [p["stars"] for p in stats["success"]["posthoc"]]
    md = (tmp_path / "out" / "summary.md").read_text()
    assert "163.5 ± 8.3" in md and "94 ± 4" in md  # the paper's values beside ours
    assert md.count("Repeated-measures ANOVA") == 2 and md.count("Holm p = ") == 2 * 6
    for pair in stats["time"]["posthoc"]:
        assert f"- {pair['a']} vs {pair['b']}: " in md
    assert "***" in md  # manual is far slower than the rest


def test_write_summary_reports_degenerate_success_as_nan_with_a_note(tmp_path):
    trials = _trials()
    trials["obstacles_avoided"] = trials["obstacles_encountered"]  # success 1.0 everywhere
    stats = write_summary(trials, tmp_path)
    assert math.isnan(stats["success"]["anova"]["F"]) and stats["success"]["note"]
    saved = _strict_json((tmp_path / "stats.json").read_text())
    assert saved["success"]["anova"]["p"] is None
    assert all(p["p_holm"] is None and p["stars"] == "" for p in saved["success"]["posthoc"])
    md = (tmp_path / "summary.md").read_text()
    assert "Note: ANOVA undefined" in md and "F(3, 21) = -" in md
    assert not math.isnan(stats["time"]["anova"]["F"])
