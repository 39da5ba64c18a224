"""``report.md`` of the demo: our planning, speed-control and transport figures
beside the paper's (its Tables I and II and the safety claims of its Fig. 7).

Pure text formatting of results computed elsewhere; the paper's numbers are quoted
from ``shared/paper/interactive-ot-gym.tex``.
"""

from __future__ import annotations

from pathlib import Path

from otgym.experiments.paper_tables import PAPER_SAFETY, PAPER_TABLE_I, number, table_ii_markdown
from otgym.experiments.speed_control_eval import acceptance
from otgym.planning.metrics import PathMetrics


def planning_section(metrics: dict[str, PathMetrics]) -> list[str]:
    """Table I, ours (um) beside the paper's (scene units), with lengths also relative to
    the B-spline path so that the rows compare across units."""
    ours_reference = metrics["B-spline"].length_um
    paper_reference = PAPER_TABLE_I["B-spline"][0]
    lines = ["## Path planning (paper Table I)", "",
             "| path | length (um) | length / B-spline | mean curvature (1/um) | angular deviation (deg) | "
             "paper: length / B-spline | paper: mean curvature | paper: angular deviation (deg) |",
             "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for name, row in metrics.items():
        paper = PAPER_TABLE_I.get(name, (None, None, None))
        paper_ratio = None if paper[0] is None else paper[0] / paper_reference
        lines.append(f"| {name} | {row.length_um:.1f} | {row.length_um / ours_reference:.3f} | "
                     f"{row.mean_curvature_per_um:.4g} | {row.angular_deviation_deg:.4g} | "
                     f"{number(paper_ratio, '.3f')} | {number(paper[1], '.5g')} | {number(paper[2], '.5g')} |")
    lines += ["", "Curvatures depend on the sampling step (ours 0.25 um, the paper's unpublished), so compare "
              "the order of the rows, not the values. Figures: `plan/paths.png`, `plan/spectrum.png`.", ""]
    return lines


def speed_control_section(rows: list[dict], safety: dict, force_limit_pn: float, distance_limit_um: float,
                          preset: str) -> list[str]:
    """Table II (ours beside the paper's) and the safety figures of the trained policy."""
    lines = ["## Learned speed control (paper Table II)", "",
             f"Preset `{preset}`; every policy runs the same seeded episodes.", "", *table_ii_markdown(rows)]
    rl = next(row for row in rows if row["policy"] == "RL")
    checks = acceptance(rows, safety["RL"])
    quicker = [row for row in rows if row["policy"] != "RL" and row["ATCT_s"] is not None
               and rl["ATCT_s"] is not None and row["ATCT_s"] < rl["ATCT_s"]]
    verdict = (f"RL: ASR {rl['ASR']:.3f}, success rate {rl['success_rate']:.3f}; its ATCT is "
               f"{'below' if checks['faster'] else 'not below'} that of every constant speed that always succeeds "
               f"({', '.join(checks['faster_than']) or 'none'}).")
    if quicker:
        verdict += (" Constant speeds with a shorter ATCT lost episodes: " +
                    ", ".join(f"{row['policy']} ({row['ATCT_s']:.2f} s, success {row['success_rate']:.3f})"
                              for row in quicker) + ".")
    after, before = safety["RL"], safety["untrained"]
    lines += ["", verdict, "", "### Safety (paper Fig. 7)", "",
              "| policy | force < " + f"{force_limit_pn:g} pN | handle within {distance_limit_um:g} um | "
              "median handle distance (um) | 99th percentile (um) | samples |",
              "|---|---:|---:|---:|---:|---:|"]
    for name, values in (("before training (random speeds)", before), ("after training (RL)", after)):
        lines.append(f"| {name} | {values['force_below_limit']:.2%} | {values['distance_within_limit']:.2%} | "
                     f"{values['distance_median_um']:.3f} | {values['distance_p99_um']:.3f} | {values['samples']} |")
    lines += ["", f"Paper: {PAPER_SAFETY}. Figure: `speed_control/safety.png`.", ""]
    if preset == "paper" and not checks["distance_safe"]:
        lines += ["The handle-distance limit is out of reach of the paper's trap law at these speeds: its centre "
                  "stiffness (0.455 pN/um) lets the handles wander 0.07 um (thermal, per axis), and the drag of "
                  "the robot-cell assembly against the opposing flow holds them about 0.3 um behind their traps "
                  "even at the slowest speed; speed control can only keep them short of the law's bend (0.446 um), "
                  "beyond which the trap lets go.", ""]
    return lines


def transport_section(summary: dict) -> list[str]:
    """The whole-path transport at constant speed (realistic preset)."""
    return ["## Whole-path transport (realistic preset, constant speed)", "",
            f"{summary['reached_goal']} of {summary['runs']} runs carried the cell the whole "
            f"{summary['path_length_um']} um path at {summary['speed_um_s']:g} um/s "
            f"(mean fraction completed {summary['mean_completed_fraction']:.3f}); outcomes: "
            f"{', '.join(summary['outcomes'])}. Mean contact force {summary['mean_contact_force_pn']} pN, "
            f"largest {summary['max_contact_force_pn']} pN. Figure: `transport/transport.png`.", ""]


def write_report(path: Path, sections: list[list[str]], header: str) -> Path:
    path = Path(path)
    lines = ["# otgym demo report", "", header, ""]
    for section in sections:
        lines += section
    path.write_text("\n".join(lines))
    return path
