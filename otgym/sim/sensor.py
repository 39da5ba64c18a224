"""Vision-based force sensor (paper section II-D): from a microscope image alone,
locate each trap handle with sub-pixel precision, then turn the trap-to-handle vector
into a force with the trap law.

The sensor knows what a real set-up knows: where it put its traps (the handle of
trap k is near trap k), the handles' radius, the image's pixel size and origin.

Localisation, per handle (compiled: ``otgym.sim.locate``):

1. Detection: among candidate centres on a one-pixel lattice within
   ``search_radius_um`` of the trap, take the darkest point of the image averaged
   over a box about one handle radius wide (ties broken towards the trap).
2. Edge points: cast ``n_rays`` rays from that point and find on each, by linear
   interpolation, where the intensity first rises through half-way between the
   body's dark level and the background (the handle's outline).
3. Robust circle fit: a least-squares circle (algebraic fit, Kasa 1976) through the
   edge points; rays whose point is far from the circle (more than 3 robust standard
   deviations) are dropped and the fit repeated. A handle is part of a rigid cluster
   of spheres, so rays that run into a neighbouring sphere of its body, or into
   another body, find no edge or an edge off the circle: this local model of the
   handle, a circle seen over the free part of its outline, needs no model of the
   rest of the robot. Rays next to a ray that found no outline are dropped as well
   (the blurred neck between touching spheres moves their edge outwards). Blur and threshold shift every edge point radially by the
   same amount, which the free radius absorbs, so the centre is unbiased.
4. Steps 2-3 are repeated from the fitted centre (rays then cross the edge at
   right angles).

Forces: ``TrapLaw.force_pn(trap - handle)``, evaluated in numpy by ``trap_force_pn``
(the same formula).

Cost: the interactive loop senses four 48 x 48 crops each tick, where numpy's cost
was per call (some 330 calls on small arrays), not per pixel. Steps 1-4 are compiled
with numba (``otgym.sim.locate``, one call for every handle of a batch; the same
arithmetic as the numpy implementation it replaced, so the same readings to float
round-off), the constant arrays (detection lattice, ray and ring offsets) are built
once per sensor and pixel size, and the trap law is evaluated in numpy: about
0.1 ms per call for four handles on this project's CPU, against 1.2 ms in numpy
(benchmarks/README.md).
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from otgym.physics.traps import TrapLaw
from otgym.physics.validation import require_positive_scalar
from otgym.sim.locate import MIN_EDGE_POINTS, locate_handles

RAY_REACH = 1.4
"""Rays end at 1.4 handle radii: past the handle's own outline, short of the far side
of a touching sphere."""
BLOCKED_MARGIN_DEG = 20.0
"""Rays this close in angle to a ray that found no outline (it ran into a touching
sphere) are dropped too: there the blurred neck between the spheres moves the edge."""
RING_POINTS = 48
"""Samples of the background ring."""


@dataclasses.dataclass(frozen=True)
class SensorReading:
    """Estimates per frame and trap: handle positions (B, K, 2) um, forces (B, K, 2) pN,
    and ``valid`` (B, K): False where no handle outline was found near the trap (too
    little contrast, too few edge points, or an outline of the wrong size); the force
    is NaN there."""

    handle_xy_um: np.ndarray
    force_pn: np.ndarray
    valid: np.ndarray


@dataclasses.dataclass(frozen=True)
class VisionForceSensor:
    trap_law: TrapLaw = TrapLaw.paper()
    handle_radius_um: float = 1.25
    search_radius_um: float = 1.0
    n_rays: int = 64
    ray_step_px: float = 0.5

    def __post_init__(self):
        require_positive_scalar("handle_radius_um", self.handle_radius_um)
        require_positive_scalar("search_radius_um", self.search_radius_um)
        require_positive_scalar("ray_step_px", self.ray_step_px)
        if self.n_rays < MIN_EDGE_POINTS:
            raise ValueError(f"n_rays must be at least {MIN_EDGE_POINTS}, got {self.n_rays}")

    def measure(self, images, origin_um, pixel_size_um: float, trap_xy_um) -> SensorReading:
        """images: (B, h, w) or (h, w); origin_um: (B, 2) or (2,) top-left corners;
        trap_xy_um: (B, K, 2) or (K, 2) trap centres in the same um frame."""
        single = np.ndim(images) == 2
        images = np.asarray(images, np.float32)[None] if single else np.asarray(images, np.float32)
        origin = np.asarray(origin_um, np.float64).reshape(-1, 2)
        traps = np.asarray(trap_xy_um, np.float64)
        traps = traps[None] if traps.ndim == 2 else traps
        require_positive_scalar("pixel_size_um", pixel_size_um)
        if images.ndim != 3 or 0 in images.shape[1:]:
            raise ValueError(f"images must have shape (B, h, w) or (h, w) with h, w >= 1, got {np.shape(images)}")
        if traps.ndim != 3 or traps.shape[-1] != 2:
            raise ValueError(f"trap_xy_um must have shape (B, K, 2) or (K, 2), got {np.shape(trap_xy_um)}")
        if traps.shape[0] != images.shape[0] or origin.shape[0] != images.shape[0]:
            raise ValueError(f"got {images.shape[0]} images, {origin.shape[0]} origins, {traps.shape[0]} trap sets")
        # everything below works in pixel-index coordinates (col, row) of the frame
        traps_px = (traps - origin[:, None, :]) / pixel_size_um - 0.5
        handle_px, valid = self._locate(images, traps_px, pixel_size_um)
        handle_um = (handle_px + 0.5) * pixel_size_um + origin[:, None, :]
        force = trap_force_pn(self.trap_law, traps - handle_um)
        return SensorReading(handle_um, np.where(valid[..., None], force, np.nan), valid)

    def _geometry(self, pixel_size_um: float) -> _Geometry:
        return _geometry(
            self.handle_radius_um, self.search_radius_um, self.n_rays, self.ray_step_px, float(pixel_size_um)
        )

    def _locate(self, images, traps_px, pixel_size_um):
        frames, k = traps_px.shape[:2]
        g = self._geometry(pixel_size_um)
        frame_of = np.repeat(np.arange(frames), k)
        images = np.ascontiguousarray(images).view()
        images.flags.writeable = False  # one numba type whatever the caller passed: one compile
        centres, valid = locate_handles(
            images,
            frame_of,
            np.ascontiguousarray(traps_px.reshape(-1, 2)),
            g.box,
            g.lattice,
            g.lattice_penalty,
            g.ring,
            g.ray_s,
            g.ray_dx,
            g.ray_dy,
            g.directions,
            g.blocked_margin,
            float(self.ray_step_px),
            g.radius_px,
        )
        return centres.reshape(frames, k, 2), valid.reshape(frames, k)


@dataclasses.dataclass(frozen=True)
class _Geometry:
    """Constant arrays of one sensor at one pixel size (read-only, cached)."""

    radius_px: float
    box: int
    lattice: np.ndarray  # (C, 2) candidate offsets of detection
    lattice_penalty: np.ndarray  # (C,) the tie-break towards the trap
    ring: np.ndarray  # (RING_POINTS, 2) background ring offsets
    directions: np.ndarray  # (R, 2) ray directions
    ray_s: np.ndarray  # (S,) distances along a ray
    ray_dx: np.ndarray  # (R, S) ray sample offsets, col
    ray_dy: np.ndarray  # (R, S) ray sample offsets, row
    blocked_margin: int  # rays within this many rays of one that found no outline are dropped


@functools.lru_cache(maxsize=64)
def _geometry(handle_radius_um, search_radius_um, n_rays, ray_step_px, pixel_size_um) -> _Geometry:
    """The constant arrays of a sensor at one pixel size, built on its first call."""
    radius_px = handle_radius_um / pixel_size_um
    reach = search_radius_um / pixel_size_um
    lattice = _disc_points(reach)
    angles = np.linspace(0.0, 2 * np.pi, RING_POINTS, endpoint=False)
    ring = 1.6 * radius_px * np.stack([np.cos(angles), np.sin(angles)], axis=-1)
    angles = np.linspace(0.0, 2 * np.pi, n_rays, endpoint=False)
    directions = np.stack([np.cos(angles), np.sin(angles)], axis=-1)
    s = np.arange(0.3 * radius_px, RAY_REACH * radius_px, ray_step_px)
    if len(s) < 2:
        raise ValueError(
            f"ray_step_px {ray_step_px} leaves fewer than two samples per ray on a handle of {radius_px:g} pixels"
        )
    offsets = s[None, :, None] * directions[:, None, :]
    geometry = _Geometry(
        radius_px=radius_px,
        box=max(int(round(radius_px)) | 1, 1),
        lattice=lattice,
        lattice_penalty=1e-3 * np.linalg.norm(lattice, axis=-1) / max(reach, 1.0),
        ring=ring,
        directions=directions,
        ray_s=s,
        ray_dx=np.ascontiguousarray(offsets[..., 0]),
        ray_dy=np.ascontiguousarray(offsets[..., 1]),
        blocked_margin=int(np.ceil(BLOCKED_MARGIN_DEG / (360.0 / n_rays))),
    )
    for field in dataclasses.fields(geometry):
        value = getattr(geometry, field.name)
        if isinstance(value, np.ndarray):
            value.flags.writeable = False
    return geometry


def _disc_points(radius_px: float) -> np.ndarray:
    steps = np.arange(-np.floor(radius_px), np.floor(radius_px) + 1)
    grid = np.stack(np.meshgrid(steps, steps), axis=-1).reshape(-1, 2)
    return grid[np.linalg.norm(grid, axis=-1) <= radius_px]


def trap_force_pn(law: TrapLaw, handle_to_trap_um) -> np.ndarray:
    """``law.force_pn`` (otgym.physics.traps) in plain numpy, the same formula term
    by term: force (..., 2) on a handle given the vector (..., 2) from handle to trap.
    For a few handles eager jax.numpy calls cost far more than the arithmetic. It
    computes in float64 where jax by default computes in float32, so the two differ
    by float32 round-off (tests/sim/test_sensor.py checks every law preset)."""
    vector = np.asarray(handle_to_trap_um, np.float64)
    distance = np.sqrt(np.sum(vector**2, axis=-1))
    safe = np.where(distance > 0, distance, 1.0)
    scale = np.where(distance > 0, law.magnitude_pn(distance, np) / safe, 0.0)
    return vector * scale[..., None]


def sensor_errors(reading: SensorReading, true_handle_xy_um, true_force_pn) -> dict[str, np.ndarray]:
    """Per-handle position error (um) and relative force error |F_est - F| / |F| against
    the simulator's truth, over the valid readings."""
    valid = reading.valid
    position = np.linalg.norm(reading.handle_xy_um - np.asarray(true_handle_xy_um), axis=-1)[valid]
    true_force = np.asarray(true_force_pn)
    force = np.linalg.norm(reading.force_pn - true_force, axis=-1)[valid]
    return {"position_um": position, "relative_force": force / np.linalg.norm(true_force, axis=-1)[valid]}
