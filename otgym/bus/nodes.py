"""The runtime's parts as bus nodes: a device node
publishes its device's samples and applies the feedback it receives; the simulator
node (``otgym.bus.sim_node``) runs a session on ``RemoteDevice`` s and publishes every
tick; a recorder node passes every checked message to a sink (``otgym.cli.node``
gives it an MCAP file); the autonomy node answers each tick with dP_r.

Faults (safety first):
- a device node dies: its liveliness token goes; the simulator's ``RemoteDevice``
  then reads as one sample at rest with every button released (the retargeter's
  clutch zeroes dP_h at once) that then ages into silence, so the traps hold; the
  device is sent no more feedback;
- the simulator dies: each device node zeros its device's force at once (the
  simulator's token went) and keeps reconnecting (``transport``); when the simulator is
  back, samples flow again and feedback resumes;
- a recorder dies: its MCAP file keeps every chunk flushed before (at most the last
  second is lost; ``otgym.record.mcap_file``);
- the autonomy node dies (or its dP_r is older than ``AUTONOMY_TIMEOUT_S``): shared
  control falls back to manual (alpha 1) and autonomous control holds the traps; the
  simulator publishes the mode it runs in (``manual``) and an ``autonomy_lost`` event,
  the cue a window shows, and ``autonomy_back`` when dP_r flows again.

The autonomy node runs the route navigator on what the simulator publishes (traps,
phase, every sphere's centre) and answers each tick's ``/otgym/bodies`` with dP_r on
``/otgym/autonomy/increments``; the simulator applies the latest answer at its next
tick (one tick, 20 ms, later than the in-process navigator).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from otgym.bus import messages as msg
from otgym.bus.transport import Node
from otgym.teleop.device import Device, DeviceCaps, Sample

if TYPE_CHECKING:  # the autonomy node's parts import JAX: a device node does without it
    from otgym.autonomy.protocol import Navigator
    from otgym.task.task import InteractiveTask

AUTONOMY_TIMEOUT_S = 0.25
"""dP_r older than this (12 ticks) counts as none. A killed autonomy node is noticed
at once by its liveliness token; this bound is for one that hangs. At 0.1 s (five
ticks) a distributed run on a loaded 2-core machine (window, five node processes)
flapped between shared and manual six times in 10 s as the autonomy node waited for a
core 60-200 ms."""

REMOTE_FORCE_LIMIT_N = 3.3
"""The simulator's cap on a remote device's feedback (a Geomagic Touch's peak force);
each device node saturates again at its own device's limit."""


class RemoteDevice(Device):
    """A device node's device, seen from the simulator through ``node``: ``read`` gives
    the latest twist and buttons of device ``name`` stamped with this process's
    ``clock`` on arrival (each new sample, and the rest sample of a lost node, also
    goes to ``on_sample``, in the order they were made; it must not block); once the
    node's liveliness token has gone, its twists are dropped until it is back, so a
    twist still in flight when the node is lost cannot move the traps after its rest
    sample (a raw peer that never declared a token is taken as it is); ``set_force``
    publishes the feedback. With
    ``answer_twists`` every twist is answered at once with the latest force, stamped
    with the twist's own stamp (the device's lowest-latency feedback, and its round
    trip), besides the force published at each tick."""

    def __init__(
        self,
        node: Node,
        name: str,
        clock: Callable[[], float] = time.monotonic,
        force_limit_n: float = REMOTE_FORCE_LIMIT_N,
        *,
        answer_twists: bool = False,
        on_sample: Callable[[Sample], None] | None = None,
    ):
        self.node, self.name, self.clock = node, msg.check_name(name), clock
        self.caps = DeviceCaps(f"remote {name}", 3, force_limit_n, (160.0, 120.0, 70.0), 1000.0)
        self.answer_twists, self.on_sample = answer_twists, on_sample
        self.alive = False
        self.losses = 0
        """Times the device node's liveliness token went away."""
        self._buttons = 0
        self._sequence = 0
        self._sample: Sample | None = None
        self._force_n = np.zeros(3)
        self._lock = threading.Lock()
        self._subscribed = False

    def start(self) -> None:
        if self._subscribed:
            return
        self._subscribed = True
        self.node.subscribe(msg.buttons_topic(self.name), self._on_buttons)
        self.node.subscribe(msg.twist_topic(self.name), self._on_twist)
        self.node.watch("device", self._on_liveliness)

    def _on_buttons(self, topic, message, data) -> None:
        self._buttons = msg.button_bits(message)

    def _on_twist(self, topic, message, data) -> None:
        with self._lock:
            if self.losses and not self.alive:
                return  # delivered after the node's token went away: must not undo its rest sample
            self._sequence += 1
            sample = self._sample = msg.sample_from(message, self._buttons, self.clock(), self._sequence)
            answer = self._force_n if self.answer_twists and self.alive else None
            self._deliver(sample)
        if answer is not None:
            self.node.publish(msg.feedback_topic(self.name), msg.wrench(answer, msg.stamp_s(message), self.name))

    def _deliver(self, sample: Sample) -> None:
        """Hand ``sample`` to ``on_sample``; called holding the lock, so the samples reach it
        in the order they were made (twists and the token arrive on different threads: a
        twist made before the token went away but handed on after its rest sample would
        move the traps again)."""
        if self.on_sample is not None:
            self.on_sample(sample)

    def _on_liveliness(self, name: str, alive: bool) -> None:
        if name != self.name:
            return
        with self._lock:
            if self.alive and not alive:
                self.losses += 1
                self._sequence += 1
                self._buttons = 0
                self._sample = Sample(self.clock(), self._sequence, np.zeros(3), np.zeros(3), 0)
                self._force_n = np.zeros(3)
                self._deliver(self._sample)
            self.alive = alive

    def stop(self) -> None:
        self.set_force(np.zeros(3))

    def read(self) -> Sample | None:
        return self._sample

    def set_force(self, force_n) -> None:
        with self._lock:
            self._force_n = np.asarray(force_n, float)
            alive = self.alive
        if alive:
            self.node.publish(msg.feedback_topic(self.name), msg.wrench(force_n, time.time(), self.name))


class RemoteAutonomy:
    """The autonomy node's dP_r, seen from the simulator through ``node``: called with an
    observation, the latest received increments (1, T, 2) um if the node is alive and
    they arrived within ``timeout_s`` (by ``clock``), else None (``InteractiveLoop``'s
    ``autonomy``)."""

    def __init__(
        self,
        node: Node,
        n_traps: int,
        clock: Callable[[], float] = time.monotonic,
        timeout_s: float = AUTONOMY_TIMEOUT_S,
        *,
        on_update: Callable[[float, np.ndarray], None] | None = None,
        on_alive: Callable[[bool], None] | None = None,
    ):
        self.node, self.n_traps, self.clock, self.timeout_s = node, n_traps, clock, timeout_s
        self.on_update, self.on_alive = on_update, on_alive
        """Also told of each accepted answer (arrival time, increments) and each change of liveliness."""
        self.alive = False
        self.losses = 0
        """Times the autonomy node's liveliness token went away."""
        self.rejected = 0
        """Messages with the wrong number of traps (checked, decoded, but not for this task)."""
        self._latest: tuple[float, np.ndarray] | None = None
        self._lock = threading.Lock()
        node.subscribe(msg.AUTONOMY, self._on_increments)
        node.watch("autonomy", self._on_liveliness)

    def _on_increments(self, topic, message, data) -> None:
        increments = msg.xy_um(message)
        if len(increments) != self.n_traps:
            self.rejected += 1
            return
        with self._lock:
            self._latest = (self.clock(), increments[None])
        if self.on_update is not None:
            self.on_update(*self._latest)

    def _on_liveliness(self, name: str, alive: bool) -> None:
        with self._lock:
            if self.alive and not alive:
                self.losses += 1
                self._latest = None
            self.alive = alive
        if self.on_alive is not None:
            self.on_alive(alive)

    def __call__(self, observation) -> np.ndarray | None:
        with self._lock:
            if not self.alive or self._latest is None or self.clock() - self._latest[0] > self.timeout_s:
                return None
            return self._latest[1]


def run_autonomy_node(
    node: Node,
    task: InteractiveTask,
    stop: threading.Event,
    cruise_speed_um_s: float = 5.0,
    max_speed_um_s: float = 20.0,
    navigator: Navigator | None = None,
) -> int:
    """An autonomy as a node: on each ``/otgym/bodies`` from the simulator, the task's
    observation rebuilt from the latest bodies, traps and phase
    (``otgym.task.layout.observation_from_spheres``; time from the bodies' stamps
    since the trial began), and the navigator's dP_r published on
    ``/otgym/autonomy/increments`` with the bodies' stamp; the navigator is reset at
    each ``trial_start``. ``navigator``: anything with ``reset(n_env)`` and
    ``increments(observation) -> (1, T, 2)`` um, by default the route navigator
    (``otgym.autonomy.navigator``); the model-predictive one
    (``otgym.autonomy.mpc_navigator.MPCNavigator``) answers a replan tick late, the others
    at once. A navigator slower than the ticks answers the newest bodies only. Until
    ``stop`` is set; returns the answers published."""
    from otgym.autonomy.navigator import RouteNavigator
    from otgym.task.layout import layout_of, observation_from_spheres

    if navigator is None:
        navigator = RouteNavigator.for_task(task, max_speed_um_s, cruise_speed_um_s)
    layout = layout_of(task)
    latest: dict[str, object] = {}
    fresh = threading.Condition()

    def keep(name):
        def on_message(topic, message, data) -> None:
            with fresh:
                latest[name] = message
                if name == "bodies":
                    fresh.notify()

        return on_message

    def on_event(topic, message, data) -> None:
        if msg.event_fields(message)["event"] == "trial_start":
            with fresh:
                latest["restart"] = True

    node.subscribe(msg.TRAPS, keep("traps"))
    node.subscribe(msg.PHASE, keep("phase"))
    node.subscribe(msg.BODIES, keep("bodies"))
    node.subscribe(msg.EVENTS, on_event)
    navigator.reset(1)
    answered, route_index, trial_began_s = 0, 0, None
    while not stop.is_set():
        with fresh:
            if not fresh.wait_for(lambda: "bodies" in latest or stop.is_set(), timeout=0.1) or stop.is_set():
                continue
            bodies, traps, phase = latest.pop("bodies"), latest.get("traps"), latest.get("phase")
            restart = latest.pop("restart", False)
        if traps is None or phase is None:
            continue
        if restart:
            navigator.reset(1)
            route_index, trial_began_s = 0, None
        spheres, trap_xy = msg.xy_um(bodies), msg.xy_um(traps)
        if len(spheres) != len(layout.sphere_body) or len(trap_xy) != layout.n_traps:
            continue  # not this task's simulator
        stamp_s = msg.stamp_s(bodies)
        trial_began_s = stamp_s if trial_began_s is None else trial_began_s
        seen, route_index = observation_from_spheres(
            layout, spheres, trap_xy, msg.PHASES.index(phase.data), stamp_s - trial_began_s, route_index
        )
        increments = np.asarray(navigator.increments(seen), float)[0]
        node.publish(msg.AUTONOMY, msg.pose_array(increments, stamp_s, "chip"))
        answered += 1
    return answered


def run_device_node(node: Node, device: Device, name: str, stop: threading.Event, rate_hz: float = 500.0) -> int:
    """Publish each new sample of ``device`` as ``name``'s twist and buttons (polled at
    ``rate_hz``), apply the simulator's feedback while a simulator is alive, zero it
    when none is; until ``stop`` is set. Returns the samples published."""
    sims: set[str] = set()
    lock = threading.Lock()
    running = [True]

    def on_feedback(topic, message, data) -> None:
        with lock:
            if sims and running[0]:
                device.set_force(msg.force_n(message))

    def on_sim(sim: str, alive: bool) -> None:
        with lock:
            (sims.add if alive else sims.discard)(sim)
            if not sims:
                device.set_force(np.zeros(3))

    device.start()
    try:
        node.subscribe(msg.feedback_topic(name), on_feedback)
        node.watch("sim", on_sim)
        published, last_sequence = 0, None
        while not stop.wait(1.0 / rate_hz):
            sample = device.read()
            if sample is None or sample.sequence == last_sequence or not sample.finite:
                continue
            last_sequence = sample.sequence
            stamp_s = time.time()
            node.publish(msg.buttons_topic(name), msg.joy(sample.buttons, stamp_s, name))
            node.publish(msg.twist_topic(name), msg.twist(sample, stamp_s, name))
            published += 1
        return published
    finally:
        with lock:  # no feedback that arrives from now on reaches the device
            running[0] = False
            device.set_force(np.zeros(3))
        device.stop()
