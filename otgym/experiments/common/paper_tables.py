"""The paper's published numbers (Tables I and II, the safety claims of Fig. 7), quoted
from the paper, and Table II as markdown with them beside
ours."""

from __future__ import annotations

from otgym.tasks.transport.presets import PAPER_SPEEDS_UM_S

PAPER_TABLE_I = {
    "manual": (9.6193, 314.34, 45.962),
    "A*": (9.4362, 3.3893, 9.5632),
    "B-spline": (9.1352, 0.64264, 0.30768),
}
"""The paper's Table I (total length in scene units, mean curvature, angular deviation
in degrees), as printed."""

PAPER_TABLE_II = {
    "RL": (1.000, 38.92),
    "G1": (0.209, None),
    "G2": (0.689, 36.20),
    "G3": (0.836, 41.41),
    "G4": (1.000, 44.80),
    "G5": (1.000, 53.40),
    "G6": (1.000, 66.56),
}
"""The paper's Table II (ASR, ATCT in s) as printed. Its G1 fails most and its G6 is
slowest, so the printed columns run from fastest to slowest, against its text."""

PAPER_GROUP_BY_SPEED = {"RL": "RL", "G1": "G6", "G2": "G5", "G3": "G4", "G4": "G3", "G5": "G2", "G6": "G1"}
"""Our groups (slowest first) to the paper's printed columns of the same speed."""


def paper_row(policy: str) -> tuple:
    """The paper's (ASR, ATCT s) for one of our rows, matched by speed; (None, None) if none."""
    return PAPER_TABLE_II.get(PAPER_GROUP_BY_SPEED.get(policy, ""), (None, None))


PAPER_SAFETY = (
    "after training, contact force below 10 pN and the robot within 0.06 um of the trap centre "
    "(median; above 0.06 um before training)"
)


def number(value, spec: str) -> str:
    return "/" if value is None else format(value, spec)


def table_ii_markdown(rows: list[dict]) -> list[str]:
    """Table II as markdown lines: our rows (RL, G1..Gn), with the paper's values beside
    them only when the constant speeds are the paper's (the ``paper`` preset)."""
    speeds = tuple(row["speed_um_s"] for row in rows if row["speed_um_s"] is not None)
    with_paper = speeds == PAPER_SPEEDS_UM_S
    head = "| policy | speed (um/s) | ASR | ATCT (s) | success rate | 95 % interval | episodes |"
    lines = [
        head + (" paper ASR | paper ATCT (s) |" if with_paper else ""),
        "|---|---:|---:|---:|---:|---:|---:|" + ("---:|---:|" if with_paper else ""),
    ]
    for row in rows:
        speed = "learned" if row["speed_um_s"] is None else f"{row['speed_um_s']:.3f}"
        line = (
            f"| {row['policy']} | {speed} | {row['ASR']:.3f} | {number(row['ATCT_s'], '.2f')} | "
            f"{row['success_rate']:.3f} | {row['success_ci95_low']:.3f}-{row['success_ci95_high']:.3f} | "
            f"{row['episodes']} |"
        )
        if with_paper:
            paper = paper_row(row["policy"])
            line += f" {number(paper[0], '.3f')} | {number(paper[1], '.2f')} |"
        lines.append(line)
    note = (
        "G1..Gn: constant speeds, slowest first, as in the paper's text. Intervals: Wilson score "
        "intervals of the success rate."
    )
    if with_paper:
        note += " The paper's values are matched by speed (its printed table runs from fastest to slowest)."
    return lines + ["", note]
