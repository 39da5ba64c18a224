"""A task's learned policy against its scripted baseline on the same episodes, with the
analysis plan of docs/tasks.md ("Report-seed comparisons: the analysis plan"):
``otgym experiment assemble`` and ``otgym experiment orient``.

Both policies run the same ``episodes`` from ``jax.random.PRNGKey(seed)`` (the same
starts, targets and step keys): ``otgym.experiments.assemble_baseline.episode_metrics``
(the plan at the baseline's constant pace against the greedy Q-network) and
``otgym.experiments.orient.rollout`` (the bang-bang controller against the greedy
Q-network).

Statistics (``compare``): each success rate with its 95 % Wilson interval
(``statsmodels.stats.proportion.proportion_confint``); McNemar's exact test on the
discordant pairs (``statsmodels.stats.contingency_tables.mcnemar``); on the episodes
both completed, the Wilcoxon signed-rank test of the times (``scipy.stats.wilcoxon``)
and the median paired difference (learned minus baseline) with its 95 %
distribution-free interval from the order statistics (the binomial). The decision
(``verdict``): the learned policy beats the baseline if its success rate is higher
with McNemar p < alpha, or if McNemar finds no difference, its rate is not lower and
its time to success is shorter with Wilcoxon p < alpha; anything else is a miss.
"""

from __future__ import annotations

import importlib
import json
from pathlib import Path

import numpy as np

from otgym.experiments import seeds as seed_protocol

TASKS = tuple(seed_protocol.TASK_REPORTS)
"""The tasks with a report (registry entries with ``report_seed``; their extras name the rest)."""
ALPHA = 0.05
POLICY_DIR = Path(__file__).resolve().parent.parent / "data" / "policies"
SHIPPED_POLICIES = {name: POLICY_DIR / extras["report_policy"] for name, extras in seed_protocol.TASK_REPORTS.items()}
"""The learned policies of the report (``otgym train --task NAME`` on
``seeds.TRAINING_SEEDS``; commands in docs/tasks.md)."""
PRESETS = {name: extras["report_preset"] for name, extras in seed_protocol.TASK_REPORTS.items()}
DEFAULT_EPISODES = 256


def policy_shape(task_name: str) -> tuple[int, int]:
    """(observation size, actions) of ``task_name``'s preset, from its config alone
    (nothing built or compiled)."""
    from otgym import tasks

    config = tasks.load(task_name).config(PRESETS[task_name])
    if task_name == "assemble":
        from otgym.tasks.assemble.core import OBS_SIZE
    else:
        from otgym.tasks.orient.core import OBS_SIZE
    return OBS_SIZE, config.n_actions


def check_policy(task_name: str, policy_path: Path) -> None:
    """ValueError (or FileNotFoundError) unless ``policy_path`` is a policy file whose
    network fits ``task_name`` (its shapes traced, nothing compiled)."""
    from otgym.rl.policy import load_policy

    load_policy(policy_path, *policy_shape(task_name))


def outcomes(task_name: str, policy_path: Path, episodes: int, seed: int) -> dict[str, dict[str, np.ndarray]]:
    """``{"baseline": ..., "learned": ...}``: per-episode arrays (``episodes``) of
    ``success``, ``time_s`` (at the episode's end) and the task's own metrics."""
    if task_name not in TASKS:
        raise ValueError(f"unknown task {task_name!r}; one of {TASKS}")
    module, _, function = seed_protocol.TASK_REPORTS[task_name]["report_outcomes"].partition(":")
    return getattr(importlib.import_module(module), function)(policy_path, PRESETS[task_name], episodes, seed)


def wilson(successes: int, n: int) -> tuple[float, float]:
    from statsmodels.stats.proportion import proportion_confint

    low, high = proportion_confint(successes, n, alpha=ALPHA, method="wilson")
    return float(low), float(high)


def median_interval(differences: np.ndarray) -> tuple[float, float] | None:
    """The 95 % distribution-free interval of the median of ``differences``: the order
    statistics d_(k), d_(n-k+1) with the largest k whose two tails each hold at most
    2.5 % of Binomial(n, 1/2); None when n is too small for one (n < 6)."""
    from scipy.stats import binom

    d = np.sort(np.asarray(differences, float))
    n = len(d)
    k = int(binom.ppf(ALPHA / 2, n, 0.5))  # P(X <= k - 1) <= alpha / 2 for this k (at least)
    while k > 0 and binom.cdf(k - 1, n, 0.5) > ALPHA / 2:
        k -= 1
    if k < 1:
        return None
    return float(d[k - 1]), float(d[n - k])


def compare(baseline: dict, learned: dict) -> dict:
    """The plan's statistics of two paired outcome sets (see the module docstring)."""
    from scipy.stats import wilcoxon
    from statsmodels.stats.contingency_tables import mcnemar

    base_ok, learn_ok = np.asarray(baseline["success"], bool), np.asarray(learned["success"], bool)
    n = len(base_ok)
    table = np.array([[np.sum(base_ok & learn_ok), np.sum(base_ok & ~learn_ok)], [np.sum(~base_ok & learn_ok), 0]])
    table[1, 1] = n - table.sum()
    discordant = int(table[0, 1] + table[1, 0])
    mcnemar_p = float(mcnemar(table, exact=True).pvalue) if discordant else 1.0
    both = base_ok & learn_ok
    differences = np.asarray(learned["time_s"], float)[both] - np.asarray(baseline["time_s"], float)[both]
    if np.any(differences != 0):
        wilcoxon_p = float(wilcoxon(differences, alternative="two-sided").pvalue)
    else:
        wilcoxon_p = 1.0 if len(differences) else None
    result = {
        "episodes": n,
        "baseline_successes": int(base_ok.sum()),
        "learned_successes": int(learn_ok.sum()),
        "baseline_wilson95": wilson(int(base_ok.sum()), n),
        "learned_wilson95": wilson(int(learn_ok.sum()), n),
        "table": {
            "both": int(table[0, 0]),
            "baseline_only": int(table[0, 1]),
            "learned_only": int(table[1, 0]),
            "neither": int(table[1, 1]),
        },
        "mcnemar_exact_p": mcnemar_p,
        "both_succeeded": int(both.sum()),
        "baseline_median_time_s": float(np.median(np.asarray(baseline["time_s"])[both])) if both.any() else None,
        "learned_median_time_s": float(np.median(np.asarray(learned["time_s"])[both])) if both.any() else None,
        "median_time_difference_s": float(np.median(differences)) if len(differences) else None,
        "median_time_difference_ci95_s": median_interval(differences),
        "wilcoxon_p": wilcoxon_p,
    }
    result["verdict"] = verdict(result)
    return result


def verdict(result: dict) -> str:
    """``"beats"`` or ``"miss"`` by the plan's rule, with the reason."""
    learned, base = result["learned_successes"], result["baseline_successes"]
    if learned > base and result["mcnemar_exact_p"] < ALPHA:
        return "beats: higher success rate (McNemar p < 0.05)"
    if result["mcnemar_exact_p"] < ALPHA:
        return "miss: lower success rate (McNemar p < 0.05)"
    if learned < base:
        return "miss: success rate not higher (lower, McNemar p >= 0.05) so time is not the deciding test"
    faster = result["median_time_difference_s"] is not None and result["median_time_difference_s"] < 0
    if faster and result["wilcoxon_p"] is not None and result["wilcoxon_p"] < ALPHA:
        return "beats: same success (McNemar p >= 0.05) and shorter time to success (Wilcoxon p < 0.05)"
    if result["wilcoxon_p"] is not None and result["wilcoxon_p"] < ALPHA:
        return "miss: same success (McNemar p >= 0.05) but longer time to success (Wilcoxon p < 0.05)"
    return "miss: no difference in success (McNemar p >= 0.05) nor in time to success (Wilcoxon p >= 0.05)"


METRICS = {name: tuple(extras["report_metrics"].split(",")) for name, extras in seed_protocol.TASK_REPORTS.items()}


def descriptives(task_name: str, outcome: dict) -> dict:
    """The task's own metrics: means over all episodes (assemble's RMS error over the
    successes, as docs/tasks.md reports it; counts as totals)."""
    success = np.asarray(outcome["success"], bool)
    found = {}
    for name in METRICS[task_name]:
        values = np.asarray(outcome[name], float)
        if name in ("rms_error_um",):
            found[name] = float(values[success].mean()) if success.any() else None
        elif name in ("final_error_deg",):
            found["median_" + name] = float(np.median(values))
        else:
            found[name] = int(values.sum())
    return found


def run(task_name: str, out: Path, episodes: int, seed: int, policy_path: Path) -> dict:
    """Run both policies, compare them, write ``results.json`` and ``summary.md`` into
    ``out`` (marked with the seed's status) and return the results."""
    found = outcomes(task_name, policy_path, episodes, seed)
    result = {
        "task": task_name,
        "preset": PRESETS[task_name],
        "policy": str(policy_path),
        "episodes": episodes,
        "comparison": compare(found["baseline"], found["learned"]),
        "baseline": descriptives(task_name, found["baseline"]),
        "learned": descriptives(task_name, found["learned"]),
    }
    out.mkdir(parents=True, exist_ok=True)
    (out / "results.json").write_text(json.dumps(result, indent=2))
    (out / "summary.md").write_text(markdown(result))
    note = seed_protocol.mark_report_files(
        task_name, seed, markdown=[out / "summary.md"], json_files=[out / "results.json"]
    )
    result.update(seed=seed, seed_status=seed_protocol.seed_status(task_name, seed), development_note=note)
    return result


def markdown(result: dict) -> str:
    c = result["comparison"]
    n = c["episodes"]

    def rate(k, interval):
        return f"{k} / {n} ({k / n:.3f}; 95 % Wilson {interval[0]:.3f}-{interval[1]:.3f})"

    def seconds(value):
        return "-" if value is None else f"{value:.2f} s"

    interval = c["median_time_difference_ci95_s"]
    p_wilcoxon = "-" if c["wilcoxon_p"] is None else f"{c['wilcoxon_p']:.3g}"
    lines = [
        f"# {result['task']} ({result['preset']}): learned policy against the baseline, {n} paired episodes",
        "",
        "| | baseline | learned |",
        "|---|---|---|",
        f"| success | {rate(c['baseline_successes'], c['baseline_wilson95'])} | "
        f"{rate(c['learned_successes'], c['learned_wilson95'])} |",
        f"| median time to success, episodes both completed ({c['both_succeeded']}) | "
        f"{seconds(c['baseline_median_time_s'])} | {seconds(c['learned_median_time_s'])} |",
    ]
    for name, value in result["baseline"].items():
        other = result["learned"][name]
        shown = [("-" if v is None else f"{v:.3g}" if isinstance(v, float) else str(v)) for v in (value, other)]
        lines.append(f"| {name} | {shown[0]} | {shown[1]} |")
    table = c["table"]
    lines += [
        "",
        f"Success pairs: both {table['both']}, baseline only {table['baseline_only']}, learned only "
        f"{table['learned_only']}, neither {table['neither']}; McNemar exact p = {c['mcnemar_exact_p']:.3g}.",
        f"Time to success, learned minus baseline: median {seconds(c['median_time_difference_s'])}"
        + (f" (95 % {interval[0]:.2f} to {interval[1]:.2f} s)" if interval else "")
        + f"; Wilcoxon signed-rank p = {p_wilcoxon}.",
        "",
        f"**Verdict: {c['verdict']}.**",
        "",
    ]
    return "\n".join(lines)
