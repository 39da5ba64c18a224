"""How the shipped speed-control policy is made, and how the training benchmark reaches
the acceptance: train a few seeds, keep the one that does best on validation
episodes; its Table II is then measured on other, held-out episodes (the report seeds
of ``otgym.experiments.common.seeds``; the validation here is ``VALIDATION_SEED``), so the
reported figures are not the ones it was picked on.

Selection rule: most validation episodes completed, then the lowest mean completion
time. Seeds run one after the other: two cores gain nothing from running them at once.

    otgym experiment pretrain [--seeds 0,1,2] [--steps 204800] [--out FILE]
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import numpy as np

from otgym.experiments.speed_control.evaluate import evaluate
from otgym.experiments.speed_control.train import TrainResult, train
from otgym.rl.dqn import DQNConfig
from otgym.rl.policy import save_policy
from otgym.tasks.transport import speed_control as spc
from otgym.tasks.transport.presets import TaskConfig, paper

VALIDATION_SEED = 1000
VALIDATION_EPISODES = 256


@dataclasses.dataclass
class Candidate:
    seed: int
    result: TrainResult
    successes: int
    mean_time_s: float

    def score(self):
        return self.successes, -self.mean_time_s


def train_and_select(
    task: TaskConfig, config: DQNConfig, seeds, params=None, episodes: int = VALIDATION_EPISODES, log=print
) -> tuple[Candidate, list[Candidate]]:
    """Train each seed, validate each on the same ``episodes`` episodes, return the best
    and all candidates."""
    params = spc.make_params(task) if params is None else params
    candidates = []
    for seed in seeds:
        result = train(task, config, seed, params=params)
        validation = evaluate(params, result.q_params, config.hidden, episodes, VALIDATION_SEED, policies=(0,))
        won = validation.success[0]
        mean_time = float(validation.time_s[0][won].mean()) if won.any() else float("inf")
        candidates.append(Candidate(seed, result, int(won.sum()), mean_time))
        log(
            f"seed {seed}: trained {result.env_steps} steps in {result.wall_s:.0f} s; validation "
            f"{int(won.sum())}/{episodes} completed, mean time {mean_time:.2f} s"
        )
    return max(candidates, key=Candidate.score), candidates


def run(seeds: list[int], steps: int, out: Path, log=print) -> Path:
    """Train ``seeds``, keep the best on the validation episodes, write its policy to ``out``."""
    start = time.perf_counter()
    task = paper()
    config = DQNConfig(total_env_steps=steps)
    best, candidates = train_and_select(task, config, seeds, log=log)
    meta = {
        **best.result.meta,
        "validation_seed": VALIDATION_SEED,
        "validation_episodes": VALIDATION_EPISODES,
        "validation_successes": best.successes,
        "validation_mean_time_s": round(best.mean_time_s, 3),
        "candidate_seeds": [c.seed for c in candidates],
        "candidate_successes": [c.successes for c in candidates],
    }
    save_policy(out, best.result.q_params, meta)
    log(
        f"kept seed {best.seed}; wrote {out} ({time.perf_counter() - start:.0f} s in all, "
        f"{np.sum([c.result.wall_s for c in candidates]):.0f} s training)"
    )
    return out
