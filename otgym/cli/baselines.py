"""``otgym experiment sort-cells-baselines`` and ``assemble-baseline``: the scripted
baselines of two tasks beside other policies on the same episodes, printed as markdown
tables (``otgym.experiments.sort_cells.run``, ``otgym.experiments.assemble.run``)."""

from __future__ import annotations

import typer

from otgym.cli import options


def _check_names(option: str, task: str):
    """A typer callback: every value of a repeatable ``option`` a preset of ``task``
    (the presets are read when the command runs: importing the task loads JAX)."""

    def check(values: list[str] | None) -> list[str] | None:
        from otgym import tasks

        presets = tasks.load(task).presets()
        for value in values or []:
            if value not in presets:
                raise typer.BadParameter(f"{value!r} is not one of {', '.join(presets)}", param_hint=option)
        return values

    return check


def _check_sort_policies(values: list[str] | None) -> list[str] | None:
    from otgym.experiments.sort_cells.run import POLICIES

    for value in values or []:
        if value not in POLICIES:
            raise typer.BadParameter(f"{value!r} is not one of {', '.join(POLICIES)}", param_hint="--policy")
    return values


def _check_pace(value: str) -> str:
    if value not in ("baseline", "all") and not value.isdigit():
        raise typer.BadParameter(f"must be 'baseline', 'all' or a level index, got {value!r}", param_hint="--pace")
    return value


def register(experiment: typer.Typer) -> None:
    @experiment.command("sort-cells-baselines")
    def sort_cells_baselines(
        episodes: int = typer.Option(
            64, "--episodes", min=2, max=65_536, help="Episodes (120 s each) per preset, the same for every policy."
        ),
        seed: int = options.seed(0, "Seed of the episodes (one batch per preset and policy),"),
        presets: list[str] = typer.Option(
            None,
            "--preset",
            metavar="NAME",
            callback=_check_names("--preset", "sort-cells"),
            help="A preset (repeatable; default: every one): robots, direct, robots-fast, direct-slow.",
        ),
        policies: list[str] = typer.Option(
            None,
            "--policy",
            metavar="NAME",
            callback=_check_sort_policies,
            help="A policy (repeatable; default: every one): baseline, random, idle.",
        ),
    ) -> None:
        """The sort-cells scripted baseline against random and idle policies per preset
        (robots against direct trapping): purity with its 95 % interval, yield,
        throughput, cells lost and the light dose per cell, as a markdown table.

        Example: otgym experiment sort-cells-baselines --episodes 64 --seed 0 --preset robots
        """
        from otgym.experiments.sort_cells.run import POLICIES, markdown, table
        from otgym.tasks.sort_cells import PRESETS

        rows = table(episodes, seed, tuple(presets or PRESETS), tuple(policies or POLICIES))
        print(markdown(rows))

    @experiment.command("assemble-baseline")
    def assemble_baseline(
        presets: list[str] = typer.Option(
            None,
            "--preset",
            metavar="NAME",
            callback=_check_names("--preset", "assemble"),
            help="A preset (repeatable; default: ring): ring, lattice, letter, ring-16.",
        ),
        episodes: int = typer.Option(64, "--episodes", min=1, max=65_536, help="Episodes per preset and policy."),
        seed: int = options.seed(0, "Seed of the episodes (the same for every policy),"),
        pace: str = typer.Option(
            "baseline",
            "--pace",
            metavar="PACE",
            callback=_check_pace,
            help="The paces run: 'baseline' (the largest level within half the waist), 'all', or a level's index.",
        ),
        policy: str = options.policy(None, "Also run this policy's greedy actions (policy.npz of otgym train --task)."),
    ) -> None:
        """The assemble task's scripted plan at constant paces (and a learned policy) on
        the same episodes: success with its 95 % interval, RMS error, time, beads lost,
        collisions, as a markdown table; and how often the plan's assignment is the
        Hungarian optimum.

        Example: otgym experiment assemble-baseline --preset ring --episodes 64 --seed 0 --pace baseline
        """
        from otgym.experiments.assemble.run import baseline_table, check_policy, paces
        from otgym.rl.policy import resolve_policy
        from otgym.tasks.assemble.config import PRESETS

        chosen = list(presets or ["ring"])
        for name in chosen:
            paces(pace, PRESETS[name])
        policy_path = None
        if policy is not None:
            policy_path = str(resolve_policy(policy))
            try:
                check_policy(policy_path, chosen)
            except (ValueError, OSError) as error:
                raise ValueError(f"--policy: {error}") from None
        for line in baseline_table(chosen, episodes, seed, pace, policy_path):
            print(line, flush=True)
