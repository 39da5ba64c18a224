"""Flow validation: rectangular-duct Poiseuille, mass conservation, no slip."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import straight_duct

from otgym.sim.fields import fields_from
from otgym.sim.flow import mid_height_factor, rectangular_duct_velocity, solve_flow

WIDTH, HEIGHT, RATE = 25.0, 50.0, 5000.0


pytestmark = pytest.mark.slow  # module fixtures that compile or solve for seconds


def _exact_profiles(y_um):
    """Exact depth-averaged and mid-height profiles of a 25 x 50 um duct carrying RATE."""
    z = np.linspace(0.0, HEIGHT, 201)
    yy = np.linspace(0.0, WIDTH, 201)
    unit_rate = np.trapezoid(np.trapezoid(rectangular_duct_velocity(yy[:, None], z[None, :], WIDTH, HEIGHT), z), yy)
    scale = RATE / unit_rate
    depth_average = np.trapezoid(rectangular_duct_velocity(y_um[:, None], z[None, :], WIDTH, HEIGHT), z) / HEIGHT
    return scale * depth_average, scale * rectangular_duct_velocity(y_um, HEIGHT / 2, WIDTH, HEIGHT)


def test_duct_matches_rectangular_poiseuille_series():
    """The model solves for the depth-averaged velocity, so its faces are compared with
    the depth average of the exact series solution (same flow rate); the focal-plane
    field the physics samples (x mid-height factor) is compared with the exact profile
    at mid-height. Both within 2 % of the peak, half-way along the duct."""
    chip = straight_duct(WIDTH, 60.0, HEIGHT, 0.5, RATE, margin_px=4)
    flow = solve_flow(chip)
    y = (np.arange(50) + 0.5) * 0.5
    depth_average, mid_height = _exact_profiles(y)
    model = flow.u_faces[4:54, flow.u_faces.shape[1] // 2]
    assert np.abs(model - depth_average).max() <= 0.02 * depth_average.max()
    focal = mid_height_factor(WIDTH, HEIGHT) * model
    assert np.abs(focal - mid_height).max() <= 0.02 * mid_height.max()
    assert np.abs(flow.v_faces).max() <= 1e-3 * model.max()


def test_mid_height_factor_limits():
    assert mid_height_factor(2000.0, 50.0) == pytest.approx(1.5, abs=2e-3)  # Hele-Shaw cell
    assert mid_height_factor(25.0, 50.0) == pytest.approx(1.347, abs=2e-3)
    assert mid_height_factor(2.0, 50.0) < 1.05  # tall slit: plug-like in depth


def _branch_sections(chip):
    """(column, row slice) of vertical lines that cut one branch of the default chip."""
    rows = chip.shape[0]
    columns = [2, 60, 120, 478, 540, 597]
    return [(col, half) for col in columns for half in (slice(0, rows // 2), slice(rows // 2, rows))]


def test_flux_through_every_section_of_the_default_chip(default_chip, default_fields):
    """Each branch carries its port's 5000 um^3/s, and all 10000 cross every full
    vertical line; the solver's faces to 1e-6, the field the physics samples
    (integrated at 0.05 um steps, divided by the mid-height factor) within 1 %."""
    flow = default_fields.flow
    grid_flow, _ = fields_from(default_fields, default_chip.fluid)
    dx = default_chip.pixel_size_um
    for col, half in _branch_sections(default_chip):
        assert flow.flux_across_column_um3_s(col, half) == pytest.approx(5000.0, rel=1e-6)
        y = np.arange(half.start * dx, half.stop * dx, 0.05) + 0.025
        xy = np.stack([np.full_like(y, col * dx), y], axis=-1).astype(np.float32)
        sampled = np.asarray(grid_flow.velocity_um_s(xy))[:, 0].sum() * 0.05 * default_chip.channel_height_um
        assert sampled / default_fields.mid_height_factor == pytest.approx(5000.0, rel=0.01)
    for col in range(0, default_chip.shape[1] + 1, 25):
        assert flow.flux_across_column_um3_s(col) == pytest.approx(10000.0, rel=1e-6)


def test_divergence_free_in_every_fluid_pixel(default_chip, default_fields):
    flow = default_fields.flow
    divergence = np.diff(flow.u_faces, axis=1) + np.diff(flow.v_faces, axis=0)
    assert np.abs(divergence[default_chip.fluid]).max() <= 1e-6 * np.abs(flow.u_faces).max()


def test_zero_flow_in_solids_and_on_walls(default_chip, default_fields):
    grid_flow, walls = fields_from(default_fields, default_chip.fluid)
    fluid = default_chip.fluid
    velocity = np.asarray(grid_flow.velocity)
    touches_solid = np.zeros(velocity.shape[:2], bool)
    touches_solid[1:-1, 1:-1] = ~(fluid[1:, 1:] & fluid[:-1, 1:] & fluid[1:, :-1] & fluid[:-1, :-1])
    assert touches_solid.sum() > 100_000 and np.all(velocity[touches_solid] == 0.0)
    rng = np.random.default_rng(0)
    xy = rng.uniform([0, 0], default_chip.size_um, (20000, 2)).astype(np.float32)
    distance, _ = walls.distance_and_normal(xy)
    speed = np.linalg.norm(np.asarray(grid_flow.velocity_um_s(xy)), axis=-1)
    solid = np.asarray(distance) < -default_chip.pixel_size_um
    assert solid.sum() > 5000 and np.all(speed[solid] == 0.0)
    peak = speed.max()
    away_from_ports = (xy[:, 0] > 2.0) & (xy[:, 0] < default_chip.size_um[0] - 2.0)
    near_wall = (np.abs(np.asarray(distance)) < 0.1) & away_from_ports
    assert near_wall.sum() > 50 and np.all(speed[near_wall] <= 0.1 * peak)


def test_flow_is_mirror_symmetric_in_the_mirror_symmetric_chip(default_chip, default_fields):
    """The default geometry is symmetric about x = 150 um with inlets and outlets
    swapped; creeping flow is reversible, so u(x, y) = u(L - x, y), v = -v(L - x, y)."""
    assert np.array_equal(default_chip.fluid, default_chip.fluid[:, ::-1])
    u, v = default_fields.flow.u_faces, default_fields.flow.v_faces
    assert np.abs(u - u[:, ::-1]).max() <= 1e-6 * np.abs(u).max()
    assert np.abs(v + v[:, ::-1]).max() <= 1e-6 * np.abs(u).max()
