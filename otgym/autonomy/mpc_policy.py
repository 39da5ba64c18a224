"""A distilled model-predictive navigator: behaviour cloning of ``MPCNavigator``.

Features (route frame, so a rotated or translated scene gives the same ones):
the cell's lateral offset and its velocity along and across the route, the
formation's pose relative to the cell (arc - cell arc, lateral, rotation), the
committed action (speed, lateral offset, rotation), the distance left to the
destination, and for each obstacle its position relative to the cell and its
predicted velocity (the MPC's own ``ObstacleTracker``), both along/across the route.
Target: the MPC's chosen next action (speed, lateral offset, rotation) at a replan.

``RecordingMPCNavigator`` runs the MPC and keeps (features, action) pairs;
``PolicyNavigator`` replaces each replan by one forward pass of a small MLP
(trained by MSE on normalised features and actions, ``train``), saved as .npz.

DAgger (Ross, Gordon & Bagnell, "A Reduction of Imitation Learning and Structured
Prediction to No-Regret Online Learning", AISTATS 2011) against the covariate shift of
plain cloning: ``DAggerNavigator`` drives with the clone (or, per decision, the MPC
with probability ``beta``), asks the MPC what it would do in the states the clone
visits (``dagger_step``), and keeps those (features, MPC action) pairs; ``dagger``
aggregates them with the data so far and retrains, round after round.
"""

from __future__ import annotations

import dataclasses
import functools
import time
from collections.abc import Callable, Iterator

import jax
import jax.numpy as jnp
import numpy as np
import optax

from otgym.autonomy.mpc_navigator import MPCNavigator
from otgym.autonomy.route_frame import route_frame


def route_features(
    route, start, committed, cell_xy_um, cell_arc_um, cell_velocity_um_s, obstacle_xy_um, obstacle_velocity_um_s
) -> np.ndarray:
    """Features (E, 10 + 4K) in the route frame at the cell's arc (see module doc)."""
    point, tangent, normal, _ = (
        np.asarray(a, float) for a in route_frame(route, jnp.asarray(cell_arc_um, jnp.float32))
    )
    along = lambda v: np.sum(v * (tangent[:, None] if v.ndim == 3 else tangent), axis=-1)  # noqa: E731
    across = lambda v: np.sum(v * (normal[:, None] if v.ndim == 3 else normal), axis=-1)  # noqa: E731
    relative = obstacle_xy_um - cell_xy_um[:, None]
    length = float(route.path.length_um)
    columns = [
        across(cell_xy_um - point),
        along(cell_velocity_um_s),
        across(cell_velocity_um_s),
        start[:, 0] - cell_arc_um,
        start[:, 1],
        start[:, 2],
        committed[:, 0],
        committed[:, 1],
        committed[:, 2],
        length - cell_arc_um,
    ]
    obstacles = np.stack(
        [along(relative), across(relative), along(obstacle_velocity_um_s), across(obstacle_velocity_um_s)], axis=-1
    ).reshape(len(start), -1)
    return np.concatenate([np.stack(columns, axis=-1), obstacles], axis=-1).astype(np.float32)


class _FeatureMixin:
    def _features(self, obs, rows, start, committed) -> np.ndarray:
        now = obs.time_s[rows]
        last = getattr(self, "_last_cell", None)
        velocity = np.zeros((len(rows), 2))
        if last is not None and len(last[0]) == len(obs.time_s):
            dt = now - last[1][rows]
            velocity = np.where(
                (dt > 0)[:, None], (obs.cell_xy_um[rows] - last[0][rows]) / np.maximum(dt, 1e-9)[:, None], 0.0
            )
        return route_features(
            self.route,
            start,
            committed,
            obs.cell_xy_um[rows],
            obs.cell_arc_um[rows],
            velocity,
            self.tracker.latest_um()[rows],
            self.tracker.velocity_um_s()[rows],
        )

    def _remember(self, obs) -> None:
        self._last_cell = (obs.cell_xy_um.copy(), obs.time_s.copy())


class RecordingMPCNavigator(_FeatureMixin, MPCNavigator):
    """The MPC, keeping (features, chosen next action) at every sampled replan."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.features, self.actions = [], []

    def _start_segments(self, obs) -> None:
        super()._start_segments(obs)
        self._remember(obs)

    def _plan(self, obs, rows, start, committed, nominal) -> np.ndarray:
        plan = super()._plan(obs, rows, start, committed, nominal)
        self.features.append(self._features(obs, rows, start, committed))
        self.actions.append(plan[:, 0].copy())
        return plan


def init_mlp(key, sizes) -> list[dict]:
    """Layers of an MLP with ``sizes`` (in, hidden..., out), He-scaled normal weights."""
    layers = []
    for k, (n_in, n_out) in zip(jax.random.split(key, len(sizes) - 1), zip(sizes[:-1], sizes[1:])):
        layers.append({"w": jax.random.normal(k, (n_in, n_out)) * np.sqrt(2.0 / n_in), "b": jnp.zeros(n_out)})
    return layers


def mlp(layers, x):
    for layer in layers[:-1]:
        x = jax.nn.tanh(x @ layer["w"] + layer["b"])
    return x @ layers[-1]["w"] + layers[-1]["b"]


@dataclasses.dataclass
class ClonedPolicy:
    """A trained clone: MLP layers and the feature/action normalisation."""

    layers: list
    feature_mean: np.ndarray
    feature_std: np.ndarray
    action_mean: np.ndarray
    action_std: np.ndarray

    def __call__(self, features) -> np.ndarray:
        x = (np.asarray(features, np.float32) - self.feature_mean) / self.feature_std
        return np.asarray(_forward(self.layers, jnp.asarray(x))) * self.action_std + self.action_mean

    def save(self, path) -> None:
        arrays = {f"w{i}": np.asarray(layer["w"]) for i, layer in enumerate(self.layers)}
        arrays |= {f"b{i}": np.asarray(layer["b"]) for i, layer in enumerate(self.layers)}
        np.savez(
            path,
            feature_mean=self.feature_mean,
            feature_std=self.feature_std,
            action_mean=self.action_mean,
            action_std=self.action_std,
            **arrays,
        )

    @classmethod
    def load(cls, path) -> ClonedPolicy:
        data = np.load(path)
        n = sum(1 for k in data.files if k.startswith("w"))
        layers = [{"w": jnp.asarray(data[f"w{i}"]), "b": jnp.asarray(data[f"b{i}"])} for i in range(n)]
        return cls(layers, data["feature_mean"], data["feature_std"], data["action_mean"], data["action_std"])


_forward = jax.jit(mlp)


def train(
    features,
    actions,
    hidden=(128, 128),
    epochs: int = 200,
    batch: int = 256,
    learning_rate: float = 1e-3,
    seed: int = 0,
) -> ClonedPolicy:
    """Fit the MLP by MSE on normalised features and actions (Adam, minibatches)."""
    features, actions = np.asarray(features, np.float32), np.asarray(actions, np.float32)
    f_mean, f_std = features.mean(0), features.std(0) + 1e-6
    a_mean, a_std = actions.mean(0), actions.std(0) + 1e-6
    x, y = jnp.asarray((features - f_mean) / f_std), jnp.asarray((actions - a_mean) / a_std)
    key = jax.random.PRNGKey(seed)
    key, init_key = jax.random.split(key)
    layers = init_mlp(init_key, (x.shape[1], *hidden, y.shape[1]))
    opt_state = optax.adam(learning_rate).init(layers)
    step = functools.partial(_train_step, learning_rate=learning_rate)
    n = len(x)
    size = min(batch, n)
    for _ in range(epochs):
        key, perm_key = jax.random.split(key)
        order = jax.random.permutation(perm_key, n)
        for begin in range(0, n - size + 1, size):
            index = order[begin : begin + size]
            layers, opt_state, _ = step(layers, opt_state, x[index], y[index])
    return ClonedPolicy(layers, f_mean, f_std, a_mean, a_std)


@functools.partial(jax.jit, static_argnames=("learning_rate",))
def _train_step(layers, opt_state, xb, yb, *, learning_rate: float):
    """One Adam step of ``train`` on a minibatch (module level: one compilation per
    shape and rate, shared by every training in the process)."""
    loss, grads = jax.value_and_grad(lambda p: jnp.mean((mlp(p, xb) - yb) ** 2))(layers)
    updates, opt_state = optax.adam(learning_rate).update(grads, opt_state, layers)
    return optax.apply_updates(layers, updates), opt_state, loss


class PolicyNavigator(_FeatureMixin, MPCNavigator):
    """``MPCNavigator`` whose every replan is one forward pass of a ``ClonedPolicy``
    (the plan holds the predicted action over the horizon)."""

    def __init__(self, task, config, costs, seed: int = 0, policy: ClonedPolicy | None = None, **kwargs):
        super().__init__(task, dataclasses.replace(config, far_replan_steps=1), costs, seed=seed, **kwargs)
        if policy is None:
            raise ValueError("PolicyNavigator needs a trained policy")
        self.policy = policy

    def _start_segments(self, obs) -> None:
        super()._start_segments(obs)
        self._remember(obs)

    def _plan(self, obs, rows, start, committed, nominal) -> np.ndarray:
        began = time.perf_counter()
        action = self.policy(self._features(obs, rows, start, committed)).astype(np.float32)
        self.replan_seconds.append(time.perf_counter() - began)
        self.replan_sizes.append(len(rows))
        return np.repeat(action[:, None], self.config.plan_steps, axis=1)


def dagger_step(features, learner: Callable, teacher: Callable, query, beta: float, rng: np.random.Generator):
    """One DAgger decision for a batch of environments: the learner's action for every
    row, the teacher's (``teacher(indices)`` -> (Q, A)) for the rows where ``query`` is
    true, which are the labels; each queried row executes the teacher's action with
    probability ``beta`` and the learner's otherwise (the mixture policy
    beta * teacher + (1 - beta) * learner; rows not queried always execute the learner's).
    Returns (executed (E, A), teacher_taken (E,) bool, labels (Q, A))."""
    query = np.asarray(query, bool)
    executed = np.array(learner(features), np.float32, copy=True)
    taken = np.zeros(len(executed), bool)
    labels = np.zeros((0, executed.shape[1]), np.float32)
    if query.any():
        labels = np.asarray(teacher(np.flatnonzero(query)), np.float32)
        taken[query] = rng.random(int(query.sum())) < beta
        executed[taken] = labels[taken[query]]
    return executed, taken, labels


def dagger(policy, features, actions, collect: Callable, iterations: int, fit: Callable = train) -> Iterator:
    """DAgger's rounds from a first ``policy`` trained on (``features``, ``actions``):
    each round ``collect(policy, round)`` -> (features, teacher's actions) on the states
    that the policy (mixed with the teacher) visits, aggregated with all data so far, and
    ``fit(features, actions)`` retrains on the aggregate. Yields (round, policy,
    features, actions) after each round."""
    features, actions = np.asarray(features, np.float32), np.asarray(actions, np.float32)
    for round_ in range(iterations):
        new_features, new_actions = collect(policy, round_)
        features = np.concatenate([features, np.asarray(new_features, np.float32)])
        actions = np.concatenate([actions, np.asarray(new_actions, np.float32)])
        policy = fit(features, actions)
        yield round_, policy, features, actions


class DAggerNavigator(PolicyNavigator):
    """``PolicyNavigator`` whose decisions are DAgger's (``dagger_step``): the MPC
    labels the clone's states, within ``far_gap_um`` of an obstacle at every decision
    and farther only every ``label_every`` decisions (the MPC's own sampling schedule,
    which bounds the labelling cost); with probability ``beta`` a labelled decision
    executes the MPC's plan. The MPC is warm-started from its own last plan for the
    environment where it labelled the decision before, else from the executed one.
    Keeps ``features`` and ``actions`` (the MPC's) and ``taken`` (decisions it executed)."""

    def __init__(
        self,
        task,
        config,
        costs,
        seed: int = 0,
        policy: ClonedPolicy | None = None,
        beta: float = 0.0,
        label_every: int = 5,
        **kwargs,
    ):
        if not 0.0 <= beta <= 1.0:
            raise ValueError(f"beta must be in [0, 1], got {beta}")
        if not (isinstance(label_every, int) and label_every >= 1):
            raise ValueError(f"label_every must be a positive integer, got {label_every!r}")
        self.beta, self.label_every = beta, label_every
        self.rng = np.random.default_rng(seed)
        self.features, self.actions, self.taken = [], [], []
        super().__init__(task, config, costs, seed=seed, policy=policy, **kwargs)

    def reset(self, n_env: int) -> None:
        super().reset(n_env)
        self.expert_plan = np.zeros((n_env, self.config.plan_steps, 3), np.float32)
        self.expert_fresh = np.zeros(n_env, bool)
        self.since_label = np.full(n_env, 10**6)

    def _plan(self, obs, rows, start, committed, nominal) -> np.ndarray:
        self.since_label[rows] += 1
        near = obs.nearest_obstacle_gap_um[rows] < self.config.far_gap_um
        query = near | (self.since_label[rows] >= self.label_every)
        fresh = self.expert_fresh[rows]
        shifted = np.concatenate([self.expert_plan[rows, 1:], self.expert_plan[rows, -1:]], axis=1)
        warm = np.where(fresh[:, None, None], shifted, nominal).astype(np.float32)
        plans = {}

        def teacher(index):
            plans["mpc"] = MPCNavigator._plan(self, obs, rows[index], start[index], committed[index], warm[index])
            return plans["mpc"][:, 0]

        features = self._features(obs, rows, start, committed)
        executed, taken, labels = dagger_step(features, self.policy, teacher, query, self.beta, self.rng)
        plan = np.repeat(executed[:, None], self.config.plan_steps, axis=1).astype(np.float32)
        self.expert_fresh[rows] = query
        if query.any():
            labelled = rows[query]
            self.expert_plan[labelled] = plans["mpc"]
            self.since_label[labelled] = 0
            plan[taken] = plans["mpc"][taken[query]]
            self.features.append(features[query])
            self.actions.append(labels)
            self.taken.append(taken[query])
        return plan
