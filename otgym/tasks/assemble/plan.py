"""Target patterns and the collision-free plan of the ``assemble`` task.

Patterns (host numpy, centred on the origin, ``spacing`` um between neighbours):
``ring`` (N beads on a circle), ``lattice`` (a square lattice filled row by row),
``letter`` (an L: a vertical stroke and a foot).

Plan (jittable): beads are assigned to targets by a swap-stable assignment of the
summed squared distances (no pair of beads lowers the sum by exchanging targets), and
all traps then move along straight lines, synchronised: trap i is at
``start_i + s (goal_i - start_i)`` at the same progress s for all. For such an
assignment (x_i - x_j) . (g_i - g_j) >= 0 for every pair, so the distance between two
traps never falls below min(start distance, goal distance) / sqrt(2) (the CAPT result:
Turpin, Michael & Kumar, Int. J. Robot. Res. 33, 1148, 2014; the optimal assignment,
which ``scipy.optimize.linear_sum_assignment`` gives on the host, is one such). The
swap-stable assignment is found by pairwise exchanges from the identity, each strictly
lowering the sum, so it ends.
"""

from __future__ import annotations

import itertools
import math

import jax
import jax.numpy as jnp
import numpy as np


def pattern_um(name: str, n: int, spacing_um: float) -> np.ndarray:
    """Target positions (n, 2), centred on the origin."""
    if name == "ring":
        if n == 1:
            points = np.zeros((1, 2))
        else:
            radius = spacing_um / (2 * math.sin(math.pi / n))
            angle = 2 * np.pi * np.arange(n) / n
            points = radius * np.column_stack([np.cos(angle), np.sin(angle)])
    elif name == "lattice":
        cols = math.ceil(math.sqrt(n))
        index = np.arange(n)
        points = spacing_um * np.column_stack([index % cols, index // cols]).astype(float)
    elif name == "letter":
        stem = max(1, math.ceil(0.6 * n))
        foot = n - stem
        points = spacing_um * np.array(
            [(0.0, float(i)) for i in range(stem)] + [(float(j + 1), float(stem - 1)) for j in range(foot)]
        )
    else:
        raise ValueError(f"unknown pattern {name!r}")
    return points - points.mean(axis=0)


def _pairs(n: int) -> np.ndarray:
    return np.array(list(itertools.combinations(range(n), 2)), np.int32).reshape(-1, 2)


def swap_stable_assignment(start_um, targets_um, max_sweeps: int = 64):
    """For starts (N, 2) and targets (N, 2): ``order`` (N,) int32, bead i's target being
    ``targets_um[order[i]]``, such that no exchange of two beads' targets lowers the
    summed squared distance (up to round-off; at most ``max_sweeps`` sweeps over the
    pairs, far more than needed for N <= 16). Jittable."""
    n = start_um.shape[0]
    pairs = jnp.asarray(_pairs(n))
    if n < 2:
        return jnp.zeros(n, jnp.int32)

    def cost(i, target):
        return jnp.sum((start_um[i] - target) ** 2)

    def visit(p, carry):
        order, changed = carry
        i, j = pairs[p, 0], pairs[p, 1]
        gi, gj = targets_um[order[i]], targets_um[order[j]]
        gain = cost(i, gi) + cost(j, gj) - cost(i, gj) - cost(j, gi)
        swap = gain > 1e-6 * (1.0 + cost(i, gi) + cost(j, gj))
        oi, oj = order[i], order[j]
        order = order.at[i].set(jnp.where(swap, oj, oi)).at[j].set(jnp.where(swap, oi, oj))
        return order, changed | swap

    def sweep(carry):
        order, _, count = carry
        order, changed = jax.lax.fori_loop(0, pairs.shape[0], visit, (order, False))
        return order, changed, count + 1

    def again(carry):
        return carry[1] & (carry[2] < max_sweeps)

    order, _, _ = jax.lax.while_loop(again, sweep, (jnp.arange(n, dtype=jnp.int32), jnp.asarray(True), 0))
    return order


def min_plan_separation_um(start_um: np.ndarray, goal_um: np.ndarray, samples: int = 201) -> float:
    """Smallest centre distance between any two traps along the synchronised straight
    moves from ``start_um`` to ``goal_um`` (host, for tests and the baseline's check)."""
    s = np.linspace(0.0, 1.0, samples)[:, None, None]
    path = start_um[None] + s * (goal_um - start_um)[None]
    i, j = _pairs(len(start_um)).T
    return float(np.min(np.linalg.norm(path[:, i] - path[:, j], axis=-1)))
