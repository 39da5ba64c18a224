"""Distil the MPC into a policy network (``otgym.runtime.mpc_policy``): record MPC
trials on development scenarios, train the clone, evaluate it in mode ``mpc`` trials
with the clone as navigator.

    python -m otgym.experiments.distil_mpc collect OUT.npz --scenarios 32 --first 900000
    python -m otgym.experiments.distil_mpc train DATA.npz POLICY.npz
    python -m otgym.experiments.distil_mpc evaluate POLICY.npz --trials 64 --seed 14 [--mpc]
"""

from __future__ import annotations

import argparse
import functools
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

from otgym.runtime.mpc_policy import ClonedPolicy, PolicyNavigator, RecordingMPCNavigator, train
from otgym.study.summary import summarize
from otgym.runtime.task import InteractiveConfig, InteractiveTask, interactive_scene
from otgym.runtime.trials import TrialSpec, run_trials
from otgym.planning.human import sample_population


def _task() -> InteractiveTask:
    return InteractiveTask(InteractiveConfig(scene=interactive_scene(), time_limit_s=300.0))


def _trials(task, scenarios, seed, navigator, stats):
    people = dict(enumerate(sample_population(1, seed)))
    specs = [TrialSpec(0, "mpc", t, s) for t, s in enumerate(scenarios)]
    last = [-1]

    def progress(fraction):
        if int(fraction * 10) > last[0]:
            last[0] = int(fraction * 10)
            print(f"  {fraction:.0%} of trials done", flush=True)

    return run_trials(task, specs, people, seed=seed, progress=progress, mpc_stats=stats, mpc_navigator=navigator)


def _positive(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive whole number, got {text}")
    return value


def _check(args) -> None:
    """Bad input as one line before any work: ValueError with the reason."""
    if args.command == "collect" and args.first < 900000:
        raise ValueError("collect only from development scenarios (--first >= 900000)")
    for name in ("data", "policy"):
        path = getattr(args, name, None)
        if path is not None and not Path(path).is_file():
            raise ValueError(f"{path} is not a file")
    out = getattr(args, "out", None)
    if out is not None and not Path(out).resolve().parent.is_dir():
        raise ValueError(f"the folder of {out} does not exist")


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

        _trials(_task(), range(args.first, args.first + args.scenarios), 0, factory, {})
        nav = holder["nav"]
        np.savez(args.out, features=np.concatenate(nav.features), actions=np.concatenate(nav.actions))
        print(f"{sum(len(f) for f in nav.features)} pairs -> {args.out}")
    elif args.command == "train":
        data = np.load(args.data)
        f, a = data["features"], data["actions"]
        order = np.random.default_rng(0).permutation(len(f))
        held = order[: len(f) // 5]
        fit = order[len(f) // 5:]
        policy = train(f[fit], a[fit], epochs=args.epochs)
        err = np.mean(((policy(f[held]) - a[held]) / policy.action_std) ** 2)
        base = np.mean(((a[fit].mean(0) - a[held]) / policy.action_std) ** 2)
        print(f"held-out normalised MSE {err:.4f} (mean predictor {base:.4f}), {len(fit)} fit / {len(held)} held out")
        policy.save(args.out)
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
        print(f"decision time per environment {1e3 * seconds.sum() / sizes.sum():.3f} ms; wall {time.perf_counter() - began:.0f} s")
        frame.to_csv(args.policy + (".mpc" if args.mpc else "") + f".seed{args.seed}.csv", index=False)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
