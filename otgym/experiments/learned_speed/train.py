"""Training of the interactive task's learned speed policy (navigator ``rl``,
``otgym.autonomy.rl_navigator``): double DQN (Mnih et al. 2015; van Hasselt et al.
2016, as ``otgym.rl.dqn``) on the batched interactive task itself, in autonomous mode
(no participant: the navigator's dP_r moves the traps), in rounds:

1. collect: ``n_envs`` environments (one scenario each, scenarios
   ``SCENARIO_BASE + round * n_envs + i``) run with ``RLNavigator`` choosing speeds
   epsilon-greedily with sticky exploration (``Explorer``; epsilon falls linearly from
   1 to ``eps_end`` over the first ``eps_rounds`` rounds); every decision (0.5 s)
   closes the previous one's transition;
2. learn: ``updates_per_round`` Adam steps on uniform mini-batches of every transition
   so far (the replay buffer keeps them all), the double-DQN target with a target
   network copied every ``target_every`` steps, Huber loss.

Reward per decision, like the paper's speed control (progress, time, failure):
``progress_reward_per_um`` times the cell's progress along the route, minus
``time_cost`` per decision, minus ``collision_cost`` per obstacle that touches the
assembly for the first time, ``detach_cost`` per detachment and ``loss_cost`` for a lost
trap (terminal). An episode ends (terminal, value 0) once the cell is past
``finish_fraction`` of the route: the scenarios' crossings lie within 0.35-0.65 of it
(``otgym.tasks.transport.scenario``), so the rest of the route holds no decision worth learning;
or at ``time_limit_s`` (truncated: its open transition is dropped).

Run ``otgym experiment learned-speed [--out OUT.npz]`` (default: the shipped
``otgym/data/policies/speed_interactive.npz``); training seed
``TRAINING_SEED`` and the scenarios are registered in ``otgym.experiments.common.seeds``.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import time
from collections.abc import Callable
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from otgym.autonomy.rl_navigator import DECISION_S, N_FEATURES, SPEEDS_UM_S, RLNavigator, SpeedPolicy
from otgym.rl.dqn import double_dqn_loss, gradient_step, make_optimiser
from otgym.rl.network import QNetwork
from otgym.rl.policy import save_policy
from otgym.task.task import InteractiveConfig, InteractiveTask

TRAINING_SEED = 29
SCENARIO_BASE = 960_000


@dataclasses.dataclass(frozen=True)
class SpeedTrainingConfig:
    rounds: int = 10
    n_envs: int = 64
    eps_rounds: int = 6
    eps_end: float = 0.02
    updates_per_round: int = 3000
    batch_size: int = 256
    learning_rate: float = 1e-3
    gamma: float = 0.98
    target_every: int = 250
    hidden: tuple[int, ...] = (64, 64)
    progress_reward_per_um: float = 0.1
    time_cost: float = 0.1
    collision_cost: float = 20.0
    detach_cost: float = 2.0
    loss_cost: float = 10.0
    finish_fraction: float = 0.75
    time_limit_s: float = 90.0

    def __post_init__(self):
        for name in ("rounds", "n_envs", "eps_rounds", "updates_per_round", "batch_size", "target_every"):
            value = getattr(self, name)
            if not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        if not (0 < self.gamma < 1 and 0 <= self.eps_end <= 1 and 0 < self.finish_fraction <= 1):
            raise ValueError("need 0 < gamma < 1, 0 <= eps_end <= 1 and 0 < finish_fraction <= 1")

    def epsilon(self, round_index: int) -> float:
        return max(self.eps_end, 1.0 - round_index / self.eps_rounds * (1.0 - self.eps_end))


class Explorer:
    """Epsilon-greedy speed choice over a Q-network (uniform while it has no
    parameters), with sticky exploration: a random speed is held for 1 to
    ``max_hold`` decisions (uniform), so that waiting several seconds for an obstacle,
    which independent draws every 0.5 s almost never do, is tried. Each call gets every
    environment's features (training's environments decide in step)."""

    speeds_um_s = SPEEDS_UM_S
    decision_s = DECISION_S

    def __init__(self, apply: Callable, q_params, epsilon: float, rng: np.random.Generator, max_hold: int = 8):
        self.apply, self.q_params, self.epsilon, self.rng, self.max_hold = apply, q_params, epsilon, rng, max_hold
        self.held = np.zeros(0, int)
        self.hold_left = np.zeros(0, int)

    def choose(self, features) -> np.ndarray:
        n = len(features)
        if len(self.held) != n:
            self.held, self.hold_left = np.zeros(n, int), np.zeros(n, int)
        start = (self.hold_left <= 0) & (self.rng.random(n) < self.epsilon)
        self.held = np.where(start, self.rng.integers(0, len(self.speeds_um_s), n), self.held)
        self.hold_left = np.where(start, self.rng.integers(1, self.max_hold + 1, n), self.hold_left)
        exploring = self.hold_left > 0
        self.hold_left = self.hold_left - exploring
        if self.q_params is None:
            return self.held
        greedy = np.argmax(np.asarray(self.apply(self.q_params, jnp.asarray(features))), axis=1)
        return np.where(exploring, self.held, greedy)


def collect(task: InteractiveTask, explorer: Explorer, scenarios: list[int], key, config: SpeedTrainingConfig) -> dict:
    """One round's transitions (arrays obs, action, reward, next_obs, terminated) and
    its episodes' outcomes (collisions, losses, finished)."""
    n_env = len(scenarios)
    navigator = RLNavigator.for_task(task, explorer)
    navigator.reset(n_env)
    key, reset_key = jax.random.split(key)
    state = task.reset([task.scenario(s) for s in scenarios], reset_key)
    obs = state.observation
    finish_arc = config.finish_fraction * float(task.route_arc_um[-1])
    active = np.ones(n_env, bool)
    open_obs = np.zeros((n_env, N_FEATURES), np.float32)
    open_action = np.full(n_env, -1)
    open_arc = np.zeros(n_env)
    open_hits = np.zeros(n_env)
    open_detach = np.zeros(n_env)
    out = {name: [] for name in ("obs", "action", "reward", "next_obs", "terminated")}

    def close(rows, next_obs, terminated, lost):
        metrics = state.metrics
        hits = metrics.collided.sum(axis=1)[rows]
        reward = (
            config.progress_reward_per_um * (obs.cell_arc_um[rows] - open_arc[rows])
            - config.time_cost
            - config.collision_cost * (hits - open_hits[rows])
            - config.detach_cost * (metrics.detachments[rows] - open_detach[rows])
            - config.loss_cost * lost
        )
        for name, value in zip(
            out, (open_obs[rows], open_action[rows], reward, next_obs, np.broadcast_to(terminated, rows.shape))
        ):
            out[name].append(np.asarray(value))

    for _ in range(int(np.ceil(config.time_limit_s / task.config.tick_s))):
        increment = navigator.increments(obs)
        decided = navigator.last_decided & active
        if decided.any():
            pick = decided[navigator.last_decided]  # rows of last_features among the decided
            rows = np.flatnonzero(decided)
            features = navigator.last_features[pick]
            had = open_action[rows] >= 0
            if had.any():
                close(rows[had], features[had], False, 0.0)
            open_obs[rows], open_action[rows] = features, navigator.last_actions[pick]
            open_arc[rows] = obs.cell_arc_um[rows]
            open_hits[rows] = state.metrics.collided.sum(axis=1)[rows]
            open_detach[rows] = state.metrics.detachments[rows]
        key, step_key = jax.random.split(key)
        obs = task.step(state, increment, step_key)
        lost = state.metrics.trap_losses > 0
        ending = active & (lost | (obs.cell_arc_um >= finish_arc) | state.metrics.done) & (open_action >= 0)
        if ending.any():
            rows = np.flatnonzero(ending)
            close(rows, np.zeros((len(rows), N_FEATURES), np.float32), True, lost[rows].astype(float))
        active &= ~(lost | (obs.cell_arc_um >= finish_arc) | state.metrics.done)
        if not active.any():
            break
    data = {name: np.concatenate(values) if values else np.zeros((0,)) for name, values in out.items()}
    data["collisions"] = int(state.metrics.collided.sum())
    data["encountered"] = int(state.metrics.encountered.sum())
    data["trap_losses"] = int((state.metrics.trap_losses > 0).sum())
    data["finished"] = int((obs.cell_arc_um >= finish_arc).sum())
    data["sim_time_s"] = float(obs.time_s.max())
    return data


def make_learner(config: SpeedTrainingConfig):
    """``(init, learn)``: ``init(key) -> (params, opt_state)``; ``learn(params, opt_state,
    data, key) -> (params, opt_state, mean loss)`` runs ``updates_per_round`` double-DQN steps."""
    network = QNetwork(len(SPEEDS_UM_S), config.hidden)
    optimiser = make_optimiser(config.learning_rate)
    loss_fn = double_dqn_loss(network, config.gamma)

    def init(key):
        params = network.init(key, jnp.zeros((1, N_FEATURES)))
        return params, optimiser.init(params)

    @functools.partial(jax.jit, static_argnums=())
    def learn(params, opt_state, data, key):
        size = data[0].shape[0]

        def step(carry, inputs):
            params, opt_state, target = carry
            index_key, count = inputs
            index = jax.random.randint(index_key, (config.batch_size,), 0, size)
            batch = tuple(column[index] for column in data)
            params, opt_state, loss = gradient_step(loss_fn, optimiser, params, opt_state, target, batch)
            sync = (count + 1) % config.target_every == 0
            target = jax.tree.map(lambda new, old: jnp.where(sync, new, old), params, target)
            return (params, opt_state, target), loss

        keys = jax.random.split(key, config.updates_per_round)
        (params, opt_state, _), losses = jax.lax.scan(
            step, (params, opt_state, params), (keys, jnp.arange(config.updates_per_round))
        )
        return params, opt_state, jnp.mean(losses)

    return network, init, learn


def train(
    config: SpeedTrainingConfig = SpeedTrainingConfig(),
    seed: int = TRAINING_SEED,
    task: InteractiveTask | None = None,
    report: Callable[[str], None] = print,
) -> tuple[SpeedPolicy, dict]:
    """Train a speed policy (module docstring); returns it and a log (per round: the
    transitions, collisions, losses and the wall time)."""
    start = time.perf_counter()
    task = task or InteractiveTask(InteractiveConfig(time_limit_s=config.time_limit_s))
    network, init, learn = make_learner(config)
    key = jax.random.PRNGKey(seed)
    key, init_key = jax.random.split(key)
    params, opt_state = init(init_key)
    rng = np.random.default_rng(seed)
    apply = jax.jit(network.apply)
    columns = {name: [] for name in ("obs", "action", "reward", "next_obs", "terminated")}
    log = {"rounds": []}
    for round_index in range(config.rounds):
        epsilon = config.epsilon(round_index)
        explorer = Explorer(apply, params if round_index else None, epsilon, rng)
        scenarios = [SCENARIO_BASE + round_index * config.n_envs + i for i in range(config.n_envs)]
        key, collect_key, learn_key = jax.random.split(key, 3)
        data = collect(task, explorer, scenarios, collect_key, config)
        for name in columns:
            columns[name].append(data[name])
        stacked = (
            jnp.asarray(np.concatenate(columns["obs"]), jnp.float32),
            jnp.asarray(np.concatenate(columns["action"]), jnp.int32),
            jnp.asarray(np.concatenate(columns["reward"]), jnp.float32),
            jnp.asarray(np.concatenate(columns["next_obs"]), jnp.float32),
            jnp.asarray(np.concatenate(columns["terminated"]), jnp.float32),
        )
        params, opt_state, loss = learn(params, opt_state, stacked, learn_key)
        entry = {
            "round": round_index,
            "epsilon": epsilon,
            "transitions": int(len(data["action"])),
            "collisions": data["collisions"],
            "encountered": data["encountered"],
            "trap_losses": data["trap_losses"],
            "finished": data["finished"],
            "mean_reward": float(np.mean(data["reward"])) if len(data["reward"]) else float("nan"),
            "loss": float(loss),
            "wall_s": time.perf_counter() - start,
        }
        log["rounds"].append(entry)
        report(
            f"round {round_index}: eps {epsilon:.2f}, {entry['transitions']} transitions, "
            f"{entry['collisions']} collisions of {entry['encountered']} met, {entry['trap_losses']} losses, "
            f"{entry['finished']}/{config.n_envs} past {config.finish_fraction:.0%}, loss {entry['loss']:.3f}, "
            f"{entry['wall_s']:.0f} s"
        )
    log["wall_s"] = time.perf_counter() - start
    return SpeedPolicy(params, tuple(config.hidden)), log


def save_speed_policy(path, policy: SpeedPolicy, config: SpeedTrainingConfig, seed: int, log: dict) -> Path:
    meta = {
        "task": "interactive",
        "obs_size": N_FEATURES,
        "n_actions": len(policy.speeds_um_s),
        "hidden": list(policy.hidden),
        "speeds_um_s": list(policy.speeds_um_s),
        "decision_s": policy.decision_s,
        "trainer": "otgym.experiments.learned_speed.train",
        "training_seed": seed,
        "scenarios": [SCENARIO_BASE, SCENARIO_BASE + config.rounds * config.n_envs - 1],
        "config": dataclasses.asdict(config),
        "wall_s": log.get("wall_s"),
    }
    return save_policy(path, policy.q_params, json.loads(json.dumps(meta)))
