"""Pure-JAX DQN (Mnih et al. 2015) over a batched functional environment, in the
style of PureJaxRL: ``make_train(config, env)`` returns functions whose whole
training loop runs inside ``jit`` and that ``vmap`` over seeds.

Per iteration: every environment acts epsilon-greedily (epsilon decays linearly from
``eps_start`` to ``eps_end`` over ``eps_fraction`` of training; the paper: 1.0 -> 0.01),
its transitions go to a circular replay buffer, finished episodes restart, and the
Q-network takes ``updates_per_iter`` Adam steps on uniform mini-batches with the
double-DQN target (van Hasselt et al. 2016) r + gamma (1 - terminated)
Q_target(s', argmax_a Q(s', a)) and the Huber loss; the target network is copied
every ``target_every`` iterations. Truncated episodes bootstrap (only termination
cuts the return). With ``explore_hold_max`` above 1 the exploration is sticky: a
random action, once drawn, is held for 1 to ``explore_hold_max`` steps (uniform), so
that a long wait, which independent draws almost never make, is tried. The paper's hyper-parameters (learning rate 6.5e-5, batch 32,
buffer 20k, target every 40 steps) were tuned for one environment and 15 hours; the
defaults here are for 64 environments and about a minute.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import NamedTuple

import jax
import jax.numpy as jnp
import optax
from flax import struct

from otgym.rl.network import QNetwork


@dataclasses.dataclass(frozen=True)
class DQNConfig:
    n_envs: int = 64
    total_env_steps: int = 200_000
    chunk_iters: int = 100
    buffer_size: int = 100_000
    batch_size: int = 256
    learning_rate: float = 1e-3
    gamma: float = 0.99
    eps_start: float = 1.0
    eps_end: float = 0.01
    eps_fraction: float = 0.4
    target_every: int = 100
    learning_starts: int = 5_000
    updates_per_iter: int = 2
    hidden: tuple[int, ...] = (128, 128)
    huber_delta: float = 1.0
    explore_hold_max: int = 1

    def __post_init__(self):
        for name in (
            "n_envs",
            "total_env_steps",
            "chunk_iters",
            "buffer_size",
            "batch_size",
            "target_every",
            "updates_per_iter",
            "explore_hold_max",
        ):
            value = getattr(self, name)
            if not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        if not 0 < self.gamma <= 1 or not 0 <= self.eps_end <= self.eps_start <= 1 or not 0 < self.eps_fraction <= 1:
            raise ValueError("need 0 < gamma <= 1, 0 <= eps_end <= eps_start <= 1 and 0 < eps_fraction <= 1")

    @property
    def n_chunks(self) -> int:
        return math.ceil(self.total_env_steps / (self.n_envs * self.chunk_iters))


class Env(NamedTuple):
    """A batched functional environment: ``reset(key, n) -> (obs, state)``,
    ``step(key, state, action) -> (obs, state, reward, terminated, truncated, info)``
    and ``auto_reset(key, obs, state, done) -> (obs, state)``; ``info`` carries
    ``success`` (E,) bool."""

    reset: Callable
    step: Callable
    auto_reset: Callable
    obs_size: int
    n_actions: int


@struct.dataclass
class Buffer:
    obs: jnp.ndarray
    action: jnp.ndarray
    reward: jnp.ndarray
    next_obs: jnp.ndarray
    terminated: jnp.ndarray
    pointer: jnp.ndarray
    size: jnp.ndarray


@struct.dataclass
class Runner:
    q_params: dict
    target_params: dict
    opt_state: optax.OptState
    buffer: Buffer
    env_state: object
    obs: jnp.ndarray
    episode_return: jnp.ndarray
    iteration: jnp.ndarray
    key: jnp.ndarray
    held_action: jnp.ndarray  # (E,) the random action being held (sticky exploration)
    hold_left: jnp.ndarray  # (E,) steps it is still held


def epsilon(config: DQNConfig, iteration):
    n_iters = config.n_chunks * config.chunk_iters
    fraction = jnp.clip(iteration / (config.eps_fraction * n_iters), 0.0, 1.0)
    return config.eps_start + fraction * (config.eps_end - config.eps_start)


def make_optimiser(learning_rate: float):
    """Adam with gradients clipped to a global norm of 10, every DQN learner's optimiser."""
    return optax.chain(optax.clip_by_global_norm(10.0), optax.adam(learning_rate))


def double_dqn_loss(network: QNetwork, gamma: float, huber_delta: float = 1.0) -> Callable:
    """``loss(q_params, target_params, batch)``: the mean Huber loss of Q(s, a) against
    the double-DQN target (van Hasselt et al. 2016) r + gamma (1 - terminated)
    Q_target(s', argmax_a Q(s', a)); ``batch`` is (obs, action, reward, next_obs,
    terminated as float). Every DQN learner in otgym uses it."""

    def loss(q_params, target_params, batch):
        obs, action, reward, next_obs, terminated = batch
        q = network.apply(q_params, obs)[jnp.arange(obs.shape[0]), action]
        best = jnp.argmax(network.apply(q_params, next_obs), axis=-1)
        next_q = network.apply(target_params, next_obs)[jnp.arange(obs.shape[0]), best]
        target = reward + gamma * (1.0 - terminated) * jax.lax.stop_gradient(next_q)
        return jnp.mean(optax.huber_loss(q, target, delta=huber_delta))

    return loss


def gradient_step(loss: Callable, optimiser, q_params, opt_state, target_params, batch):
    """One optimiser step of ``loss`` on ``batch``: (q_params, opt_state, loss value)."""
    value, grads = jax.value_and_grad(loss)(q_params, target_params, batch)
    updates, opt_state = optimiser.update(grads, opt_state, q_params)
    return optax.apply_updates(q_params, updates), opt_state, value


def make_train(config: DQNConfig, env: Env):
    """Returns ``(init, run_chunk, train)``: ``init(key) -> Runner``;
    ``run_chunk(runner) -> (runner, metrics)`` runs ``chunk_iters`` iterations
    (metrics per iteration: ``return_sum`` and ``episodes`` of the episodes that ended,
    ``successes``, ``loss``); ``train(key)`` is init plus all chunks, jittable and
    vmappable over keys."""
    network = QNetwork(env.n_actions, config.hidden)
    optimiser = make_optimiser(config.learning_rate)
    loss_fn = double_dqn_loss(network, config.gamma, config.huber_delta)
    capacity = config.buffer_size // config.n_envs * config.n_envs

    def init(key) -> Runner:
        net_key, env_key, key = jax.random.split(key, 3)
        obs, env_state = env.reset(env_key, config.n_envs)
        params = network.init(net_key, obs[:1])
        zeros = lambda *shape, dtype=jnp.float32: jnp.zeros(shape, dtype)  # noqa: E731
        buffer = Buffer(
            zeros(capacity, env.obs_size),
            zeros(capacity, dtype=jnp.int32),
            zeros(capacity),
            zeros(capacity, env.obs_size),
            zeros(capacity, dtype=bool),
            jnp.zeros((), jnp.int32),
            jnp.zeros((), jnp.int32),
        )
        return Runner(
            params,
            params,
            optimiser.init(params),
            buffer,
            env_state,
            obs,
            jnp.zeros(config.n_envs),
            jnp.zeros((), jnp.int32),
            key,
            jnp.zeros(config.n_envs, jnp.int32),
            jnp.zeros(config.n_envs, jnp.int32),
        )

    def update(carry, key):
        q_params, opt_state, buffer, target_params = carry
        index = jax.random.randint(key, (config.batch_size,), 0, jnp.maximum(buffer.size, 1))
        batch = (
            buffer.obs[index],
            buffer.action[index],
            buffer.reward[index],
            buffer.next_obs[index],
            buffer.terminated[index].astype(jnp.float32),
        )
        q_params, opt_state, loss = gradient_step(loss_fn, optimiser, q_params, opt_state, target_params, batch)
        return (q_params, opt_state, buffer, target_params), loss

    def iteration(runner: Runner, _):
        key, act_key, explore_key, step_key, reset_key, update_key = jax.random.split(runner.key, 6)
        greedy = jnp.argmax(network.apply(runner.q_params, runner.obs), axis=-1)
        random_action = jax.random.randint(act_key, greedy.shape, 0, env.n_actions)
        explore = jax.random.uniform(explore_key, greedy.shape) < epsilon(config, runner.iteration)
        held_action, hold_left = runner.held_action, runner.hold_left
        if config.explore_hold_max > 1:
            start = (hold_left <= 0) & explore
            held_action = jnp.where(start, random_action, held_action)
            hold_steps = jax.random.randint(
                jax.random.fold_in(act_key, 1), greedy.shape, 1, config.explore_hold_max + 1
            )
            hold_left = jnp.where(start, hold_steps, hold_left)
            exploring = hold_left > 0
            hold_left = hold_left - exploring
            action = jnp.where(exploring, held_action, greedy)
        else:
            action = jnp.where(explore, random_action, greedy)
        next_obs, env_state, reward, terminated, truncated, info = env.step(step_key, runner.env_state, action)
        buffer = runner.buffer
        rows = (buffer.pointer + jnp.arange(config.n_envs)) % capacity
        buffer = buffer.replace(
            obs=buffer.obs.at[rows].set(runner.obs),
            action=buffer.action.at[rows].set(action),
            reward=buffer.reward.at[rows].set(reward),
            next_obs=buffer.next_obs.at[rows].set(next_obs),
            terminated=buffer.terminated.at[rows].set(terminated),
            pointer=(buffer.pointer + config.n_envs) % capacity,
            size=jnp.minimum(buffer.size + config.n_envs, capacity),
        )
        episode_return = runner.episode_return + reward
        done = terminated | truncated
        metrics = {
            "return_sum": jnp.sum(jnp.where(done, episode_return, 0.0)),
            "episodes": jnp.sum(done),
            "successes": jnp.sum(info["success"]),
        }
        obs, env_state = env.auto_reset(reset_key, next_obs, env_state, done)

        def learn(args):
            (q_params, opt_state, _, _), losses = jax.lax.scan(
                update, args, jax.random.split(update_key, config.updates_per_iter)
            )
            return q_params, opt_state, jnp.mean(losses)

        q_params, opt_state, loss = jax.lax.cond(
            buffer.size >= config.learning_starts,
            learn,
            lambda args: (args[0], args[1], jnp.zeros(())),
            (runner.q_params, runner.opt_state, buffer, runner.target_params),
        )
        sync = (runner.iteration + 1) % config.target_every == 0
        target_params = jax.tree.map(lambda new, old: jnp.where(sync, new, old), q_params, runner.target_params)
        metrics["loss"] = loss
        runner = Runner(
            q_params,
            target_params,
            opt_state,
            buffer,
            env_state,
            obs,
            jnp.where(done, 0.0, episode_return),
            runner.iteration + 1,
            key,
            held_action,
            jnp.where(done, 0, hold_left),
        )
        return runner, metrics

    def run_chunk(runner: Runner):
        return jax.lax.scan(iteration, runner, None, length=config.chunk_iters)

    def train(key):
        runner = init(key)
        runner, metrics = jax.lax.scan(lambda r, _: run_chunk(r), runner, None, length=config.n_chunks)
        return runner, jax.tree.map(lambda m: m.reshape(-1), metrics)

    return init, run_chunk, train
