"""A ``Session`` (the interactive loop: its ticks, the devices' retargeting, its
recording) in a process of its own, so that whatever drives it (a window drawing at 60
frames per second, a zenoh node answering the devices) never shares an interpreter
lock with the ticks: each process has a core of its own on a 2-core machine.

Processes: ``SessionProcess(spec).start()`` spawns the worker (``multiprocessing``'s
spawn context; nothing but pipes and shared-memory blocks: no socket) with the BLAS
and OpenMP libraries limited to ``spec.threads`` threads, and the worker pins itself
to one core (``pin_to_one_core``), so that neither they nor XLA's own thread pool take
the other core from the window or the sim node's bus side
(docs/decisions/0012-session-in-its-own-process.md). The worker calls ``spec.setup``
(a picklable callable: the task, the bindings, the sink, the autonomy), starts the
session and paces it by the wall clock until it is asked to quit, its parent dies, or
(without ``hold_between_trials``) its duration is spent.

Channels:
- parent -> worker, a pipe of commands (``("set_mode", "manual")``, ``("drag",
  robot, pointer_um, traps_um)``, ``("autonomy", arrival_s, increments)``,
  ``("measured", arrival_s, stamp_s, sphere_xy_um)``, ``("quit",)``...), applied
  between ticks; the worker waits for its next tick on
  this pipe, so a command is applied at once;
- parent -> worker, each forwarded device's latest sample in a ``LatestBytes`` block
  of its own (``feed``): a device that sends 1000 samples a second costs the worker
  nothing until it reads the latest before a tick, and a worker busy for a moment
  (a trial's start) never blocks the sender;
- worker -> parent, a pipe of events: ``status`` (what it is doing while it starts:
  building the task, compiling), ``ready`` (what the parent asked to know:
  the task's layout, the devices' force limits), ``finished`` (a trial's row),
  ``over``, ``publish`` (whatever the sink sends: the sim node's messages), ``force``
  (a forwarded device's feedback), ``error`` and ``closed``;
- the latest ``Snapshot``, pickled into a ``LatestBytes`` block (a seqlock: the
  worker never waits for a reader, a reader never waits for the worker; a window
  that stalls only misses snapshots, it never slows simulated time).

Failures: a device that cannot start comes back as ``DeviceError`` from ``start``
(with nothing left running); a worker that dies is ``WorkerError`` with its exit code
at the parent's next ``poll``; a parent that dies makes the worker end its trial as
aborted, close its recording and exit. SIGTERM ends the worker through the same path;
SIGINT is ignored there (Ctrl-C reaches the whole process group: the parent decides).
"""

from __future__ import annotations

import collections
import dataclasses
import functools
import inspect
import multiprocessing
import os
import pickle
import signal
import threading
import time
import traceback
from collections.abc import Callable
from typing import Any

from otgym.runtime.latest_bytes import SAMPLE_BYTES, LatestBytes, pack_sample, unpack_sample
from otgym.runtime.protocols import SessionCommands, Sink, protocol_methods
from otgym.teleop.device import DeviceCaps, DeviceError, Sample

STATUS_COMPILING = "compiling the simulation (the first run takes longest: compiled code is cached)"
"""The worker's status while its session's first tick compiles."""
SNAPSHOT_BYTES = 1 << 17
"""Room for one pickled snapshot (about 5 kB for the interactive task's 19 spheres)."""


class WorkerError(RuntimeError):
    """The worker process failed or ended unasked; ``str()`` says how."""


@dataclasses.dataclass
class WorkerParts:
    """What ``WorkerSpec.setup`` builds in the worker."""

    task: Any
    bindings: list
    sink: Sink | None = None
    autonomy: ForwardedAutonomy | None = None
    measurements: Any = None
    """The plant's measured poses (``otgym.task.rig.MeasuredPoses``), fed by the parent's
    ``measured``; None for a plant that measures nothing from outside."""
    on_failure: Callable[[], None] | None = None
    """Called when the session cannot start (e.g. remove a recording just created)."""


@dataclasses.dataclass(frozen=True)
class WorkerSpec:
    """The session to run. ``setup(forwarded, outbox) -> WorkerParts`` runs in the
    worker: ``forwarded`` are the ``ForwardedDevice`` s made from ``forwarded_caps``
    (fed by the parent's ``feed``; with ``forwarded_haptics`` their ``set_force``
    reaches the parent as ``force`` events), ``outbox(obj)`` sends ``("publish", obj)``
    to the parent. ``snapshots``: publish every snapshot for a view and send the
    task's layout and the bindings' force limits with ``ready``."""

    setup: Callable
    participant: str
    mode: str
    seed: int
    duration_s: float | None = None
    forwarded_caps: tuple[DeviceCaps, ...] = ()
    forwarded_haptics: bool = False
    hold_between_trials: bool = True
    snapshots: bool = True
    threads: int = 1
    first_trial: int = 1
    hold_first_trial: bool = False


def thread_limits(threads: int) -> dict[str, str]:
    """Environment that keeps the BLAS and OpenMP libraries to ``threads`` threads."""
    return {name: str(threads) for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")}


class ForwardedAutonomy:
    """dP_r that the parent forwards (an autonomy node's answers): the latest
    increments (1, T, 2) if the autonomy is alive and they arrived within
    ``timeout_s`` (by ``time.monotonic``, one clock for every process), else None
    (``InteractiveLoop``'s ``autonomy``)."""

    def __init__(self, timeout_s: float):
        self.timeout_s = timeout_s
        self.alive = False
        self._latest = None

    def update(self, arrival_s: float, increments) -> None:
        self._latest = (arrival_s, increments)

    def set_alive(self, alive: bool) -> None:
        self.alive = alive
        if not alive:
            self._latest = None

    def __call__(self, observation):
        if not self.alive or self._latest is None or time.monotonic() - self._latest[0] > self.timeout_s:
            return None
        return self._latest[1]


SESSION_COMMANDS = protocol_methods(SessionCommands)
"""The commands the parent forwards to the worker's ``Session``: ``SessionCommands``' methods."""


def _exit_on_sigterm(signum, frame):
    raise SystemExit(0)


def pin_to_one_core() -> None:
    """Keep this process, and the threads XLA starts in it later, on one core: the last
    it may use. One environment's tick is latency-bound (XLA's pool of a thread per core
    gains it little), and the other cores stay free for the window, the sim node's
    answers to the devices and the haptic servo (which widens its own affinity again:
    ``otgym.teleop.servo``). Linux only; elsewhere nothing (docs/decisions/0012)."""
    if not hasattr(os, "sched_setaffinity"):
        return
    cores = sorted(os.sched_getaffinity(0))
    if len(cores) > 1:
        os.sched_setaffinity(0, {cores[-1]})


def _worker_main(
    spec: WorkerSpec,
    commands,
    events,
    snapshot_block: LatestBytes | None,
    device_blocks: list[LatestBytes],
    parent_pid: int,
) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _exit_on_sigterm)
    pin_to_one_core()
    import numpy as np

    from otgym.runtime.session import Session
    from otgym.teleop.forwarded import ForwardedDevice

    def send(message) -> None:
        try:
            events.send(message)
        except (BrokenPipeError, OSError):
            pass  # the parent is gone; the recording still closes

    def force_sender(index: int):
        return lambda force_n: send(("force", index, np.asarray(force_n, float)))

    parts = session = None
    try:
        send(("status", "building the task: chip, route, robots and cell"))
        forwarded = [
            ForwardedDevice(caps, on_force=force_sender(i) if spec.forwarded_haptics else None)
            for i, caps in enumerate(spec.forwarded_caps)
        ]
        parts = spec.setup(forwarded, lambda payload: send(("publish", payload)))
        session = Session(
            parts.task,
            parts.bindings,
            spec.participant,
            spec.mode,
            spec.seed,
            spec.duration_s,
            sink=parts.sink,
            autonomy=parts.autonomy,
            hold_between_trials=spec.hold_between_trials,
            forwarded=tuple(forwarded),
            first_trial=spec.first_trial,
            hold_first_trial=spec.hold_first_trial,
        )
        send(("status", STATUS_COMPILING))
        session.start()
    except DeviceError as error:
        if parts is not None and parts.on_failure is not None:
            parts.on_failure()
        send(("error", "device", str(error)))
        return
    except BaseException:
        if parts is not None and parts.on_failure is not None:
            parts.on_failure()
        send(("error", "crash", traceback.format_exc()))
        return
    info = {"n_traps": parts.task.n_traps}
    if spec.snapshots:
        info.update(layout=session.layout, force_limits_n=session.force_limits_n)
    send(("ready", info))
    published = None
    over_sent = False
    fed = [0] * len(device_blocks)
    try:
        while os.getppid() == parent_pid:
            for index, block in enumerate(device_blocks):
                latest = block.read()
                if latest is not None and latest[0] != fed[index]:
                    fed[index] = latest[0]
                    forwarded[index].feed(unpack_sample(latest[1]))
            quit_asked = False
            while commands.poll():
                name, *arguments = commands.recv()
                if name == "quit":
                    quit_asked = True
                    break
                if name in SESSION_COMMANDS:
                    getattr(session, name)(*arguments)
                elif name == "autonomy":
                    parts.autonomy.update(*arguments)
                elif name == "autonomy_alive":
                    parts.autonomy.set_alive(*arguments)
                elif name == "measured" and parts.measurements is not None:
                    parts.measurements.update(*arguments)
            if quit_asked:
                break
            session.advance()
            if snapshot_block is not None and session.snapshot is not published:
                published = session.snapshot
                snapshot_block.write(pickle.dumps(published, protocol=pickle.HIGHEST_PROTOCOL))
            while (row := session.take_finished()) is not None:
                send(("finished", row))
            if session.over and not over_sent:
                over_sent = True
                send(("over",))
                if not spec.hold_between_trials:
                    break
            commands.poll(min(session.next_tick_in_s(), 0.05))
    except (SystemExit, EOFError):
        pass
    except BaseException:
        send(("error", "crash", traceback.format_exc()))
    finally:
        session.finish()
        while (row := session.take_finished()) is not None:
            send(("finished", row))
        session.close()
        send(("closed", {"ticks": session.ticks, "late_ticks": session.late_ticks, "trials": session.trial}))


class SessionProcess(SessionCommands):
    """The parent's side of a worker running ``spec`` (a ``SessionControl``): start it,
    read its latest ``snapshot``, send it commands (``SessionCommands``' methods,
    forwarded as they are: generated below from the protocol; ``feed`` through a
    shared-memory block; and ``autonomy``, ``autonomy_alive``, ``measured``), take the
    rows of
    finished trials, ``finish`` it. ``on_publish(payload)`` and ``on_force(index,
    force_n)`` get the worker's ``publish`` and ``force`` events (from ``poll``, or from
    the thread of ``serve_events``); ``on_status(text)`` what the worker is doing while
    it starts (from ``start``'s thread)."""

    def __init__(
        self,
        spec: WorkerSpec,
        *,
        on_publish: Callable[[Any], None] | None = None,
        on_force: Callable[[int, Any], None] | None = None,
        on_status: Callable[[str], None] | None = None,
        start_timeout_s: float = 900.0,
    ):
        self.spec = spec
        self.participant = spec.participant
        self.on_publish, self.on_force, self.on_status = on_publish, on_force, on_status
        self.start_timeout_s = start_timeout_s
        self.layout = None
        self.force_limits_n: list[float] = []
        self.n_traps = 0
        self.over = False
        self.stats: dict | None = None
        self.failure: str | None = None
        """The worker's traceback when it failed while running."""
        self.process = None
        self._context = multiprocessing.get_context("spawn")
        self._snapshots = LatestBytes(SNAPSHOT_BYTES, self._context) if spec.snapshots else None
        self._device_blocks = [LatestBytes(SAMPLE_BYTES, self._context) for _ in spec.forwarded_caps]
        self._snapshot = None
        self._snapshot_sequence = 0
        self._finished: collections.deque = collections.deque()
        self._send_lock = threading.Lock()
        self._commands = self._events = None

    # --- lifetime ---------------------------------------------------------------
    def start(self) -> None:
        """Spawn the worker and wait until its session runs; DeviceError when a device
        cannot start, WorkerError when the worker fails otherwise."""
        command_reader, self._commands = self._context.Pipe(duplex=False)
        self._events, event_writer = self._context.Pipe(duplex=False)
        self.process = self._context.Process(
            target=_worker_main,
            name="otgym-session",
            args=(self.spec, command_reader, event_writer, self._snapshots, self._device_blocks, os.getpid()),
        )
        limits = thread_limits(self.spec.threads)
        saved = {name: os.environ.get(name) for name in limits}
        os.environ.update(limits)  # the spawned interpreter inherits the environment at its start
        try:
            self.process.start()
        finally:
            for name, value in saved.items():
                if value is None:
                    os.environ.pop(name, None)
                else:
                    os.environ[name] = value
        command_reader.close()
        event_writer.close()
        deadline = time.monotonic() + self.start_timeout_s
        while True:
            if not self._events.poll(0.1):
                if not self.process.is_alive() or time.monotonic() > deadline:
                    self._kill()
                    raise WorkerError(
                        f"the simulation process ended before it was ready (exit code {self.process.exitcode})"
                    )
                continue
            message = self._events.recv()
            if message[0] == "ready":
                info = message[1]
                self.layout, self.force_limits_n = info.get("layout"), info.get("force_limits_n", [])
                self.n_traps = info["n_traps"]
                return
            if message[0] == "error":
                break
            self._handle(message)  # e.g. the warm-up's zero forces
        self.process.join(5.0)
        self._kill()
        if message[1] == "device":
            raise DeviceError(message[2])
        raise WorkerError(f"the simulation process failed to start:\n{message[-1]}")

    def finish(self, timeout_s: float = 30.0) -> dict | None:
        """Quit: the worker ends a trial under way as aborted (its row to
        ``take_finished``), stops its devices, closes its recording and exits; killed
        if it has not within ``timeout_s``. Returns its counts (ticks, late_ticks,
        trials), None if it died."""
        if self.process is None:
            return self.stats
        self.send("quit")
        deadline = time.monotonic() + timeout_s
        while self.stats is None and self.process.is_alive() and time.monotonic() < deadline:
            try:
                if self._events.poll(0.05):
                    self._handle(self._events.recv())
            except (EOFError, OSError):
                break
        self.process.join(max(deadline - time.monotonic(), 0.1))
        self._kill()
        return self.stats

    def _kill(self) -> None:
        if self.process is not None and self.process.is_alive():
            self.process.kill()
        if self.process is not None:
            self.process.join()

    # --- commands ---------------------------------------------------------------
    def send(self, name: str, *arguments) -> None:
        with self._send_lock:
            try:
                self._commands.send((name, *arguments))
            except (BrokenPipeError, OSError):
                pass  # the worker is gone: poll reports it

    def feed(self, index: int, sample: Sample) -> None:
        """The latest sample of forwarded device ``index`` (never blocks; one writer per device)."""
        self._device_blocks[index].write(pack_sample(sample))

    def autonomy(self, arrival_s: float, increments) -> None:
        self.send("autonomy", arrival_s, increments)

    def autonomy_alive(self, alive: bool) -> None:
        self.send("autonomy_alive", alive)

    def measured(self, arrival_s: float, stamp_s: float, sphere_xy_um) -> None:
        """A rig's measured spheres (``WorkerParts.measurements``): arrival by
        ``time.monotonic``, stamp in UNIX seconds, centres (S, 2) um."""
        self.send("measured", arrival_s, stamp_s, sphere_xy_um)

    # --- what comes back --------------------------------------------------------
    @property
    def snapshot(self):
        """The worker's latest snapshot (unpickled once per new one)."""
        if self._snapshots is not None:
            latest = self._snapshots.read()
            if latest is not None and latest[0] != self._snapshot_sequence:
                self._snapshot_sequence = latest[0]
                self._snapshot = pickle.loads(latest[1])
        return self._snapshot

    @property
    def snapshot_sequence(self) -> int:
        """How many snapshots the worker has written (changes with every new one)."""
        return self._snapshot_sequence

    def take_finished(self) -> dict | None:
        return self._finished.popleft() if self._finished else None

    def poll(self, timeout_s: float = 0.0) -> None:
        """Handle the events waiting, after waiting up to ``timeout_s`` for one;
        WorkerError if the worker failed or died unasked."""
        alive = self.process.is_alive()
        try:
            if self._events.poll(timeout_s):
                while self._events.poll():
                    self._handle(self._events.recv())
        except (EOFError, OSError):
            alive = False
        if self.failure is not None:
            raise WorkerError(f"the simulation process failed:\n{self.failure}")
        if not alive and self.stats is None:
            self.process.join(1.0)
            raise WorkerError(f"the simulation process ended unexpectedly (exit code {self.process.exitcode})")

    def serve_events(self, stop: threading.Event) -> None:
        """Handle events as they come until ``stop`` is set or the worker has closed
        (a thread's loop: the sim node publishes from here); WorkerError as ``poll``."""
        while not stop.is_set() and self.stats is None:
            self.poll(0.05)

    def _handle(self, message) -> None:
        kind = message[0]
        if kind == "finished":
            self._finished.append(message[1])
        elif kind == "over":
            self.over = True
        elif kind == "publish":
            if self.on_publish is not None:
                self.on_publish(message[1])
        elif kind == "force":
            if self.on_force is not None:
                self.on_force(message[1], message[2])
        elif kind == "status":
            if self.on_status is not None:
                self.on_status(message[1])
        elif kind == "closed":
            self.stats = message[1]
            self.over = True
        elif kind == "error":
            self.failure = message[-1]

    @property
    def running(self) -> bool:
        return self.process is not None and self.stats is None and self.process.is_alive()


def _forwarder(name: str):
    """``SessionProcess.<name>``: send the command and its arguments (bound to the
    protocol method's signature, so a wrong call fails here, not in the worker)."""
    declared = getattr(SessionCommands, name)
    signature = inspect.signature(declared)

    def forward(self, *arguments, **keywords) -> None:
        bound = signature.bind(self, *arguments, **keywords)
        self.send(name, *bound.args[1:])

    return functools.update_wrapper(forward, declared)


for _name in SESSION_COMMANDS:
    setattr(SessionProcess, _name, _forwarder(_name))
