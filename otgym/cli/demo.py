"""``otgym demo``: the main job, a headless run that writes its results to a folder.

One line per stage on stdout, flushed, whether or not stdout is a terminal (a progress
bar follows the long stages only in a terminal). Like every command it keeps compiled
XLA programs in JAX's persistent cache (``otgym.cli.app``), so a second run skips most
of its compiling."""

from __future__ import annotations

import time
from contextlib import ExitStack
from pathlib import Path

import typer
from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

from otgym.cli import options
from otgym.experiments.demo.config import (
    DEMO_EPISODES,
    DEMO_RUNS,
    DEMO_SPEED_UM_S,
    DEMO_TASK_EPISODES,
    FULL_EPISODES,
    SIZE_RANGES,
    StudyConfig,
)
from otgym.experiments.demo.whole_path import RECOMMENDED_AUTONOMY


def _range(name: str) -> str:
    low, high = SIZE_RANGES[name]
    return f"[{low}, {high}]" if isinstance(low, int) else f"[{low:g}, {high:g}]"


def _bounds(name: str) -> dict:
    """typer's min/max of a size."""
    low, high = SIZE_RANGES[name]
    return {"min": low, "max": high}


def register(app: typer.Typer) -> None:
    @app.command()
    def demo(
        out: Path = options.out_dir(Path("results"), "Folder for the results (created if needed)."),
        policy: str = options.policy("pretrained", "Speed-control policy file or 'pretrained'."),
        episodes: int = typer.Option(
            DEMO_EPISODES,
            "--episodes",
            **_bounds("episodes"),
            help=f"Speed-control episodes per policy (RL, G1..G6, untrained), "
            f"{_range('episodes')}; `otgym evaluate` runs the full {FULL_EPISODES}.",
        ),
        speed_um_s: float = typer.Option(
            DEMO_SPEED_UM_S,
            "--speed-um-s",
            **_bounds("speed_um_s"),
            help=f"Constant speed of the whole path's route follower (the baseline beside the autonomy), um/s, "
            f"{_range('speed_um_s')}.",
        ),
        runs: int = typer.Option(
            DEMO_RUNS,
            "--runs",
            **_bounds("runs"),
            help=f"Whole-path scenarios, each run by the route follower and the autonomy in one batch, {_range('runs')}.",
        ),
        autonomy: str = options.registered(
            RECOMMENDED_AUTONOMY,
            "--autonomy",
            "navigators",
            "trial-mode",
            "The whole path's autonomy beside the route follower (rl: the learned speed; mpc: the MPC, "
            "which steps aside but replans every 0.1 s).",
        ),
        seed: int = options.seed(1, "Random seed of the episodes, runs and study,"),
        study_participants: int = typer.Option(
            StudyConfig.participants,
            "--study-participants",
            min=0,
            max=SIZE_RANGES["study_participants"][1],
            help=f"Simulated participants of the shared-control study, "
            f"{_range('study_participants')}; 0 leaves the study out.",
        ),
        study_trials: int = typer.Option(
            StudyConfig.trials,
            "--study-trials",
            **_bounds("study_trials"),
            help=f"Trials per participant and mode, {_range('study_trials')}.",
        ),
        study_time_limit_s: float = typer.Option(
            StudyConfig.time_limit_s,
            "--study-time-limit-s",
            **_bounds("study_time_limit_s"),
            help=f"Simulated seconds after which a study trial ends unfinished, {_range('study_time_limit_s')}.",
        ),
        task_episodes: int = typer.Option(
            DEMO_TASK_EPISODES,
            "--task-episodes",
            **_bounds("task_episodes"),
            help=f"Paired episodes of each task with a report in the registry (its learned policy against its "
            f"scripted baseline), {_range('task_episodes')}; 0 leaves them out.",
        ),
        sequential: bool = typer.Option(
            False,
            "--sequential",
            help="Run the study on its own, right after the planning, instead of beside the other stages.",
        ),
    ) -> None:
        """Plan on the default chip (Table I), evaluate the pretrained speed controller
        against constant speeds (Table II, safety violins), carry the cell along the
        whole path past moving obstacles with the learned speed (or the MPC) beside the
        constant-speed route follower, run a small manual/autonomous/shared study (Fig. 8), run each
        other task's learned policy beside its scripted baseline, and write report.md beside the
        paper's numbers. Small samples, a few minutes on two
        cores; every size is printed with its result.

        Example: otgym demo --out results
        """
        from otgym.experiments.demo.config import demo_config
        from otgym.experiments.demo.run import run_demo

        began = time.perf_counter()
        config = demo_config(
            policy,
            episodes,
            speed_um_s,
            runs,
            seed,
            study_participants,
            study_trials,
            study_time_limit_s,
            background_study=not sequential,
            autonomy=autonomy,
            task_episodes=task_episodes,
        )
        console = Console(soft_wrap=True)
        columns = (
            TextColumn("{task.description}"),
            BarColumn(),
            TextColumn("{task.completed}/{task.total}"),
            TimeElapsedColumn(),
        )
        with ExitStack() as stack:
            bars = {}  # the progress bars, started with the first stage: nothing shows before the checks pass

            def bar(name: str, description: str) -> None:
                if "progress" not in bars:
                    bars["progress"] = stack.enter_context(Progress(*columns, console=console, transient=True))
                if name not in bars:
                    bars[name] = bars["progress"].add_task(description, total=None)
                bars["progress"].update(bars[name], description=description)

            def stage(text: str) -> None:
                console.print(f"{text}  ({time.perf_counter() - began:.0f} s)", markup=False, highlight=False)
                console.file.flush()
                if "shared-control study" not in text:
                    bar("main", text.split(":")[0])
                    bars["progress"].update(bars["main"], completed=0, total=None)

            def report(done: int, total: int) -> None:
                if "main" in bars:
                    bars["progress"].update(bars["main"], completed=done, total=total)

            def detail(text: str) -> None:
                bar("study", f"shared-control study: {text}")

            summary = run_demo(config, out, stage, report, detail)
        console.print((out / "speed_control" / "table.md").read_text(), markup=False)
        safety, limits, whole_path = summary["safety"]["RL"], summary["limits"], summary["whole_path"]
        console.print(
            f"RL safety over {safety['samples']} force samples of {summary['episodes']} episodes: contact "
            f"force < {limits['force_pn']:g} pN in {safety['force_below_limit']:.2%} of them, handle within "
            f"{limits['distance_um']:g} um in {safety['distance_within_limit']:.2%}",
            highlight=False,
        )
        console.print(
            f"whole path past the moving obstacles ({whole_path['route_length_um']:g} um, seed {whole_path['seed']}): "
            + "; ".join(
                f"{row['name']} reached the goal in {row['reached_goal']} of {row['runs']} runs "
                f"({row['reached_goal_clean']} untouched), avoided {row['obstacles_avoided']} of "
                f"{row['obstacles_encountered']} obstacles met"
                for row in whole_path["modes"]
            ),
            highlight=False,
        )
        written = "plan/, speed_control/, whole_path/"
        if summary["tasks"] is not None:
            from otgym.experiments.demo.tasks import task_line

            console.print(f"the other tasks, {task_episodes} paired episodes each (seed {seed}):", highlight=False)
            for row in summary["tasks"]:
                console.print(f"  {task_line(row)}", markup=False, highlight=False)
            written += ", tasks/"
        study = summary["shared_control"]
        if study is not None:
            from otgym.study.paper_fig8 import PAPER_FIG8

            size = study["size"]
            console.print(
                f"shared-control study (Fig. 8), {size['participants']} simulated participants x "
                f"{size['trials_per_mode']} trial{'s' * (size['trials_per_mode'] > 1)} per mode, cut at "
                f"{size['time_limit_s']:g} s (details in report.md):",
                highlight=False,
            )
            for row in study["modes"]:
                paper = PAPER_FIG8.get(row["mode"], {})
                rate = (
                    f"{row['avoided_rate']:.0%}, 95 % CI {row['avoided_rate_ci_low']:.0%}-"
                    f"{row['avoided_rate_ci_high']:.0%}"
                    if row["obstacles_encountered"]
                    else "-"
                )
                time_s = (
                    ""
                    if row["completion_time_mean_s"] is None
                    else f", mean time {row['completion_time_mean_s']:.1f} s"
                )
                console.print(
                    f"  {row['mode']}: obstacles avoided {row['obstacles_avoided']} of "
                    f"{row['obstacles_encountered']} ({rate}), goal reached in {row['goals_reached']} of "
                    f"{row['trials']} trials{time_s}"
                    + (f" (paper: {paper['success_mean']:.0%} avoided, {paper['time_mean_s']:g} s)" if paper else ""),
                    highlight=False,
                )
            written += ", shared_control/"
        console.print(
            f"otgym demo wrote {out}/report.md, summary.json, {written} in "
            f"{time.perf_counter() - began:.0f} s (small samples; full size: otgym evaluate, "
            f"otgym experiment shared-control)",
            markup=False,
            highlight=False,
        )
