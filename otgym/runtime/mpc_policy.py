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
"""

from __future__ import annotations

import dataclasses
import time

import jax
import jax.numpy as jnp
import numpy as np
import optax

from otgym.runtime.mpc_navigator import MPCNavigator
from otgym.runtime.route_frame import route_frame


def route_features(route, start, committed, cell_xy_um, cell_arc_um, cell_velocity_um_s, obstacle_xy_um,
                   obstacle_velocity_um_s) -> np.ndarray:
    """Features (E, 10 + 4K) in the route frame at the cell's arc (see module doc)."""
    point, tangent, normal, _ = (np.asarray(a, float) for a in route_frame(route, jnp.asarray(cell_arc_um, jnp.float32)))
    along = lambda v: np.sum(v * (tangent[:, None] if v.ndim == 3 else tangent), axis=-1)  # noqa: E731
    across = lambda v: np.sum(v * (normal[:, None] if v.ndim == 3 else normal), axis=-1)  # noqa: E731
    relative = obstacle_xy_um - cell_xy_um[:, None]
    length = float(route.path.length_um)
    columns = [across(cell_xy_um - point), along(cell_velocity_um_s), across(cell_velocity_um_s),
               start[:, 0] - cell_arc_um, start[:, 1], start[:, 2], committed[:, 0], committed[:, 1], committed[:, 2],
               length - cell_arc_um]
    obstacles = np.stack([along(relative), across(relative), along(obstacle_velocity_um_s),
                          across(obstacle_velocity_um_s)], axis=-1).reshape(len(start), -1)
    return np.concatenate([np.stack(columns, axis=-1), obstacles], axis=-1).astype(np.float32)


class _FeatureMixin:
    def _features(self, obs, rows, start, committed) -> np.ndarray:
        now = obs.time_s[rows]
        last = getattr(self, "_last_cell", None)
        velocity = np.zeros((len(rows), 2))
        if last is not None and len(last[0]) == len(obs.time_s):
            dt = now - last[1][rows]
            velocity = np.where((dt > 0)[:, None], (obs.cell_xy_um[rows] - last[0][rows]) / np.maximum(dt, 1e-9)[:, None], 0.0)
        return route_features(self.route, start, committed, obs.cell_xy_um[rows], obs.cell_arc_um[rows], velocity,
                              self.tracker.latest_um()[rows], self.tracker.velocity_um_s()[rows])

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
        arrays = {f"w{i}": np.asarray(l["w"]) for i, l in enumerate(self.layers)}
        arrays |= {f"b{i}": np.asarray(l["b"]) for i, l in enumerate(self.layers)}
        np.savez(path, feature_mean=self.feature_mean, feature_std=self.feature_std, action_mean=self.action_mean,
                 action_std=self.action_std, **arrays)

    @classmethod
    def load(cls, path) -> "ClonedPolicy":
        data = np.load(path)
        n = sum(1 for k in data.files if k.startswith("w"))
        layers = [{"w": jnp.asarray(data[f"w{i}"]), "b": jnp.asarray(data[f"b{i}"])} for i in range(n)]
        return cls(layers, data["feature_mean"], data["feature_std"], data["action_mean"], data["action_std"])


_forward = jax.jit(mlp)


def train(features, actions, hidden=(128, 128), epochs: int = 200, batch: int = 256, learning_rate: float = 1e-3,
          seed: int = 0) -> ClonedPolicy:
    """Fit the MLP by MSE on normalised features and actions (Adam, minibatches)."""
    features, actions = np.asarray(features, np.float32), np.asarray(actions, np.float32)
    f_mean, f_std = features.mean(0), features.std(0) + 1e-6
    a_mean, a_std = actions.mean(0), actions.std(0) + 1e-6
    x, y = jnp.asarray((features - f_mean) / f_std), jnp.asarray((actions - a_mean) / a_std)
    key = jax.random.PRNGKey(seed)
    key, init_key = jax.random.split(key)
    layers = init_mlp(init_key, (x.shape[1], *hidden, y.shape[1]))
    optimiser = optax.adam(learning_rate)
    opt_state = optimiser.init(layers)

    @jax.jit
    def step(layers, opt_state, xb, yb):
        loss, grads = jax.value_and_grad(lambda p: jnp.mean((mlp(p, xb) - yb) ** 2))(layers)
        updates, opt_state = optimiser.update(grads, opt_state, layers)
        return optax.apply_updates(layers, updates), opt_state, loss

    n = len(x)
    size = min(batch, n)
    for _ in range(epochs):
        key, perm_key = jax.random.split(key)
        order = jax.random.permutation(perm_key, n)
        for begin in range(0, n - size + 1, size):
            index = order[begin:begin + size]
            layers, opt_state, _ = step(layers, opt_state, x[index], y[index])
    return ClonedPolicy(layers, f_mean, f_std, a_mean, a_std)


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
