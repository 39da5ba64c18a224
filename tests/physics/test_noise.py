"""A control step's noise drawn substep by substep inside the loop
(``otgym.physics.noise``) is bitwise the noise of one up-front draw, and the step holds
only one substep's noise at a time."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.extend.random import threefry2x32_p

from otgym import physics as ph
from otgym.physics import noise as nz


def drawn_substep_by_substep(key, substeps, shape):
    noise = nz.substep_noise(key, substeps, shape, jnp.float32)
    assert isinstance(noise.inputs, tuple), "expected the in-loop draw (partitionable threefry, float32)"
    return np.asarray(jax.jit(lambda inputs: jax.lax.map(noise.draw, inputs))(noise.inputs))


@pytest.mark.parametrize(
    "key", [jax.random.PRNGKey(3), jax.random.key(5), jax.random.fold_in(jax.random.PRNGKey(1), 7)]
)
def test_each_substep_is_bitwise_its_slice_of_one_draw(key):
    """11 substeps of (3, 7, 5) values (a 7-body step of 5 environments): every bit equals
    ``jax.random.normal(key, (11, 3, 7, 5))`` (fails if a counter, the bit-to-float
    conversion or the key handling differs, or if JAX changes its threefry layout)."""
    shape = (3, 7, 5)
    expected = np.asarray(jax.random.normal(key, (11,) + shape, jnp.float32))
    got = drawn_substep_by_substep(key, 11, shape)
    assert got.tobytes() == expected.tobytes()


def test_hash_is_bitwise_jax_threefry2x32():
    """The written-out hash against JAX's ``threefry2x32`` primitive on 4096 random
    counter pairs (and the extremes 0 and 2^32 - 1) for three keys, one of them all ones:
    every output word equal (fails on a wrong rotation, key-schedule word or injection
    constant)."""
    rng = np.random.default_rng(0)
    counts = rng.integers(0, 2**32, size=(2, 4096), dtype=np.uint32)
    counts[:, :2] = [[0, 2**32 - 1], [2**32 - 1, 0]]
    for key in ([0, 0], [2**32 - 1, 2**32 - 1], rng.integers(0, 2**32, size=2, dtype=np.uint32).tolist()):
        key0, key1 = (jnp.uint32(word) for word in key)
        ours = jax.jit(nz.threefry2x32)(key0, key1, counts[0], counts[1])
        jax_words = threefry2x32_p.bind(key0, key1, jnp.asarray(counts[0]), jnp.asarray(counts[1]))
        for mine, theirs in zip(ours, jax_words, strict=True):
            assert np.asarray(mine).tobytes() == np.asarray(theirs).tobytes()


def test_the_integration_loop_holds_no_loop_of_its_own():
    """The compiled one-environment step of a 7-body model has one loop, the substeps',
    and the hash's 20 rounds (20 left rotations) are compiled twice: the first substep's
    bits before the loop, the next substep's in it. JAX's threefry primitive lowers on
    the CPU to a loop of five trips; drawn through it, each substep ran that loop too,
    which at one environment (where a step's time is mostly the runtime's per-operation
    cost) made the step about 30 % more instructions. Computed where they are read, the
    bits were recomputed in each of four fusions."""
    config = ph.PhysicsConfig(dt_s=1e-4, substeps=10)
    bodies = [ph.two_handle_robot("a"), ph.two_handle_robot("b"), ph.cell("c")]
    bodies += [ph.obstacle(f"o{i}", kinematic=False) for i in range(4)]
    model = ph.build_model(bodies, config)
    pose = np.array([[0, -6.0, 0], [0, 6.0, np.pi], [0, 0, 0], [25, 0, 0], [-25, 0, 0], [0, 25, 0], [0, -25, 0]])
    state = jax.tree.map(lambda a: a[None], ph.initial_state(model, pose))
    key = jax.random.PRNGKey(0)
    assert nz.drawn_in_loop(key, jnp.float32)
    text = jax.jit(ph.control_step_batch).lower(model, state, ph.Controls.zeros(model, 1), key).compile().as_text()
    assert text.count(" while(") == 1, f"{text.count(' while(')} loops in the compiled step"
    assert text.count(" shift-left(") == 2 * 20, f"{text.count(' shift-left(')} left shifts"


def test_counters_carry_into_the_high_word():
    """Steps of more than 2^32 values in all (a 2000-substep, 7-body step of 131,072
    environments draws 5.5e9): the values on either side of counter 2^32 come from
    (0, 2^32 - 3 ..) and carry on as those computed from (1, 0 ..) (fails if the low
    word wraps without carrying into the high word)."""
    words = jax.random.key_data(jax.random.key(11))
    across = np.asarray(nz.normal_from_counter(words, jnp.uint32(0), jnp.uint32(2**32 - 3), (6,)))
    above = np.asarray(nz.normal_from_counter(words, jnp.uint32(1), jnp.uint32(0), (3,)))
    below = np.asarray(nz.normal_from_counter(words, jnp.uint32(0), jnp.uint32(2**32 - 3), (3,)))
    assert across[3:].tobytes() == above.tobytes() and across[:3].tobytes() == below.tobytes()
    assert across[2] != across[3]
    high, low = nz.first_counters(3, 2**31 + 5)
    assert high.tolist() == [0, 0, 1] and low.tolist() == [0, 2**31 + 5, 10]


def up_front(key, substeps, shape, dtype):
    """The draw as it was made before ``substep_noise``: all substeps at once."""
    return nz.SubstepNoise(jax.random.normal(key, (substeps,) + tuple(shape), dtype), lambda slice_: slice_)


@pytest.mark.parametrize("n_env", [1, 5])
@pytest.mark.slow
def test_steps_match_those_with_the_noise_drawn_up_front(monkeypatch, n_env):
    """30 substeps in field-refresh blocks of 10 at room temperature, against the same
    step with its noise drawn up front. One environment: bitwise. Five: to float32
    round-off (XLA fuses the loop's body differently when the noise is computed in it;
    measured up to 6e-8 um, positions of about 6 um whose last bit is 4.8e-7 um). Fails
    if a substep read another substep's noise (differences of the noise's size, 1e-2 um)."""
    config = ph.PhysicsConfig(dt_s=1e-4, substeps=30, field_refresh_substeps=10)
    model = ph.build_model([ph.two_handle_robot("a"), ph.cell("c")], config)
    state = ph.initial_state(model, np.array([[0.0, -6.0, 0.3], [0.0, 1.0, 0.0]]))
    states = jax.tree.map(lambda a: jnp.broadcast_to(a, (n_env,) + a.shape), state)
    controls = ph.Controls.zeros(model, n_env)
    key = jax.random.PRNGKey(2)
    in_loop, _ = jax.jit(lambda *args: ph.control_step_batch(*args))(model, states, controls, key)
    monkeypatch.setattr("otgym.physics.integrator.substep_noise", up_front)
    # a new function, so traced again with the patch (each step one compile, not op by op)
    reference, _ = jax.jit(lambda *args: ph.control_step_batch(*args))(model, states, controls, key)
    in_loop, reference = np.asarray(in_loop.pose), np.asarray(reference.pose)
    assert np.abs(reference - np.asarray(states.pose)).max() > 1e-3  # the noise moved the bodies
    if n_env == 1:
        assert in_loop.tobytes() == reference.tobytes()
    else:
        np.testing.assert_allclose(in_loop, reference, rtol=0, atol=4.8e-7)
