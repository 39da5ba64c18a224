"""Episodes of the ``orient`` task under a policy, run as one jitted ``lax.scan`` over
a batch: the scripted baseline (``otgym.tasks.orient.baseline``), holding still, the
fastest turn toward the target throughout, or a learned Q-network (``otgym train
--task orient``). ``evaluate`` summarises a batch: success rate with its Wilson 95 %
interval, mean time to success, failures, final angle errors.

Development figure (docs/tasks.md, section ``orient``)::

    python -c "from otgym.experiments.orient.run import evaluate; print(evaluate('baseline', 64, seed=1))"
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np

from otgym import tasks
from otgym.rl.network import QNetwork
from otgym.study import wilson_interval
from otgym.tasks.orient import baseline
from otgym.tasks.orient.core import OrientParams, wrap

POLICIES = ("baseline", "hold", "fastest")
"""Scripted policies by name; a learned one is given as Q-network parameters."""


def _scripted_actions(obs, direction, modes, config):
    """Actions of each environment's scripted policy (``modes``: index into ``POLICIES``)."""
    hold = jnp.full(obs.shape[0], config.hold_action, jnp.int32)
    fastest = jnp.where(direction > 0, config.n_actions - 1, 0).astype(jnp.int32)  # toward the start's target
    return jnp.select([modes == 0, modes == 1], [baseline.actions(obs, config), hold], fastest)


@functools.partial(jax.jit, static_argnums=(2, 4))
def _rollout(key, params: OrientParams, n_episodes: int, modes, greedy=None):
    """Episodes ``n_episodes`` from ``key``, each run once per row of ``modes`` (P, n)."""
    task = tasks.load("orient")
    config = params.config
    reset_key, run_key = jax.random.split(key)
    obs, state = task.reset_batch(reset_key, params, n_episodes)
    copies = modes.shape[0]
    obs, state = jax.tree.map(lambda a: jnp.concatenate([a] * copies), (obs, state))
    modes = modes.reshape(-1)
    direction = jnp.sign(state.target_rad)
    zeros = jnp.zeros(modes.shape[0], bool)

    def body(carry, step_key):
        obs, state, done, success, failed, time_s, error, turn, dose = carry
        action = _scripted_actions(obs, direction, modes, config) if greedy is None else greedy(obs)
        obs, state, _, terminated, truncated, info = task.step_batch(step_key, state, action, params)
        alive = ~done
        success = success | (alive & info["success"])
        failed = failed | (alive & info["failed"])
        time_s = jnp.where(alive, info["time_s"], time_s)
        error = jnp.where(alive, info["angle_error_rad"], error)
        turn = jnp.where(alive, turn + wrap(info["turn_rad"] - turn), turn)  # unwrapped
        dose = jnp.where(alive, info["light_dose_mj_per_um2"], dose)
        return (obs, state, done | terminated | truncated, success, failed, time_s, error, turn, dose), None

    none = jnp.zeros(modes.shape[0])
    start = (obs, state, zeros, zeros, zeros, none, state.target_rad, none, none)
    final, _ = jax.lax.scan(body, start, jax.random.split(run_key, config.max_steps))
    _, _, _, success, failed, time_s, error, turn, dose = final
    outcome = {"target_rad": state.target_rad, "success": success, "failed": failed, "time_s": time_s}
    outcome.update(error_rad=error, turn_rad=turn, light_dose_mj_per_um2=dose)
    return jax.tree.map(lambda a: a.reshape(copies, n_episodes), outcome)


def _params(params):
    task = tasks.load("orient")
    return task.make_params(task.config()) if params is None else params


def rollout(policy, n_episodes: int, seed: int, params: OrientParams | None = None) -> dict:
    """Per-episode outcomes (numpy, (n,)) of ``n_episodes`` episodes from
    ``PRNGKey(seed)`` under ``policy`` (a name of ``POLICIES`` or Q-network parameters):
    ``target_rad``, ``success``, ``failed``, ``time_s`` (at the episode's end) and
    ``error_rad`` (the angle error at the episode's end, wrapped) and ``turn_rad`` (the
    measured turn at the episode's end, unwrapped: beyond the target is an overshoot) and
    ``light_dose_mj_per_um2`` (the cell's light dose over the episode)."""
    params = _params(params)
    key = jax.random.PRNGKey(seed)
    if isinstance(policy, str):
        if policy not in POLICIES:
            raise ValueError(f"unknown policy {policy!r}; choose one of {POLICIES} or give Q-network parameters")
        out = _rollout(key, params, n_episodes, jnp.full((1, n_episodes), POLICIES.index(policy)))
    else:
        network = QNetwork(params.config.n_actions, _hidden(policy))
        greedy = _Greedy(network, jax.tree.map(jnp.asarray, policy))
        out = _rollout(key, params, n_episodes, jnp.zeros((1, n_episodes), jnp.int32), greedy)
    return {name: value[0] for name, value in jax.device_get(out).items()}


def compare_scripted(n_episodes: int, seed: int, params: OrientParams | None = None) -> dict:
    """``{name: outcome}`` for every scripted policy on the same ``n_episodes``
    episodes (one batch, one compile)."""
    params = _params(params)
    modes = jnp.repeat(jnp.arange(len(POLICIES))[:, None], n_episodes, axis=1)
    out = jax.device_get(_rollout(jax.random.PRNGKey(seed), params, n_episodes, modes))
    return {name: {key: value[i] for key, value in out.items()} for i, name in enumerate(POLICIES)}


class _Greedy:
    """Greedy actions of a Q-network (hashable by identity, so a static jit argument)."""

    def __init__(self, network, q_params):
        self.network, self.q_params = network, q_params

    def __call__(self, obs):
        return jnp.argmax(self.network.apply(self.q_params, obs), axis=-1).astype(jnp.int32)


def _hidden(q_params) -> tuple[int, ...]:
    layers = q_params["params"]
    return tuple(int(layers[f"Dense_{i}"]["kernel"].shape[1]) for i in range(len(layers) - 1))


def summarise(outcome: dict, tolerance_deg: float = 2.0) -> dict:
    """Success rate, its Wilson 95 % interval, mean time of the successes (s), failures,
    overshoots (episodes that end turned beyond the target by more than the tolerance)
    the median absolute final error (deg) and the mean light dose of the cell (mJ/um^2)."""
    success = np.asarray(outcome["success"], bool)
    target = np.asarray(outcome["target_rad"])
    tolerance = np.deg2rad(tolerance_deg)
    n, k = len(success), int(success.sum())
    low, high = wilson_interval(k, n)
    return {
        "episodes": n,
        "successes": k,
        "success_rate": k / n,
        "wilson95": (round(low, 3), round(high, 3)),
        "mean_time_s": round(float(np.mean(outcome["time_s"][success])), 2) if k else None,
        "failures": int(np.sum(outcome["failed"])),
        "overshoots": int(np.sum(np.sign(target) * outcome["turn_rad"] > np.abs(target) + tolerance)),
        "median_final_error_deg": round(float(np.rad2deg(np.median(np.abs(outcome["error_rad"])))), 2),
        "mean_light_dose_mj_per_um2": (
            float(np.mean(outcome["light_dose_mj_per_um2"])) if "light_dose_mj_per_um2" in outcome else None
        ),
    }


def evaluate(policy, n_episodes: int = 64, seed: int = 1) -> dict:
    """``summarise(rollout(policy, n_episodes, seed))``."""
    return summarise(rollout(policy, n_episodes, seed))


def report_outcomes(policy_path, preset: str, episodes: int, seed: int) -> dict:
    """The report comparison's paired outcomes (``otgym.experiments.task_report.run``): the
    bang-bang controller and the greedy Q-network of ``policy_path`` on the same
    ``episodes`` from ``seed`` (the default preset: ``preset`` is checked), with each
    episode's overshoot and final error."""
    from otgym.experiments.task_report.run import policy_shape
    from otgym.rl.policy import load_policy

    if preset != "default":
        raise ValueError(f"orient's report runs the default preset, not {preset!r}")
    q_params, _ = load_policy(policy_path, *policy_shape("orient"))
    found = {"baseline": rollout("baseline", episodes, seed), "learned": rollout(q_params, episodes, seed)}
    for outcome in found.values():
        target = np.asarray(outcome["target_rad"])
        outcome["overshoot"] = np.sign(target) * outcome["turn_rad"] > np.abs(target) + np.deg2rad(2.0)
        outcome["final_error_deg"] = np.rad2deg(np.abs(outcome["error_rad"]))
    return found
