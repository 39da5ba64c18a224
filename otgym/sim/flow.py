"""Steady low-Reynolds-number flow in a chip: depth-averaged Stokes-Brinkman.

Model. A chip channel has a uniform height h. Averaging the Stokes equations over the
depth with a parabolic depth profile gives, for the depth-averaged in-plane velocity
u(x, y) (the Brinkman-Hele-Shaw model, e.g. Gallaire et al., Phys. Fluids 26, 2014;
Bruus, Theoretical Microfluidics, ch. 4):

    eta lap(u) - (12 eta / h^2) u = grad p,    div u = 0,    u = 0 on the side walls.

The Darcy term 12 eta/h^2 carries the no-slip floor and ceiling; the Laplacian the
side walls. In a straight duct 25 um wide and 50 um tall its profile matches the depth
average of the exact rectangular-duct solution within 0.3 % of the peak.

The physics needs the velocity in the focal plane, taken at mid-height. In a straight
duct of width w the mid-height profile has the same shape as the depth average to
within 1 % of the peak, scaled by c(w/h) = u(w/2, h/2) / <u>_z(w/2) from the series
solution (``mid_height_factor``; 1.5 for a shallow Hele-Shaw cell, 1.35 for 25 x 50 um,
towards 1 for a tall slit). We scale the whole field by c of the chip's median channel
width; this is exact for straight channels of that width and an approximation in
chambers.

Discretisation: the marker-and-cell (staggered) grid on the chip's pixels (Harlow &
Welch 1965): pressure in fluid pixels, normal velocities on pixel faces, no-slip by
ghost values on the walls, so the discrete divergence of every fluid pixel is exactly
zero (mass is conserved to solver precision). Ports prescribe the depth-averaged
velocity on the image border with the Brinkman duct profile across the opening. One
pressure per connected channel network is pinned. The sparse saddle-point system is
solved directly (SuperLU via scipy.sparse).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy import ndimage

from otgym.physics.constants import WATER_VISCOSITY_PA_S
from otgym.sim.chip import Chip, PortOpening

DUCT_SERIES_TERMS = 200


@dataclasses.dataclass(frozen=True)
class FlowSolution:
    """Depth-averaged face velocities (um/s) of a chip: ``u_faces`` (H, W+1) on the
    vertical pixel faces (x = col * dx), ``v_faces`` (H+1, W) on the horizontal ones."""

    u_faces: np.ndarray
    v_faces: np.ndarray
    pixel_size_um: float
    channel_height_um: float

    def flux_across_column_um3_s(self, col: int, rows: slice = slice(None)) -> float:
        """Volume flow (um^3/s) in +x through the vertical line x = col * dx."""
        return float(self.u_faces[rows, col].sum() * self.pixel_size_um * self.channel_height_um)

    def flux_across_row_um3_s(self, row: int, cols: slice = slice(None)) -> float:
        """Volume flow (um^3/s) in +y through the horizontal line y = row * dx."""
        return float(self.v_faces[row, cols].sum() * self.pixel_size_um * self.channel_height_um)

    def node_velocity_um_s(self, fluid: np.ndarray) -> np.ndarray:
        """Depth-averaged velocity (H+1, W+1, 2) on the pixel corners (x = col * dx,
        y = row * dx): the mean of the two faces meeting there, and zero on every
        corner that touches a solid pixel, so that bilinear interpolation between
        corners vanishes on the walls. Beyond the border the edge pixels repeat (the
        flow stays open at the ports)."""
        padded = np.pad(fluid, 1, mode="edge")
        open_corner = padded[:-1, :-1] & padded[:-1, 1:] & padded[1:, :-1] & padded[1:, 1:]
        u_pad = np.pad(self.u_faces, ((1, 1), (0, 0)))
        v_pad = np.pad(self.v_faces, ((0, 0), (1, 1)))
        u = 0.5 * (u_pad[1:] + u_pad[:-1])
        v = 0.5 * (v_pad[:, 1:] + v_pad[:, :-1])
        return np.where(open_corner[..., None], np.stack([u, v], axis=-1), 0.0)

    def node_vorticity_per_s(self, fluid: np.ndarray) -> np.ndarray:
        """Vorticity dv/dx - du/dy (H+1, W+1) on the pixel corners from the staggered
        differences of the faces around each corner; a face inside a wall takes the
        no-slip ghost value (minus its fluid neighbour), so the wall shear is kept."""
        cols_padded = np.pad(fluid, ((0, 0), (1, 1)), mode="edge")
        rows_padded = np.pad(fluid, ((1, 1), (0, 0)), mode="edge")
        u_fluid = np.pad(cols_padded[:, 1:] & cols_padded[:, :-1], ((1, 1), (0, 0)))
        v_fluid = np.pad(rows_padded[1:] & rows_padded[:-1], ((0, 0), (1, 1)))
        u = np.pad(self.u_faces, ((1, 1), (0, 0)))
        v = np.pad(self.v_faces, ((0, 0), (1, 1)))
        du_dy = _ghost_difference(u[:-1], u[1:], u_fluid[:-1], u_fluid[1:])
        dv_dx = _ghost_difference(v[:, :-1], v[:, 1:], v_fluid[:, :-1], v_fluid[:, 1:])
        return (dv_dx - du_dy) / self.pixel_size_um


def _ghost_difference(low, high, low_fluid, high_fluid):
    """high - low, where a face outside the fluid mirrors its fluid partner (no slip)."""
    low = np.where(low_fluid, low, np.where(high_fluid, -high, 0.0))
    high = np.where(high_fluid, high, np.where(low_fluid, -low, 0.0))
    return high - low


def brinkman_duct_profile(n_cells: int, pixel_size_um: float, height_um: float) -> np.ndarray:
    """Depth-averaged Brinkman profile across a straight duct of ``n_cells`` pixels,
    sampled at the pixel centres and normalised to unit mean."""
    width = n_cells * pixel_size_um
    s = (np.arange(n_cells) + 0.5) * pixel_size_um - width / 2
    k = math.sqrt(12.0) / height_um
    profile = 1.0 - np.exp(k * (np.abs(s) - width / 2)) * (1 + np.exp(-2 * k * np.abs(s))) / (1 + np.exp(-k * width))
    return profile / profile.mean()


def rectangular_duct_velocity(y_um, z_um, width_um: float, height_um: float, terms: int = DUCT_SERIES_TERMS):
    """Exact Poiseuille velocity in a rectangular duct [0, w] x [0, h] for a unit
    pressure gradient over viscosity (-dp/dx / eta = 1), in um^2 (series along the
    width; White, Viscous Fluid Flow, eq. 3-48)."""
    y = np.asarray(y_um, float)[..., None]
    z = np.asarray(z_um, float)[..., None]
    m = np.arange(1, 2 * terms, 2)
    a = np.abs(m * np.pi * (z - height_um / 2) / width_um)
    b = m * np.pi * height_um / (2 * width_um)
    cosh_ratio = np.exp(a - b) * (1 + np.exp(-2 * a)) / (1 + np.exp(-2 * b))
    series = (1 - cosh_ratio) * np.sin(m * np.pi * y / width_um) / m**3
    return 4 * width_um**2 / np.pi**3 * series.sum(axis=-1)


def mid_height_factor(width_um: float, height_um: float, n_depth: int = 401) -> float:
    """u(w/2, h/2) / <u>_z(w/2) of the exact duct flow: mid-height over depth average."""
    z = np.linspace(0.0, height_um, n_depth)
    column = rectangular_duct_velocity(np.full_like(z, width_um / 2), z, width_um, height_um)
    mean = np.trapezoid(column, z) / height_um
    return float(rectangular_duct_velocity(width_um / 2, height_um / 2, width_um, height_um) / mean)


class _Numbering:
    """Indices of the unknowns: interior faces between two fluid pixels, then pixels."""

    def __init__(self, fluid: np.ndarray):
        rows, cols = fluid.shape
        self.u_active = np.zeros((rows, cols + 1), bool)
        self.u_active[:, 1:-1] = fluid[:, 1:] & fluid[:, :-1]
        self.v_active = np.zeros((rows + 1, cols), bool)
        self.v_active[1:-1, :] = fluid[1:, :] & fluid[:-1, :]
        self.u_index = np.full(self.u_active.shape, -1)
        self.v_index = np.full(self.v_active.shape, -1)
        self.p_index = np.full(fluid.shape, -1)
        n_u, n_v, n_p = self.u_active.sum(), self.v_active.sum(), fluid.sum()
        self.u_index[self.u_active] = np.arange(n_u)
        self.v_index[self.v_active] = np.arange(n_u, n_u + n_v)
        self.p_index[fluid] = np.arange(n_u + n_v, n_u + n_v + n_p)
        self.size = int(n_u + n_v + n_p)


def _boundary_velocities(chip: Chip) -> tuple[np.ndarray, np.ndarray]:
    """Prescribed face velocities on the image border (zero except at the ports)."""
    rows, cols = chip.shape
    u = np.zeros((rows, cols + 1))
    v = np.zeros((rows + 1, cols))
    for opening in chip.openings():
        profile = _port_profile(opening, chip)
        if opening.edge == "left":
            u[opening.indices, 0] = profile
        elif opening.edge == "right":
            u[opening.indices, -1] = -profile
        elif opening.edge == "top":
            v[0, opening.indices] = profile
        else:
            v[-1, opening.indices] = -profile
    return u, v


def _port_profile(opening: PortOpening, chip: Chip) -> np.ndarray:
    mean = opening.port.flow_rate_um3_s / (opening.indices.size * chip.pixel_size_um * chip.channel_height_um)
    shape = brinkman_duct_profile(opening.indices.size, chip.pixel_size_um, chip.channel_height_um)
    return opening.inward_sign * mean * shape


def _momentum_rows(active, index, p_index, beta, boundary, axis):
    """Triplets and right-hand side of the scaled momentum equation
    lap(u) - beta u - (p+ - p-) = 0 for the faces normal to ``axis`` (0: u-faces,
    normal x; 1: v-faces, normal y). Neighbours along the normal are faces (known on
    the image border, zero on walls); a neighbour across it that is not a fluid face
    is a wall half a pixel away (no-slip ghost value -u)."""
    faces = np.argwhere(active)
    me = index[active]
    diagonal = np.full(me.size, -4.0 - beta)
    along = np.array([0, 1]) if axis == 0 else np.array([1, 0])
    across = along[::-1]
    rows_, cols_, vals, rhs_rows, rhs_vals = [me], [me], [diagonal], [], []
    for step in (along, -along, across, -across):
        target = faces + step
        in_range = np.all((target >= 0) & (target < np.array(active.shape)), axis=1)
        safe = np.where(in_range[:, None], target, 0)
        unknown = in_range & active[safe[:, 0], safe[:, 1]]
        rows_.append(me[unknown])
        cols_.append(index[safe[unknown, 0], safe[unknown, 1]])
        vals.append(np.ones(unknown.sum()))
        if step @ along != 0:
            rhs_rows.append(me[~unknown])
            rhs_vals.append(-boundary[safe[~unknown, 0], safe[~unknown, 1]])
        else:
            diagonal[~unknown] -= 1.0
    minus = faces - along
    rows_ += [me, me]
    cols_ += [p_index[faces[:, 0], faces[:, 1]], p_index[minus[:, 0], minus[:, 1]]]
    vals += [-np.ones(me.size), np.ones(me.size)]
    return rows_, cols_, vals, np.concatenate(rhs_rows), np.concatenate(rhs_vals)


def solve_flow(chip: Chip, viscosity_pa_s: float = WATER_VISCOSITY_PA_S) -> FlowSolution:
    """Solve the depth-averaged Stokes-Brinkman flow of ``chip`` (see module docstring).

    Creeping flow is linear and the momentum equation is scaled by dx^2/eta, so the
    velocity does not depend on the viscosity; it only sets the pressure, which we do
    not return. ``viscosity_pa_s`` is validated and kept for that reason in the API."""
    if not viscosity_pa_s > 0:
        raise ValueError(f"viscosity_pa_s must be positive, got {viscosity_pa_s!r}")
    fluid = chip.fluid
    numbering = _Numbering(fluid)
    u_boundary, v_boundary = _boundary_velocities(chip)
    beta = 12.0 * chip.pixel_size_um**2 / chip.channel_height_um**2
    rows_, cols_, vals = [], [], []
    rhs = np.zeros(numbering.size)
    for axis, active, index, boundary in (
        (0, numbering.u_active, numbering.u_index, u_boundary),
        (1, numbering.v_active, numbering.v_index, v_boundary),
    ):
        r, c, v, rhs_rows, rhs_vals = _momentum_rows(active, index, numbering.p_index, beta, boundary, axis)
        rows_ += r
        cols_ += c
        vals += v
        np.add.at(rhs, rhs_rows, rhs_vals)
    # continuity of every fluid pixel: u(c+1) - u(c) + v(r+1) - v(r) = 0
    pixels = np.argwhere(fluid)
    me = numbering.p_index[fluid]
    for face_index, boundary, offsets in (
        (numbering.u_index, u_boundary, ((0, 1, 1.0), (0, 0, -1.0))),
        (numbering.v_index, v_boundary, ((1, 0, 1.0), (0, 0, -1.0))),
    ):
        for dr, dc, sign in offsets:
            target = face_index[pixels[:, 0] + dr, pixels[:, 1] + dc]
            unknown = target >= 0
            rows_.append(me[unknown])
            cols_.append(target[unknown])
            vals.append(np.full(unknown.sum(), sign))
            np.add.at(rhs, me[~unknown], -sign * boundary[pixels[~unknown, 0] + dr, pixels[~unknown, 1] + dc])
    matrix = sp.csr_matrix(
        (np.concatenate(vals), (np.concatenate(rows_), np.concatenate(cols_))), shape=(numbering.size,) * 2
    )
    matrix, rhs = _pin_pressures(matrix, rhs, fluid, numbering)
    solution = spla.spsolve(matrix.tocsc(), rhs, permc_spec="COLAMD")
    u_faces = u_boundary.copy()
    v_faces = v_boundary.copy()
    u_faces[numbering.u_active] = solution[numbering.u_index[numbering.u_active]]
    v_faces[numbering.v_active] = solution[numbering.v_index[numbering.v_active]]
    return FlowSolution(u_faces, v_faces, chip.pixel_size_um, chip.channel_height_um)


def _pin_pressures(matrix, rhs, fluid, numbering):
    """Replace the continuity row of one pixel per channel network by p = 0 (the
    pressure is defined up to a constant; the dropped row is implied by the others
    because each network's port flows balance, which ``Chip`` checks)."""
    labels, count = ndimage.label(fluid)
    first = ndimage.minimum_position(np.arange(labels.size).reshape(labels.shape), labels, range(1, count + 1))
    pinned = np.array([numbering.p_index[position] for position in first])
    matrix = matrix.tolil()
    for row in pinned:
        matrix.rows[row] = [row]
        matrix.data[row] = [1.0]
    rhs = rhs.copy()
    rhs[pinned] = 0.0
    return matrix.tocsr(), rhs
