"""The distilled MPC policy: route-frame features and the clone's fit."""

import pytest
import numpy as np
import jax.numpy as jnp

from otgym.control import formation as fm
from otgym.runtime.mpc_policy import ClonedPolicy, route_features, train
from otgym.runtime.route_frame import RouteData


def _route(points):
    arc = jnp.linspace(0.0, 1.0, 4, dtype=jnp.float32)
    return RouteData(fm.dense_path(points), arc, jnp.ones(4, jnp.float32), jnp.ones(4, jnp.float32))


def _turn(v, angle, shift=(0.0, 0.0)):
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], axis=-1) + np.asarray(shift)


def test_features_are_the_same_for_a_rotated_and_translated_scene():
    rng = np.random.default_rng(0)
    bend = np.array([[0.0, 0.0], [60.0, 0.0], [100.0, 40.0], [100.0, 120.0]])
    arc = np.array([20.0, 70.0, 130.0])
    start = rng.normal(size=(3, 3)).astype(np.float32)
    committed = rng.normal(size=(3, 3)).astype(np.float32)
    cell = np.array([[20.0, 3.0], [62.0, 5.0], [96.0, 50.0]])
    cell_v = rng.normal(size=(3, 2))
    obstacles = rng.uniform(0, 100, size=(3, 2, 2))
    obstacle_v = rng.normal(size=(3, 2, 2))
    plain = route_features(_route(bend), start, committed, cell, arc, cell_v, obstacles, obstacle_v)
    angle, shift = 1.1, (-40.0, 250.0)
    moved = route_features(_route(_turn(bend, angle, shift)), start, committed, _turn(cell, angle, shift), arc,
                           _turn(cell_v, angle), _turn(obstacles, angle, shift), _turn(obstacle_v, angle))
    np.testing.assert_allclose(moved, plain, atol=2e-3)  # float32 route geometry at ~250 um
    # and the features do see the world: moving an obstacle changes them
    shifted = route_features(_route(bend), start, committed, cell, arc, cell_v, obstacles + 5.0, obstacle_v)
    assert np.abs(shifted - plain).max() > 1.0


def test_the_clone_beats_the_mean_predictor_on_held_out_states(tmp_path):
    # a nonlinear teacher (a saturating avoidance rule of the kind the MPC shows):
    # 600 fit / 200 held-out samples
    rng = np.random.default_rng(1)
    x = rng.normal(size=(800, 6)).astype(np.float32)
    y = np.stack([np.tanh(x[:, 0] - x[:, 1]), x[:, 2] * np.exp(-x[:, 3] ** 2), 0.5 * x[:, 4]], axis=-1)
    policy = train(x[:600], y[:600], hidden=(32, 32), epochs=60, batch=100)
    held = np.mean((policy(x[600:]) - y[600:]) ** 2)
    mean = np.mean((y[:600].mean(0) - y[600:]) ** 2)
    assert held < 0.3 * mean
    policy.save(tmp_path / "p.npz")
    np.testing.assert_allclose(ClonedPolicy.load(tmp_path / "p.npz")(x[600:]), policy(x[600:]), rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("argv, reason", [
    (["collect", "x.npz", "--first", "130000"], "development scenarios"),
    (["train", "missing.npz", "out.npz"], "is not a file"),
    (["evaluate", "missing.npz"], "is not a file"),
    (["collect", "no/such/folder/x.npz"], "does not exist"),
])
def test_distil_script_refuses_bad_input_in_one_line_before_any_work(argv, reason, tmp_path, monkeypatch, capsys):
    from otgym.experiments.distil_mpc import main

    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and reason in err and err.count("\n") == 1
    assert list(tmp_path.iterdir()) == []  # nothing written
