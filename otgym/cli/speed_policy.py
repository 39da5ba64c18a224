"""``otgym experiment pretrain`` (how the shipped speed-control policy is made) and
``otgym experiment reward-terms`` (does every term of its reward matter?)."""

from __future__ import annotations

from pathlib import Path

import typer

from otgym.cli import options


def _seeds(text: str) -> list[int]:
    """``"0,1,2"`` -> [0, 1, 2]: distinct seeds in [0, 2**32 - 1] (typer.BadParameter)."""
    try:
        seeds = [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        seeds = []
    if not seeds or any(not 0 <= seed < 2**32 for seed in seeds) or len(set(seeds)) != len(seeds):
        raise typer.BadParameter(
            f"must be distinct comma-separated seeds in [0, 2**32 - 1], got {text!r}", param_hint="--seeds"
        )
    return seeds


def register(experiment: typer.Typer) -> None:
    from otgym.rl.policy import PRETRAINED_POLICY

    @experiment.command("pretrain")
    def pretrain(
        seeds: str = typer.Option(
            "0,1,2",
            "--seeds",
            metavar="NUMBERS",
            callback=lambda value: value if _seeds(value) else value,
            help="Comma-separated training seeds.",
        ),
        steps: int = typer.Option(204_800, "--steps", min=1, max=10**9, help="Environment steps per seed."),
        out: Path = typer.Option(PRETRAINED_POLICY, "--out", dir_okay=False, help="The policy file to write."),
    ) -> None:
        """Train the speed controller on several seeds, keep the best on validation
        episodes, write its policy (the shipped one by default).

        Example: otgym experiment pretrain --seeds 0,1,2 --out results/policy.npz
        """
        from otgym.experiments.speed_control.pretrain import run

        chosen = _seeds(seeds)
        if out.parent and not out.parent.is_dir():
            raise typer.BadParameter(f"folder {out.parent} does not exist", param_hint="--out")
        run(chosen, steps, out, log=lambda line: print(line, flush=True))

    @experiment.command("reward-terms")
    def reward_terms(
        policy: str = options.policy("pretrained"),
        episodes: int = typer.Option(256, "--episodes", min=1, max=4096, help="Episodes per policy."),
        seed: int = options.seed(401, "Episodes' seed,"),
        out: Path = options.out_dir(..., "Folder for reward_terms.csv, .md and .png."),
    ) -> None:
        """How often each term of the speed-control reward binds, for the policy and for
        random speeds on the same episodes.

        Example: otgym experiment reward-terms --episodes 256 --seed 401 --out results/reward-terms
        """
        from otgym.experiments.speed_control.reward_terms import run

        try:
            run(policy, episodes, seed, out, log=lambda line: print(line, flush=True))
        except (ValueError, OSError) as error:
            raise typer.BadParameter(str(error)) from None
