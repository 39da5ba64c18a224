"""otgym.study.figures: Fig. 8's content read back from its matplotlib objects
(``tests.study.fig8_content``) against the trials it was drawn from: panel (a)'s bars are
the per-mode means of the participants' pooled avoided rates (in %), (b)'s of their mean
completion times over the trials that reached the goal; each mode has one dot per
participant at that participant's value; the paper's diamonds sit beside the bars at the
paper's values; the brackets are exactly the pairs that the stats passed (or computed)
call significant, with their stars. For three and four modes, with stats computed,
passed, read back from JSON, or undefined. One PNG smoke test of the written file."""

import json

import numpy as np
import pandas as pd
import pytest
from PIL import Image

from otgym.study.figures import fig8_figure, plot_fig8
from otgym.study.paper_fig8 import PAPER_FIG8
from otgym.study.stats import compare_modes
from otgym.study.summary import write_summary
from tests.study import make_trials
from tests.study.fig8_content import mode_bars, mode_brackets, mode_dots, paper_diamonds

PARTICIPANTS = 6
PAPER_KEYS = {"success": ("success_mean", 100.0), "time": ("time_mean_s", 1.0)}


def _trials(modes, all_avoided=False):
    """Six participants, two trials each per mode: trial 0 meets 10 obstacles, trial 1
    meets 4 (so a participant's pooled rate is not the mean of their trials' rates); the
    modes' times and rates differ (manual slow, autonomous avoiding fewer). Participant
    0's manual trial 1 misses the goal with a time of 999 s that no mean may hold."""
    rng = np.random.default_rng(4)
    means = {"manual": (160, 0.9), "autonomous": (54, 0.6), "shared": (54, 1.0), "mpc": (60, 0.8)}
    trials = []
    for trial, encountered in ((0, 10), (1, 4)):
        times = {m: rng.normal(means[m][0], 2.0, PARTICIPANTS) for m in modes}
        avoided = None if all_avoided else {m: rng.binomial(encountered, means[m][1], PARTICIPANTS) for m in modes}
        trials.append(make_trials(times, avoided, encountered).assign(trial=trial, scenario=trial))
    table = pd.concat(trials, ignore_index=True)
    missed = (table["participant"] == 0) & (table["mode"] == "manual") & (table["trial"] == 1)
    table.loc[missed, ["reached_goal", "completion_time_s"]] = [False, 999.0]
    return table


def _participant_values(trials, mode) -> dict[str, list[float]]:
    """Each participant's value in ``mode``, by hand: avoided / encountered over their
    trials (%), and the mean time of their trials that reached the goal."""
    success, time = [], []
    for participant in sorted(set(trials["participant"])):
        rows = trials[(trials["participant"] == participant) & (trials["mode"] == mode)].to_dict("records")
        success.append(
            100.0 * sum(r["obstacles_avoided"] for r in rows) / sum(r["obstacles_encountered"] for r in rows)
        )
        reached = [r["completion_time_s"] for r in rows if r["reached_goal"]]
        time.append(sum(reached) / len(reached))
    return {"success": success, "time": time}


def _significant(result) -> dict[frozenset, str]:
    return {
        frozenset((pair["a"], pair["b"])): pair["stars"]
        for pair in result["posthoc"]
        if pair["p_holm"] is not None and pair["p_holm"] < 0.05
    }


@pytest.mark.parametrize("modes", [("manual", "autonomous", "shared"), ("manual", "autonomous", "shared", "mpc")])
def test_fig8_bars_dots_and_diamonds_are_the_trials_per_mode(modes):
    """Catches modes swapped between bars and labels, a bar that is the mean over trials
    instead of over participants, a rate averaged over trials instead of pooled, a time
    that counts a trial that missed the goal, dots missing or misplaced, the paper's
    values on the wrong mode."""
    trials = _trials(modes)
    fig = fig8_figure(trials)
    axes = fig.axes
    assert [ax.get_title() for ax in axes] == ["(a) Success rate", "(b) Task completion time"]
    for ax, metric in zip(axes, ("success", "time")):
        bars, dots = mode_bars(ax), mode_dots(ax)
        assert list(bars) == list(modes)
        for mode in modes:
            values = _participant_values(trials, mode)[metric]
            assert bars[mode] == pytest.approx(np.mean(values), rel=1e-12), (metric, mode)
            np.testing.assert_allclose(dots[mode], np.sort(values), rtol=1e-12)
        key, scale = PAPER_KEYS[metric]
        assert paper_diamonds(ax) == pytest.approx(
            {round(x + 0.32, 9): PAPER_FIG8[mode][key] * scale for x, mode in enumerate(modes) if mode in PAPER_FIG8}
        )
    assert max(mode_bars(axes[1]).values()) < 200  # the missed goal's 999 s is in no bar


@pytest.mark.slow
def test_fig8_brackets_are_the_significant_pairs_of_the_stats_with_their_stars():
    """Computed stats: manual is slower than the others and autonomous avoids fewer, so
    some pairs are significant; the brackets are exactly those pairs with their stars.
    Stats passed in are what is drawn: all made non-significant (Holm p 0.06), no bracket; one pair
    set to p = 0.004, that one bracket with '**'. Catches brackets drawn for
    non-significant pairs, on the wrong modes, with the wrong stars, or from stats the
    figure computed itself instead of those it was given."""
    trials = _trials(("manual", "autonomous", "shared"))
    stats = {metric: compare_modes(trials, metric) for metric in ("success", "time")}
    drawn = fig8_figure(trials, stats)
    for ax, metric in zip(drawn.axes, ("success", "time")):
        assert _significant(stats[metric]), metric  # not vacuous
        assert mode_brackets(ax) == _significant(stats[metric]), metric
    for result in stats.values():
        for pair in result["posthoc"]:
            pair["p_holm"], pair["stars"] = 0.06, "ns"  # just above the 0.05 threshold
    assert all(mode_brackets(ax) == {} for ax in fig8_figure(trials, stats).axes)
    stats["time"]["posthoc"][2].update(p_holm=0.004, stars="**")
    chosen = frozenset((stats["time"]["posthoc"][2]["a"], stats["time"]["posthoc"][2]["b"]))
    success_ax, time_ax = fig8_figure(trials, stats).axes
    assert mode_brackets(success_ax) == {} and mode_brackets(time_ax) == {chosen: "**"}


def test_fig8_takes_stats_read_back_from_json_and_degenerate_data(tmp_path):
    """Every obstacle avoided in every mode: the success ANOVA is undefined (NaN, null in
    stats.json). Drawn from the stats read back from JSON: panel (a) has bars of 100 %,
    no bracket and says the tests are undefined; panel (b) has the brackets of the
    time tests."""
    trials = _trials(("manual", "autonomous", "shared"), all_avoided=True)
    write_summary(trials, tmp_path)
    stats = json.loads((tmp_path / "stats.json").read_text())  # NaN came back as None
    assert stats["success"]["anova"]["p"] is None
    success_ax, time_ax = fig8_figure(trials, stats).axes
    assert mode_bars(success_ax) == pytest.approx(dict.fromkeys(("manual", "autonomous", "shared"), 100.0))
    assert mode_brackets(success_ax) == {}
    assert "tests undefined (see the stats note)" in [text.get_text() for text in success_ax.texts]
    assert mode_brackets(time_ax) == _significant(stats["time"]) != {}


@pytest.mark.slow
def test_fig8_png_is_written_drawn_and_of_sensible_size(tmp_path):
    """The file ``plot_fig8`` writes (its folder created): a PNG of sensible size, drawn
    (not blank), and the titles of the panels it drew."""
    titles = plot_fig8(_trials(("manual", "autonomous", "shared")), tmp_path / "fig" / "fig8.png")
    assert titles == ["(a) Success rate", "(b) Task completion time"]
    image = Image.open(tmp_path / "fig" / "fig8.png")
    assert image.format == "PNG"
    width, height = image.size
    assert 1200 <= width <= 2500 and 500 <= height <= 1500
    gray = np.asarray(image.convert("L"), dtype=float)
    assert gray.std() > 20  # drawn, not blank
    assert (gray < 128).mean() > 0.01  # bars, text and markers, not a white page
