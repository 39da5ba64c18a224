"""A physics model: bodies, traps, fluid and walls compiled into flat JAX arrays.

``build_model`` turns validated Python descriptions (``BodySpec``, ``PhysicsConfig``)
into a ``Model`` pytree whose array shapes depend only on the scene's structure, so
one compiled step serves every environment of that structure (``vmap`` over states).
Spheres of all bodies are flattened into one list; the sphere pairs that can touch
(different bodies, not both kinematic) are listed once, statically.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Sequence

import jax.numpy as jnp
import numpy as np
from flax import struct

from otgym.physics.adhesion import Adhesion
from otgym.physics.bodies import BodySpec
from otgym.physics.constants import (
    ROOM_TEMPERATURE_K,
    WATER_VISCOSITY_PA_S,
    thermal_energy_pn_um,
)
from otgym.physics.fields import NoWalls, UniformFlow
from otgym.physics.interactions import CONTACT_STEP_FRACTION
from otgym.physics.mobility import body_hydrodynamics
from otgym.physics.traps import TrapLaw
from otgym.physics.validation import (
    require_non_negative,
    require_positive,
    require_positive_scalar,
    require_shape,
)

STABILITY_LIMIT = 1.0
"""Largest allowed dt * (trap stiffness * point mobility): explicit Euler is stable
below 2; below 1 it relaxes without overshoot."""

TUNNELLING_FRACTION = 0.5
"""A step may move a sphere (drift + 3 sigma of noise) by at most this fraction of
the smallest sphere radius, so nothing passes through anything in one step."""


@dataclasses.dataclass(frozen=True)
class PhysicsConfig:
    """Physical and numerical parameters (units in the names; defaults from the
    literature, see otgym.physics.constants)."""

    dt_s: float = 1e-4
    substeps: int = 1
    temperature_k: float = ROOM_TEMPERATURE_K
    viscosity_pa_s: float = WATER_VISCOSITY_PA_S
    adhesion: Adhesion = Adhesion()
    """Van der Waals between materials (``otgym.physics.adhesion``)."""
    hydrodynamic_interaction: bool = True
    """True: a body's spheres interact hydrodynamically (RPY rigid multiblob); False:
    free-draining spheres (``otgym.physics.mobility``)."""
    height_above_floor_um: float | None = None
    """Near-floor (Faxen) drag correction; only with ``hydrodynamic_interaction=False``."""
    trap_law: TrapLaw = TrapLaw()
    dtype: str = "float32"
    field_refresh_substeps: int = 1
    """Sample the chip's flow and walls every this many steps (see integrator)."""
    contact_overlap_cap: float | None = None
    """None (default): penalty contact alone. A fraction c in (0, 1): after each step,
    bodies are projected apart so that no overlap exceeds c times the smaller radius
    of its pair, or c times the radius at a wall (``otgym.physics.projection``)."""
    contact_projection_iterations: int = 64
    """Most Jacobi iterations of that projection per step (they stop once converged).
    In dense driven packings the deepest overlap at the end of a control step was
    1.00-1.01 times its cap at 64, up to 1.08 at 32, 1.54 at 16 and 1.48 at 8."""

    def __post_init__(self):
        require_positive_scalar("dt_s", self.dt_s)
        if not isinstance(self.substeps, int) or self.substeps < 1:
            raise ValueError(f"substeps must be a positive integer, got {self.substeps!r}")
        refresh = self.field_refresh_substeps
        if not isinstance(refresh, int) or refresh < 1 or self.substeps % refresh:
            raise ValueError(
                f"field_refresh_substeps must be a positive integer dividing substeps={self.substeps}, got {refresh!r}"
            )
        require_non_negative("temperature_k", self.temperature_k)
        require_positive("viscosity_pa_s", self.viscosity_pa_s)
        if not isinstance(self.adhesion, Adhesion):
            raise ValueError(f"adhesion must be an otgym.physics.Adhesion, got {self.adhesion!r}")
        if not isinstance(self.hydrodynamic_interaction, bool):
            raise ValueError(f"hydrodynamic_interaction must be True or False, got {self.hydrodynamic_interaction!r}")
        if self.height_above_floor_um is not None:
            require_positive("height_above_floor_um", self.height_above_floor_um)
            if self.hydrodynamic_interaction:
                raise ValueError(
                    "height_above_floor_um: the near-floor correction exists only for free-draining "
                    "spheres; set hydrodynamic_interaction=False to use it"
                )
        if self.dtype not in ("float32", "float64"):
            raise ValueError(f"dtype must be 'float32' or 'float64', got {self.dtype!r}")
        if not isinstance(self.trap_law, TrapLaw):
            raise ValueError(f"trap_law must be a TrapLaw, got {self.trap_law!r}")
        cap = self.contact_overlap_cap
        if cap is not None and not (isinstance(cap, (int, float)) and 0 < cap < 1):
            raise ValueError(f"contact_overlap_cap must be None or a fraction in (0, 1), got {cap!r}")
        iterations = self.contact_projection_iterations
        if not isinstance(iterations, int) or not 1 <= iterations <= 100:
            raise ValueError(f"contact_projection_iterations must be an integer within 1..100, got {iterations!r}")

    @property
    def kt_pn_um(self) -> float:
        return thermal_energy_pn_um(self.temperature_k)

    @property
    def control_period_s(self) -> float:
        return self.dt_s * self.substeps


@struct.dataclass
class Model:
    """Flat arrays of one scene structure (N spheres, B bodies, P pairs, T traps)."""

    sphere_offset_um: jnp.ndarray  # (N, 2) in the body frame, about the hydrodynamic centre
    sphere_radius_um: jnp.ndarray  # (N,)
    sphere_flow_weight: jnp.ndarray  # (N, 3, 3) body frame: [F, T] from [u, w/2] at the sphere
    body_of_sphere: jnp.ndarray  # (N, B) one-hot
    body_translational_resistance_pn_s_per_um: jnp.ndarray  # (B, 2, 2) body frame
    body_translational_mobility: jnp.ndarray  # (B, 2, 2) body frame, um/(pN s); 0 if kinematic
    body_rotational_mobility: jnp.ndarray  # (B,) 1/(pN um s); 0 if kinematic
    body_translational_noise_um: jnp.ndarray  # (B, 2, 2): sqrt(2 kT dt) chol(mobility), body frame
    body_rotational_noise_rad: jnp.ndarray  # (B,): sqrt(2 kT dt rotational mobility)
    kinematic_mask: jnp.ndarray  # (B, 3): 1 for kinematic bodies
    pair_stiffness_pn_per_um: jnp.ndarray  # (P,)
    pair_incidence: jnp.ndarray  # (N, P): +1 at the pair's first sphere, -1 at its second
    pair_to_body_pair: jnp.ndarray  # (P, BP) one-hot
    trap_incidence: jnp.ndarray  # (N, T) one-hot: the sphere each trap holds
    wall_stiffness_pn_per_um: jnp.ndarray  # (N,); 0 for spheres of kinematic bodies
    pair_hamaker_pn_um: jnp.ndarray  # (P,) Hamaker constant of each pair's materials
    wall_hamaker_pn_um: jnp.ndarray  # (N,) Hamaker constant of each sphere with the walls
    pair_overlap_cap_um: jnp.ndarray  # (P,) deepest overlap the projection allows (with it on)
    wall_overlap_cap_um: jnp.ndarray  # (N,) the same at the walls
    dt_s: jnp.ndarray
    min_gap_um: jnp.ndarray
    retardation_wavelength_um: jnp.ndarray
    flow: object = struct.field(default_factory=UniformFlow)
    walls: object = struct.field(default_factory=NoWalls)
    pair_a: tuple = struct.field(pytree_node=False, default=())
    pair_b: tuple = struct.field(pytree_node=False, default=())
    trap_sphere: tuple = struct.field(pytree_node=False, default=())
    sphere_body: tuple = struct.field(pytree_node=False, default=())
    body_pairs: tuple = struct.field(pytree_node=False, default=())
    body_names: tuple = struct.field(pytree_node=False, default=())
    body_kinds: tuple = struct.field(pytree_node=False, default=())
    trap_law: TrapLaw = struct.field(pytree_node=False, default=TrapLaw())
    substeps: int = struct.field(pytree_node=False, default=1)
    field_refresh: int = struct.field(pytree_node=False, default=1)
    projection_iterations: int = struct.field(pytree_node=False, default=0)
    """0: penalty contact alone; else the overlap projection's iterations per step."""

    @property
    def n_bodies(self) -> int:
        return len(self.body_names)

    @property
    def n_traps(self) -> int:
        return len(self.trap_sphere)

    def body_index(self, name: str) -> int:
        if name not in self.body_names:
            raise ValueError(f"no body named {name!r}; bodies are {self.body_names}")
        return self.body_names.index(name)

    def body_pair_index(self, a: str | int, b: str | int) -> int:
        """Index into per-body-pair reports (order of the two bodies does not matter)."""
        ia = self.body_index(a) if isinstance(a, str) else int(a)
        ib = self.body_index(b) if isinstance(b, str) else int(b)
        key = (min(ia, ib), max(ia, ib))
        if key not in self.body_pairs:
            raise ValueError(f"bodies {a!r} and {b!r} cannot touch (same body or both kinematic)")
        return self.body_pairs.index(key)


@struct.dataclass
class PhysicsState:
    """Pose (x_um, y_um, theta_rad) of each body's hydrodynamic centre and each trap's centre."""

    pose: jnp.ndarray  # (B, 3)
    trap_xy_um: jnp.ndarray  # (T, 2)


def default_traps(bodies: Sequence[BodySpec]) -> list[tuple[int, int]]:
    """One trap on every handle of every body, in body order."""
    return [(b, h) for b, body in enumerate(bodies) for h in body.handle_indices]


def max_stable_dt_s(
    bodies: Sequence[BodySpec], config: PhysicsConfig, traps: Sequence[tuple[int, int]] | None = None
) -> float:
    """Largest step that keeps explicit Euler-Maruyama stable (trap relaxation) and
    free of tunnelling (drift plus 3 sigma of noise below half the smallest radius)."""
    traps = default_traps(bodies) if traps is None else traps
    law = config.trap_law
    kt = config.kt_pn_um
    smallest_radius = min(float(b.radii_um.min()) for b in bodies)
    limit = math.inf
    for index, body in enumerate(bodies):
        if body.kinematic:
            continue
        mobility = _hydrodynamics(body, config).max_point_mobility_um_per_pn_s
        n_traps = sum(1 for b, _ in traps if b == index)
        if n_traps:
            limit = min(limit, STABILITY_LIMIT / (mobility * n_traps * law.centre_stiffness_pn_per_um))
        drift_um_per_s = mobility * n_traps * law.max_force_pn if n_traps else 0.0
        step_budget = TUNNELLING_FRACTION * smallest_radius
        # solve drift*dt + 3*sqrt(2 kT mobility dt) = budget for dt
        noise = 3 * math.sqrt(2 * kt * mobility)
        if drift_um_per_s > 0:
            root = (-noise + math.sqrt(noise**2 + 4 * drift_um_per_s * step_budget)) / (2 * drift_um_per_s)
        else:
            root = step_budget / noise if noise > 0 else math.inf
        limit = min(limit, root**2)
    return limit


def _hydrodynamics(body: BodySpec, config: PhysicsConfig):
    return body_hydrodynamics(
        body.offsets_um,
        body.radii_um,
        config.viscosity_pa_s,
        interaction=config.hydrodynamic_interaction,
        height_above_floor_um=config.height_above_floor_um,
    )


def _check_traps(bodies: Sequence[BodySpec], traps) -> list[tuple[int, int]]:
    checked = []
    for entry in traps:
        if len(entry) != 2:
            raise ValueError(f"traps entries must be (body_index, handle_index), got {entry!r}")
        b, h = int(entry[0]), int(entry[1])
        if not 0 <= b < len(bodies):
            raise ValueError(f"traps: body index {b} outside 0..{len(bodies) - 1}")
        if h not in bodies[b].handle_indices:
            raise ValueError(
                f"traps: sphere {h} of body {bodies[b].name!r} is not a handle (handles: {bodies[b].handle_indices})"
            )
        checked.append((b, h))
    return checked


def build_model(
    bodies: Sequence[BodySpec],
    config: PhysicsConfig = PhysicsConfig(),
    *,
    traps: Sequence[tuple[int, int]] | None = None,
    flow=None,
    walls=None,
) -> Model:
    """Compile a scene description into a ``Model``.

    traps: (body_index, handle_sphere_index) for each optical trap; default one per
    handle. Raises ValueError naming the parameter for any invalid input, including
    a ``dt_s`` too large for stability (see ``max_stable_dt_s``).
    """
    if len(bodies) == 0:
        raise ValueError("bodies must contain at least one body")
    if not all(isinstance(b, BodySpec) for b in bodies):
        raise ValueError("bodies must be BodySpec instances (see otgym.physics.bodies)")
    names = [b.name for b in bodies]
    if len(set(names)) != len(names):
        raise ValueError(f"body names must be unique, got {names}")
    traps = _check_traps(bodies, default_traps(bodies) if traps is None else traps)
    dt_limit = max_stable_dt_s(bodies, config, traps)
    if config.dt_s > dt_limit:
        raise ValueError(
            f"dt_s={config.dt_s:g} is too large for stability with these bodies "
            f"and trap law: it must be at most {dt_limit:.3g} s"
        )

    dtype = jnp.float64 if config.dtype == "float64" else jnp.float32
    kt = config.kt_pn_um
    offsets, radii, flow_weights, sphere_body, sphere_start = [], [], [], [], []
    resistance_t = np.zeros((len(bodies), 2, 2))
    mobility_t = np.zeros((len(bodies), 2, 2))
    mobility_r = np.zeros(len(bodies))
    point_mobility = np.zeros(len(bodies))
    for index, body in enumerate(bodies):
        hydro = _hydrodynamics(body, config)
        sphere_start.append(len(radii))
        offsets.extend(body.offsets_um - hydro.centre_um)
        radii.extend(body.radii_um)
        flow_weights.extend(hydro.flow_weights)
        sphere_body.extend([index] * body.n_spheres)
        resistance_t[index] = hydro.translational_resistance_pn_s_per_um
        if not body.kinematic:
            mobility_t[index] = hydro.translational_mobility_um_per_pn_s
            mobility_r[index] = hydro.rotational_mobility_per_pn_um_s
            point_mobility[index] = hydro.max_point_mobility_um_per_pn_s
    n_spheres, n_bodies = len(radii), len(bodies)
    noise_scale = math.sqrt(2 * kt * config.dt_s)
    noise_t = np.stack([np.linalg.cholesky(m) if np.any(m) else m for m in mobility_t]) * noise_scale
    kinematic = np.array([b.kinematic for b in bodies])

    pair_a, pair_b, pair_stiffness, pair_body_pair, pair_hamaker = [], [], [], [], []
    adhesion = config.adhesion
    body_pairs = [(i, j) for i, j in itertools.combinations(range(n_bodies), 2) if not (kinematic[i] and kinematic[j])]
    for bp, (i, j) in enumerate(body_pairs):
        stiffness = CONTACT_STEP_FRACTION / (config.dt_s * (point_mobility[i] + point_mobility[j]))
        hamaker = adhesion.hamaker_pn_um(bodies[i].material, bodies[j].material)
        for si in range(sphere_start[i], sphere_start[i] + bodies[i].n_spheres):
            for sj in range(sphere_start[j], sphere_start[j] + bodies[j].n_spheres):
                pair_a.append(si)
                pair_b.append(sj)
                pair_stiffness.append(stiffness)
                pair_hamaker.append(hamaker)
                pair_body_pair.append(bp)
    n_pairs = len(pair_a)
    incidence = np.zeros((n_spheres, n_pairs))
    incidence[pair_a, np.arange(n_pairs)] = 1.0
    incidence[pair_b, np.arange(n_pairs)] = -1.0
    pair_to_body_pair = np.zeros((n_pairs, len(body_pairs)))
    pair_to_body_pair[np.arange(n_pairs), pair_body_pair] = 1.0
    sphere_point_mobility = point_mobility[sphere_body]
    wall_stiffness = np.where(
        sphere_point_mobility > 0, CONTACT_STEP_FRACTION / (config.dt_s * np.maximum(sphere_point_mobility, 1e-30)), 0.0
    )
    body_of_sphere = np.zeros((n_spheres, n_bodies))
    body_of_sphere[np.arange(n_spheres), sphere_body] = 1.0
    trap_sphere = tuple(sphere_start[b] + h for b, h in traps)

    def arr(x):  # rounded to dtype on the host: no conversion program compiled per field
        return jnp.asarray(np.asarray(x, float).astype(dtype))

    return Model(
        sphere_offset_um=arr(offsets).reshape(n_spheres, 2),
        sphere_radius_um=arr(radii),
        sphere_flow_weight=arr(flow_weights).reshape(n_spheres, 3, 3),
        body_of_sphere=arr(body_of_sphere),
        body_translational_resistance_pn_s_per_um=arr(resistance_t),
        body_translational_mobility=arr(mobility_t),
        body_rotational_mobility=arr(mobility_r),
        body_translational_noise_um=arr(noise_t),
        body_rotational_noise_rad=arr(noise_scale * np.sqrt(mobility_r)),
        kinematic_mask=arr(np.repeat(kinematic[:, None], 3, axis=1)),
        pair_stiffness_pn_per_um=arr(pair_stiffness),
        pair_incidence=arr(incidence),
        pair_to_body_pair=arr(pair_to_body_pair),
        trap_incidence=arr(np.eye(n_spheres)[:, list(trap_sphere)].reshape(n_spheres, len(trap_sphere))),
        wall_stiffness_pn_per_um=arr(wall_stiffness),
        pair_hamaker_pn_um=arr(pair_hamaker),
        wall_hamaker_pn_um=arr(
            [adhesion.hamaker_pn_um(bodies[b].material, adhesion.wall_material) for b in sphere_body]
        ),
        pair_overlap_cap_um=arr(
            (config.contact_overlap_cap or 0.0)
            * np.minimum(np.asarray(radii, float)[pair_a], np.asarray(radii, float)[pair_b])
        ),
        wall_overlap_cap_um=arr((config.contact_overlap_cap or 0.0) * np.asarray(radii, float)),
        dt_s=arr(config.dt_s),
        min_gap_um=arr(adhesion.min_gap_um),
        retardation_wavelength_um=arr(adhesion.retardation_wavelength_um),
        flow=UniformFlow(jnp.zeros(2, dtype)) if flow is None else flow,
        walls=NoWalls() if walls is None else walls,
        pair_a=tuple(pair_a),
        pair_b=tuple(pair_b),
        trap_sphere=trap_sphere,
        sphere_body=tuple(sphere_body),
        body_pairs=tuple(body_pairs),
        body_names=tuple(names),
        body_kinds=tuple(int(b.kind) for b in bodies),
        trap_law=config.trap_law,
        substeps=config.substeps,
        field_refresh=config.field_refresh_substeps,
        projection_iterations=0 if config.contact_overlap_cap is None else config.contact_projection_iterations,
    )


def sphere_positions_um(model: Model, pose):
    """World positions (..., N, 2) of every sphere for body poses (..., B, 3)."""
    per_sphere = model.body_of_sphere @ pose  # (..., N, 3)
    cos, sin = jnp.cos(per_sphere[..., 2]), jnp.sin(per_sphere[..., 2])
    ox, oy = model.sphere_offset_um[:, 0], model.sphere_offset_um[:, 1]
    rotated = jnp.stack([cos * ox - sin * oy, sin * ox + cos * oy], axis=-1)
    return per_sphere[..., :2] + rotated


def rotate_body_frame(theta, x, y):
    """Vector components (x, y) in a body frame turned by theta -> lab frame."""
    return turn_to_lab((jnp.cos(theta), jnp.sin(theta)), x, y)


def turn_to_lab(turn, x, y):
    """Body-frame components (x, y) -> lab frame, for bodies turned by ``turn`` = (cos,
    sin) of their angles (precomputed: the integrator carries them)."""
    cos, sin = turn
    return cos * x - sin * y, sin * x + cos * y


def turn_to_body(turn, x, y):
    """Lab-frame components (x, y) -> body frame (the inverse of ``turn_to_lab``)."""
    cos, sin = turn
    return cos * x + sin * y, cos * y - sin * x


def drag_force_pn(model: Model, pose, velocity_um_s):
    """Force (..., B, 2) that moves each body's centre at ``velocity_um_s`` (..., B, 2)
    through still fluid: R(theta) A R(theta)^T v, A the body-frame translational
    resistance (anisotropic for elongated bodies)."""
    theta = pose[..., 2]
    to_body_x, to_body_y = rotate_body_frame(-theta, velocity_um_s[..., 0], velocity_um_s[..., 1])
    resistance = model.body_translational_resistance_pn_s_per_um
    force_x = resistance[:, 0, 0] * to_body_x + resistance[:, 0, 1] * to_body_y
    force_y = resistance[:, 1, 0] * to_body_x + resistance[:, 1, 1] * to_body_y
    return jnp.stack(rotate_body_frame(theta, force_x, force_y), axis=-1)


def initial_state(model: Model, pose, trap_xy_um=None) -> PhysicsState:
    """A state with the given body poses (B, 3); traps start centred on their handles
    unless ``trap_xy_um`` (T, 2) is given."""
    dtype = model.sphere_radius_um.dtype
    pose = np.asarray(pose, float)
    require_shape("pose", pose, (model.n_bodies, 3))
    if not np.all(np.isfinite(pose)):
        raise ValueError("pose must be finite")
    pose = jnp.asarray(pose, dtype)
    if trap_xy_um is None:
        trap_xy_um = (
            sphere_positions_um(model, pose)[jnp.array(model.trap_sphere, int)]
            if model.n_traps
            else jnp.zeros((0, 2), dtype)
        )
    else:
        trap_xy_um = np.asarray(trap_xy_um, float)
        require_shape("trap_xy_um", trap_xy_um, (model.n_traps, 2))
    return PhysicsState(pose=pose, trap_xy_um=jnp.asarray(trap_xy_um, dtype))
