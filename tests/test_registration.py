"""``import otgym`` registers the Gymnasium ids without importing JAX (issue 10 item 9)."""

import subprocess
import sys

import pytest


def test_import_otgym_registers_gym_ids_without_jax():
    """In a fresh interpreter (this test process has JAX loaded already)."""
    code = (
        "import otgym, gymnasium, sys; "
        "assert 'otgym/SpeedControl-v0' in gymnasium.registry; "
        "assert 'otgym/CellTransport-v0' in gymnasium.registry; "
        "assert 'jax' not in sys.modules, 'import otgym imported jax'"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr


@pytest.mark.slow
def test_registration_is_idempotent_and_entry_points_are_strings():
    """Reloading the package (as a notebook's autoreload does) registers nothing twice
    (Gymnasium would warn about overriding an id), and the entry points name the
    adapters by string, so they load only at ``gymnasium.make``."""
    code = (
        "import importlib, warnings, gymnasium, otgym\n"
        "warnings.simplefilter('error')\n"
        "importlib.reload(otgym)\n"
        "import otgym.envs\n"
        "spec = gymnasium.spec('otgym/CellTransport-v0')\n"
        "assert spec.entry_point == 'otgym.envs.gym_adapter:TaskEnv', spec.entry_point\n"
        "assert spec.vector_entry_point == 'otgym.envs.gym_vector:TaskVectorEnv'\n"
        "assert spec.kwargs == {'task': 'cell-transport'}, spec.kwargs\n"
        "from otgym import registry\n"
        "assert sum(k.startswith('otgym/') for k in gymnasium.registry) == len(registry.names('tasks'))\n"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
