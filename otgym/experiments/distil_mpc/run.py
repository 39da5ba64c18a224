"""Distil the MPC into a policy network (``otgym.autonomy.mpc_policy``): record MPC
trials on development scenarios, train the clone, evaluate it in mode ``mpc`` trials
with the clone as navigator.

    otgym experiment distil-mpc collect OUT.npz --scenarios 32 --first 900000
    otgym experiment distil-mpc train DATA.npz POLICY.npz
    otgym experiment distil-mpc dagger DATA.npz POLICY.npz OUT_DIR --iterations 3 --scenarios 8 \
        --first 900100 --beta 0.5 --decay 0 --time-limit-s 90
    otgym experiment distil-mpc evaluate POLICY.npz --trials 64 --seed 14 [--mpc]

(``otgym.cli.distil_mpc`` parses and checks; this module runs.) ``dagger`` (Ross, Gordon & Bagnell 2011): each round drives the current clone (mixed
with the MPC by ``--beta``, times ``--decay`` each round) on the next ``--scenarios``
development scenarios (simulation seed 0, trials cut at ``--time-limit-s``), labels
the states it visits with the MPC's decisions, aggregates them with all data so far and
retrains; it writes OUT_DIR/dagger<round>.data.npz and OUT_DIR/dagger<round>.policy.npz
after every round (rounds use scenarios first, first + scenarios, ...).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd

from otgym.autonomy.mpc_policy import (
    ClonedPolicy,
    DAggerNavigator,
    PolicyNavigator,
    RecordingMPCNavigator,
    dagger,
    train,
)
from otgym.human.params import sample_population
from otgym.runtime.trials import TrialSpec, run_trials
from otgym.study.summary import summarize
from otgym.task.task import InteractiveConfig, InteractiveTask
from otgym.tasks.transport.interactive import interactive_scene


def _task(time_limit_s: float = 300.0) -> InteractiveTask:
    return InteractiveTask(InteractiveConfig(scene=interactive_scene(), time_limit_s=time_limit_s))


def _trials(task, scenarios, seed, navigator, stats, pairs: Callable[[], int] | None = None):
    """Run the scenarios as one batch in mode ``mpc`` (with ``navigator`` in the MPC's
    place where given; ``stats`` receives the MPC's replan statistics); progress at every tenth of the
    trials done and at least once a minute of wall time (with ``pairs()``, the
    (features, action) pairs kept so far)."""
    people = dict(enumerate(sample_population(1, seed)))
    specs = [TrialSpec(0, "mpc", t, s) for t, s in enumerate(scenarios)]
    last = [-1, time.perf_counter()]
    began = last[1]

    def progress(fraction):
        now = time.perf_counter()
        if int(fraction * 10) > last[0] or now - last[1] > 60.0:
            last[0], last[1] = max(last[0], int(fraction * 10)), now
            kept = f", {pairs()} pairs kept" if pairs is not None else ""
            print(f"  {fraction:.0%} of trials done, wall {now - began:.0f} s{kept}", flush=True)

    built = {} if navigator is None else {"mpc": navigator}
    navigators = {}
    rows = run_trials(task, specs, people, seed=seed, progress=progress, navigator_stats=navigators, navigators=built)
    stats.update(navigators.get("mpc", {}))
    return rows


def _kept(navigator) -> int:
    """Pairs kept so far by the recording ``navigator``."""
    return sum(len(f) for f in navigator.features)


DEVELOPMENT_FIRST_SCENARIO = 900_000
"""Collection and DAgger run on development scenarios only: numbers from here on."""


@dataclasses.dataclass(frozen=True)
class DaggerRun:
    """A ``dagger`` run: the data and clone to start from, the output folder and the
    rounds' sizes (``otgym experiment distil-mpc dagger --help``)."""

    data: Path
    policy: Path
    out: Path
    iterations: int = 1
    scenarios: int = 8
    first: int = 900_100
    beta: float = 0.0
    decay: float = 1.0
    label_every: int = 5
    epochs: int = 200
    time_limit_s: float = 300.0


def _fit(f, a, epochs: int) -> ClonedPolicy:
    """Train on a random 80 % and print the normalised MSE on the other 20 % (against
    the mean predictor's); a random split of the same trajectories, so optimistic."""
    order = np.random.default_rng(0).permutation(len(f))
    held, fit = order[: len(f) // 5], order[len(f) // 5 :]
    policy = train(f[fit], a[fit], epochs=epochs)
    err = np.mean(((policy(f[held]) - a[held]) / policy.action_std) ** 2)
    base = np.mean(((a[fit].mean(0) - a[held]) / policy.action_std) ** 2)
    print(
        f"held-out normalised MSE {err:.4f} (mean predictor {base:.4f}), {len(fit)} fit / {len(held)} held out",
        flush=True,
    )
    return policy


def dagger_rounds(args: DaggerRun) -> None:
    """Run ``args.iterations`` DAgger rounds, writing each round's data and clone."""
    data = np.load(args.data)
    task = _task(args.time_limit_s)
    out = Path(args.out)

    def collect(policy, round_):
        first = args.first + round_ * args.scenarios
        beta = args.beta * args.decay**round_
        nav = DAggerNavigator.for_task(task, policy=policy, beta=beta, label_every=args.label_every)
        began = time.perf_counter()
        print(
            f"round {round_ + 1}: the clone on scenarios {first}-{first + args.scenarios - 1} (beta {beta:g})",
            flush=True,
        )
        rows = pd.DataFrame(_trials(task, range(first, first + args.scenarios), 0, nav, {}, pairs=lambda: _kept(nav)))
        taken = np.concatenate(nav.taken) if nav.taken else np.zeros(0, bool)
        share = taken.mean() if len(taken) else 0.0
        print(
            f"round {round_ + 1}: {len(taken)} states labelled by the MPC ({share:.0%} "
            f"executed its action); the rollouts: goal {int(rows['reached_goal'].sum())} of {len(rows)}, "
            f"wall {time.perf_counter() - began:.0f} s",
            flush=True,
        )
        return np.concatenate(nav.features), np.concatenate(nav.actions)

    rounds = dagger(
        ClonedPolicy.load(args.policy),
        data["features"],
        data["actions"],
        collect,
        args.iterations,
        fit=lambda f, a: _fit(f, a, args.epochs),
    )
    for round_, policy, features, actions in rounds:
        np.savez(out / f"dagger{round_ + 1}.data.npz", features=features, actions=actions)
        policy.save(out / f"dagger{round_ + 1}.policy.npz")
        print(
            f"round {round_ + 1}: {len(features)} pairs in all -> {out}/dagger{round_ + 1}.{{data,policy}}.npz",
            flush=True,
        )


def collect(out: Path, scenarios: int = 32, first: int = DEVELOPMENT_FIRST_SCENARIO) -> None:
    """Record the MPC's (features, action) pairs on ``scenarios`` development scenarios."""
    task = _task()
    nav = RecordingMPCNavigator.for_task(task)
    _trials(task, range(first, first + scenarios), 0, nav, {}, pairs=lambda: _kept(nav))
    np.savez(out, features=np.concatenate(nav.features), actions=np.concatenate(nav.actions))
    print(f"{sum(len(f) for f in nav.features)} pairs -> {out}")


def fit_file(data: Path, out: Path, epochs: int = 200) -> None:
    """Train the clone on a collected data file and save it."""
    loaded = np.load(data)
    _fit(loaded["features"], loaded["actions"], epochs).save(out)


def evaluate(policy: Path, trials: int = 64, seed: int = 14, mpc: bool = False) -> None:
    """The clone (or, with ``mpc``, the MPC itself) as navigator of mode ``mpc`` trials
    on scenarios ``seed * 10000 + t``; writes POLICY[.mpc].seedSEED.csv beside it."""
    task = _task()
    scenarios = [seed * 10_000 + t for t in range(trials)]
    stats = {}
    navigator = None if mpc else PolicyNavigator.for_task(task, seed=seed, policy=ClonedPolicy.load(policy))
    began = time.perf_counter()
    rows = _trials(task, scenarios, seed, navigator, stats)
    frame = pd.DataFrame(rows)
    print(summarize(frame).T.to_string())
    seconds, sizes = np.asarray(stats["replan_seconds"]), np.asarray(stats["environments_planned"])
    print(
        f"decision time per environment {1e3 * seconds.sum() / sizes.sum():.3f} ms; wall {time.perf_counter() - began:.0f} s"
    )
    frame.to_csv(str(policy) + (".mpc" if mpc else "") + f".seed{seed}.csv", index=False)
