"""The scripted baseline of ``sort-cells``: hold the target only while it is on the wrong
side of the junction's dividing streamline (the inlet's axis) or within ``margin_um`` of
it, and move it toward its kind's outlet; let go otherwise, so that no cell is held (and
lit) longer than it must be. Pure and jittable: ``actions(obs, params)`` for a batch."""

from __future__ import annotations

import jax.numpy as jnp

from otgym.tasks.sort_cells.core import SortParams

MARGIN_UM = 5.0
"""How far past the axis the baseline brings a cell: the larger kind's radius, so that
the whole of a cell is on its side."""


def actions(obs, params: SortParams, margin_um: float = MARGIN_UM):
    """Integer actions (E,) for observations (E, 11)."""
    present = obs[:, 0] > 0.5
    kind = jnp.where(obs[:, 1] > 0, 0, 1)
    offset_um = obs[:, 3] * params.half_width_um
    past = offset_um * params.side_sign[kind]
    return jnp.where(present & (past < margin_um), kind + 1, 0).astype(jnp.int32)
