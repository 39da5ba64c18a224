"""Shared test setup.

- JAX's persistent compilation cache, shared by every xdist worker and every process a
  test starts (through ``JAX_COMPILATION_CACHE_DIR``), so a program compiled once in a
  run is read back instead of compiled again.
- Python's bytecode cache likewise, where the environment turns it off
  (``PYTHONDONTWRITEBYTECODE``): the suite starts a hundred-odd Python processes (nodes,
  windows, commands), and each would otherwise compile otgym's modules from source
  again, and each xdist worker rewrite every test module's asserts again (about 1 CPU-s
  a process, and 8 a worker, here). The caches are ``__pycache__`` folders, gitignored.
- Hypothesis profiles: ``ci`` (the default: derandomised, so every run draws the same
  cases; no deadline, since a loaded machine is no failure) and ``dev``
  (``HYPOTHESIS_PROFILE=dev``: fresh random cases each run). A failure prints the
  ``@reproduce_failure`` blob that replays it.
- The slow tests run first (a stable reorder), so that xdist's workers share the long
  end-to-end runs at the start instead of one worker finishing them alone at the end.
- No test leaves SDL's display open (``no_display_left_open``): a display left open keeps
  its driver, so the worker's next X-window test would open its window with the dummy
  driver and never reach X.
- Fixtures shared across packages: the ``paper`` preset's task parameters, Q-network
  parameters with a fixed greedy action, a real X server (``xvfb``: ``tests.xserver``).
"""

import os
import sys
from pathlib import Path

if os.environ.pop("PYTHONDONTWRITEBYTECODE", None) is not None:
    sys.dont_write_bytecode = False

_CACHE = Path(os.environ.get("OTGYM_JAX_CACHE", Path.home() / ".cache" / "otgym" / "jax"))
_CACHE.mkdir(parents=True, exist_ok=True)
os.environ.setdefault("JAX_COMPILATION_CACHE_DIR", str(_CACHE))
os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "0")

import jax  # noqa: E402
import pytest  # noqa: E402
from hypothesis import settings  # noqa: E402

jax.config.update("jax_compilation_cache_dir", os.environ["JAX_COMPILATION_CACHE_DIR"])
jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)


def pytest_collection_modifyitems(config, items):
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)


settings.register_profile("ci", derandomize=True, deadline=None, print_blob=True)
settings.register_profile("dev", deadline=None, print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


@pytest.fixture(autouse=True)
def no_display_left_open():
    """Fails the test (in its teardown) that leaves pygame's display initialised, and
    closes it, so the next test in this worker starts without one."""
    yield
    pygame = sys.modules.get("pygame")
    if pygame is not None and pygame.display.get_init():
        pygame.quit()
        pytest.fail("the test left pygame's display open (pygame.quit() it, or stop the device that opened it)")


@pytest.fixture(scope="session")
def paper_params():
    """The ``paper`` preset's task parameters, built once (scene, path plan) for all tests."""
    from otgym.tasks.transport import speed_control as spc

    return spc.make_params("paper")


@pytest.fixture(scope="session")
def xvfb():
    """One Xvfb for the test session (``tests.xserver.Xvfb``): its ``env()`` opens a child's
    windows on it with SDL's x11 driver. Skips, saying why, where Xvfb is not installed;
    stops only its own process at the end."""
    from tests.xserver import MISSING, Xvfb, available

    if not available():
        pytest.skip(MISSING)
    server = Xvfb().start()
    yield server
    server.stop()


FIXED_POLICY_HIDDEN = (16,)


@pytest.fixture(scope="session")
def fixed_action_q_params():
    """``make(action)``: Q-network parameters (hidden widths ``FIXED_POLICY_HIDDEN``)
    whose greedy action is always ``action``, so evaluations can be checked against the
    exact times of constant speeds."""
    import jax.numpy as jnp

    from otgym.rl.network import QNetwork
    from otgym.tasks.transport import core as tr

    def make(action: int, n_actions: int = 6):
        params = QNetwork(n_actions, FIXED_POLICY_HIDDEN).init(jax.random.PRNGKey(0), jnp.zeros((1, tr.OBS_SIZE)))
        last = params["params"][f"Dense_{len(FIXED_POLICY_HIDDEN)}"]
        last["kernel"] = jnp.zeros_like(last["kernel"])
        last["bias"] = jnp.zeros(n_actions).at[action].set(1.0)
        return params

    return make


if os.environ.get("OTGYM_COMPILE_STATS"):  # a profile of the suite: XLA compilations and CPU per test, as JSON lines
    import json
    import logging
    import re
    import resource
    import time

    _compiles: list[float] = []
    _programs: list[tuple[str, float]] = []
    jax.monitoring.register_event_duration_secs_listener(
        lambda event, duration, **kwargs: _compiles.append(duration) if "backend_compile" in event else None
    )

    class _ProgramNames(logging.Handler):
        """The name and seconds of each XLA compilation over 1 s (JAX's log_compiles lines)."""

        FINISHED = re.compile(r"Finished XLA compilation of (\S+) in ([0-9.e-]+) sec")

        def emit(self, record):
            found = self.FINISHED.search(record.getMessage())
            if found and float(found[2]) > 1.0:
                _programs.append((found[1], round(float(found[2]), 1)))

    jax.config.update("jax_log_compiles", True)
    _jax_log = logging.getLogger("jax")
    _jax_log.addHandler(_ProgramNames())
    _jax_log.setLevel(logging.DEBUG)
    _jax_log.propagate = False

    def _cpu_s() -> float:
        own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
        return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime

    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_protocol(item, nextitem):
        _compiles.clear()
        _programs.clear()
        began, cpu = time.perf_counter(), _cpu_s()
        yield
        with open(os.environ["OTGYM_COMPILE_STATS"], "a") as stats:
            row = {"test": item.nodeid, "wall_s": time.perf_counter() - began, "cpu_s": _cpu_s() - cpu}
            row |= {"compiles": len(_compiles), "compile_s": sum(_compiles), "programs": list(_programs)}
            stats.write(json.dumps(row) + "\n")
