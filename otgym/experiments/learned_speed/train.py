"""Training of the interactive task's learned speed policy (navigator ``rl``,
``otgym.autonomy.rl_navigator``): the one DQN trainer (``otgym.rl.dqn`` through
``otgym.experiments.speed_control.train.train_task``) on task ``interactive-speed``
(``otgym.tasks.transport.interactive_speed``: the interactive task in autonomous mode,
one step per 0.5 s speed decision), preset ``train`` (its pool of 640 scenarios from
962000), with the task's own DQN hyper-parameters (``InteractiveSpeed.dqn_config``).
The same as ``otgym train --task interactive-speed --preset train --seed 31``; this
module names the registered training seed and writes the policy where the navigator
reads it.

Run ``otgym experiment learned-speed [--out OUT.npz]`` (default: the shipped
``otgym/data/policies/speed_interactive.npz``); the training seed and the scenarios are
registered in ``otgym.experiments.common.seeds``.
"""

from __future__ import annotations

from pathlib import Path

from otgym import tasks
from otgym.experiments.speed_control.train import TrainResult, train_task
from otgym.rl.dqn import DQNConfig
from otgym.rl.policy import save_policy

TASK = "interactive-speed"
PRESET = "train"
TRAINING_SEED = 31


def train(seed: int = TRAINING_SEED, progress=None, preset: str = PRESET, **overrides) -> TrainResult:
    """Train the speed policy (module docstring); ``overrides`` replace ``DQNConfig``
    fields of the task's own (a shorter run, fewer environments)."""
    task = tasks.load(TASK)
    config = DQNConfig(**{**task.dqn_config(task.config(preset)), **overrides})
    return train_task(task, None, config, seed, progress, preset=preset)


def save_speed_policy(path, result: TrainResult) -> Path:
    """Write the trained policy with its meta (the task, speeds, decision period, the DQN's settings)."""
    return save_policy(path, result.q_params, {**result.meta, "wall_s": round(result.wall_s, 1)})
