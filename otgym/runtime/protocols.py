"""The interfaces of the runtime, declared as ``typing.Protocol`` s (structural: an
implementation need not inherit from them) and checked member by member in
``tests/runtime/test_protocols.py``:

* ``SessionCommands``: what a driver posts to a running session (the mode keys, pause,
  reset, the next trial, a lost device, the mouse dragging a robot). The worker proxy
  ``SessionProcess`` forwards exactly these to its process, generated from this
  protocol's methods (``protocol_methods``).
* ``SessionControl``: what the window (``otgym.ui.app.PlayApp``) drives; offered by a
  ``Session`` in this process, a ``SessionProcess`` (the session in a worker process)
  and a ``BusSession`` (a sim node behind the bus), which are interchangeable.
* ``Sink``: what a session tells as it runs (the MCAP recording of ``otgym play``, the
  sim node's publisher).
The autonomy's interfaces (``Navigator``; ``Autonomy``, what the real-time loop asks
for dP_r) are in ``otgym.autonomy.protocol``.
"""

from __future__ import annotations

import inspect
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

if TYPE_CHECKING:
    import numpy as np

    from otgym.runtime.loop import TickRecord
    from otgym.runtime.snapshot import Snapshot
    from otgym.task.layout import TaskLayout
    from otgym.task.task import InteractiveTask
    from otgym.teleop.device import Sample


@runtime_checkable
class SessionCommands(Protocol):
    """Commands to a session: applied between its ticks, in the order posted; none
    blocks. Modes are ``otgym.shared.MODES``; robots index ``task.scene.robots``;
    points are chip um."""

    def set_mode(self, mode: str) -> None:
        """Switch the control mode (manual, shared, autonomous) mid-trial."""

    def toggle_pause(self) -> None:
        """Pause or resume simulated time (a pause sends every device zero force)."""

    def set_paused(self, paused: bool) -> None:
        """Pause (True) or resume (False)."""

    def reset(self) -> None:
        """Abandon the trial (no row) and start the next trial number."""

    def next_trial(self) -> None:
        """Start the next trial after a finished one (held for the questionnaires)."""

    def lose(self, index: int, reason: str) -> None:
        """Forwarded device ``index`` was lost (its driver raised ``reason``)."""

    def drag(self, robot: int, pointer_um, traps_um) -> None:
        """Begin or continue dragging robot ``robot``: the pointer (2,) and the robot's
        trap centre (2,), chip um."""

    def release_drag(self) -> None:
        """End a drag: the robots go back to their devices."""


@runtime_checkable
class SessionControl(SessionCommands, Protocol):
    """A session as the window drives it (see the module's docstring)."""

    participant: str
    """The participant ID written with every trial."""
    over: bool
    """The session has ended (its duration spent, or quit)."""

    @property
    def snapshot(self) -> Snapshot | None:
        """The latest tick's state (None before the first); read from any thread."""

    @property
    def layout(self) -> TaskLayout:
        """What a view draws the task with (chip, route, bodies' radii)."""

    @property
    def force_limits_n(self) -> list[float]:
        """Each bound device's force limit in N (0: no haptics)."""

    def feed(self, index: int, sample: Sample) -> None:
        """The latest sample of forwarded device ``index`` (a device read by the window)."""

    def take_finished(self) -> dict | None:
        """The row of a trial that ended, once; None when none is waiting."""

    def poll(self) -> None:
        """Handle what the session sent back since the last call (each frame)."""

    def finish(self) -> Any:
        """Quit: a trial under way ends as aborted, devices get zero force, the
        recording closes."""


@runtime_checkable
class Sink(Protocol):
    """What a session tells as it runs (``otgym.runtime.session`` lists the events)."""

    def describe(self, task: InteractiveTask) -> None:
        """The task, once at the start: chip, route and spheres (latched topics)."""

    def tick(self, record: TickRecord, sphere_xy_um: np.ndarray, mode: str) -> None:
        """Every tick: its record, every sphere's centre (S, 2) um, the mode it ran in."""

    def event(self, name: str, **fields) -> None:
        """A session event (``trial_start``, ``mode``, ``trial_end``...) and its fields."""

    def close(self) -> None:
        """The session has ended; flush and release."""


def protocol_methods(protocol: type) -> tuple[str, ...]:
    """The methods a protocol declares (its own and its protocol bases'), in
    declaration order; not its data members or properties."""
    names: list[str] = []
    for base in reversed(protocol.__mro__):
        if base in (object, Protocol) or not getattr(base, "_is_protocol", False):
            continue
        for name, member in vars(base).items():
            if not name.startswith("_") or name == "__call__":
                if inspect.isfunction(member) and name not in names:
                    names.append(name)
    return tuple(names)


def protocol_members(protocol: type) -> tuple[str, ...]:
    """Every member a protocol declares: methods, properties and annotated attributes."""
    names: list[str] = []
    for base in reversed(protocol.__mro__):
        if base in (object, Protocol) or not getattr(base, "_is_protocol", False):
            continue
        for name in [*vars(base).get("__annotations__", {}), *vars(base)]:
            member = vars(base).get(name)
            public = not name.startswith("_") or name == "__call__"
            declared = name in vars(base).get("__annotations__", {}) or inspect.isfunction(member)
            if public and (declared or isinstance(member, property)) and name not in names:
                names.append(name)
    return tuple(names)
