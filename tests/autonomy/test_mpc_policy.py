"""The distilled MPC policy: route-frame features and the clone's fit."""

import jax.numpy as jnp
import numpy as np
import pytest

from otgym.autonomy.mpc_policy import ClonedPolicy, dagger, dagger_step, route_features, train
from otgym.autonomy.route_frame import RouteData
from otgym.planning import formation as fm


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
    moved = route_features(
        _route(_turn(bend, angle, shift)),
        start,
        committed,
        _turn(cell, angle, shift),
        arc,
        _turn(cell_v, angle),
        _turn(obstacles, angle, shift),
        _turn(obstacle_v, angle),
    )
    np.testing.assert_allclose(moved, plain, atol=2e-3)  # float32 route geometry at ~250 um
    # and the features do see the world: moving an obstacle changes them
    shifted = route_features(_route(bend), start, committed, cell, arc, cell_v, obstacles + 5.0, obstacle_v)
    assert np.abs(shifted - plain).max() > 1.0


@pytest.mark.slow
def test_the_clone_beats_the_mean_predictor_on_held_out_states(tmp_path):
    # a nonlinear teacher (a saturating avoidance rule of the kind the MPC shows):
    # 600 fit / 200 held-out samples
    rng = np.random.default_rng(1)
    x = rng.normal(size=(800, 6)).astype(np.float32)
    y = np.stack([np.tanh(x[:, 0] - x[:, 1]), x[:, 2] * np.exp(-(x[:, 3] ** 2)), 0.5 * x[:, 4]], axis=-1)
    policy = train(x[:600], y[:600], hidden=(32, 32), epochs=60, batch=100)
    held = np.mean((policy(x[600:]) - y[600:]) ** 2)
    mean = np.mean((y[:600].mean(0) - y[600:]) ** 2)
    assert held < 0.3 * mean
    policy.save(tmp_path / "p.npz")
    np.testing.assert_allclose(ClonedPolicy.load(tmp_path / "p.npz")(x[600:]), policy(x[600:]), rtol=1e-5, atol=1e-6)


# A cheap covariate-shift problem for DAgger: a lane with a constant drift, where the
# teacher cancels the drift and steers back to the centre, s' = s + a + DRIFT + noise.
DRIFT = 0.5


def _teacher(s):
    return (-0.8 * s - DRIFT)[:, None]


def _rollout(policy, beta, rng, episodes=8, steps=15):
    """The mixture of ``policy`` and the teacher, driven by ``dagger_step``: (states
    visited, the teacher's labels of them, |s| at the end, the states as the lane saw them)."""
    s = rng.uniform(-0.2, 0.2, episodes)
    features, labels, seen = [], [], []
    for _ in range(steps):
        f = s[:, None].astype(np.float32)
        seen.append(s.copy())
        executed, _, label = dagger_step(f, policy, lambda i: _teacher(s[i]), np.ones(episodes, bool), beta, rng)
        features.append(f)
        labels.append(label)
        s = s + executed[:, 0] + DRIFT + rng.normal(0.0, 0.02, episodes)
    return np.concatenate(features), np.concatenate(labels), np.abs(s), np.concatenate(seen)


def test_dagger_step_labels_every_queried_row_with_the_teacher_and_executes_the_mixture():
    learner = lambda f: np.full((len(f), 2), 7.0)  # noqa: E731
    teacher = lambda index: np.stack([index, -index], axis=-1).astype(float)  # noqa: E731
    query = np.array([True, False, True, True, False, True])
    features = np.zeros((6, 3))
    for beta, expected in ((0.0, 0), (1.0, 4)):
        executed, taken, labels = dagger_step(features, learner, teacher, query, beta, np.random.default_rng(0))
        np.testing.assert_array_equal(labels, teacher(np.flatnonzero(query)))
        assert taken.sum() == expected and not taken[~query].any()
        np.testing.assert_array_equal(executed[~taken], 7.0)
        np.testing.assert_array_equal(executed[taken], labels[taken[query]])
    # a half mixture takes the teacher's action about half the time
    taken = [
        dagger_step(features, learner, teacher, query, 0.5, np.random.default_rng(s))[1][query] for s in range(200)
    ]
    assert 0.4 < np.mean(taken) < 0.6
    # nothing queried: the learner acts, no labels
    executed, taken, labels = dagger_step(features, learner, teacher, np.zeros(6, bool), 1.0, np.random.default_rng(0))
    assert labels.shape == (0, 2) and not taken.any() and (executed == 7.0).all()


def test_dagger_aggregates_the_learners_states_labelled_by_the_teacher():
    drifter = lambda f: np.zeros((len(f), 1), np.float32)  # noqa: E731  (ignores the drift)
    fits = []

    def fit(f, a):
        fits.append((f.copy(), a.copy()))
        return drifter

    first = (np.zeros((5, 1), np.float32), np.full((5, 1), -DRIFT, np.float32))
    visited = []

    def collect(policy, round_):
        f, a, _, seen = _rollout(policy, 0.0, np.random.default_rng(round_))
        visited.append(seen)
        return f, a

    rounds = list(dagger(drifter, *first, collect, 2, fit=fit))
    assert [r[0] for r in rounds] == [0, 1] and len(fits) == 2
    f, a = fits[-1]
    assert len(f) == 5 + 2 * 8 * 15
    np.testing.assert_array_equal(f[:5], first[0])
    np.testing.assert_allclose(f[5:, 0], np.concatenate(visited), rtol=1e-6)  # the learner's states, not the teacher's
    assert f[5:, 0].max() > 5.0  # the drifting learner went far from the centre the teacher keeps
    np.testing.assert_allclose(a[5:], _teacher(f[5:, 0]), rtol=1e-5)


@pytest.mark.slow
def test_dagger_corrects_the_covariate_shift_of_plain_cloning():
    # demonstrations: the teacher's states only (near the centre); the clone trained on
    # them drifts off in closed loop; one DAgger round on the clone's own states fixes it
    rng = np.random.default_rng(0)
    s = rng.normal(0.0, 0.05, 120)
    features, actions = s[:, None].astype(np.float32), _teacher(s).astype(np.float32)
    fit = lambda f, a: train(f, a, hidden=(16, 16), epochs=40, batch=64)  # noqa: E731
    clone = fit(features, actions)
    ((_, improved, _, _),) = dagger(
        clone, features, actions, lambda p, r: _rollout(p, 0.0, np.random.default_rng(10 + r))[:2], 1, fit=fit
    )
    cloned_error = _rollout(clone, 0.0, np.random.default_rng(100))[2].mean()
    dagger_error = _rollout(improved, 0.0, np.random.default_rng(100))[2].mean()
    teacher_error = _rollout(clone, 1.0, np.random.default_rng(100))[2].mean()
    assert cloned_error > 0.15 > 0.05 > dagger_error
    assert dagger_error < 3 * teacher_error + 0.02


@pytest.mark.parametrize(
    "argv, reason",
    [
        (["collect", "x.npz", "--first", "130000"], "development scenario"),
        (["dagger", "d.npz", "p.npz", ".", "--first", "140000"], "development scenario"),
        (["dagger", "missing.npz", "missing.npz", "."], "does not exist"),
        (["train", "missing.npz", "out.npz"], "does not exist"),
        (["evaluate", "missing.npz"], "does not exist"),
        (["collect", "no/such/folder/x.npz"], "does not exist"),
    ],
)
def test_distil_command_refuses_bad_input_in_one_line_before_any_work(argv, reason, tmp_path, monkeypatch):
    from tests.otgym_cli import run_otgym

    monkeypatch.chdir(tmp_path)
    if argv[0] == "dagger" and "missing.npz" not in argv:
        for name in argv[1:3]:
            (tmp_path / name).write_bytes(b"")
    before = sorted(tmp_path.iterdir())
    run = run_otgym(["experiment", "distil-mpc", *argv])
    assert run.returncode == 2
    assert run.stderr.startswith("error: ") and reason in run.stderr and run.stderr.count("\n") == 1, run.stderr
    assert sorted(tmp_path.iterdir()) == before  # nothing written


def test_dagger_refuses_an_output_folder_that_does_not_exist(tmp_path):
    from tests.otgym_cli import run_otgym

    for name in ("d.npz", "p.npz"):
        (tmp_path / name).write_bytes(b"")
    run = run_otgym(["experiment", "distil-mpc", "dagger", tmp_path / "d.npz", tmp_path / "p.npz", tmp_path / "no"])
    assert run.returncode == 2 and run.stderr.startswith("error: ") and "does not exist" in run.stderr
    assert run.stderr.count("\n") == 1 and sorted(p.name for p in tmp_path.iterdir()) == ["d.npz", "p.npz"]
