"""The simulator as a bus node: a ``Session`` (``otgym.runtime.session``: trials one
after another, paced by the wall clock) on the devices of device nodes
(``RemoteDevice``), publishing every tick's messages and the trial events, taking
commands from a ui node (``/otgym/command``).

Two ways to run it:
- ``run_sim_node``: the session ticks in this process (tests; a tick holds the
  interpreter lock while zenoh's threads wait for it);
- ``serve_sim_node`` (``otgym node sim``): the session ticks in a worker process of
  its own (``otgym.runtime.worker``), this process being only the bus side: it feeds
  each device's samples to the worker, publishes what the worker's ticks produce, and
  answers every twist at once with the latest feedback force from zenoh's own thread,
  which never waits for a tick (benchmarks/bus.py: the round trip).

The plant (``--plant``, the registry's ``plants``): the simulator's physics, or a rig
outside otgym (``otgym.task.rig``) that takes the trap commands from ``/otgym/traps``
and answers with its measured spheres on ``/otgym/rig/poses``; the controller (devices,
autonomy, arbitration, the trap-speed cap, phases and metrics) is the same for both,
and so is everything the node publishes.

Devices and robots: device ``devices[i]`` drives robot i; ``takeover[i]`` (a ui
node's mouse, ``ui<i>``) takes robot i over while its clutch bit is held
(``otgym.teleop.takeover``); a robot with only a takeover device moves only by it.

Commands (``messages.COMMANDS``): ``mode`` switches the mode, ``pause`` / ``resume``
stop and restart simulated time (devices get zero force), ``reset`` abandons the trial
for the next, ``next_trial`` starts the next one (with ``hold_between_trials`` the
session waits for it after each trial: the ui node's questionnaires), ``quit`` ends the
session (a trial under way saved as aborted, its ``trial_end`` published).
"""

from __future__ import annotations

import functools
import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING

from otgym import registry
from otgym.bus import messages as msg
from otgym.bus import task_messages
from otgym.bus.nodes import AUTONOMY_TIMEOUT_S, RemoteAutonomy, RemoteDevice
from otgym.bus.transport import Node
from otgym.runtime.worker import ForwardedAutonomy, SessionProcess, WorkerParts, WorkerSpec

if TYPE_CHECKING:  # the loop and the trials import JAX: the sim node's bus side (serve_sim_node) does without
    from otgym.runtime.loop import DeviceBinding


class BusSink:
    """A session's ticks and events as the sim publishes them, handed to ``send`` as
        lists of (topic, CDR): the session's description, chip and route once at its start
        (latched topics), every tick's traps, phase, alpha and bodies, the mode at a trial's
        first tick and when it changes (``messages.tick_messages``; each device's feedback
        is its ``RemoteDevice`` 's to publish), every event on ``/otgym/trial/events``, and
    each ``trial_start`` also on the latched ``/otgym/trial/current``."""

    def __init__(self, send: Callable[[list[tuple[str, bytes]]], None]):
        self.send = send
        self._mode_sent: str | None = None

    def describe(self, task) -> None:
        self.send(task_messages.session_messages(task, [], time.time()))

    def tick(self, record, sphere_xy_um, mode: str) -> None:
        changed = mode if mode != self._mode_sent else None
        self._mode_sent = mode
        self.send(task_messages.tick_messages(record, [], sphere_xy_um, stamp_s=time.time(), mode=changed))

    def event(self, name: str, **fields) -> None:
        data = msg.event(name, **fields)
        if name == "trial_start":
            self._mode_sent = None
            self.send([(msg.EVENTS, data), (msg.TRIAL, data)])  # and latched, for a window that joins later
        else:
            self.send([(msg.EVENTS, data)])

    def close(self) -> None:
        pass


def device_plan(devices: list[str], takeover: list[str] = ()) -> tuple[list[str], list[tuple[int | None, int | None]]]:
    """The distinct device names, and for each robot (index into them) its device and
    the device that may take it over (None: none)."""
    names: list[str] = []

    def index(name: str) -> int:
        msg.check_name(name)
        if name not in names:
            names.append(name)
        return names.index(name)

    plan = []
    for robot in range(max(len(devices), len(takeover))):
        primary = index(devices[robot]) if robot < len(devices) else None
        over = index(takeover[robot]) if robot < len(takeover) else None
        plan.append((primary, over))
    return names, plan


def plan_bindings(plan, devices: list, feedback=None) -> list[DeviceBinding]:
    """One binding per robot: its device, wrapped in a ``TakeoverDevice`` where one may
    take it over; ``feedback``: the styluses' (``trials.stylus_feedback``, as ``otgym
    play`` gives them)."""
    from otgym.runtime.loop import DeviceBinding
    from otgym.teleop.takeover import TakeoverDevice

    bindings = []
    for robot, (primary, over) in enumerate(plan):
        device = devices[primary] if primary is not None else None
        if over is not None:
            device = TakeoverDevice(device, devices[over])
        bindings.append(DeviceBinding(device, robots=(robot,), feedback=feedback))
    return bindings


def follow_commands(node: Node, session, on_quit: Callable[[], None]) -> None:
    """Apply the ui node's commands to ``session`` (a ``Session`` or ``SessionProcess``)."""

    def on_command(topic, message, data) -> None:
        fields = msg.event_fields(message)
        name = fields["command"]
        if name == "mode":
            session.set_mode(fields["mode"])
        elif name in ("pause", "resume"):
            session.set_paused(name == "pause")
        elif name == "reset":
            session.reset()
        elif name == "next_trial":
            session.next_trial()
        elif name == "quit":
            on_quit()

    node.subscribe(msg.COMMAND, on_command)


def build_task(chip: str = "default"):
    """The interactive task on ``chip`` (a name or a PNG)."""
    from otgym.sim.chip import load_chip
    from otgym.task.task import InteractiveConfig, InteractiveTask
    from otgym.tasks.transport.interactive import interactive_scene

    return InteractiveTask(InteractiveConfig(scene=interactive_scene(chip=load_chip(chip))))


def run_sim_node(
    node: Node,
    task,
    devices: list[str],
    mode: str,
    seed: int,
    stop: threading.Event,
    duration_s: float | None = None,
    remote_autonomy: bool = False,
    *,
    takeover: list[str] = (),
    participant: str = "P1",
    hold_between_trials: bool = False,
    hold_first_trial: bool = False,
) -> int:
    """The sim node with its session ticking in this process, until ``stop`` is set, a
    ``quit`` command, or ``duration_s`` of simulated time spent; returns the ticks run.
    With ``remote_autonomy`` dP_r comes from an autonomy node (``RemoteAutonomy``),
    else from each loop's own navigator."""
    from otgym.runtime.session import Session
    from otgym.runtime.trials import stylus_feedback

    names, plan = device_plan(devices, takeover)
    remotes = [RemoteDevice(node, name) for name in names]
    autonomy = RemoteAutonomy(node, task.n_traps) if remote_autonomy else None
    sink = BusSink(lambda messages: [node.publish(topic, data) for topic, data in messages])
    session = Session(
        task,
        plan_bindings(plan, remotes, stylus_feedback(task)),
        participant,
        mode,
        seed,
        duration_s,
        sink=sink,
        autonomy=autonomy,
        hold_between_trials=hold_between_trials,
        hold_first_trial=hold_first_trial,
    )
    follow_commands(node, session, stop.set)
    session.start()
    try:
        while not stop.is_set() and not session.over:
            session.advance()
            while session.take_finished() is not None:
                pass  # trial_end carried the row
            stop.wait(min(session.next_tick_in_s(), 0.05))
    finally:
        session.finish()
        session.close()
    return session.ticks


def sim_worker_setup(
    chip: str, plan, remote_autonomy: bool, forwarded, outbox, plant: str = "simulator"
) -> WorkerParts:
    """What the sim node's worker builds (``WorkerSpec.setup``): the task on the plant
    ``plant`` (a name of the registry's ``plants``; one tagged ``measured`` gets the
    measurements the bus side forwards, and its trials' starts go out on
    ``/otgym/rig/start``), one binding per robot over the forwarded devices, a
    ``BusSink`` that sends each tick's messages to the bus side, and the forwarded
    autonomy."""
    from otgym.runtime.trials import stylus_feedback
    from otgym.task.rig import MeasuredPoses

    autonomy = ForwardedAutonomy(AUTONOMY_TIMEOUT_S) if remote_autonomy else None
    task = build_task(chip)
    measured = MeasuredPoses() if plant in registry.names("plants", "measured") else None

    def send_start(sphere_xy_um, stamp_s: float) -> None:
        outbox([(msg.RIG_START, msg.pose_array(sphere_xy_um, stamp_s))])

    stepped = registry.load("plants", plant)(task, measured, send_start)
    return WorkerParts(
        stepped,
        plan_bindings(plan, list(forwarded), stylus_feedback(task)),
        sink=BusSink(outbox),
        autonomy=autonomy,
        measurements=measured,
    )


def serve_sim_node(
    node: Node,
    devices: list[str],
    mode: str,
    seed: int,
    stop: threading.Event,
    duration_s: float | None = None,
    remote_autonomy: bool = False,
    *,
    chip: str = "default",
    takeover: list[str] = (),
    participant: str = "P1",
    hold_between_trials: bool = False,
    hold_first_trial: bool = False,
    plant: str = "simulator",
    on_ready: Callable[[], None] | None = None,
    on_status: Callable[[str], None] | None = None,
) -> dict:
    """The sim node with its session in a worker process (see the module's docstring),
    until ``stop`` is set, a ``quit`` command, the duration spent, or the worker fails
    (``WorkerError``); returns the worker's counts (ticks, late_ticks, trials).
    ``plant``: what moves the bodies (``sim_worker_setup``); for a measured plant the
    node forwards each ``/otgym/rig/poses`` to the worker.
    ``on_status(text)`` hears what the worker is doing while it starts (building the
    task, compiling); ``on_ready`` is called once the session runs its ticks and the node
    listens to its devices."""
    names, plan = device_plan(devices, takeover)
    remotes = [RemoteDevice(node, name, answer_twists=True) for name in names]
    spec = WorkerSpec(
        functools.partial(sim_worker_setup, chip, plan, remote_autonomy, plant=plant),
        participant,
        mode,
        seed,
        duration_s,
        forwarded_caps=tuple(r.caps for r in remotes),
        forwarded_haptics=True,
        hold_between_trials=hold_between_trials,
        hold_first_trial=hold_first_trial,
        snapshots=False,
    )

    def publish(messages) -> None:
        for topic, data in messages:
            node.publish(topic, data)

    session = SessionProcess(
        spec, on_publish=publish, on_force=lambda i, force: remotes[i].set_force(force), on_status=on_status
    )
    session.start()
    events_stop = threading.Event()
    failure: list[BaseException] = []

    def serve() -> None:
        try:
            session.serve_events(events_stop)
        except BaseException as error:  # noqa: BLE001  the main loop re-raises it
            failure.append(error)

    events = threading.Thread(target=serve, name="otgym-sim-events", daemon=True)
    try:
        for index, remote in enumerate(remotes):
            remote.on_sample = functools.partial(session.feed, index)
            remote.start()
        if remote_autonomy:
            RemoteAutonomy(node, session.n_traps, on_update=session.autonomy, on_alive=session.autonomy_alive)
        if plant in registry.names("plants", "measured"):
            node.subscribe(
                msg.RIG_POSES,
                lambda topic, message, data: session.measured(
                    time.monotonic(), msg.stamp_s(message), msg.xy_um(message)
                ),
            )
        follow_commands(node, session, stop.set)
        events.start()
        if on_ready is not None:
            on_ready()
        while not stop.is_set() and not session.over and not failure:
            stop.wait(0.05)
    finally:
        events_stop.set()  # one reader of the worker's events at a time: finish reads the last ones
        if events.is_alive():
            events.join(5.0)
        stats = session.finish()
        for remote in remotes:
            remote.on_sample = None
    if failure:
        raise failure[0]
    return stats or {}
