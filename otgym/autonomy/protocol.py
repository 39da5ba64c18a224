"""The autonomy's interfaces (``typing.Protocol`` s, checked member by member in
``tests/runtime/test_protocols.py``):

* ``Navigator``: dP_r for many environments at once, what the batched trials and the
  autonomy node need (``RouteNavigator``, ``MPCNavigator`` and the distilled
  ``PolicyNavigator`` offer it);
* ``Autonomy``: dP_r for the real-time loop's one environment, or None while there is
  none (the loop's own navigator's ``increments``, an autonomy node's answers forwarded
  to the session's worker, ``otgym.runtime.worker.ForwardedAutonomy``, or received on
  the bus, ``otgym.bus.nodes.RemoteAutonomy``)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol, runtime_checkable

if TYPE_CHECKING:
    import numpy as np

    from otgym.task.task import Observation


@runtime_checkable
class Navigator(Protocol):
    """dP_r for E environments of the interactive task."""

    def reset(self, n_env: int) -> None:
        """Forget every environment's progress; the next ``increments`` gets ``n_env``."""

    def increments(self, obs: Observation) -> np.ndarray:
        """dP_r (E, T, 2) um for this tick, each trap's capped at the navigator's speed
        limit times the tick."""


@runtime_checkable
class Autonomy(Protocol):
    """The autonomy of the real-time loop."""

    def __call__(self, observation: Observation) -> np.ndarray | None:
        """dP_r (1, T, 2) um for this tick, or None while there is none (the loop then
        runs shared control as manual and autonomous control holds the traps)."""
