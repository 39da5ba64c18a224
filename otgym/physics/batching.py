"""Custom batching: ``jax.vmap`` of a one-environment step runs its batched kernel.

The physics kernels keep the environment axis last and draw a whole batch's noise in
one call, which plain batching of a one-environment function cannot do (it is 6x
slower on CPU). ``batch_through`` builds the ``custom_vmap`` rule that sends
``vmap(step)(model, states, inputs, keys)`` to ``batch(model, states, inputs, key)``
with one key derived from all the batch's keys (so results are statistically, not
bitwise, those of separate calls). A batch of models falls back to plain batching.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp


def batch_key(keys):
    """One key that depends on every key of a batch (their words summed mod 2^32)."""
    if jnp.issubdtype(keys.dtype, jax.dtypes.prng_key):
        data = jax.random.key_data(keys)
        return jax.random.wrap_key_data(jnp.sum(data, axis=0, dtype=data.dtype), impl=jax.random.key_impl(keys))
    return jnp.sum(keys, axis=0, dtype=keys.dtype)


def batch_through(one, batch):
    """The ``def_vmap`` rule for ``one(model, state, inputs, key)`` given its batched
    kernel ``batch(model, states, inputs, key)``."""

    def rule(axis_size, in_batched, model, state, inputs, key):
        model_batched, state_batched, inputs_batched, key_batched = in_batched
        if any(jax.tree.leaves(model_batched)):
            axes = tuple(jax.tree.map(lambda b: 0 if b else None, batched) for batched in in_batched)
            result = jax.vmap(one, in_axes=axes)(model, state, inputs, key)
        else:

            def broadcast(tree, batched):
                return jax.tree.map(lambda a, b: a if b else jnp.broadcast_to(a, (axis_size,) + a.shape), tree, batched)

            result = batch(
                model,
                broadcast(state, state_batched),
                broadcast(inputs, inputs_batched),
                batch_key(key) if key_batched else key,
            )
        return result, jax.tree.map(lambda _: True, result)

    return rule
