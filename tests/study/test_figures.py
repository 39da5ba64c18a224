"""otgym.study.figures: Fig. 8 is written as a non-blank PNG of sensible size for three
and four modes, with stats passed, computed, read back from JSON, or undefined."""

import json

import numpy as np
import pytest
from PIL import Image

from otgym.study.figures import plot_fig8
from otgym.study.summary import write_summary
from tests.study import make_trials


def _trials(modes, all_avoided=False):
    rng = np.random.default_rng(4)
    means = {"manual": (160, 0.9), "autonomous": (54, 0.6), "shared": (54, 1.0), "mpc": (60, 0.8)}
    times = {m: rng.normal(means[m][0], 2.0, 8) for m in modes}
    avoided = None if all_avoided else {m: rng.binomial(10, means[m][1], 8) for m in modes}
    return make_trials(times, avoided)


def _check_png(path):
    image = Image.open(path)
    assert image.format == "PNG"
    width, height = image.size
    assert 1200 <= width <= 2500 and 500 <= height <= 1500
    gray = np.asarray(image.convert("L"), dtype=float)
    assert gray.std() > 20  # drawn, not blank
    assert (gray < 128).mean() > 0.01  # bars, text and markers, not a white page


@pytest.mark.parametrize("modes", [("manual", "autonomous", "shared"), ("manual", "autonomous", "shared", "mpc")])
def test_fig8_is_a_non_blank_png(tmp_path, modes):
    trials = _trials(modes)
    plot_fig8(trials, tmp_path / "fig" / "fig8.png")
    _check_png(tmp_path / "fig" / "fig8.png")


def test_fig8_takes_stats_read_back_from_json_and_degenerate_data(tmp_path):
    trials = _trials(("manual", "autonomous", "shared"), all_avoided=True)
    write_summary(trials, tmp_path)
    stats = json.loads((tmp_path / "stats.json").read_text())  # NaN came back as None
    plot_fig8(trials, tmp_path / "fig8.png", stats)
    _check_png(tmp_path / "fig8.png")


def test_fig8_with_and_without_significance_differ(tmp_path):
    """The brackets are drawn from the stats: the same trials with the tests' p-values
    made non-significant give a different picture."""
    trials = _trials(("manual", "autonomous", "shared"))
    stats = write_summary(trials, tmp_path)
    plot_fig8(trials, tmp_path / "with.png", stats)
    for result in stats.values():
        for pair in result["posthoc"]:
            pair["p_holm"], pair["stars"] = 1.0, "ns"
    plot_fig8(trials, tmp_path / "without.png", stats)
    with_brackets = np.asarray(Image.open(tmp_path / "with.png").convert("L"))
    without = np.asarray(Image.open(tmp_path / "without.png").convert("L"))
    assert with_brackets.shape == without.shape and (with_brackets != without).any()
