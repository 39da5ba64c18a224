"""Small shared helpers for the physics tests (statistics, jitted steppers)."""

import functools

import jax

from otgym import physics as ph

step_batch = jax.jit(ph.control_step_batch)
step = jax.jit(ph.control_step)


@functools.partial(jax.jit, static_argnames=("n_steps",))
def run_batch(model, state, controls, key, n_steps: int):
    """Scan ``n_steps`` control steps of a batch; returns (final state, (states stacked
    (n, E, ...), reports stacked))."""

    def body(carry, step_key):
        new_state, report = ph.control_step_batch(model, carry, controls, step_key)
        return new_state, (new_state, report)

    return jax.lax.scan(body, state, jax.random.split(key, n_steps))


def batch_state(model, pose, n_env, trap_xy=None):
    state = ph.initial_state(model, pose, trap_xy)
    return jax.tree.map(lambda a: jax.numpy.broadcast_to(a, (n_env,) + a.shape), state)
