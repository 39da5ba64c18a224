"""Shared test setup: JAX's persistent compilation cache, so repeated runs (and CI on
the same machine) reuse compiled XLA programs instead of compiling again."""

import os
from pathlib import Path

import jax

_CACHE = Path(os.environ.get("OTGYM_JAX_CACHE", Path.home() / ".cache" / "otgym" / "jax"))
_CACHE.mkdir(parents=True, exist_ok=True)
jax.config.update("jax_compilation_cache_dir", str(_CACHE))
jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.5)
