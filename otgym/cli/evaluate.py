"""``otgym evaluate``: the RL policy against each constant speed on the same seeded
episodes; writes table.csv, table.md (Table II), safety.png (Fig. 7), safety.json and
acceptance.json (RL against the fastest constant speed as safe as it, paired tests)."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console

from otgym.cli import options
from otgym.experiments.common.seeds import REPORT_SEEDS


def register(app: typer.Typer) -> None:
    @app.command()
    def evaluate(
        policy: str = options.policy(...),
        episodes: int = typer.Option(
            256, "--episodes", min=1, max=2**20, help="Episodes per policy (the same seeded episodes for each)."
        ),
        out: Path = options.out_dir(Path("results/evaluate"), "Folder for the results."),
        seed: int = options.seed(
            REPORT_SEEDS["evaluate"],
            "Seed of the episodes (batch r: SEED + r); the default is the held-out report seed,",
        ),
        repeats: int = typer.Option(
            1,
            "--repeats",
            min=1,
            max=1000,
            help="Batches of --episodes to pool, seeds SEED .. SEED+R-1 "
            "(e.g. --episodes 256 --repeats 4: 1024 episodes over 4 seeds).",
        ),
    ) -> None:
        """Table II: ASR, ATCT and success rate of RL and constant speeds G1..Gn, and the safety figure.

        Example: otgym evaluate --policy pretrained --episodes 256 --out results/evaluate
        """
        if episodes < 1:
            raise ValueError(f"--episodes must be at least 1, got {episodes}")
        if not 1 <= repeats <= 1000:
            raise ValueError(f"--repeats must be between 1 and 1000, got {repeats}")
        from otgym.experiments.common.output_folder import check_out_dir

        check_out_dir(out)
        from otgym.experiments.common.seeds import development_note, mark_report_files
        from otgym.experiments.demo.report import reference_verdict
        from otgym.experiments.speed_control.evaluate import evaluate as run
        from otgym.experiments.speed_control.report import write_results
        from otgym.rl.policy import load_policy, policy_meta, resolve_policy
        from otgym.tasks.transport import core as tr
        from otgym.tasks.transport import speed_control as spc
        from otgym.tasks.transport.presets import preset

        path = resolve_policy(policy)
        task = preset(policy_meta(path).get("preset", "paper"))
        q_params, meta = load_policy(path, tr.OBS_SIZE, task.n_actions)
        console = Console()
        if development_note("evaluate", seed, batches=repeats):
            console.print(development_note("evaluate", seed, batches=repeats), style="bold yellow", markup=False)

        def progress(done: int, total: int) -> None:
            if total > 1:
                console.print(f"batch {done}/{total} done (seed {seed + done - 1})")

        with console.status("planning, compiling and running the episodes"):
            evaluation = run(
                spc.make_params(task), q_params, meta["hidden"], episodes, seed, repeats=repeats, progress=progress
            )
        limits = task.force_band_pn[1], task.deviation_limit_um
        rows, safety, checks = write_results(evaluation, out, *limits)
        note = mark_report_files("evaluate", seed, [out / "table.md"], [out / "acceptance.json"], batches=repeats)
        console.print((out / "table.md").read_text())
        console.print(reference_verdict(checks, rows))
        console.print(
            f"safety of RL: force < {limits[0]:g} pN in {safety['RL']['force_below_limit']:.2%} of samples, "
            f"handle within {limits[1]:g} um in {safety['RL']['distance_within_limit']:.2%}"
        )
        if note:
            console.print(note, style="bold yellow", markup=False)
        console.print(f"wrote {out}/table.csv, table.md, safety.png, safety.json, acceptance.json ({len(rows)} rows)")
