"""What the Task abstraction costs the compiled step: the number of instructions in the
optimised XLA program of the transport core's own ``step_batch`` / ``step`` against
``Task.step_batch`` / ``Task.step`` of the same task (``speed-control``, preset
``paper``), at 1 and 1024 environments. A count, not a time: it does not depend on the
machine's load. Equal or fewer instructions: the abstraction adds nothing to the
program (the Task's info drops the scene events the adapters never read).

    python benchmarks/task_overhead.py
"""

import re

import jax
import jax.numpy as jnp

from otgym import tasks
from otgym.tasks.transport import presets
from otgym.tasks.transport import speed_control as spc


def count(function, *arguments) -> int:
    text = jax.jit(function).lower(*arguments).compile().as_text()
    return len(re.findall(r"^\s+\S+ = ", text, re.M))


def main() -> None:
    task = tasks.load("speed-control")
    params = task.make_params(presets.preset("paper"))
    key = jax.random.PRNGKey(0)
    for n in (1, 1024):
        _, state = jax.jit(task.reset_batch, static_argnums=2)(key, params, n)
        actions = jnp.zeros(n, jnp.int32)
        old = count(lambda k, s, a: spc.step_batch(k, s, a, params), key, state, actions)
        new = count(lambda k, s, a: task.step_batch(k, s, a, params), key, state, actions)
        print(f"{n:5d} environments: step_batch {old} instructions, Task.step_batch {new} ({new / old:.3f})")
    _, state = jax.jit(task.reset)(key, params)
    old = count(lambda k, s, a: spc.step(k, s, a, params), key, state, jnp.int32(0))
    new = count(lambda k, s, a: task.step(k, s, a, params), key, state, jnp.int32(0))
    print(f"    one environment: step {old} instructions, Task.step {new} ({new / old:.3f})")


if __name__ == "__main__":
    main()
