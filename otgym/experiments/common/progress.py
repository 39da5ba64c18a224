"""Progress lines for the long experiment runs: one line each time another tenth of a
batch's trials is done."""

from __future__ import annotations

from collections.abc import Callable


def tenths(report: Callable[[str], None], label: str = "") -> Callable[[float], None]:
    """A ``progress(fraction)`` callback for ``run_trials`` that calls ``report`` with
    ``"      LABEL: 30% of trials done"`` the first time ``fraction`` reaches each tenth
    (0 %, 10 %, ..., 100 %), never twice for the same tenth."""
    last = [-1]
    prefix = f"      {label}: " if label else "      "

    def progress(fraction: float) -> None:
        tenth = int(fraction * 10)
        if tenth > last[0]:
            last[0] = tenth
            report(f"{prefix}{fraction:.0%} of trials done")

    return progress
