"""The ``Task`` contract: what every otgym task provides, and what every consumer
(Gymnasium single and vector environments, gymnax, ``otgym train`` / ``evaluate``,
``otgym play --task``) relies on. In the functional style of gymnax and
mujoco_playground:

- ``default_config()`` / ``config(preset)``: a frozen, hashable config (static under
  ``jit``); ``presets()`` names the task's presets.
- ``make_params(config)``: host work done once (scene build, path plan); returns the
  params pytree, so domain randomisation is sampling params.
- ``reset_batch(key, params, n) -> (obs (n, O) float32, state)`` and
  ``step_batch(key, state, action (n, ...), params) -> (obs, state, reward (n,),
  terminated (n,), truncated (n,), info)``: pure and jittable; ``info`` is a flat dict
  of arrays with leading axis n and holds at least ``success`` (bool). Out-of-range
  actions are clipped here (nothing can raise inside ``jit``); ``check_action``
  rejects them at the host edge.
- ``reset`` / ``step``: one environment, by default the batch of one.
- ``observation_size(params)``, ``action_space(params)`` (a Gymnasium ``Discrete`` or
  ``Box``), ``policy_shape(config)`` (a discrete task's sizes, from its config alone),
  ``policy_meta(params)`` (what its policy files record), ``dqn_config(config)`` (the
  DQN hyper-parameters it trains with),
  ``check_action(action, params)`` (numpy in, ValueError on bad input).
- ``frame(state, params, size_px)``: an RGB image (H, W, 3) uint8 of one environment,
  what the Gymnasium renderer and the generic play window draw.
- ``device_action(velocity_um_s, params)``: the action a 2-D pointing device (keyboard,
  mouse, gamepad, haptic stylus) asks for with velocity (vx, vy) um/s; what ``otgym
  play --task`` sends.
- ``control_period_s(params)``: the simulated seconds one ``step`` spans, so ``otgym
  play --task`` steps in real time (default None: the window's own rate).
- ``scene(state, params)``: a ``TaskScene`` of one environment (its spheres, traps,
  targets and lines in um), what ``otgym play --task`` records for Foxglove's 3D scene
  (default None: the recording has the episodes' events but no scene).

A task is registered by name (``otgym.registry``, kind ``tasks``, target the ``Task``
subclass); ``otgym.tasks.load(name)`` returns an instance.
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

import gymnasium as gym
import jax
import jax.numpy as jnp
import numpy as np


@dataclasses.dataclass(frozen=True)
class TaskScene:
    """What one environment shows, in the task's plane (um; x right, y down, as the
    chip frame): each sphere's centre, radius and kind (one of ``"robot"``, ``"cell"``,
    ``"obstacle"``, ``"bead"``: ``otgym.physics.bodies.BodyKind`` by value), each trap's
    centre, the targets (discs of ``target_radius_um`` where something should end up),
    polylines (a planned path, a target direction) and text labels (``(x, y)`` um, text:
    what a port takes)."""

    spheres_um: np.ndarray
    radii_um: np.ndarray
    kinds: tuple[str, ...]
    traps_um: np.ndarray
    targets_um: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 2)))
    target_radius_um: float = 0.5
    lines_um: tuple[np.ndarray, ...] = ()
    labels: tuple[tuple[tuple[float, float], str], ...] = ()

    def __post_init__(self):
        n = np.asarray(self.spheres_um).reshape(-1, 2).shape[0]
        if np.asarray(self.radii_um).shape != (n,) or len(self.kinds) != n:
            raise ValueError(f"need one radius and one kind per sphere ({n}), got {self.radii_um!r}, {self.kinds!r}")


KIND_NAMES = ("robot", "cell", "obstacle", "bead")
"""``otgym.physics.bodies.BodyKind`` names by value, as ``TaskScene.kinds`` gives them."""


class Task:
    """Base class of a task (see the module docstring for the contract)."""

    name: ClassVar[str] = ""
    """The registry name, set by subclasses."""

    # -- configuration -------------------------------------------------------------
    def default_config(self) -> Any:
        raise NotImplementedError

    def presets(self) -> tuple[str, ...]:
        """Names accepted by ``config``; the first is the default."""
        return ("default",)

    def config(self, preset: str | None = None) -> Any:
        """The config of ``preset`` (None: the default); ValueError for an unknown name."""
        if preset not in (None, *self.presets()):
            raise ValueError(f"task {self.name!r} has no preset {preset!r}; choose one of {list(self.presets())}")
        return self.default_config()

    def make_params(self, config: Any) -> Any:
        raise NotImplementedError

    def max_steps(self, params) -> int:
        """Control steps after which an episode is truncated."""
        raise NotImplementedError

    def control_period_s(self, params) -> float | None:
        """Simulated seconds per ``step`` (None: not a physical time)."""
        return None

    # -- functional core -----------------------------------------------------------
    def reset_batch(self, key, params, n_envs: int):
        keys = jax.random.split(key, n_envs)
        return jax.vmap(lambda k: self.reset(k, params))(keys)

    def step_batch(self, key, state, action, params):
        keys = jax.random.split(key, jax.tree.leaves(state)[0].shape[0])
        return jax.vmap(lambda k, s, a: self.step(k, s, a, params))(keys, state, action)

    def reset(self, key, params):
        obs, state = self.reset_batch(key, params, 1)
        return obs[0], jax.tree.map(lambda a: a[0], state)

    def step(self, key, state, action, params):
        batch = jax.tree.map(lambda a: a[None], state)
        out = self.step_batch(key, batch, jnp.asarray(action)[None], params)
        return jax.tree.map(lambda a: a[0], out)

    def auto_reset(self, key, params, obs, state, done):
        """Replace the finished environments (``done`` (n,)) by fresh episodes."""

        def fresh(_):
            new_obs, new_state = self.reset_batch(key, params, done.shape[0])
            pick = lambda a, b: jnp.where(done.reshape(done.shape + (1,) * (a.ndim - 1)), a, b)  # noqa: E731
            return pick(new_obs, obs), jax.tree.map(pick, new_state, state)

        return jax.lax.cond(jnp.any(done), fresh, lambda _: (obs, state), None)

    # -- spaces and the host edge --------------------------------------------------
    def observation_size(self, params) -> int:
        raise NotImplementedError

    def observation_space(self, params) -> gym.spaces.Box:
        return gym.spaces.Box(-np.inf, np.inf, (self.observation_size(params),), np.float32)

    def action_space(self, params) -> gym.Space:
        raise NotImplementedError

    def policy_shape(self, config) -> tuple[int, int]:
        """(observation size, number of actions) of a discrete-action task under
        ``config``: what a policy file's network must fit, checked before any work. The
        default builds the params (``make_params``); a task whose sizes follow from its
        config alone overrides it so that nothing is built. ValueError for a task whose
        actions are not ``Discrete``."""
        params = self.make_params(config)
        space = self.action_space(params)
        if not isinstance(space, gym.spaces.Discrete):
            raise ValueError(f"task {self.name!r} has no discrete actions for a Q-network policy")
        return self.observation_size(params), int(space.n)

    def dqn_config(self, config) -> dict:
        """The DQN hyper-parameters (``otgym.rl.dqn.DQNConfig`` fields) this task trains
        with under ``config`` where they differ from ``DQNConfig``'s defaults: what
        ``otgym train --task`` starts from (default: none)."""
        return {}

    def policy_meta(self, params) -> dict:
        """What a policy file trained on this task records beside its network, so that
        whoever loads it can act without the task (default: nothing; speed control: its
        speed levels). JSON-serialisable."""
        return {}

    action_unit: ClassVar[str] = ""
    """The unit of a ``Box`` action's components, as error messages name it."""

    def check_action(self, action, params) -> np.ndarray:
        """``action`` as the array ``step`` takes, or ValueError saying what is wrong."""
        return check_action(self.action_space(params), action, self.action_unit)

    def check_actions(self, actions, params, num_envs: int) -> np.ndarray:
        """A batch of ``num_envs`` actions, or ValueError naming the bad environments."""
        return check_actions(self.action_space(params), actions, num_envs, self.action_unit)

    def frame(self, state, params, size_px: tuple[int, int] = (600, 400)) -> np.ndarray:
        raise NotImplementedError(f"task {self.name!r} draws no frame")

    def device_action(self, velocity_um_s: np.ndarray, params) -> np.ndarray:
        """The action a 2-D pointing device asks for (default: none, ValueError)."""
        raise ValueError(f"task {self.name!r} takes no pointing-device input")

    def scene(self, state, params) -> TaskScene | None:
        """One environment's ``TaskScene`` for a recording's 3D scene (default: None)."""
        return None


def check_action(space: gym.Space, action, unit: str = "") -> np.ndarray:
    """Validate one action against a ``Discrete`` or ``Box`` space (ValueError)."""
    if isinstance(space, gym.spaces.Discrete):
        integer = isinstance(action, (int, np.integer)) and not isinstance(action, bool)
        integer = integer or (
            isinstance(action, np.ndarray) and action.ndim == 0 and np.issubdtype(action.dtype, np.integer)
        )
        if not integer or not 0 <= int(action) < space.n:
            raise ValueError(f"action must be an integer in 0..{space.n - 1}, got {action!r}")
        return np.asarray(int(action), np.int32)
    if isinstance(space, gym.spaces.Box):
        try:
            array = np.asarray(action, np.float32)
        except (TypeError, ValueError) as error:
            raise ValueError(f"action must be a float array of shape {space.shape}, got {action!r}") from error
        if array.shape != space.shape:
            raise ValueError(f"action must have shape {space.shape}, got {array.shape}")
        if not np.all(np.isfinite(array)):
            raise ValueError(f"action must be finite, got {array.tolist()}")
        if not space.contains(array):
            bounds = f"[{float(space.low.min())}, {float(space.high.max())}]" + (f" {unit}" if unit else "")
            raise ValueError(f"action components must lie in {bounds}, got {array.tolist()}")
        return array
    raise TypeError(f"unsupported action space {space!r}")


def check_actions(space: gym.Space, actions, num_envs: int, unit: str = "") -> np.ndarray:
    """Validate a batch of ``num_envs`` actions (ValueError naming the environments)."""
    array = np.asarray(actions)
    if isinstance(space, gym.spaces.Box):
        try:
            array = np.asarray(actions, np.float32)
        except (TypeError, ValueError) as error:
            raise ValueError(
                f"actions must be a float array of shape {(num_envs, *space.shape)}, got {actions!r}"
            ) from error
        if array.shape != (num_envs, *space.shape):
            raise ValueError(f"actions must have shape {(num_envs, *space.shape)}, got {array.shape}")
    elif array.shape[:1] != (num_envs,):
        raise ValueError(f"actions must have shape ({num_envs},) (one per environment), got {array.shape}")
    if isinstance(space, gym.spaces.Discrete):
        if array.shape != (num_envs,) or not np.issubdtype(array.dtype, np.integer):
            raise ValueError(f"actions must be integers in 0..{space.n - 1}, shape ({num_envs},), got {array!r}")
        if np.any(array < 0) or np.any(array >= space.n):
            raise ValueError(f"actions must be integers in 0..{space.n - 1}, got {array.tolist()}")
        return array.astype(np.int32)
    bad = []
    for index in range(num_envs):
        try:
            check_action(space, array[index], unit)
        except ValueError as error:
            bad.append((index, str(error)))
    if bad:
        raise ValueError(f"{bad[0][1]}: in environments {[i for i, _ in bad]}")
    return array.astype(np.float32)
