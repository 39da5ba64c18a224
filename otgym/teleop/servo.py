"""A haptic servo loop in its own process.

A Python loop that shares the GIL with JAX misses its deadlines, so the servo loop of a
haptic device runs in a separate process (``multiprocessing``'s spawn context). Each
tick (target ``caps.rate_hz``, 1 kHz for a Touch) it takes the latest commanded force,
calls the backend's ``servo_step(force_n) -> (position_mm, velocity_mm_s, buttons)``
and publishes the sample; then it sleeps until the next deadline and busy-waits the
last ``busy_wait_s``. A tick that falls more than a period behind restarts the
schedule instead of bursting to catch up. The loop asks the kernel for real-time
scheduling (``SCHED_FIFO`` at ``realtime_priority``, as haptic vendors' servo
schedulers run): a process that runs only about a fifth of each millisecond then
preempts the simulation's threads the moment its deadline comes, instead of waiting
for a core they hold. Without the privilege (CAP_SYS_NICE, or root) it runs at normal
priority; ``ServoDevice.realtime`` says which.

Sharing: one ``RawArray`` of doubles holds two blocks, each guarded by a seqlock (a
counter that is odd while its single writer writes; a reader retries when it saw an
odd or changed counter, and gives up after a few tries keeping its previous value), so
neither side ever blocks on the other: the child writes the sample, the parent writes
the force and the time it wrote it. The child records its loop periods in a ring
buffer the parent reads (``loop_periods_s``).

Safety: a force older than ``force_timeout_s`` is replaced by zero (the parent must
refresh it, as a control loop does every tick), the child zeros the force and closes
the backend when it stops, and it stops by itself when its parent dies (its parent
pid changes).

``SimulatedHapticBackend`` is a virtual stylus for tests, benchmarks and CI; the
Geomagic Touch backend is in ``otgym.teleop.touch``.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import multiprocessing
import os
import time
from collections.abc import Callable
from signal import SIGTERM
from signal import signal as on_signal
from typing import Protocol

import numpy as np

from otgym.teleop.device import Device, DeviceCaps, DeviceError, Sample, saturate_force

_SAMPLE = 0  # [counter, time_s, sequence, x, y, z, vx, vy, vz, buttons]
_SAMPLE_SIZE = 9
_FORCE = 10  # [counter, write time_s, fx, fy, fz]
_FORCE_SIZE = 4
_BLOCK_SIZE = 15
_SEQLOCK_TRIES = 64


def _write(block, start: int, values) -> None:
    block[start] += 1.0
    block[start + 1 : start + 1 + len(values)] = values
    block[start] += 1.0


def _read(block, start: int, size: int) -> list[float] | None:
    for _ in range(_SEQLOCK_TRIES):
        before = block[start]
        if before % 2 == 0:
            values = block[start + 1 : start + 1 + size]
            if block[start] == before:
                return values
    return None


class ServoBackend(Protocol):
    """What the servo loop drives; built inside the servo process by a factory.
    ``servo_step`` applies a force and returns the tip's state; ``close`` zeros the
    force and releases the hardware."""

    def servo_step(self, force_n: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]: ...

    def close(self) -> None: ...


def butterworth3_sos(cutoff_hz: float, rate_hz: float) -> np.ndarray:
    """Second-order sections (2, 6) of a third-order Butterworth low-pass by the
    bilinear transform with pre-warping, in closed form: a first-order section and a
    second-order one with Q = 1 (the poles of H(s) = 1 / ((s + 1)(s^2 + s + 1)) at
    unit cutoff). Equal to ``scipy.signal.butter(3, cutoff_hz, fs=rate_hz,
    output="sos")`` (tested); written out so that the servo process need not import
    scipy.signal, which takes seconds to import on a loaded machine."""
    if not 0 < cutoff_hz < rate_hz / 2:
        raise ValueError(f"cutoff_hz must be within (0, {rate_hz / 2}) Hz, got {cutoff_hz!r}")
    k = math.tan(math.pi * cutoff_hz / rate_hz)
    first = [k / (k + 1), k / (k + 1), 0.0, 1.0, (k - 1) / (k + 1), 0.0]
    norm = 1.0 / (1.0 + k + k * k)
    second = [k * k * norm, 2 * k * k * norm, k * k * norm, 1.0, 2 * (k * k - 1) * norm, (1 - k + k * k) * norm]
    return np.array([first, second])


class VelocityEstimator:
    """Tip velocity as in the authors' release: a second-order backward difference
    of positions (on the actual, possibly uneven, time steps), then a third-order
    Butterworth low-pass at ``cutoff_hz`` (20 Hz) designed for ``rate_hz``, run as
    transposed direct-form II sections with their state kept between calls. The first
    call gives zero, the second a first-order difference."""

    def __init__(self, rate_hz: float, cutoff_hz: float = 20.0):
        self._sos = butterworth3_sos(cutoff_hz, rate_hz)
        self._state = np.zeros((len(self._sos), 2, 3))
        self._history: list[tuple[np.ndarray, float]] = []
        self._output = np.zeros(3)

    def __call__(self, position_mm: np.ndarray, time_s: float) -> np.ndarray:
        """The velocity (mm/s) after a new position; a time not after the previous one
        carries no information and returns the previous estimate."""
        history = self._history
        if history and time_s <= history[-1][1]:
            return self._output.copy()
        if not history:
            raw = np.zeros(3)
        elif len(history) == 1:
            raw = (position_mm - history[-1][0]) / (time_s - history[-1][1])
        else:
            (x1, t1), (x2, t2) = history[-1], history[-2]
            h1, h2 = time_s - t1, t1 - t2
            raw = (
                (2 * h1 + h2) / (h1 * (h1 + h2)) * position_mm - (h1 + h2) / (h1 * h2) * x1 + h1 / (h2 * (h1 + h2)) * x2
            )
        self._history = history[-1:] + [(position_mm, time_s)]
        value = raw
        for (b0, b1, b2, _, a1, a2), state in zip(self._sos, self._state):
            out = b0 * value + state[0]
            state[0] = b1 * value - a1 * out + state[1]
            state[1] = b2 * value - a2 * out
            value = out
        self._output = value
        return value.copy()


@dataclasses.dataclass(frozen=True)
class SteadyHand:
    """A scripted hand target: ``start_mm + velocity_mm_s * t`` (device frame)."""

    start_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    velocity_mm_s: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self):
        for name in ("start_mm", "velocity_mm_s"):
            value = np.asarray(getattr(self, name), dtype=float)
            if value.shape != (3,) or not np.isfinite(value).all():
                raise ValueError(f"{name} must be three finite numbers, got {getattr(self, name)!r}")

    def __call__(self, time_s: float) -> np.ndarray:
        return np.asarray(self.start_mm, dtype=float) + np.asarray(self.velocity_mm_s, dtype=float) * time_s


class SimulatedHapticBackend:
    """A virtual stylus: a point mass (``mass_kg`` 0.045 kg, about a Touch's apparent
    tip mass; 3D Systems quotes 45 g) pushed by the commanded force and held by a hand,
    a spring-damper pulling it toward the scripted target ``hand(t)`` (t from the
    backend's creation): m dv/dt = F + k (target - x) - b v. Defaults k = 300 N/m,
    b = 6 N s/m: a light grip, within the 100-1000 N/m of human hand-arm stiffness
    measurements (Mussa-Ivaldi, Hogan & Bizzi, J. Neurosci. 5, 2732, 1985); with the
    mass they give a 13 Hz, slightly under-damped (zeta 0.8) hand. Integrated by
    backward Euler on the actual elapsed time (unconditionally stable, so a late tick
    cannot blow it up). Velocity is estimated from positions like a real device's
    (``VelocityEstimator``). ``buttons`` are held constant (bit 0: the clutch)."""

    def __init__(
        self,
        hand: Callable[[float], np.ndarray] = SteadyHand(),
        mass_kg: float = 0.045,
        hand_stiffness_n_per_m: float = 300.0,
        hand_damping_n_s_per_m: float = 6.0,
        buttons: int = 1,
        rate_hz: float = 1000.0,
    ):
        for name, value in (
            ("mass_kg", mass_kg),
            ("hand_stiffness_n_per_m", hand_stiffness_n_per_m),
            ("rate_hz", rate_hz),
        ):
            if not math.isfinite(value) or value <= 0:
                raise ValueError(f"{name} must be positive and finite, got {value!r}")
        if not math.isfinite(hand_damping_n_s_per_m) or hand_damping_n_s_per_m < 0:
            raise ValueError(f"hand_damping_n_s_per_m must be finite and >= 0, got {hand_damping_n_s_per_m!r}")
        if buttons < 0:
            raise ValueError(f"buttons must be non-negative bits, got {buttons!r}")
        self._hand = hand
        self._mass_kg = mass_kg
        self._stiffness = hand_stiffness_n_per_m
        self._damping = hand_damping_n_s_per_m
        self._buttons = int(buttons)
        self._nominal_step_s = 1.0 / rate_hz
        self._estimator = VelocityEstimator(rate_hz)
        self._start_s = time.monotonic()
        self._last_s: float | None = None
        self._position_m = np.asarray(hand(0.0), dtype=float) / 1000.0
        self._velocity_m_s = np.zeros(3)

    def servo_step(self, force_n: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
        now = time.monotonic()
        dt = self._nominal_step_s if self._last_s is None else max(now - self._last_s, 1e-6)
        self._last_s = now
        target_m = np.asarray(self._hand(now - self._start_s), dtype=float) / 1000.0
        m, k, b = self._mass_kg, self._stiffness, self._damping
        drive = np.asarray(force_n, dtype=float) + k * (target_m - self._position_m)
        self._velocity_m_s = (self._velocity_m_s + dt / m * drive) / (1.0 + dt * b / m + dt * dt * k / m)
        self._position_m = self._position_m + dt * self._velocity_m_s
        position_mm = self._position_m * 1000.0
        return position_mm, self._estimator(position_mm, now), self._buttons

    def close(self) -> None:
        """Nothing to release: a virtual stylus has no motors."""


def _sleep_until(deadline_s: float, busy_wait_s: float) -> None:
    remaining = deadline_s - time.monotonic()
    if remaining > busy_wait_s:
        time.sleep(remaining - busy_wait_s)
    while time.monotonic() < deadline_s:
        pass


def _exit_on_sigterm(signum, frame):
    raise SystemExit(0)


def _ask_realtime(priority: int | None) -> bool:
    """Real-time FIFO scheduling for this process at ``priority`` (1-99); False when
    not asked (None) or not granted."""
    if priority is None or not hasattr(os, "sched_setscheduler"):
        return False
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except OSError:  # no privilege: normal priority
        return False
    return True


def _widen_affinity() -> None:
    """Run on any core the machine allows: a servo started by a session worker inherits
    the one core the worker pinned itself to (``otgym.runtime.worker.pin_to_one_core``)."""
    if hasattr(os, "sched_setaffinity"):
        try:
            os.sched_setaffinity(0, range(os.cpu_count() or 1))
        except OSError:
            pass  # a cpuset that allows none of them: keep the inherited core


def _servo_main(
    factory,
    block,
    periods,
    period_count,
    stop_flag,
    conn,
    parent_pid: int,
    rate_hz: float,
    busy_wait_s: float,
    force_timeout_s: float,
    realtime_priority: int | None,
    realtime_flag,
) -> None:
    """The child process: build the backend, report readiness (an empty message) or
    the one-line reason it failed, run the loop, and report why it ended if it was
    not asked to. SIGTERM (sent to daemon children when the parent exits normally)
    ends the loop through the same ``finally``, so the force is zeroed."""
    on_signal(SIGTERM, _exit_on_sigterm)
    _widen_affinity()
    try:
        backend = factory()
    except Exception as error:  # any failure to open the backend is reported to the parent
        conn.send(str(error) or type(error).__name__)
        return
    realtime_flag.value = int(_ask_realtime(realtime_priority))
    conn.send("")
    period_s = 1.0 / rate_hz
    capacity = len(periods)
    command_s, command_n = -math.inf, np.zeros(3)
    sequence = 0
    last_tick_s = None
    deadline_s = time.monotonic()
    zero = np.zeros(3)
    try:
        while not stop_flag.value and os.getppid() == parent_pid:
            tick_s = time.monotonic()
            if last_tick_s is not None:
                periods[period_count.value % capacity] = tick_s - last_tick_s
                period_count.value += 1
            last_tick_s = tick_s
            command = _read(block, _FORCE, _FORCE_SIZE)
            if command is not None:
                command_s, command_n = command[0], np.asarray(command[1:])
            force = command_n if tick_s - command_s <= force_timeout_s else zero
            position, velocity, buttons = backend.servo_step(force)
            sequence += 1
            _write(block, _SAMPLE, [time.monotonic(), float(sequence), *position, *velocity, float(buttons)])
            deadline_s += period_s
            if time.monotonic() - deadline_s > period_s:
                deadline_s = time.monotonic()
            _sleep_until(deadline_s, busy_wait_s)
    except Exception as error:  # a lost device: tell the parent why, then release it
        conn.send(str(error) or type(error).__name__)
    finally:
        backend.close()


class ServoDevice(Device):
    """A Device whose servo loop runs in its own process around a backend made by
    ``backend_factory`` (a picklable zero-argument callable, called in the child).

    ``process`` is the child (None before ``start``; a daemon, so a daemonic process
    cannot start one); ``loop_periods_s()`` the recorded loop periods, oldest first
    (the last ``period_capacity``). One thread of the parent should call ``set_force``
    (the force block has a single writer). ``realtime_priority``: the SCHED_FIFO
    priority the loop asks for (None: normal scheduling); ``realtime`` whether it got it."""

    def __init__(
        self,
        backend_factory: Callable[[], ServoBackend],
        caps: DeviceCaps,
        *,
        busy_wait_s: float = 2e-4,
        force_timeout_s: float = 0.25,
        period_capacity: int = 4096,
        start_timeout_s: float = 20.0,
        realtime_priority: int | None = 50,
    ):
        for name, value in (("force_timeout_s", force_timeout_s), ("start_timeout_s", start_timeout_s)):
            if not math.isfinite(value) or value <= 0:
                raise ValueError(f"{name} must be positive and finite, got {value!r}")
        if not math.isfinite(busy_wait_s) or not 0 <= busy_wait_s < 1.0 / caps.rate_hz:
            raise ValueError(f"busy_wait_s must be within [0, one period {1.0 / caps.rate_hz} s), got {busy_wait_s!r}")
        if not isinstance(period_capacity, int) or period_capacity < 1:
            raise ValueError(f"period_capacity must be a positive integer, got {period_capacity!r}")
        if realtime_priority is not None and not (isinstance(realtime_priority, int) and 1 <= realtime_priority <= 99):
            raise ValueError(f"realtime_priority must be None or an integer in [1, 99], got {realtime_priority!r}")
        self.caps = caps
        self._factory = backend_factory
        self._busy_wait_s = busy_wait_s
        self._force_timeout_s = force_timeout_s
        self._start_timeout_s = start_timeout_s
        context = multiprocessing.get_context("spawn")
        self._context = context
        self._block = context.RawArray("d", _BLOCK_SIZE)
        self._periods = context.RawArray("d", period_capacity)
        self._period_count = context.RawValue("q", 0)
        self._stop_flag = context.RawValue("i", 0)
        self._realtime_priority = realtime_priority
        self._realtime_flag = context.RawValue("i", 0)
        self._conn = None
        self._last: Sample | None = None
        self.process = None

    @property
    def running(self) -> bool:
        return self._conn is not None

    @property
    def realtime(self) -> bool:
        """Whether the running servo loop got real-time scheduling."""
        return self.running and bool(self._realtime_flag.value)

    def start(self) -> None:
        if self.running:
            return
        receiver, sender = self._context.Pipe(duplex=False)
        self._stop_flag.value = 0
        self.process = self._context.Process(
            target=_servo_main,
            name=f"otgym-servo ({self.caps.name})",
            daemon=True,
            args=(
                self._factory,
                self._block,
                self._periods,
                self._period_count,
                self._stop_flag,
                sender,
                os.getpid(),
                self.caps.rate_hz,
                self._busy_wait_s,
                self._force_timeout_s,
                self._realtime_priority,
                self._realtime_flag,
            ),
        )
        self.process.start()
        sender.close()
        message = None
        try:
            if receiver.poll(self._start_timeout_s):
                message = receiver.recv()
        except EOFError:
            pass
        if message != "":
            self.process.kill()
            self.process.join()
            receiver.close()
            reason = message or f"its servo process did not start within {self._start_timeout_s} s"
            raise DeviceError(f"{self.caps.name}: {reason}")
        self._conn = receiver

    def stop(self) -> None:
        """Zero the force, ask the loop to end (it zeros the backend's force and closes
        it), wait for the process; kill it if it does not end within 2 s."""
        if not self.running:
            return
        self.set_force(np.zeros(3))
        self._stop_flag.value = 1
        self.process.join(timeout=2.0)
        if self.process.is_alive():
            self.process.kill()
            self.process.join()
        self._conn.close()
        self._conn = None
        self._last = None

    def read(self) -> Sample | None:
        """The latest sample; None before the first or when not running. Raises
        DeviceError when the servo process ended without being asked to."""
        if not self.running:
            return None
        if self.process.exitcode is not None:
            reason = self._conn.recv() if self._conn.poll() else f"exit code {self.process.exitcode}"
            self._conn.close()
            self._conn = None
            raise DeviceError(f"{self.caps.name}: servo process ended ({reason})")
        values = _read(self._block, _SAMPLE, _SAMPLE_SIZE)
        if values is not None and values[1] > 0 and (self._last is None or values[1] != self._last.sequence):
            self._last = Sample(values[0], int(values[1]), values[2:5], values[5:8], int(values[8]))
        return self._last

    def set_force(self, force_n) -> None:
        """Command a force (saturated to the device's limit) until the next call; the
        servo loop zeros it if no call comes within ``force_timeout_s``."""
        if self.running:
            force = saturate_force(force_n, self.caps.force_limit_n)
            _write(self._block, _FORCE, [time.monotonic(), *force])

    def loop_periods_s(self) -> np.ndarray:
        count = self._period_count.value
        capacity = len(self._periods)
        periods = np.frombuffer(self._periods, dtype=np.float64).copy()
        if count <= capacity:
            return periods[:count]
        return np.roll(periods, -(count % capacity))


SIMULATED_HAPTIC_CAPS = DeviceCaps(
    name="simulated haptic stylus", dof=3, force_limit_n=0.88, workspace_mm=(160.0, 120.0, 70.0), rate_hz=1000.0
)
"""A virtual Touch: its continuous force limit and workspace (3D Systems' figures)."""


def simulated_haptic_device(hand: Callable[[float], np.ndarray] = SteadyHand(), **device_options) -> ServoDevice:
    """A simulated haptic stylus (``SimulatedHapticBackend`` held by ``hand``, a
    picklable callable of time) in its own 1 kHz servo process: the hardware-free
    stand-in for a Geomagic Touch."""
    return ServoDevice(functools.partial(SimulatedHapticBackend, hand), SIMULATED_HAPTIC_CAPS, **device_options)
