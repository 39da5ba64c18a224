"""``otgym experiment shared-control``: the paper's Fig. 8 (a, b) with simulated participants."""

from __future__ import annotations

from pathlib import Path

import typer

from otgym.cli import options
from otgym.experiments.common.seeds import REPORT_SEEDS


def parse_speeds(text: str) -> list[float]:
    """``"5,8"`` -> [5.0, 8.0]: at least one speed, each finite in (0, 20] um/s."""
    import math

    try:
        speeds = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        speeds = []
    if not speeds or not all(math.isfinite(v) and 0 < v <= 20 for v in speeds):
        raise ValueError(f"--speeds-um-s must be comma-separated speeds in (0, 20] um/s, got {text!r}")
    return speeds


def _check_speeds(value: str) -> str:
    try:
        parse_speeds(value)
    except ValueError as error:
        raise typer.BadParameter(str(error)) from None
    return value


def _check_modes(value: str) -> str:
    from otgym.experiments.shared_control.config import parse_modes

    try:
        parse_modes(value)
    except ValueError as error:
        raise typer.BadParameter(str(error), param_hint="--modes") from None
    return value


def _check_trace(value: str | None) -> str | None:
    from otgym.experiments.shared_control.trace_files import parse_trace

    if value is not None:
        try:
            parse_trace(value)
        except ValueError as error:
            raise typer.BadParameter(str(error), param_hint="--trace") from None
    return value


def register(app: typer.Typer) -> None:
    experiment = typer.Typer(
        help="The paper's experiments: Fig. 8 with simulated participants, Table II as a front.", no_args_is_help=True
    )
    app.add_typer(experiment, name="experiment")
    from otgym.cli.baselines import register as register_baselines
    from otgym.cli.calibrate import register as register_calibrate
    from otgym.cli.distil_mpc import register as register_distil_mpc
    from otgym.cli.human_sensitivity import register as register_human_sensitivity
    from otgym.cli.shipped import register as register_shipped
    from otgym.cli.speed_front import register as register_speed_front
    from otgym.cli.speed_policy import register as register_speed_policy
    from otgym.cli.task_experiment import register as register_task_experiments

    register_speed_front(experiment)
    register_calibrate(experiment)
    register_human_sensitivity(experiment)
    register_speed_policy(experiment)
    register_distil_mpc(experiment)
    register_task_experiments(experiment)
    register_baselines(experiment)
    register_shipped(experiment)

    @experiment.command("shared-control")
    def shared_control(
        participants: int = typer.Option(
            8,
            "--participants",
            min=1,
            max=1000,
            help="Simulated participants (the statistical tests need 2 or more; with "
            "one, summary.md says that no test is possible).",
        ),
        trials: int = typer.Option(8, "--trials", min=1, max=1000, help="Trials per participant and mode."),
        modes: str = typer.Option(
            "manual,autonomous,shared",
            "--modes",
            metavar="MODES",
            callback=_check_modes,
            help="Comma-separated modes: manual, autonomous, shared, or a navigator registered as a trial mode "
            "(otgym list navigators; built in: mpc, model-predictive; rl, autonomous with the learned speed).",
        ),
        seed: int = options.seed(
            REPORT_SEEDS["shared-control"],
            "Seed of the participants and scenarios (trial t: scenario SEED * 10000 + t); the default is the "
            "held-out report seed,",
        ),
        chip: str = options.chip("default"),
        time_limit_s: float = options.time_limit_s(),
        shared_autonomy: str = options.registered(
            "route", "--shared-autonomy", "navigators", "shared", "Shared control's dP_r: the navigator it blends with."
        ),
        mpc_rollouts: int = typer.Option(32, "--mpc-rollouts", min=1, max=4096, help="The MPC's rollouts per replan."),
        mpc_plan_steps: int = typer.Option(
            24, "--mpc-plan-steps", min=1, max=1000, help="The MPC's plan length in 0.1 s steps (horizon: one more)."
        ),
        rl_policy: Path = typer.Option(
            None,
            "--rl-policy",
            exists=True,
            dir_okay=False,
            metavar="FILE",
            help="The speed policy (.npz) of navigator rl; default: the shipped one (otgym experiment learned-speed).",
        ),
        out: Path = options.out_dir(..., "Folder for trials.csv, summary.*, stats.json, fig8.png."),
        trace: str = typer.Option(
            None,
            "--trace",
            metavar="P:T",
            callback=_check_trace,
            help="Also write participant P's trial T (from 0) tick by tick, per mode: trace_pP_tT_MODE.csv.",
        ),
    ) -> None:
        """Manual, autonomous, shared and model-predictive control on the same seeded
        scenarios: success (obstacles avoided / encountered) and completion time per
        mode (Fig. 8 a, b).

        Example: otgym experiment shared-control --participants 8 --trials 8 --out results/fig8
        """
        from otgym.autonomy.mpc import MPCConfig
        from otgym.experiments.common.output_folder import check_out_dir
        from otgym.experiments.shared_control.config import SharedControlConfig, parse_modes
        from otgym.experiments.shared_control.run import run_study
        from otgym.experiments.shared_control.trace_files import check_trace

        traced = None
        if trace is not None:
            try:
                traced = check_trace(trace, participants, trials)
            except ValueError as error:
                raise typer.BadParameter(str(error), param_hint="--trace") from None
        try:
            mpc_config = MPCConfig(n_rollouts=mpc_rollouts, plan_steps=mpc_plan_steps)
        except ValueError as error:
            raise ValueError(f"--mpc-rollouts/--mpc-plan-steps: {error}") from None
        if rl_policy is not None:
            from otgym.autonomy.rl_navigator import load_speed_policy

            try:
                speed_policy = load_speed_policy(rl_policy)
            except (OSError, ValueError) as error:
                raise typer.BadParameter(str(error), param_hint="--rl-policy") from None
        config = SharedControlConfig(
            participants,
            trials,
            tuple(parse_modes(modes)),
            seed,
            chip,
            time_limit_s,
            shared_autonomy,
            {"mpc": {"config": mpc_config}, **({} if rl_policy is None else {"rl": {"policy": speed_policy}})},
            traced,
        )
        check_out_dir(out)
        result = run_study(config, out, report=lambda line: print(line, flush=True))
        if result["traced"]:
            names = ", ".join(p.name for p in result["traced"])
            print(f"traced participant {traced[0]}'s trial {traced[1]}: {names}")
        print((out / "summary.md").read_text())
        for name, passed in result["checks"].items():
            print(f"{'PASS' if passed else 'FAIL'}  {name}")
        if result["note"]:
            print(result["note"])
        print(f"wrote {out}/" + ", ".join(result["written"]))

    @experiment.command("route-bound")
    def route_bound(
        trials: int = typer.Option(
            8, "--trials", min=1, max=1000, help="Scenarios: those of trials 0..N-1 of the study's seed."
        ),
        seed: int = options.seed(
            REPORT_SEEDS["route-bound"],
            "The study's seed (scenarios SEED * 10000 + trial); the default is the held-out report seed,",
        ),
        speeds_um_s: str = typer.Option(
            "5,8",
            "--speeds-um-s",
            metavar="NUMBERS",
            callback=_check_speeds,
            help="Comma-separated speed limits in um/s, each in (0, 20] (5: the autonomy's cruise; "
            "8: a person's hurried pace).",
        ),
        chip: str = options.chip("default"),
        out: Path = options.out_dir(..., "Folder for route_bound.csv, .json and .md."),
    ) -> None:
        """The earliest a controller that keeps the assembly on the planned route could
        reach the goal past the obstacles of shared-control's scenarios (perfect
        foresight): a lower bound on manual and shared control's completion time.

        Example: otgym experiment route-bound --trials 8 --out results/route-bound
        """
        from otgym.experiments.common.output_folder import check_out_dir
        from otgym.experiments.shared_control.config import check_arguments
        from otgym.experiments.shared_control.route_bound import run_route_bound, write_route_bound

        speeds = parse_speeds(speeds_um_s)
        check_arguments(2, trials, seed)
        check_out_dir(out)
        from otgym.experiments.common.seeds import development_note, mark_report_files

        note = development_note("route-bound", seed, trials=trials)
        if note:
            print(note, flush=True)
        frame = run_route_bound(trials, seed, speeds, chip, report=lambda line: print(line, flush=True))
        write_route_bound(frame, out)
        mark_report_files("route-bound", seed, [out / "route_bound.md"], trials=trials)
        print((out / "route_bound.md").read_text())
        if note:
            print(note)
        print(f"wrote {out}/route_bound.csv, route_bound.json, route_bound.md")
