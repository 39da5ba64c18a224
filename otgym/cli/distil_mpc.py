"""``otgym experiment distil-mpc collect|train|dagger|evaluate``: distil the MPC into a
policy network (``otgym.experiments.distil_mpc.run`` runs each step; this module parses and
checks)."""

from __future__ import annotations

from pathlib import Path

import typer

from otgym.cli import options

SCENARIO_MAX = 10**9


def _development(value: int) -> int:
    from otgym.experiments.distil_mpc.run import DEVELOPMENT_FIRST_SCENARIO

    if value < DEVELOPMENT_FIRST_SCENARIO:
        raise typer.BadParameter(
            f"must be a development scenario (>= {DEVELOPMENT_FIRST_SCENARIO}), got {value}", param_hint="--first"
        )
    return value


def _first(default: int) -> typer.Option:
    return typer.Option(
        default,
        "--first",
        min=0,
        max=SCENARIO_MAX,
        callback=_development,
        help="First development scenario (>= 900000).",
    )


def _scenarios(default: int) -> typer.Option:
    return typer.Option(default, "--scenarios", min=1, max=4096, help="Scenarios (trials) to run.")


def _epochs() -> typer.Option:
    return typer.Option(200, "--epochs", min=1, max=100_000, help="Training epochs of the clone.")


def _input_file(help: str) -> typer.Argument:
    return typer.Argument(..., exists=True, file_okay=True, dir_okay=False, help=help)


def _output_file(help: str) -> typer.Argument:
    return typer.Argument(..., file_okay=True, dir_okay=False, help=help)


def _folder_of(path: Path) -> Path:
    if not path.resolve().parent.is_dir():
        raise typer.BadParameter(f"the folder of {path} does not exist", param_hint="OUT")
    return path


def register(experiment: typer.Typer) -> None:
    distil = typer.Typer(help="Distil the MPC into a policy network: collect, train, dagger, evaluate.")
    experiment.add_typer(distil, name="distil-mpc")

    @distil.command("collect")
    def collect(
        out: Path = _output_file("The data file to write (.npz)."),
        scenarios: int = _scenarios(32),
        first: int = _first(900_000),
    ) -> None:
        """Record the MPC's decisions (route-frame features, action) on development scenarios.

        Example: otgym experiment distil-mpc collect results/bc8.npz --scenarios 8 --first 900000
        """
        from otgym.experiments.distil_mpc.run import collect as run

        run(_folder_of(out), scenarios, first)

    @distil.command("train")
    def train(
        data: Path = _input_file("A data file from collect or dagger (.npz)."),
        out: Path = _output_file("The policy file to write (.npz)."),
        epochs: int = _epochs(),
    ) -> None:
        """Train the clone on collected decisions; prints its held-out error.

        Example: otgym experiment distil-mpc train results/bc8.npz results/bc8.policy.npz
        """
        from otgym.experiments.distil_mpc.run import fit_file

        fit_file(data, _folder_of(out), epochs)

    @distil.command("dagger")
    def dagger(
        data: Path = _input_file("The data so far (.npz)."),
        policy: Path = _input_file("The clone to start from (.npz)."),
        out: Path = typer.Argument(
            ..., exists=True, file_okay=False, dir_okay=True, help="An existing folder for each round's files."
        ),
        iterations: int = typer.Option(1, "--iterations", min=1, max=100, help="DAgger rounds."),
        scenarios: int = _scenarios(8),
        first: int = _first(900_100),
        beta: float = typer.Option(
            0.0, "--beta", min=0.0, max=1.0, help="Probability that a labelled decision executes the MPC's in round 1."
        ),
        decay: float = typer.Option(
            1.0, "--decay", min=0.0, max=1.0, help="Round i's beta is beta * decay ** (i - 1) (Ross et al. 2011)."
        ),
        label_every: int = typer.Option(5, "--label-every", min=1, max=10_000, help="Label every n-th decision."),
        epochs: int = _epochs(),
        time_limit_s: float = options.time_limit_s(),
    ) -> None:
        """DAgger (Ross et al. 2011): drive the clone, label its states by the MPC, retrain.

        Each round drives the current clone (mixed with the MPC by --beta) on the next
        --scenarios development scenarios, labels the states it visits with the MPC's
        decisions, aggregates them with all data so far and retrains.

        Example: otgym experiment distil-mpc dagger results/bc8.npz results/bc8.policy.npz results/dagger --iterations 3 --beta 0.5 --decay 0 --time-limit-s 90
        """
        from otgym.experiments.distil_mpc.run import DaggerRun, dagger_rounds

        dagger_rounds(
            DaggerRun(data, policy, out, iterations, scenarios, first, beta, decay, label_every, epochs, time_limit_s)
        )

    @distil.command("evaluate")
    def evaluate(
        policy: Path = _input_file("The clone to evaluate (.npz)."),
        trials: int = typer.Option(64, "--trials", min=1, max=4096, help="Trials (scenarios SEED * 10000 + t)."),
        seed: int = options.seed(14, "Scenarios' and simulation's seed,"),
        mpc: bool = typer.Option(False, "--mpc", help="Run the MPC itself instead of the clone (the reference)."),
    ) -> None:
        """The clone as the navigator of mode-mpc trials: goals, obstacles avoided, decision time.

        Example: otgym experiment distil-mpc evaluate results/dagger/dagger3.policy.npz --trials 64 --seed 14
        """
        from otgym.experiments.distil_mpc.run import evaluate as run

        run(policy, trials, seed, mpc)
