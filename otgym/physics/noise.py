"""A control step's Gaussian noise, drawn substep by substep inside the integration loop,
each substep's values bitwise those of the same slice of one up-front draw
``jax.random.normal(key, (substeps,) + shape, float32)``.

Why: drawn up front, a step's noise is a (substeps, 3, bodies, environments) array that
lives through the whole loop together with the random bits it is made from; for the
transport scene (2000 substeps, 7 bodies) that was 0.67 MB of scratch per environment
(XLA's memory analysis), which capped one GPU's batch. Drawn inside the loop, a substep
holds only its own (3, bodies, environments) values.

How: with JAX's threefry PRNG in its partitionable mode (``jax_threefry_partitionable``,
the default since JAX 0.5), element i (row-major flat index) of a draw of 32-bit values
depends on the key and i alone: (y1, y2) = threefry2x32(key, (i >> 32, i mod 2^32)),
bits = y1 ^ y2; ``jax.random.normal`` turns the bits' top 23 into a uniform u in
[nextafter(-1, 0), 1) and returns sqrt(2) erfinv(u). Substep s is the counters
s m .. s m + m - 1 (m = prod(shape)). ``tests/physics/test_noise.py`` checks the
values bitwise against ``jax.random.normal``, so a JAX release that changes the layout
fails there. Where the layout does not apply (another PRNG implementation, the
non-partitionable mode, float64) the noise is drawn up front as before.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

_FLOAT32_ONE_BITS = np.uint32(0x3F800000)
_UNIFORM_LOW = np.nextafter(np.float32(-1.0), np.float32(0.0), dtype=np.float32)
_UNIFORM_SPAN = np.float32(1.0) - _UNIFORM_LOW
_SQRT2 = np.float32(np.sqrt(2))
_ROTATIONS = ((13, 15, 26, 6), (17, 29, 16, 24))
_KEY_PARITY = np.uint32(0x1BD11BDA)


class SubstepNoise(NamedTuple):
    """``inputs``: a pytree with a leading substep axis, to be fed to the integration
    loop's scan; ``draw(inputs[s])``: the noise of substep s, shape ``shape``.

    Drawn in the loop, ``draw`` is ``from_bits(bits(inputs[s]))``: the hash's random
    bits, then the normal values made from them. The loop computes a substep's bits one
    substep ahead and carries them, so that they are materialised once: computed where
    they are read, XLA recomputes the 20 hash rounds in each fusion that reads a part
    of the noise (four per substep of the standard scene). None with the up-front draw."""

    inputs: object
    draw: Callable
    bits: Callable | None = None
    from_bits: Callable | None = None


def _threefry_words(key):
    """The key's two uint32 words if it is a threefry2x32 key, else None."""
    if jnp.issubdtype(key.dtype, jax.dtypes.prng_key):
        if str(jax.random.key_impl(key)) != "threefry2x32":
            return None
        key = jax.random.key_data(key)
    elif jax.config.jax_default_prng_impl != "threefry2x32":
        return None
    return key[0], key[1]


def drawn_in_loop(key, dtype) -> bool:
    """Whether ``substep_noise`` draws in the loop for this key and dtype."""
    return jax.config.jax_threefry_partitionable and np.dtype(dtype) == np.float32 and _threefry_words(key) is not None


def first_counters(substeps: int, per_substep: int):
    """The 64-bit counter of each substep's first value, as (high, low) uint32 words (substeps,)."""
    counts = np.arange(substeps, dtype=np.uint64) * np.uint64(per_substep)
    return (counts >> np.uint64(32)).astype(np.uint32), (counts & np.uint64(0xFFFFFFFF)).astype(np.uint32)


def threefry2x32(key0, key1, count0, count1):
    """Threefry-2x32 with 20 rounds (Salmon et al., "Parallel random numbers: as easy as
    1, 2, 3", SC 2011; the hash of JAX's threefry PRNG): the two uint32 output words
    for the key (key0, key1) and the counter words (count0, count1), elementwise.

    Written out as plain integer operations, so that XLA fuses the 20 rounds with
    whatever computes the counters and reads the bits. JAX's own primitive lowers on the
    CPU to a loop of five iterations, which inside the integration loop costs five
    trips through the runtime per substep. Bitwise the primitive's result (integer
    arithmetic; ``tests/physics/test_noise.py`` compares them)."""
    keys = (key0, key1, key0 ^ key1 ^ _KEY_PARITY)
    x0, x1 = count0 + keys[0], count1 + keys[1]
    for group in range(5):
        for rotation in _ROTATIONS[group % 2]:
            x0 = x0 + x1
            x1 = jax.lax.shift_left(x1, np.uint32(rotation)) | jax.lax.shift_right_logical(x1, np.uint32(32 - rotation))
            x1 = x0 ^ x1
        x0 = x0 + keys[(group + 1) % 3]
        x1 = x1 + keys[(group + 2) % 3] + np.uint32(group + 1)
    return x0, x1


def bits_from_counter(words, first_high, first_low, shape: tuple):
    """The random uint32 bits of shape ``shape`` at counters first, first + 1, ... in
    row-major order, those ``jax.random.normal`` turns into values (``normal_from_bits``).
    ``words``: the key's uint32 pair; ``first_high/low``: the first counter's words."""
    strides = np.cumprod((1,) + shape[::-1][:-1])[::-1]
    offset = sum(
        jax.lax.broadcasted_iota(jnp.uint32, shape, axis) * np.uint32(stride) for axis, stride in enumerate(strides)
    )
    low = first_low + offset
    high = first_high + (low < first_low).astype(jnp.uint32)  # carry into the high word
    bits1, bits2 = threefry2x32(words[0], words[1], jnp.broadcast_to(high, shape), low)
    return jnp.bitwise_xor(bits1, bits2)


def normal_from_bits(bits):
    """float32 normal values from random bits, as ``jax.random.normal`` makes them."""
    mantissa = jax.lax.shift_right_logical(bits, np.uint32(32 - 23)) | _FLOAT32_ONE_BITS
    floats = jax.lax.bitcast_convert_type(mantissa, jnp.float32) - np.float32(1.0)
    uniform = jax.lax.max(_UNIFORM_LOW, floats * _UNIFORM_SPAN + _UNIFORM_LOW)
    return _SQRT2 * jax.lax.erf_inv(uniform)


def normal_from_counter(words, first_high, first_low, shape: tuple):
    """float32 normal values of shape ``shape`` at counters first, first + 1, ... in
    row-major order: bitwise ``jax.random.normal(key, (n,) + shape)`` at those flat
    indices. ``words``: the key's uint32 pair; ``first_high/low``: the first counter's words."""
    return normal_from_bits(bits_from_counter(words, first_high, first_low, shape))


def substep_noise(key, substeps: int, shape: tuple, dtype) -> SubstepNoise:
    """The noise of ``substeps`` substeps of shape ``shape`` each: drawn per substep
    inside the loop where ``drawn_in_loop``, else one up-front draw (the same values)."""
    size = int(np.prod(shape))
    if not drawn_in_loop(key, dtype) or size >= 2**32:
        noise = jax.random.normal(key, (substeps,) + tuple(shape), dtype)
        return SubstepNoise(noise, lambda slice_: slice_)
    words = _threefry_words(key)
    high, low = first_counters(substeps, size)
    return SubstepNoise(
        (jnp.asarray(high), jnp.asarray(low)),
        lambda counter: normal_from_counter(words, counter[0], counter[1], tuple(shape)),
        lambda counter: bits_from_counter(words, counter[0], counter[1], tuple(shape)),
        normal_from_bits,
    )
