"""Optical trap force laws acting on trap handles.

Every law gives a force on the handle directed from the handle towards the trap
centre, with a magnitude f(r) of the handle-to-trap distance r (um):

* ``harmonic``: f = k r, the linear spring used in trap calibration
  (Berg-Sorensen & Flyvbjerg, Rev. Sci. Instrum. 75, 594, 2004).
* ``paper``: the paper's equation 3, f = K r for r < delta and C + A / r^2 for
  r >= delta, with K = 0.455 pN/um, delta = 0.446 um, A = 0.058 pN*um^2,
  C = 0.01 pN (units as otgym reads them; the paper gives none). Note that the
  published constants make the law discontinuous at delta: K delta = 0.203 pN below,
  C + A/delta^2 = 0.302 pN above. We keep the law as published.
* ``gaussian``: the gradient force of a Gaussian beam on a small particle,
  U = -U0 exp(-2 r^2 / w^2) with U0 = k w^2 / 4 so that k is the stiffness at the
  centre: f = k r exp(-2 r^2 / w^2), largest at r = w/2 where it is
  k w exp(-1/2) / 2 (Ashkin, Biophys. J. 61, 569, 1992; Harada & Asakura 1996).

A handle farther than ``escape_distance_um`` from its trap counts as lost (default:
never for ``harmonic``, 2 delta for ``paper``, the waist w for ``gaussian``).

Capture radius: the paper's far field C + A / r^2 never vanishes, so a lost handle
anywhere in the chip would still be pulled back, which a focused beam cannot do (its
gradient force dies out within a few waists, as the Gaussian law's does). The paper law
is therefore zero beyond ``capture_radius_um``, by default its escape distance 2 delta
(0.89 um): a handle the law counts as lost is free. The Gaussian law is left as it is
(its force at 2 w is e^-8 of its peak); the harmonic law has no reach.
"""

from __future__ import annotations

import dataclasses
import math

import jax.numpy as jnp

from otgym.physics.validation import require_positive_scalar

TRAP_LAWS = ("harmonic", "paper", "gaussian")

PAPER_K_PN_PER_UM = 0.455
PAPER_DELTA_UM = 0.446
PAPER_A_PN_UM2 = 0.058
PAPER_C_PN = 0.01


@dataclasses.dataclass(frozen=True)
class TrapLaw:
    """One force law shared by all traps of a model (hashable, static under jit)."""

    name: str = "gaussian"
    stiffness_pn_per_um: float = 50.0
    waist_um: float = 0.6
    paper_k_pn_per_um: float = PAPER_K_PN_PER_UM
    paper_delta_um: float = PAPER_DELTA_UM
    paper_a_pn_um2: float = PAPER_A_PN_UM2
    paper_c_pn: float = PAPER_C_PN
    escape_distance_um: float | None = None
    capture_radius_um: float | None = None

    def __post_init__(self):
        if self.name not in TRAP_LAWS:
            raise ValueError(f"trap law name must be one of {TRAP_LAWS}, got {self.name!r}")
        if self.name == "paper":
            for field in ("paper_k_pn_per_um", "paper_delta_um", "paper_a_pn_um2"):
                require_positive_scalar(field, getattr(self, field))
            if not math.isfinite(self.paper_c_pn) or self.paper_c_pn < 0:
                raise ValueError(f"paper_c_pn must be non-negative, got {self.paper_c_pn!r}")
        else:
            require_positive_scalar("stiffness_pn_per_um", self.stiffness_pn_per_um)
        if self.name == "gaussian":
            require_positive_scalar("waist_um", self.waist_um)
        if self.escape_distance_um is not None and not (
            self.escape_distance_um == math.inf
            or require_positive_scalar("escape_distance_um", self.escape_distance_um)
        ):
            raise ValueError("escape_distance_um must be positive")
        if self.capture_radius_um is not None:
            if self.name != "paper":
                raise ValueError(f"capture_radius_um applies to the paper law only, not {self.name!r}")
            require_positive_scalar("capture_radius_um", self.capture_radius_um)

    @classmethod
    def paper(cls, **overrides) -> TrapLaw:
        return cls(name="paper", **overrides)

    @property
    def escape_distance(self) -> float:
        if self.escape_distance_um is not None:
            return float(self.escape_distance_um)
        return {"harmonic": math.inf, "paper": 2 * self.paper_delta_um, "gaussian": self.waist_um}[self.name]

    @property
    def capture_radius(self) -> float:
        """Distance (um) beyond which the law exerts no force (paper law: its escape
        distance unless set; the other laws: unbounded)."""
        if self.name != "paper":
            return math.inf
        return float(self.capture_radius_um) if self.capture_radius_um is not None else self.escape_distance

    @property
    def centre_stiffness_pn_per_um(self) -> float:
        """Stiffness at the trap centre (the restoring rate the integrator must resolve)."""
        return self.paper_k_pn_per_um if self.name == "paper" else self.stiffness_pn_per_um

    @property
    def max_force_pn(self) -> float:
        """Largest restoring force within the escape distance; a steady drag above it
        pulls the handle out (escape speed = max_force_pn / drag)."""
        if self.name == "harmonic":
            return self.stiffness_pn_per_um * self.escape_distance
        if self.name == "paper":
            k, d = self.paper_k_pn_per_um, self.paper_delta_um
            return max(k * d, self.paper_c_pn + self.paper_a_pn_um2 / d**2)
        return self.stiffness_pn_per_um * self.waist_um * math.exp(-0.5) / 2

    def magnitude_pn(self, distance_um, xp=jnp):
        """Restoring force magnitude f(r) in pN for handle-to-trap distance r (um);
        ``xp`` is the array module (``jax.numpy``, or ``numpy`` for host-side code)."""
        r = xp.asarray(distance_um)
        if self.name == "harmonic":
            return self.stiffness_pn_per_um * r
        if self.name == "gaussian":
            return self.stiffness_pn_per_um * r * xp.exp(-2 * r**2 / self.waist_um**2)
        safe_r = xp.maximum(r, self.paper_delta_um)
        far = xp.where(r <= self.capture_radius, self.paper_c_pn + self.paper_a_pn_um2 / safe_r**2, 0.0)
        return xp.where(r < self.paper_delta_um, self.paper_k_pn_per_um * r, far)

    def force_pn(self, handle_to_trap_um):
        """Force (..., 2) on a handle given the vector (..., 2) from handle to trap."""
        vector = jnp.asarray(handle_to_trap_um)
        distance = jnp.sqrt(jnp.sum(vector**2, axis=-1))
        safe = jnp.where(distance > 0, distance, 1.0)
        scale = jnp.where(distance > 0, self.magnitude_pn(distance) / safe, 0.0)
        return vector * scale[..., None]
