"""A task's learned policy against its scripted baseline on the same episodes, with the
analysis plan of docs/tasks.md ("Report-seed comparisons: the analysis plan"):
``otgym experiment assemble``, ``orient`` and ``sort-cells``.

Both policies run the same ``episodes`` from ``jax.random.PRNGKey(seed)`` (the same
starts, targets and step keys): ``otgym.experiments.assemble.run.episode_metrics``
(the plan at the baseline's constant pace against the greedy Q-network) and
``otgym.experiments.orient.run.rollout`` (the bang-bang controller against the greedy
Q-network), ``otgym.experiments.sort_cells.run.report_outcomes`` (the scripted baseline
against the greedy Q-network, with the same arrivals).

Statistics (``compare``): each success rate with its 95 % Wilson interval
(``statsmodels.stats.proportion.proportion_confint``); McNemar's exact test on the
discordant pairs (``statsmodels.stats.contingency_tables.mcnemar``); the secondary
outcome by the Wilcoxon signed-rank test (``scipy.stats.wilcoxon``, two-sided) with the
median paired difference (learned minus baseline) and its 95 % distribution-free
interval from the order statistics (the binomial). The secondary outcome is the time
to success on the episodes both completed (lower is better), or, where a task's
registry entry names ``report_secondary`` (a per-episode metric, higher is better:
``sort-cells``' throughput, its episodes all of one length), that metric on all the
paired episodes; its direction is that of the signed-rank statistic (the rank sum of
the positive differences against the negative ones; zero differences dropped, as
``scipy.stats.wilcoxon`` drops them). The decision (``verdict``): the learned policy
beats the baseline if its success rate is higher with McNemar p < alpha, or if McNemar
finds no difference, its rate is not lower and its secondary outcome is better with
Wilcoxon p < alpha; anything else is a miss.
"""

from __future__ import annotations

import importlib
import json
from pathlib import Path

import numpy as np

from otgym.experiments.common import seeds as seed_protocol

TASKS = tuple(seed_protocol.TASK_REPORTS)
"""The tasks with a report (registry entries with ``report_seed``; their extras name the rest)."""
ALPHA = 0.05
POLICY_DIR = Path(__file__).resolve().parents[2] / "data" / "policies"
SHIPPED_POLICIES = {name: POLICY_DIR / extras["report_policy"] for name, extras in seed_protocol.TASK_REPORTS.items()}
"""The learned policies of the report (``otgym train --task NAME`` on
``seeds.TRAINING_SEEDS``; commands in docs/tasks.md)."""
PRESETS = {name: extras["report_preset"] for name, extras in seed_protocol.TASK_REPORTS.items()}
SECONDARY = {name: extras.get("report_secondary") for name, extras in seed_protocol.TASK_REPORTS.items()}
"""Each task's secondary outcome: None for the time to success, else a metric (higher is better)."""
DEFAULT_EPISODES = 256


def policy_shape(task_name: str) -> tuple[int, int]:
    """(observation size, actions) of ``task_name``'s preset, from its config alone
    (nothing built or compiled)."""
    from otgym import tasks

    task = tasks.load(task_name)
    return task.policy_shape(task.config(PRESETS[task_name]))


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


def compare(baseline: dict, learned: dict, secondary: str | None = None) -> dict:
    """The plan's statistics of two paired outcome sets (see the module docstring);
    ``secondary``: None for the time to success (``time_s``), else the name of a
    per-episode metric of both sets, higher is better."""
    from scipy.stats import wilcoxon
    from statsmodels.stats.contingency_tables import mcnemar

    base_ok, learn_ok = np.asarray(baseline["success"], bool), np.asarray(learned["success"], bool)
    n = len(base_ok)
    table = np.array([[np.sum(base_ok & learn_ok), np.sum(base_ok & ~learn_ok)], [np.sum(~base_ok & learn_ok), 0]])
    table[1, 1] = n - table.sum()
    discordant = int(table[0, 1] + table[1, 0])
    mcnemar_p = float(mcnemar(table, exact=True).pvalue) if discordant else 1.0
    both = base_ok & learn_ok
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
    }
    if secondary is None:
        differences = np.asarray(learned["time_s"], float)[both] - np.asarray(baseline["time_s"], float)[both]
        result.update(
            baseline_median_time_s=float(np.median(np.asarray(baseline["time_s"])[both])) if both.any() else None,
            learned_median_time_s=float(np.median(np.asarray(learned["time_s"])[both])) if both.any() else None,
            median_time_difference_s=float(np.median(differences)) if len(differences) else None,
            median_time_difference_ci95_s=median_interval(differences),
        )
    else:
        base_values, learned_values = (np.asarray(o[secondary], float) for o in (baseline, learned))
        differences = learned_values - base_values
        result.update(
            secondary=secondary,
            baseline_median=float(np.median(base_values)),
            learned_median=float(np.median(learned_values)),
            baseline_mean=float(np.mean(base_values)),
            learned_mean=float(np.mean(learned_values)),
            mean_difference=float(np.mean(differences)),
            median_difference=float(np.median(differences)),
            median_difference_ci95=median_interval(differences),
            signed_rank_direction=_signed_rank_direction(differences),
        )
    if np.any(differences != 0):
        result["wilcoxon_p"] = float(wilcoxon(differences, alternative="two-sided").pvalue)
    else:
        result["wilcoxon_p"] = 1.0 if len(differences) else None
    result["verdict"] = verdict(result)
    return result


def _signed_rank_direction(differences: np.ndarray) -> int:
    """+1 if the ranks of the positive differences (by absolute value, zeros dropped)
    outweigh the negative ones', -1 if the reverse, 0 if they balance."""
    from scipy.stats import rankdata

    d = np.asarray(differences, float)
    d = d[d != 0]
    if not len(d):
        return 0
    ranks = rankdata(np.abs(d))
    return int(np.sign(ranks[d > 0].sum() - ranks[d < 0].sum()))


def verdict(result: dict) -> str:
    """``"beats"`` or ``"miss"`` by the plan's rule, with the reason."""
    learned, base = result["learned_successes"], result["baseline_successes"]
    if learned > base and result["mcnemar_exact_p"] < ALPHA:
        return "beats: higher success rate (McNemar p < 0.05)"
    if result["mcnemar_exact_p"] < ALPHA:
        return "miss: lower success rate (McNemar p < 0.05)"
    if learned < base:
        deciding = result.get("secondary", "time")
        return f"miss: success rate not higher (lower, McNemar p >= 0.05) so {deciding} is not the deciding test"
    if "secondary" in result:
        better, what = result["signed_rank_direction"], f"{result['secondary']}"
        worse_word, better_word = f"lower {what}", f"higher {what}"
    else:
        difference = result["median_time_difference_s"]
        better = 0 if difference is None else -int(np.sign(difference))
        worse_word, better_word = "longer time to success", "shorter time to success"
    significant = result["wilcoxon_p"] is not None and result["wilcoxon_p"] < ALPHA
    if better > 0 and significant:
        return f"beats: same success (McNemar p >= 0.05) and {better_word} (Wilcoxon p < 0.05)"
    if significant:
        return f"miss: same success (McNemar p >= 0.05) but {worse_word} (Wilcoxon p < 0.05)"
    secondary = result.get("secondary", "time to success")
    return f"miss: no difference in success (McNemar p >= 0.05) nor in {secondary} (Wilcoxon p >= 0.05)"


METRICS = {name: tuple(extras["report_metrics"].split(",")) for name, extras in seed_protocol.TASK_REPORTS.items()}
MEAN_METRICS = ("purity", "yield", "throughput_cells_per_min", "light_dose_per_cell_mj_per_um2")


def descriptives(task_name: str, outcome: dict) -> dict:
    """The task's own metrics: assemble's RMS error the mean over the successes (as
    docs/tasks.md reports it), orient's final error the median, sort-cells' rates and
    doses (``MEAN_METRICS``) the means over all episodes; counts as totals."""
    success = np.asarray(outcome["success"], bool)
    found = {}
    for name in METRICS[task_name]:
        values = np.asarray(outcome[name], float)
        if name in ("rms_error_um",):
            found[name] = float(values[success].mean()) if success.any() else None
        elif name in ("final_error_deg",):
            found["median_" + name] = float(np.median(values))
        elif name in MEAN_METRICS:
            found["mean_" + name] = float(values.mean())
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
        "comparison": compare(found["baseline"], found["learned"], SECONDARY[task_name]),
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

    p_wilcoxon = "-" if c["wilcoxon_p"] is None else f"{c['wilcoxon_p']:.3g}"
    lines = [
        f"# {result['task']} ({result['preset']}): learned policy against the baseline, {n} paired episodes",
        "",
        "| | baseline | learned |",
        "|---|---|---|",
        f"| success | {rate(c['baseline_successes'], c['baseline_wilson95'])} | "
        f"{rate(c['learned_successes'], c['learned_wilson95'])} |",
    ]
    if "secondary" in c:
        name = c["secondary"]
        lines.append(f"| median {name}, all {n} episodes | {c['baseline_median']:.3g} | {c['learned_median']:.3g} |")
        interval = c["median_difference_ci95"]
        secondary_line = (
            f"{name}, learned minus baseline: median {c['median_difference']:.3g}"
            + (f" (95 % {interval[0]:.3g} to {interval[1]:.3g})" if interval else "")
            + f", mean {c['mean_difference']:.3g}; Wilcoxon signed-rank p = {p_wilcoxon}"
            + f" (signed ranks favour the {_favoured(c['signed_rank_direction'])})."
        )
    else:
        lines.append(
            f"| median time to success, episodes both completed ({c['both_succeeded']}) | "
            f"{seconds(c['baseline_median_time_s'])} | {seconds(c['learned_median_time_s'])} |"
        )
        interval = c["median_time_difference_ci95_s"]
        secondary_line = (
            f"Time to success, learned minus baseline: median {seconds(c['median_time_difference_s'])}"
            + (f" (95 % {interval[0]:.2f} to {interval[1]:.2f} s)" if interval else "")
            + f"; Wilcoxon signed-rank p = {p_wilcoxon}."
        )
    for name, value in result["baseline"].items():
        other = result["learned"][name]
        shown = [("-" if v is None else f"{v:.3g}" if isinstance(v, float) else str(v)) for v in (value, other)]
        lines.append(f"| {name} | {shown[0]} | {shown[1]} |")
    table = c["table"]
    lines += [
        "",
        f"Success pairs: both {table['both']}, baseline only {table['baseline_only']}, learned only "
        f"{table['learned_only']}, neither {table['neither']}; McNemar exact p = {c['mcnemar_exact_p']:.3g}.",
        secondary_line,
        "",
        f"**Verdict: {c['verdict']}.**",
        "",
    ]
    return "\n".join(lines)


def _favoured(direction: int) -> str:
    return {1: "learned policy", -1: "baseline", 0: "neither"}[direction]
