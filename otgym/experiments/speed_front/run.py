"""Table II as a front (``otgym experiment speed-front``): a family of learned speed
controllers, one per reward and training seed, and the shipped policy, against the six
constant speeds on the same held-out episodes.

The family varies the reward's failure penalty (and optionally its time cost), every
other term as the ``paper`` preset's ``RewardWeights``; each member is trained by
``otgym.experiments.speed_control.train.train`` with ``FRONT_DQN`` (the shipped policy's
training configuration). Training seeds come from the run's seed
(``training_seeds``), the same for every reward, so that rewards are compared on the
same training draws. Evaluation: ``episodes`` episodes in batches of
``seeds.EPISODES_PER_BATCH``, batch r on seed ``seed + r``, every policy and constant
speed on the same episodes (``make_outcome_rollout``: ``otgym evaluate``'s episodes for
the same seeds). What the front and goals are: ``otgym.experiments.speed_front.stats``.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np

from otgym.experiments.common import seeds as seed_protocol
from otgym.experiments.speed_control.train import train
from otgym.experiments.speed_front.config import FrontConfig, group_name, training_seeds
from otgym.experiments.speed_front.stats import Outcomes
from otgym.rl.dqn import DQNConfig
from otgym.rl.network import QNetwork
from otgym.tasks.transport import core as tr
from otgym.tasks.transport import speed_control as spc
from otgym.tasks.transport.presets import TaskConfig, paper

FRONT_DQN = DQNConfig()
"""Training configuration of every family member: the shipped policy's."""


def member_task(task: TaskConfig, penalty: float, time_cost: float) -> TaskConfig:
    """``task`` with the reward priced at failure penalty ``penalty`` (``RewardWeights.priced``:
    the precursor shaping scaled with it) and time cost ``time_cost`` per control step."""
    reward = dataclasses.replace(task.reward.priced(penalty), time=-float(time_cost))
    return dataclasses.replace(task, reward=reward)


@dataclasses.dataclass
class Member:
    name: str
    group: str
    penalty: float
    time_cost: float
    training_seed: int
    train_s: float
    q_params: dict
    hidden: tuple[int, ...] = FRONT_DQN.hidden

    @property
    def file_stem(self) -> str:
        """``penalty100_time0.05_seed1``: the member's policy file name without suffix."""
        return f"penalty{self.penalty:g}_time{self.time_cost:g}_seed{self.name.rsplit('#', 1)[1]}"


@dataclasses.dataclass
class FrontResult:
    config: FrontConfig
    outcomes: list[Outcomes]  # constants G1..Gn, then pretrained, then the family
    members: list[Member]
    evaluation_seeds: list[int]
    wall_s: float
    seed_note: str | None  # development_note of the run's seed


Progress = Callable[[str, int, int], None]
"""``progress(stage, done, total)``: stage "train" (trainings) or "evaluate" (policy runs)."""


def run_front(config: FrontConfig, progress: Progress | None = None, pretrained_q=None) -> FrontResult:
    """Train the family, then evaluate the constant speeds, ``pretrained_q`` (the
    shipped policy's (q_params, hidden), if given) and every member on the same
    episodes."""
    start = time.perf_counter()
    progress = progress or (lambda stage, done, total: None)
    base = paper()
    params = spc.make_params(base)
    seeds = training_seeds(config.seed, config.seeds)
    dqn = dataclasses.replace(FRONT_DQN, total_env_steps=config.steps)
    members = []
    progress("train", 0, config.trainings)
    for penalty, time_cost in config.rewards:
        task = member_task(base, penalty, time_cost)
        member_params = params.replace(config=task)
        for index, seed in enumerate(seeds):
            result = train(task, dqn, seed, params=member_params)
            group = group_name(penalty, time_cost)
            members.append(
                Member(f"{group} #{index + 1}", group, penalty, time_cost, seed, result.wall_s, result.q_params)
            )
            progress("train", len(members), config.trainings)

    hidden = tuple(dqn.hidden)
    runs = base.n_actions + (pretrained_q is not None) + len(members)
    progress("evaluate", 0, runs)
    rollout = make_outcome_rollout(params, hidden, config.batch_size)
    keys = [jax.random.PRNGKey(config.seed + r) for r in range(config.batches)]
    any_q = members[0].q_params if members else pretrained_q[0]

    def run(q_params, level: int):
        parts = [jax.device_get(rollout(q_params, level, key)) for key in keys]
        return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])

    outcomes = []
    for level, speed in enumerate(base.speed_levels_um_s):
        outcomes.append(Outcomes(f"G{level + 1}", *run(any_q, level), speed))
        progress("evaluate", len(outcomes), runs)
    if pretrained_q is not None:
        q_params, pretrained_hidden = pretrained_q
        shipped_rollout = rollout if tuple(pretrained_hidden) == hidden else None
        if shipped_rollout is None:  # another network shape: its own compiled rollout
            shipped_rollout = make_outcome_rollout(params, tuple(pretrained_hidden), config.batch_size)
        parts = [jax.device_get(shipped_rollout(q_params, -1, key)) for key in keys]
        success, time_s = np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])
        outcomes.append(Outcomes("pretrained", success, time_s, None, "pretrained"))
        progress("evaluate", len(outcomes), runs)
    for member in members:
        outcomes.append(Outcomes(member.name, *run(member.q_params, -1), None, member.group))
        progress("evaluate", len(outcomes), runs)
    note = seed_protocol.development_note("speed-front", config.seed, batches=config.batches)
    evaluation_seeds = list(range(config.seed, config.seed + config.batches))
    return FrontResult(config, outcomes, members, evaluation_seeds, time.perf_counter() - start, note)


def make_outcome_rollout(params: tr.TransportParams, hidden, n_episodes: int):
    """A jitted ``rollout(q_params, level, key) -> (success (N,), time_s (N,))`` of
    ``n_episodes`` episodes: greedy on the Q-network when ``level`` < 0, else the
    constant speed level ``level`` (0 the slowest). The episodes are
    ``otgym evaluate``'s for the same key (``reset_batch`` on the key's first split);
    step t's noise is ``fold_in(key, t)``, the same draws for every policy of the same
    batch size. Steps until every episode has ended (or ``max_steps``), so a batch costs
    its longest episode, not ``max_steps``."""
    config = params.config
    network = QNetwork(config.n_actions, tuple(hidden))

    def rollout(q_params, level, key):
        reset_key, key = jax.random.split(key)
        obs, state = spc.reset_batch(reset_key, params, n_episodes)
        active = jnp.ones(n_episodes, bool)

        def running(carry):
            step, _, _, active, _, _ = carry
            return (step < config.max_steps) & jnp.any(active)

        def advance(carry):
            step, obs, state, active, success, time_s = carry
            greedy = jnp.argmax(network.apply(q_params, obs), axis=-1)
            action = jnp.where(level < 0, greedy, level)
            obs, state, _, terminated, truncated, info = spc.step_batch(
                jax.random.fold_in(key, step), state, action, params
            )
            success = success | (active & info["success"])
            time_s = jnp.where(active, info["time_s"], time_s)
            return step + 1, obs, state, active & ~(terminated | truncated), success, time_s

        carry = (jnp.zeros((), jnp.int32), obs, state, active, jnp.zeros(n_episodes, bool), jnp.zeros(n_episodes))
        carry = jax.lax.while_loop(running, advance, carry)
        return carry[4], carry[5]

    return jax.jit(rollout)
