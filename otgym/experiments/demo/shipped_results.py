"""The report runs' results shipped with otgym, and their paragraphs in the demo's report.

Two full-size commands take too long for the demo (minutes to an hour on a laptop), so
their held-out report runs are shipped as JSON under ``otgym/data/results/`` and quoted
by ``otgym demo``'s report beside its own small runs:

- ``speed_front.json``: ``front.json`` of the report run of ``otgym experiment
  speed-front`` (Table II as a front), copied unchanged (docs/results-table2.md).
- ``fig8.json``: the report runs of ``otgym experiment shared-control`` (Fig. 8 restated,
  one run per autonomy), collected from their output folders by
  ``otgym experiment fig8-json --out OUT.json LABEL=DIR...``
  (``collect_fig8_run``): each folder's ``summary.csv``, ``acceptance.json`` (with the
  route bound it judged item (c) against) and ``stats.json`` (the repeated-measures
  ANOVA and the Holm-corrected paired tests, p-values included), with the command read
  from ``command.txt``.

Pure reading and text formatting; every number printed comes from these files.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

from otgym.study.summary import SUMMARY_COLUMNS

RESULTS_DIR = Path(__file__).resolve().parents[2] / "data" / "results"
SHIPPED_FRONT = RESULTS_DIR / "speed_front.json"
SHIPPED_FIG8 = RESULTS_DIR / "fig8.json"

FIG8_MODE_FIELDS = tuple(column for column in SUMMARY_COLUMNS if not column.startswith("paper_"))
"""The columns of a shared-control run's ``summary.csv`` that ``fig8.json`` keeps per mode
(all but the paper's values)."""


def _read_json(path: Path) -> dict | None:
    return json.loads(path.read_text()) if path.is_file() else None


def shipped_front() -> dict | None:
    """The shipped policy's measured front (``SHIPPED_FRONT``), or None if absent."""
    return _read_json(SHIPPED_FRONT)


def shipped_fig8() -> dict | None:
    """The shipped Fig. 8 report runs (``SHIPPED_FIG8``), or None if absent."""
    return _read_json(SHIPPED_FIG8)


def front_lines(front: dict | None) -> list[str]:
    """How the shipped policy stands against the constant speeds on the front measured by
    ``otgym experiment speed-front`` (its ``front.json``, shipped as
    ``otgym/data/results/speed_front.json``): its success with the 95 % interval and
    ATCT, and per constant speed the paired tests, with the command, seed and sample size.
    Empty when no front is given."""
    if not front:
        return []
    rows = {row["name"]: row for row in front["rows"]}
    shipped = rows.get("pretrained")
    if shipped is None:
        return []
    n = front["episodes"]
    held = "held-out seed" if front["seed_status"] == "held out" else "development seed"
    lines = [
        "### The shipped policy on the front (Table II as a front)",
        "",
        f"Measured by `{front['command']}` ({held} {front['seed']}, {n} episodes, the same for every policy; "
        f"not by this demo): the shipped policy completed {shipped['successes']} of {n} "
        f"({shipped['success_rate']:.3f}, 95 % interval [{shipped['success_ci95_low']:.3f}, "
        f"{shipped['success_ci95_high']:.3f}]) in {shipped['ATCT_s']:.2f} s on average.",
        "",
        "| constant | success [95 % CI] | ATCT (s) | shipped policy: ATCT ratio | only shipped lost / only "
        "constant lost (McNemar p) | as safe | >= 10 % faster (sign p) |",
        "|---|---|---:|---:|---:|:---:|:---:|",
    ]
    for test in front["pretrained_tests"]:
        row = rows[test["constant"]]
        ratio = "-" if test["time_ratio"] is None else f"{test['time_ratio']:.3f}"
        atct = "-" if row["ATCT_s"] is None else f"{row['ATCT_s']:.2f}"
        lines.append(
            f"| {row['name']} | {row['success_rate']:.3f} [{row['success_ci95_low']:.3f}, "
            f"{row['success_ci95_high']:.3f}] | {atct} | {ratio} | {test['policy_only_lost']} / "
            f"{test['constant_only_lost']} ({test['less_safe_p']:.2g}) | {'yes' if test['as_safe'] else 'no'} | "
            f"{'yes' if test['faster'] else 'no'} ({test['faster_p']:.2g}) |"
        )
    covered = [t["constant"] for t in front["pretrained_tests"] if t["covers"]]
    goals = front["goals"]
    lines += [
        "",
        f"It covers (at least as safe and at least 10 % faster): {', '.join(covered) or 'none'}. "
        f"Constant speeds exempt from the goal (success < 0.90): {', '.join(goals['exempt']) or 'none'}; "
        f"every other one covered by some policy of the front's family: "
        f"{'yes' if goals['every_eligible_covered'] else 'no'}.",
        "",
    ]
    return lines


def _number(text: str):
    """A summary.csv cell as int, float or None (empty or NaN)."""
    if text == "":
        return None
    try:
        return int(text)
    except ValueError:
        value = float(text)
        return None if math.isnan(value) else value


def collect_fig8_run(label: str, out_dir: Path) -> dict:
    """One shared-control output folder as a ``fig8.json`` run: label, command (from
    ``command.txt``, which the person who ran it writes), seed and its status (from
    ``acceptance.json``), per-mode rows (``FIG8_MODE_FIELDS`` of ``summary.csv``), the
    acceptance items, the route bound and ``tests`` (``fig8_tests`` of ``stats.json``).
    Raises FileNotFoundError naming a missing file."""
    out_dir = Path(out_dir)
    for name in ("summary.csv", "acceptance.json", "stats.json", "command.txt"):
        if not (out_dir / name).is_file():
            raise FileNotFoundError(f"{out_dir / name} is missing: not a finished shared-control run folder?")
    acceptance = json.loads((out_dir / "acceptance.json").read_text())
    with open(out_dir / "summary.csv", newline="") as handle:
        modes = [
            {field: _number(row[field]) if field != "mode" else row[field] for field in FIG8_MODE_FIELDS}
            for row in csv.DictReader(handle)
        ]
    return {
        "label": label,
        "command": (out_dir / "command.txt").read_text().strip(),
        "seed": acceptance.get("seed"),
        "seed_status": acceptance.get("seed_status"),
        "route_bound_s": acceptance.get("route_bound_s"),
        "modes": modes,
        "items": {key: value for key, value in acceptance.items() if isinstance(value, bool)},
        "tests": fig8_tests(json.loads((out_dir / "stats.json").read_text())),
        "tests_source": "stats.json of the run folder",
    }


def fig8_tests(stats: dict) -> dict:
    """Per metric of a run's ``stats.json`` (``otgym.study.compare_modes``: success, time):
    the participants tested, the repeated-measures ANOVA (F, its degrees of freedom, p)
    and each pair's paired t-test (T of a minus b, dof, p uncorrected and Holm-corrected);
    NaN statistics stay null."""
    tests = {}
    for metric, result in stats.items():
        anova = result.get("anova") or {}
        tests[metric] = {
            "n_participants": result.get("n_participants"),
            "anova": {key: anova.get(key) for key in ("F", "ddof1", "ddof2", "p")},
            "pairs": [
                {key: pair.get(key) for key in ("a", "b", "T", "dof", "p_unc", "p_holm")}
                for pair in result.get("posthoc", [])
            ],
        }
    return tests


def _pair(run: dict, metric: str, a: str, b: str) -> dict | None:
    """The paired test of modes ``a`` and ``b`` on ``metric`` in a fig8.json run, or None."""
    for pair in ((run.get("tests") or {}).get(metric) or {}).get("pairs", []):
        if {pair["a"], pair["b"]} == {a, b}:
            return pair
    return None


def _test_text(pair: dict | None) -> str:
    """'paired t(7) = -1.20, Holm p = 0.27' from a pair's figures (what is known of them)."""
    if pair is None or pair.get("p_holm") is None:
        return "no paired test recorded"
    t = "" if pair.get("T") is None or pair.get("dof") is None else f"paired t({pair['dof']:g}) = {pair['T']:.2f}, "
    return f"{t}Holm p = {pair['p_holm']:.2g}"


def _item_line(run: dict, item: str, passed: bool) -> str:
    """One acceptance item with the statistic behind it: (a) and (d) their modes' success
    means and paired test (a (d) that passes on point estimates with Holm p >= 0.05, or
    with no test recorded, says it is not shown significant), (b) and (c) the time ratio."""
    modes = {row["mode"]: row for row in run["modes"]}
    verdict = "passes" if passed else "**misses**"

    def success(mode):
        value = modes.get(mode, {}).get("success_mean")
        return "-" if value is None else f"{100 * value:.1f} %"

    def time_s(mode):
        return modes.get(mode, {}).get("completion_time_mean_s")

    if item.startswith("(d)") and "manual" in modes and "shared" in modes:
        pair = _pair(run, "success", "manual", "shared")
        measured = f"shared {success('shared')} against manual {success('manual')}, {_test_text(pair)}"
        significant = pair is not None and pair.get("p_holm") is not None and pair["p_holm"] < 0.05
        if passed and not significant:
            verdict = (
                "passes on point estimates only; the difference is **not significant**"
                if pair is not None and pair.get("p_holm") is not None
                else "passes on point estimates only; **not tested**"
            )
        return f"- {verdict}: {item} ({measured})"
    if item.startswith("(a)") and "autonomous" in modes and "shared" in modes:
        pair = _pair(run, "success", "autonomous", "shared")
        return f"- {verdict}: {item} (autonomous {success('autonomous')} against shared {success('shared')}, {_test_text(pair)})"
    if item.startswith("(b)") and time_s("manual") and time_s("shared"):
        return f"- {verdict}: {item} (manual {time_s('manual'):.1f} s against shared {time_s('shared'):.1f} s: {time_s('manual') / time_s('shared'):.2f}x)"
    if item.startswith("(c)") and time_s("shared") and run.get("route_bound_s"):
        bound = run["route_bound_s"]
        return f"- {verdict}: {item} (shared {time_s('shared'):.1f} s against the bound {bound:.1f} s: {time_s('shared') / bound:.2f}x)"
    return f"- {verdict}: {item}"


def fig8_lines(fig8: dict | None) -> list[str]:
    """The shipped Fig. 8 report runs: per run, its command, seed and size, a row per mode
    (obstacles avoided / met with the 95 % Wilson interval, goals, time, trap losses) and
    each acceptance item passed or missed with its statistic (``_item_line``). Empty when
    nothing is shipped."""
    if not fig8 or not fig8.get("runs"):
        return []
    lines = [
        "### The full study on held-out seeds (shipped report runs)",
        "",
        "Not run by this demo: the report runs of `otgym experiment shared-control` at full size, "
        "shipped with otgym (`otgym/data/results/fig8.json`; docs: Results).",
        "",
    ]
    for run in fig8["runs"]:
        first = run["modes"][0]
        status = "held-out seed" if run["seed_status"] == "report seed" else "development seed"
        lines += [
            f"**{run['label']}**: `{run['command']}` ({status} {run['seed']}, {first['participants']} "
            f"participants x {first['trials'] // max(first['participants'], 1)} trials per mode).",
            "",
            "| mode | obstacles avoided / met [95 % CI] | success, mean ± SD over participants | goal reached | "
            "time to goal (s) | trap losses |",
            "|---|---|---|---|---|---:|",
        ]
        for row in run["modes"]:
            rate = (
                "-"
                if row["avoided_rate"] is None
                else f"{row['obstacles_avoided']} / {row['obstacles_encountered']} = {100 * row['avoided_rate']:.1f} % "
                f"[{100 * row['avoided_rate_ci_low']:.1f}, {100 * row['avoided_rate_ci_high']:.1f}]"
            )
            success = (
                "-"
                if row["success_mean"] is None
                else f"{100 * row['success_mean']:.1f} ± {100 * (row['success_sd'] or 0):.1f} %"
            )
            time_s = (
                "-"
                if row["completion_time_mean_s"] is None
                else f"{row['completion_time_mean_s']:.1f} ± {row['completion_time_sd_s'] or 0:.1f}"
            )
            lines.append(
                f"| {row['mode']} | {rate} | {success} | {row['goals_reached']} of {row['trials']} | {time_s} | "
                f"{row['trap_losses']} |"
            )
        lines += [
            "",
            *(_item_line(run, item, passed) for item, passed in run["items"].items()),
            "",
        ]
    return lines
