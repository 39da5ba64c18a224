"""Distil the MPC into a policy network (``otgym.autonomy.mpc_policy``): record MPC
trials on development scenarios, train the clone, evaluate it in mode ``mpc`` trials
with the clone as navigator.

    python -m otgym.experiments.distil_mpc collect OUT.npz --scenarios 32 --first 900000
    python -m otgym.experiments.distil_mpc train DATA.npz POLICY.npz
    python -m otgym.experiments.distil_mpc dagger DATA.npz POLICY.npz OUT_DIR --iterations 3 --scenarios 8 \
        --first 900100 --beta 0.5 --decay 0 --time-limit 90
    python -m otgym.experiments.distil_mpc evaluate POLICY.npz --trials 64 --seed 14 [--mpc]

``dagger`` (Ross, Gordon & Bagnell 2011): each round drives the current clone (mixed
with the MPC by ``--beta``, times ``--decay`` each round) on the next ``--scenarios``
development scenarios (simulation seed 0, trials cut at ``--time-limit`` s), labels
the states it visits with the MPC's decisions, aggregates them with all data so far and
retrains; it writes OUT_DIR/dagger<round>.data.npz and OUT_DIR/dagger<round>.policy.npz
after every round (rounds use scenarios first, first + scenarios, ...).
"""

from __future__ import annotations

import argparse
import functools
import sys
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
from otgym.task.task import InteractiveConfig, InteractiveTask, interactive_scene


def _task(time_limit_s: float = 300.0) -> InteractiveTask:
    return InteractiveTask(InteractiveConfig(scene=interactive_scene(), time_limit_s=time_limit_s))


def _trials(task, scenarios, seed, navigator, stats, pairs: Callable[[], int] | None = None):
    """Run the scenarios as one batch in mode ``mpc``; progress at every tenth of the
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

    return run_trials(task, specs, people, seed=seed, progress=progress, mpc_stats=stats, mpc_navigator=navigator)


def _kept(holder: dict) -> int:
    """Pairs kept so far by the recording navigator in ``holder`` (0 before it is built)."""
    return sum(len(f) for f in holder["nav"].features) if "nav" in holder else 0


def _positive(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive whole number, got {text}")
    return value


def _fraction(text: str) -> float:
    value = float(text)
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"must be between 0 and 1, got {text}")
    return value


def _check(args) -> None:
    """Bad input as one line before any work: ValueError with the reason."""
    if args.command in ("collect", "dagger") and args.first < 900000:
        raise ValueError(f"{args.command} only from development scenarios (--first >= 900000)")
    if args.command == "dagger" and args.time_limit <= 0:
        raise ValueError(f"--time-limit must be positive, got {args.time_limit}")
    for name in ("data", "policy"):
        path = getattr(args, name, None)
        if path is not None and not Path(path).is_file():
            raise ValueError(f"{path} is not a file")
    out = getattr(args, "out", None)
    if args.command == "dagger":
        if not Path(out).is_dir():
            raise ValueError(f"the output folder {out} does not exist")
    elif out is not None and not Path(out).resolve().parent.is_dir():
        raise ValueError(f"the folder of {out} does not exist")


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


def _dagger(args) -> None:
    data = np.load(args.data)
    task = _task(args.time_limit)
    out = Path(args.out)

    def collect(policy, round_):
        first = args.first + round_ * args.scenarios
        beta = args.beta * args.decay**round_
        holder = {}

        def factory(*a, **k):
            holder["nav"] = DAggerNavigator(*a, policy=policy, beta=beta, label_every=args.label_every, **k)
            return holder["nav"]

        began = time.perf_counter()
        print(
            f"round {round_ + 1}: the clone on scenarios {first}-{first + args.scenarios - 1} (beta {beta:g})",
            flush=True,
        )
        rows = pd.DataFrame(
            _trials(task, range(first, first + args.scenarios), 0, factory, {}, pairs=lambda: _kept(holder))
        )
        nav = holder["nav"]
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


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="distil_mpc")
    sub = parser.add_subparsers(dest="command", required=True)
    collect = sub.add_parser("collect")
    collect.add_argument("out")
    collect.add_argument("--scenarios", type=_positive, default=32)
    collect.add_argument("--first", type=int, default=900000)
    fit = sub.add_parser("train")
    fit.add_argument("data")
    fit.add_argument("out")
    fit.add_argument("--epochs", type=_positive, default=200)
    aggregate = sub.add_parser("dagger")
    aggregate.add_argument("data")
    aggregate.add_argument("policy")
    aggregate.add_argument("out")
    aggregate.add_argument("--iterations", type=_positive, default=1)
    aggregate.add_argument("--scenarios", type=_positive, default=8)
    aggregate.add_argument("--first", type=int, default=900100)
    aggregate.add_argument(
        "--beta",
        type=_fraction,
        default=0.0,
        help="probability that a labelled decision executes the MPC's action in round 1",
    )
    aggregate.add_argument(
        "--decay",
        type=_fraction,
        default=1.0,
        help="beta of round i is beta * decay ** (i - 1) (Ross et al.'s beta_i = p ** (i - 1))",
    )
    aggregate.add_argument("--label-every", type=_positive, default=5)
    aggregate.add_argument("--epochs", type=_positive, default=200)
    aggregate.add_argument("--time-limit", type=float, default=300.0)
    evaluate = sub.add_parser("evaluate")
    evaluate.add_argument("policy")
    evaluate.add_argument("--trials", type=_positive, default=64)
    evaluate.add_argument("--seed", type=int, default=14)
    evaluate.add_argument("--mpc", action="store_true")
    args = parser.parse_args(argv)
    try:
        _check(args)
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    if args.command == "collect":
        holder = {}

        def factory(*a, **k):
            holder["nav"] = RecordingMPCNavigator(*a, **k)
            return holder["nav"]

        _trials(_task(), range(args.first, args.first + args.scenarios), 0, factory, {}, pairs=lambda: _kept(holder))
        nav = holder["nav"]
        np.savez(args.out, features=np.concatenate(nav.features), actions=np.concatenate(nav.actions))
        print(f"{sum(len(f) for f in nav.features)} pairs -> {args.out}")
    elif args.command == "train":
        data = np.load(args.data)
        _fit(data["features"], data["actions"], args.epochs).save(args.out)
    elif args.command == "dagger":
        _dagger(args)
    else:
        task = _task()
        scenarios = [args.seed * 10_000 + t for t in range(args.trials)]
        stats = {}
        navigator = None if args.mpc else functools.partial(PolicyNavigator, policy=ClonedPolicy.load(args.policy))
        began = time.perf_counter()
        rows = _trials(task, scenarios, args.seed, navigator, stats)
        frame = pd.DataFrame(rows)
        print(summarize(frame).T.to_string())
        seconds, sizes = np.asarray(stats["replan_seconds"]), np.asarray(stats["environments_planned"])
        print(
            f"decision time per environment {1e3 * seconds.sum() / sizes.sum():.3f} ms; wall {time.perf_counter() - began:.0f} s"
        )
        frame.to_csv(args.policy + (".mpc" if args.mpc else "") + f".seed{args.seed}.csv", index=False)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
