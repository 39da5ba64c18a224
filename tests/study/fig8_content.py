"""What a drawn Fig. 8 (``otgym.study.figures.fig8_figure``) shows, read back from its
matplotlib objects, so that tests compare a figure's content with the trials and
statistics it was drawn from: each bar's height, each participant's dot, each
significance bracket's pair and stars, and where a mode's paper diamond sits.

Panels (a, b) put mode i at x = i (the x tick labelled with the mode); the questionnaire
panels (c, d) put measure g's group at x = g (its tick label) with mode i of n at
g + (i - (n - 1) / 2) * 0.8 / n. A bracket is a 4-point line (x1, x1, x2, x2) whose top
carries a star text at its middle."""

from __future__ import annotations

import numpy as np
from matplotlib.collections import PathCollection

STARS = ("*", "**", "***", "ns")


def tick_positions(ax) -> dict[float, str]:
    """x position -> tick label."""
    return {float(tick.get_position()[0]): tick.get_text() for tick in ax.get_xticklabels()}


def bar_heights(ax) -> dict[float, float]:
    """Bar centre x -> height, for every bar of the panel."""
    return {round(bar.get_x() + bar.get_width() / 2, 9): bar.get_height() for bar in ax.patches}


def mode_bars(ax) -> dict[str, float]:
    """Panels (a, b): mode (its tick's label) -> the height of the bar at its tick."""
    heights = bar_heights(ax)
    assert len(heights) == len(tick_positions(ax)), "one bar per mode"
    return {label: heights[round(x, 9)] for x, label in tick_positions(ax).items()}


def mode_dots(ax) -> dict[str, np.ndarray]:
    """Panels (a, b): mode -> the y values of the participants' dots jittered around its tick, sorted."""
    ticks = tick_positions(ax)
    dots: dict[str, list[float]] = {label: [] for label in ticks.values()}
    for collection in ax.collections:
        if isinstance(collection, PathCollection):
            for x, y in collection.get_offsets():
                nearest = min(ticks, key=lambda tick: abs(tick - x))
                assert abs(nearest - x) <= 0.12 + 1e-9, f"a dot at x = {x} beside no mode"
                dots[ticks[nearest]].append(float(y))
    return {label: np.sort(values) for label, values in dots.items()}


def brackets(ax, name_of_x) -> dict[frozenset, str]:
    """Every significance bracket: {the two names its ends stand on (``name_of_x(x)``):
    its stars}."""
    tops = {}
    for line in ax.lines:
        xs, ys = np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float)
        if len(xs) == 4 and xs[0] == xs[1] and xs[2] == xs[3] and ys[1] == ys[2]:
            tops[(round((xs[0] + xs[3]) / 2, 9), round(ys[1], 9))] = (xs[0], xs[3])
    found = {}
    for text in ax.texts:
        if text.get_text() in STARS:
            x, y = text.get_position()
            ends = tops.pop((round(x, 9), round(y, 9)))
            pair = frozenset(name_of_x(end) for end in ends)
            assert len(pair) == 2 and pair not in found, f"bracket {ends} drawn twice or on one mode"
            found[pair] = text.get_text()
    assert not tops, f"brackets without stars: {tops}"
    return found


def mode_brackets(ax) -> dict[frozenset, str]:
    """Panels (a, b): {frozenset of two modes: stars} for every bracket."""
    ticks = tick_positions(ax)
    return brackets(ax, lambda x: ticks[float(x)])


def paper_diamonds(ax) -> dict[float, float]:
    """The paper's values drawn as diamonds: x -> y."""
    return {
        round(float(line.get_xdata()[0]), 9): float(line.get_ydata()[0])
        for line in ax.lines
        if line.get_marker() == "D"
    }


def group_position(ax, modes: list[str]):
    """Questionnaire panels: a function x -> (measure's tick label, mode) for a bar or
    bracket end at x, given the panel's ``modes`` in order."""
    ticks = tick_positions(ax)
    width = 0.8 / len(modes)

    def name_of_x(x: float) -> tuple[str, str]:
        group = min(ticks, key=lambda tick: abs(tick - x))
        index = (x - group) / width + (len(modes) - 1) / 2
        assert abs(index - round(index)) < 1e-6, f"x = {x} is at no mode's place in its group"
        return ticks[group], modes[int(round(index))]

    return name_of_x


def group_bars(ax, modes: list[str]) -> dict[tuple[str, str], float]:
    """Questionnaire panels: (measure's tick label, mode) -> bar height."""
    name_of_x = group_position(ax, modes)
    return {name_of_x(x): height for x, height in bar_heights(ax).items()}


def group_dots(ax, modes: list[str]) -> dict[tuple[str, str], np.ndarray]:
    """Questionnaire panels: (measure's tick label, mode) -> its participants' values,
    sorted: each dot collection goes to the bar it is jittered around (within 0.2 bar widths)."""
    name_of_x = group_position(ax, modes)
    bars = np.array([bar.get_x() + bar.get_width() / 2 for bar in ax.patches])
    width = 0.8 / len(modes)
    dots = {}
    for collection in ax.collections:
        if isinstance(collection, PathCollection):
            xs = collection.get_offsets()[:, 0]
            bar = bars[np.argmin(np.abs(bars - xs.mean()))]
            assert np.all(np.abs(xs - bar) <= 0.2 * width + 1e-9), f"dots at {xs} beside no bar"
            key = name_of_x(bar)
            assert key not in dots, f"two dot collections at {key}"
            dots[key] = np.sort(collection.get_offsets()[:, 1])
    return dots
