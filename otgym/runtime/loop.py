"""The real-time interactive loop for one environment of the interactive task
(paper sections II-D and II-E, Fig. 2's closed loop).

One tick (50 Hz by default; ``InteractiveTask``'s control period), in this order:

    device(s) --read--> Retargeter (clutch, dead band, tremor low-pass, tau)  --> dP_h
    RouteNavigator (the autonomy along the planned route)                     --> dP_r
    alpha, dP_s = control_tick(mode, gap, dP_h, dP_r)   (otgym.runtime.tick, as the trials)
    InteractiveTask.dispatch(dP_s)                                 ("physics", started)
    microscope crops around each trap, frame of the tick's start   ("render")
    VisionForceSensor.measure -> handle positions and trap forces  ("sense")
    FeedbackLaw per device on its robots' handles -> device.set_force
    InteractiveTask.complete                                       ("physics", waited for)

The physics runs on JAX's own thread (asynchronous dispatch) while this thread draws
and reads the microscope frame of the state the tick started from, so on two cores the
two overlap. The feedback a device gets therefore comes from a camera frame one tick
(20 ms) old, as it would from a real camera whose frame is read while the next is
exposed; the record keeps that frame's trap positions (``frame_trap_xy_um``) beside
the sensed handles.

The command is ``otgym.runtime.tick.control_tick``, the one that
``otgym.runtime.trials.run_trials`` runs, for one environment with real devices; the
two differ only in where dP_h and the feedback's handle forces come from: devices, not
simulated participants, and the vision sensor reading a rendered microscope frame, not
the simulator's true offsets.

Devices. Each ``DeviceBinding`` ties one ``otgym.teleop.device.Device`` to the robots
it drives: one device per robot (bimanual: robot 0 and robot 1, as the paper's two
Geomagic Touches), or one device driving both robots as a formation (its increment
moves every trap of both). A robot no device drives gets dP_h = 0 (in manual mode its
traps hold). Each device has its own ``Retargeter`` (default
``otgym.runtime.trials.TASK_RETARGET``) and ``FeedbackLaw`` (default scale
``newtons_per_pn_for(trap_law)``, saturated at the device's own force limit).

Microscope. One ``crop_px`` x ``crop_px`` bright-field crop per trap (default 48 px at
0.1 um: 4.8 um, room for a 2.5 um handle that lags its trap, the sensor's 1 um search
radius and its background ring at 1.6 handle radii), its origin on the camera's pixel
grid (``otgym.sim.microscope``; chip as the background, every sphere of the scene drawn
except those too far to change a grey level). The sensor knows what a real set-up
knows: where it put its traps, the handles' radius, the pixel size. The handle offset
fed to the feedback law is trap minus sensed handle. The robot-cell contact force of
the feedback's contact cue is the simulator's report (no camera measures it).

Safety first: a device whose latest sample is non-finite or
older than the retargeter's ``silence_timeout_s`` (100 ms) gives dP_h = 0 (the
``Retargeter`` drops NaN samples and holds nothing stale) and is sent zero force (its
feedback filter is cleared, so the force ramps up again through the low-pass when it
comes back); a device whose link is lost (``read`` raises ``DeviceError``) is treated
as silent from then on; the trap speed is clamped; ``close`` zeros every device's
force before stopping it.

Timing. ``tick`` returns a ``TickRecord`` with the wall time of each stage;
``run(duration_s, realtime=True)`` paces ticks to wall time on a fixed schedule
(sleeping to each deadline; a tick that ends more than a period late restarts the
schedule instead of bursting, as the servo loop of ``otgym.teleop.servo`` does, and
counts in ``late_ticks``) and stops when the task is DONE.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable

import jax
import numpy as np

from otgym import physics as ph
from otgym.autonomy.navigator import RouteNavigator
from otgym.autonomy.protocol import Autonomy
from otgym.runtime.tick import control_tick
from otgym.runtime.trials import TASK_RETARGET
from otgym.shared import MODES, ArbitrationConfig
from otgym.sim.microscope import MicroscopeParams, microscope_images
from otgym.sim.sensor import VisionForceSensor
from otgym.task.task import DONE, InteractiveTask, Observation
from otgym.tasks.transport.scenario import Scenario
from otgym.teleop.device import Device, DeviceError, start_devices
from otgym.teleop.feedback import FeedbackConfig, FeedbackLaw, newtons_per_pn_for
from otgym.teleop.retarget import RetargetConfig, Retargeter

CULL_HALO_WIDTHS = 12.0
"""Spheres whose surface is farther than this many halo widths from every crop are not
drawn: the halo there is 0.25 x 12 e^-11 = 5e-5 of the background, a fifth of one
12-bit grey level (2.4e-4)."""
KEY_BLOCK = 4096
"""PRNG keys drawn at once (one split call per 82 s of ticks instead of one per tick)."""


@dataclasses.dataclass(frozen=True)
class DeviceBinding:
    """One device and the robots (indices into ``task.scene.robots``) it drives; two
    robots make a formation. ``feedback`` None: the trap law's scale
    (``newtons_per_pn_for``) in the retargeting plane."""

    device: Device
    robots: tuple[int, ...] = (0,)
    retarget: RetargetConfig = TASK_RETARGET
    feedback: FeedbackConfig | None = None

    def __post_init__(self):
        robots = tuple(self.robots)
        if not robots or len(set(robots)) != len(robots) or not all(isinstance(r, int) for r in robots):
            raise ValueError(f"robots must be distinct robot indices, got {self.robots!r}")
        object.__setattr__(self, "robots", robots)
        if self.feedback is not None and self.feedback.plane != self.retarget.plane:
            raise ValueError(
                f"feedback plane {self.feedback.plane!r} differs from the retargeting plane {self.retarget.plane!r}"
            )


@dataclasses.dataclass(frozen=True)
class TickRecord:
    """What one tick did (one environment; T traps, D devices). Increments in um at the
    trap, chip frame; forces on handles in pN; device forces in N (device frame);
    stage times in wall seconds."""

    time_s: float
    """Simulated time after the tick."""
    phase: int
    alpha: float
    human_um: np.ndarray  # (T, 2) dP_h
    robot_um: np.ndarray  # (T, 2) dP_r
    shared_um: np.ndarray  # (T, 2) dP_s, what the traps moved by
    trap_xy_um: np.ndarray  # (T, 2) after the tick
    frame_trap_xy_um: np.ndarray  # (T, 2) at the tick's start: the microscope frame the sensor read
    sensed_handle_xy_um: np.ndarray  # (T, 2) in that frame
    sensed_force_pn: np.ndarray  # (T, 2), NaN where not valid
    sensed_valid: np.ndarray  # (T,)
    feedback_n: np.ndarray  # (D, 3) sent to each device
    device_live: np.ndarray  # (D,) fresh, finite input this tick
    physics_s: float
    render_s: float
    sense_s: float
    rest_s: float
    mode: str = "shared"
    """The mode the tick ran in: the loop's, or manual where shared control lost its autonomy."""
    autonomy_live: bool = True
    """The autonomy gave dP_r this tick."""

    @property
    def wall_s(self) -> float:
        return self.physics_s + self.render_s + self.sense_s + self.rest_s


class _Channel:
    """Per-device state: its retargeter, feedback law, traps and link."""

    def __init__(
        self,
        binding: DeviceBinding,
        trap_mask: np.ndarray,
        robot_columns: list[int],
        feedback: FeedbackConfig,
        trap_law: ph.TrapLaw,
        tick_rate_hz: float,
    ):
        self.device = binding.device
        self.retargeter = Retargeter(binding.retarget, tick_rate_hz)
        self.feedback = FeedbackLaw(feedback, trap_law, tick_rate_hz)
        self.trap_mask = trap_mask
        self.robot_columns = robot_columns
        self.lost = False


class InteractiveLoop:
    """The interactive task for one person (or two hands) in real time.

    task: a built ``InteractiveTask`` (its jitted step is shared by every loop over it);
    bindings: the devices; scenario: the obstacles' tracks (``task.scenario(seed)``);
    mode: "manual", "shared" or "autonomous"; clock: the devices' time base
    (``time.monotonic``, as ``Sample.time_s``; a test may drive devices by simulated
    time); autonomy: dP_r (1, T, 2) um from an observation, or None while it has none
    (default: the loop's own ``RouteNavigator``; ``otgym.bus.nodes.RemoteAutonomy`` for
    an autonomy node). Without dP_r, shared control falls back to manual (alpha 1) and
    autonomous control holds the traps; the tick's record says so. Use as a context manager, or call ``start`` and ``close``."""

    def __init__(
        self,
        task: InteractiveTask,
        bindings: list[DeviceBinding],
        scenario: Scenario,
        mode: str = "shared",
        *,
        seed: int = 0,
        arbitration: ArbitrationConfig = ArbitrationConfig(),
        cruise_speed_um_s: float = 5.0,
        max_trap_speed_um_s: float = TASK_RETARGET.max_trap_speed_um_s,
        microscope: MicroscopeParams = MicroscopeParams(),
        crop_px: int = 48,
        clock: Callable[[], float] = time.monotonic,
        autonomy: Autonomy | None = None,
    ):
        if mode not in MODES:
            raise ValueError(f"unknown mode {mode!r}; choose one of {', '.join(MODES)}")
        if not (
            isinstance(max_trap_speed_um_s, (int, float))
            and math.isfinite(max_trap_speed_um_s)
            and max_trap_speed_um_s > 0
        ):
            raise ValueError(f"max_trap_speed_um_s must be positive and finite, got {max_trap_speed_um_s!r}")
        if not isinstance(crop_px, int) or crop_px < 16:
            raise ValueError(f"crop_px must be an integer of at least 16, got {crop_px!r}")
        scene = task.scene
        n_robots = len(scene.robots)
        driven = [r for b in bindings for r in b.robots]
        if any(not 0 <= r < n_robots for r in driven):
            raise ValueError(f"robot indices must be within 0..{n_robots - 1}, got {sorted(driven)}")
        if len(set(driven)) != len(driven):
            raise ValueError(f"each robot takes at most one device; robots {sorted(driven)} are driven twice")
        self.task = task
        self.mode = mode
        self.arbitration = arbitration
        self.clock = clock
        self.tick_s = task.config.tick_s
        self.max_step_um = max_trap_speed_um_s * self.tick_s
        self.microscope = microscope
        self.crop_px = crop_px
        law = task.config.scene.trap_law
        model = scene.model
        handle_radii = np.asarray(model.sphere_radius_um)[task.trap_sphere]
        if not np.allclose(handle_radii, handle_radii[0]):
            raise ValueError(f"the vision sensor needs handles of one radius, got {handle_radii}")
        self.sensor = VisionForceSensor(law, handle_radius_um=float(handle_radii[0]))
        self._sphere_radius_um = np.asarray(model.sphere_radius_um, float)
        tick_rate_hz = 1.0 / self.tick_s
        self._channels = []
        for binding in bindings:
            bodies = [scene.robots[r] for r in binding.robots]
            feedback = binding.feedback or FeedbackConfig(
                newtons_per_pn=newtons_per_pn_for(law), plane=binding.retarget.plane
            )
            limit_n = min(feedback.force_limit_n, binding.device.caps.force_limit_n)
            self._channels.append(
                _Channel(
                    binding,
                    np.isin(task.trap_robot, bodies),
                    list(binding.robots),
                    dataclasses.replace(feedback, force_limit_n=limit_n),
                    law,
                    tick_rate_hz,
                )
            )
        self.navigator = RouteNavigator(
            task.route_um,
            task.route_arc_um,
            task.offsets_um,
            self.tick_s,
            cruise_speed_um_s,
            max_speed_um_s=max_trap_speed_um_s,
        )
        self.navigator.reset(1)
        self.autonomy = autonomy or self.navigator.increments
        self._rng = np.random.default_rng(seed)
        key, reset_key = jax.random.split(jax.random.PRNGKey(seed))
        self._key = key
        self._keys = np.zeros((0, 2), np.uint32)
        self.state = task.reset([scenario], reset_key)
        self.late_ticks = 0

    @property
    def observation(self) -> Observation:
        """The latest observation of the task (leading environment axis of length 1)."""
        return self.state.observation

    @property
    def time_s(self) -> float:
        return float(self.state.observation.time_s[0])

    @property
    def done(self) -> bool:
        return bool(self.state.phase[0] == DONE)

    @property
    def lost_devices(self) -> tuple[int, ...]:
        """The bindings (by index) whose device's link is lost."""
        return tuple(index for index, channel in enumerate(self._channels) if channel.lost)

    def start(self) -> None:
        """Start every device; if one fails, stop those already started and re-raise."""
        start_devices([channel.device for channel in self._channels])

    def close(self) -> None:
        """Zero every device's force, then stop it."""
        for channel in self._channels:
            channel.device.set_force(np.zeros(3))
            channel.device.stop()

    def __enter__(self):
        self.start()
        return self

    def __exit__(self, *exc_info):
        self.close()

    def _next_key(self) -> np.ndarray:
        if not len(self._keys):
            self._key, block = jax.random.split(self._key)
            self._keys = np.asarray(jax.random.split(block, KEY_BLOCK))
        key, self._keys = self._keys[0], self._keys[1:]
        return key

    def _human_increments(self, now_s: float) -> tuple[np.ndarray, np.ndarray]:
        """dP_h (T, 2) from every device, and which devices gave fresh input."""
        human = np.zeros((self.task.n_traps, 2))
        live = np.zeros(len(self._channels), bool)
        for index, channel in enumerate(self._channels):
            sample = None
            if not channel.lost:
                try:
                    sample = channel.device.read()
                except DeviceError:
                    channel.lost = True
            silent_before = channel.retargeter.silent_ticks
            human[channel.trap_mask] = channel.retargeter(sample, now_s)
            live[index] = channel.retargeter.silent_ticks == silent_before
        return human, live

    @property
    def sphere_radius_um(self) -> np.ndarray:
        """(S,) radius of every sphere of the scene (``task.scene.model``'s order)."""
        return self._sphere_radius_um

    def sphere_xy_um(self) -> np.ndarray:
        """(S, 2) centres in um of every sphere of the scene now (what a view draws)."""
        return self.state.sphere_xy_um[0]

    def _render(self, trap_xy_um: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """One crop per trap (T, crop_px, crop_px) and the crops' origins (T, 2) in um."""
        pixel = self.microscope.pixel_size_um
        origin = (np.floor(trap_xy_um / pixel) - self.crop_px // 2) * pixel
        spheres = self.sphere_xy_um()
        centre = origin + 0.5 * self.crop_px * pixel
        reach = np.sqrt(0.5) * self.crop_px * pixel + CULL_HALO_WIDTHS * self.microscope.halo_width_um
        gap = np.linalg.norm(spheres[None] - centre[:, None], axis=-1) - self._sphere_radius_um[None]
        near = np.any(gap < reach, axis=0)
        images = microscope_images(
            np.broadcast_to(spheres[near], (len(origin), int(near.sum()), 2)),
            self._sphere_radius_um[near],
            origin,
            (self.crop_px, self.crop_px),
            self.microscope,
            self._rng,
            self.task.chip,
        )
        return images, origin

    def tick(self) -> TickRecord:
        """One tick: devices and autonomy -> arbitration -> physics dispatched; while JAX
        computes it, the microscope frame of the tick's start -> sensor -> feedback to the
        devices; then the physics is completed."""
        begin = time.perf_counter()
        obs = self.state.observation
        human, live = self._human_increments(self.clock())
        robot = self.autonomy(obs)
        autonomy_live = robot is not None
        robot = np.zeros((self.task.n_traps, 2)) if robot is None else np.asarray(robot, float)[0]
        command = control_tick(
            obs,
            [self.mode],
            robot[None],
            lambda modes, alpha: human[None],
            self.arbitration,
            self.max_step_um,
            autonomy_live,
        )
        mode, alpha, shared = str(command.modes[0]), float(command.alpha[0]), command.shared_um[0]
        physics_begin = time.perf_counter()
        pending = self.task.dispatch(self.state, shared[None], self._next_key())
        render_begin = time.perf_counter()
        frame_traps = obs.trap_xy_um[0]
        images, origin = self._render(frame_traps)
        sense_begin = time.perf_counter()
        reading = self.sensor.measure(images, origin, self.microscope.pixel_size_um, frame_traps[:, None])
        sense_end = time.perf_counter()
        sensed_xy, sensed_force, valid = reading.handle_xy_um[:, 0], reading.force_pn[:, 0], reading.valid[:, 0]
        feedback = np.zeros((len(self._channels), 3))
        for index, channel in enumerate(self._channels):
            if live[index]:
                mask = channel.trap_mask
                contact_pn = float(obs.contact_force_pn[0, channel.robot_columns].max())
                feedback[index] = channel.feedback(
                    sensed_force[mask], frame_traps[mask] - sensed_xy[mask], contact_pn, valid[mask]
                )
            else:
                channel.feedback.reset()
            channel.device.set_force(feedback[index])
        complete_begin = time.perf_counter()
        obs = self.task.complete(self.state, pending, np.array([alpha]))
        end = time.perf_counter()
        return TickRecord(
            time_s=float(obs.time_s[0]),
            phase=int(obs.phase[0]),
            alpha=alpha,
            human_um=human,
            robot_um=robot,
            shared_um=shared,
            trap_xy_um=obs.trap_xy_um[0],
            frame_trap_xy_um=frame_traps,
            sensed_handle_xy_um=sensed_xy,
            sensed_force_pn=sensed_force,
            sensed_valid=valid,
            feedback_n=feedback,
            device_live=live,
            physics_s=(render_begin - physics_begin) + (end - complete_begin),
            render_s=sense_begin - render_begin,
            sense_s=sense_end - sense_begin,
            rest_s=(physics_begin - begin) + (complete_begin - sense_end),
            mode=mode,
            autonomy_live=autonomy_live,
        )

    def run(self, duration_s: float, realtime: bool = True) -> list[TickRecord]:
        """Tick for ``duration_s`` of simulated time (rounded to whole ticks), or until
        the task is DONE; with ``realtime`` each tick waits for its wall-clock deadline,
        without it ticks run back to back. Returns the ticks' records."""
        if not (isinstance(duration_s, (int, float)) and math.isfinite(duration_s) and duration_s >= 0):
            raise ValueError(f"duration_s must be finite and non-negative, got {duration_s!r}")
        records = []
        deadline_s = time.monotonic()
        for _ in range(int(round(duration_s / self.tick_s))):
            if self.done:
                break
            records.append(self.tick())
            if realtime:
                deadline_s += self.tick_s
                remaining_s = deadline_s - time.monotonic()
                if remaining_s > 0:
                    time.sleep(remaining_s)
                elif remaining_s < -self.tick_s:
                    self.late_ticks += 1
                    deadline_s = time.monotonic()
        return records
