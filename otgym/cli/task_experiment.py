"""``otgym experiment assemble``, ``orient`` and ``sort-cells``: a task's shipped
learned policy against its scripted baseline on the held-out report seed
(``otgym.experiments.task_report.run``; the plan in docs/tasks.md)."""

from __future__ import annotations

from pathlib import Path

import typer

from otgym.cli import options
from otgym.experiments.common.seeds import REPORT_SEEDS, TASK_REPORTS


def _register_one(experiment: typer.Typer, task_name: str) -> None:
    from otgym.experiments.task_report.run import DEFAULT_EPISODES, PRESETS, SECONDARY

    @experiment.command(task_name)
    def command(
        episodes: int = typer.Option(
            DEFAULT_EPISODES, "--episodes", min=1, max=65_536, help="Paired episodes (both policies run each)."
        ),
        seed: int = options.seed(
            REPORT_SEEDS[task_name], "Seed of the episodes (one batch); the default is the held-out report seed,"
        ),
        policy: str = options.policy(
            None, "The learned policy (policy.npz of otgym train --task); default: the shipped one."
        ),
        out: Path = options.out_dir(..., "Folder for results.json and summary.md."),
    ) -> None:
        from otgym.experiments.common.output_folder import check_out_dir
        from otgym.experiments.task_report import run as task_report
        from otgym.rl.policy import resolve_policy

        policy_path = task_report.SHIPPED_POLICIES[task_name] if policy is None else resolve_policy(policy)
        try:
            task_report.check_policy(task_name, policy_path)
        except (ValueError, OSError) as error:
            raise ValueError(f"--policy: {error}") from None
        check_out_dir(out)
        print(f"{task_name}: {episodes} paired episodes from seed {seed}, policy {policy_path} ...", flush=True)
        result = task_report.run(task_name, out, episodes, seed, policy_path)
        comparison = result["comparison"]
        if result["development_note"]:
            print(result["development_note"])
        print(
            f"success: baseline {comparison['baseline_successes']}/{episodes}, learned "
            f"{comparison['learned_successes']}/{episodes} (McNemar p {comparison['mcnemar_exact_p']:.3g}); "
            f"{comparison['verdict']}; wrote {out / 'results.json'}, {out / 'summary.md'}"
        )

    secondary = "time to success" if SECONDARY[task_name] is None else SECONDARY[task_name]
    command.__doc__ = f"""The {task_name} task ({PRESETS[task_name]}): the shipped learned policy against
        {TASK_REPORTS[task_name]["report_baseline"]} on the same episodes: success (McNemar, Wilson intervals),
        {secondary} (Wilcoxon signed-rank), the task's own metrics (docs/tasks.md).

        Example: otgym experiment {task_name} --episodes 256 --out results/{task_name}-report
        """


def register(experiment: typer.Typer) -> None:
    for task_name in TASK_REPORTS:
        _register_one(experiment, task_name)
