"""The window as a node on the bus (``otgym node ui``, and the window of ``otgym play
--distributed``): it draws from the sim node's topics, sends the person's keyboard,
gamepad and mouse as devices, and the mode, pause and reset keys, the next trial after
the questionnaires and quitting as commands (``/otgym/command``).

``BusSession`` is the window's driver (``otgym.ui.app``'s interface) over a ``Node``:

- what it draws: a ``Snapshot`` rebuilt at each ``/otgym/bodies`` (the last of a tick's
  messages) from the latest traps, phase and alpha, the bodies, each device's feedback
  (``/otgym/feedback/<name>`` for the device nodes named), and the events
  (``trial_start`` resets the trial's clock, which counts ticks, also read from the
  latched ``/otgym/trial/current`` when the window joins mid-trial; ``mode``, ``paused``,
  ``autonomy_lost``, ``trial_end`` with the trial's row, ``session_end``). What the
  bus does not carry is derived or left out: obstacle gaps, encounters and collisions
  from the spheres (``TaskLayout``'s radii), the handle lag from the handles' true
  positions (no camera image travels), the cell's light dose from the traps and the
  cell at each tick seen (``TaskLayout.trap_beam``; from the trial's start, or from
  when the window joined), no contact force (the gauge says so);
- what it sends: robot i's input as the device ``ui<i>`` (``UI_DEVICES``; a liveliness
  token each, so the sim treats them as device nodes): the keyboard (both robots, as
  a formation, its clutch bit always held: its keys are their own deadman) or the
  gamepad's sticks, each under a ``MouseDragDevice`` so a drag takes the robot over;
  with neither (``mouse``: the robots belong to device nodes) only drags, which the sim
  node applies with ``--takeover ui0,ui1``; every frame (``poll``), each new sample;
- the loss cue: a device node whose liveliness token went away, the autonomy lost (the
  sim's ``autonomy_lost``), the simulator gone.
"""

from __future__ import annotations

import collections
import dataclasses
import threading
import time

import numpy as np

from otgym import registry
from otgym.bus import messages as msg
from otgym.bus.nodes import REMOTE_FORCE_LIMIT_N
from otgym.bus.transport import Node
from otgym.physics import light_dose as ld
from otgym.runtime.loop import TickRecord
from otgym.runtime.snapshot import Snapshot, smoothed_velocity
from otgym.runtime.trials import TASK_RETARGET
from otgym.shared.arbitration import MODES
from otgym.task.layout import TaskLayout, observation_from_spheres
from otgym.teleop.device import DeviceCaps, DeviceError, Sample
from otgym.teleop.forwarded import ForwardedDevice
from otgym.teleop.mouse_drag import MouseDragDevice
from otgym.ui.bindings import play_binding

UI_DEVICES = ("ui0", "ui1")
"""The names under which the window publishes robot 0's and robot 1's input."""


class BusSession:
    """The window's driver over ``node`` (see the module's docstring). ``window_caps``:
    the caps of the window's devices (``PlayApp``'s ``window_devices``, fed by
    ``feed``); ``kind``: keyboard, gamepad or mouse; ``device_names``: the device
    nodes driving robot 0, 1... (their feedback and liveliness)."""

    def __init__(
        self, node: Node, layout: TaskLayout, window_caps: list[DeviceCaps], kind: str, device_names: list[str] = ()
    ):
        registry.check("devices", kind, "window")
        self.node, self.layout, self.kind = node, layout, kind
        self.clutch = play_binding(kind).clutch
        self.device_names = [msg.check_name(name) for name in device_names]
        self.forwarded = [ForwardedDevice(caps) for caps in window_caps]
        # one window device drives both robots (the keyboard), two one each (the gamepad's
        # sticks), none leaves the robots to the mouse's drags
        primaries = [
            self.forwarded[min(robot, len(self.forwarded) - 1)] if self.forwarded else None for robot in (0, 1)
        ]
        self.drags = [
            MouseDragDevice(robot, primary, TASK_RETARGET.motion_scale_um_per_mm)
            for robot, primary in enumerate(primaries)
        ]
        self.force_limits_n = [
            REMOTE_FORCE_LIMIT_N if robot < len(self.device_names) else 0.0 for robot in range(len(layout.robots))
        ]
        self.participant = "?"
        self.snapshot: Snapshot | None = None
        self.over = False
        self.simulator_live = False
        self._lock = threading.Lock()
        self._finished: collections.deque = collections.deque()
        self._published: list[int | None] = [None] * len(self.drags)
        self._lost_inputs: set[int] = set()
        self._alive_devices: set[str] = set()
        self._lost_devices: set[str] = set()
        self._trial = 0
        self._mode = "shared"
        self._paused = False
        self._autonomy_live = True
        self._new_trial()
        self._traps = self._phase = self._alpha = self._tick_mode = None
        self._feedback_n = np.zeros((len(layout.robots), 3))
        self._tokens = [node.session.liveliness().declare_token(f"otgym/node/device/{name}") for name in UI_DEVICES]
        node.subscribe(msg.TRAPS, self._keep("_traps", msg.xy_um))
        node.subscribe(msg.PHASE, self._keep("_phase", lambda m: msg.PHASES.index(m.data)))
        node.subscribe(msg.ALPHA, self._keep("_alpha", lambda m: float(m.data)))
        node.subscribe(msg.MODE, self._keep("_tick_mode", lambda m: m.data))
        node.subscribe(msg.BODIES, self._on_bodies)
        node.subscribe(msg.EVENTS, self._on_event)
        node.subscribe(msg.TRIAL, self._on_event)  # latched: the trial under way when this node joined
        for robot, name in enumerate(self.device_names):
            node.subscribe(msg.feedback_topic(name), self._feedback_of(robot))
        node.watch("device", self._on_device)
        node.watch("sim", self._on_sim)

    # --- what arrives -----------------------------------------------------------------
    def _keep(self, attribute: str, convert):
        def on_message(topic, message, data) -> None:
            with self._lock:
                setattr(self, attribute, convert(message))

        return on_message

    def _feedback_of(self, robot: int):
        def on_message(topic, message, data) -> None:
            with self._lock:
                self._feedback_n[robot] = msg.force_n(message)

        return on_message

    def _new_trial(self) -> None:
        k = len(self.layout.obstacles)
        self._ticks, self._route_index, self._dose_mj_per_um2 = 0, 0, 0.0
        self._encountered, self._collided = np.zeros(k, bool), np.zeros(k, bool)
        self._obstacle_xy, self._obstacle_velocity = None, np.zeros((k, 2))

    def _on_event(self, topic, message, data) -> None:
        fields = msg.event_fields(message)
        name = fields["event"]
        with self._lock:
            if name == "trial_start":
                if int(fields.get("trial", self._trial + 1)) == self._trial:
                    return  # the same trial_start from /otgym/trial/current and the events
                self._trial, self._mode = int(fields.get("trial", self._trial + 1)), fields.get("mode", self._mode)
                self.participant = str(fields.get("participant", self.participant))
                self._paused = False
                self._new_trial()
            elif name == "mode" and fields.get("mode") in MODES:
                self._mode = fields["mode"]
            elif name in ("paused", "resumed"):
                self._paused = name == "paused"
            elif name in ("autonomy_lost", "autonomy_back"):
                self._autonomy_live = name == "autonomy_back"
            elif name == "trial_end":
                self._finished.append(fields)
            elif name == "session_end":
                self.over = True
            if self.snapshot is not None:
                self.snapshot = dataclasses.replace(
                    self.snapshot, mode=self._mode, paused=self._paused, autonomy_live=self._autonomy_live
                )

    def _on_device(self, name: str, alive: bool) -> None:
        with self._lock:
            if alive:
                self._alive_devices.add(name)
                self._lost_devices.discard(name)
            elif name in self._alive_devices:
                self._alive_devices.discard(name)
                self._lost_devices.add(name)

    def _on_sim(self, name: str, alive: bool) -> None:
        with self._lock:
            self.simulator_live = alive

    def _on_bodies(self, topic, message, data) -> None:
        spheres = msg.xy_um(message)
        layout = self.layout
        with self._lock:
            if self._traps is None or len(spheres) != len(layout.sphere_body) or len(self._traps) != layout.n_traps:
                return  # not this task's simulator, or its first messages still on their way
            self._ticks += 1
            time_s, phase, alpha = self._ticks * layout.tick_s, self._phase or 0, self._alpha or 0.0
            observation, self._route_index = observation_from_spheres(
                layout, spheres, self._traps, phase, time_s, self._route_index
            )
            obstacles, gaps = observation.obstacle_xy_um[0], observation.obstacle_gap_um[0]
            self._encountered |= gaps < layout.encounter_gap_um
            self._collided |= gaps <= 0.0
            if self._obstacle_xy is not None:
                self._obstacle_velocity = smoothed_velocity(
                    self._obstacle_velocity, self._obstacle_xy, obstacles, layout.tick_s
                )
            self._obstacle_xy = obstacles
            traps, handles = self._traps, observation.handle_xy_um[0]
            intensity = ld.cell_intensity_jit(layout.trap_beam, traps, observation.cell_xy_um[0], layout.cell_radius_um)
            self._dose_mj_per_um2 += layout.tick_s * float(intensity)  # as TrialMetrics adds it, tick by tick
            n_robots, n_traps = len(layout.robots), layout.n_traps
            zeros = np.zeros((n_traps, 2))
            record = TickRecord(
                time_s=time_s,
                phase=phase,
                alpha=alpha,
                human_um=zeros,
                robot_um=zeros,
                shared_um=zeros,
                trap_xy_um=traps,
                frame_trap_xy_um=traps,
                sensed_handle_xy_um=handles,
                sensed_force_pn=np.full((n_traps, 2), np.nan),
                sensed_valid=np.ones(n_traps, bool),
                feedback_n=self._feedback_n.copy(),
                device_live=np.ones(n_robots, bool),
                physics_s=0.0,
                render_s=0.0,
                sense_s=0.0,
                rest_s=0.0,
                mode=self._tick_mode or self._mode,
                autonomy_live=self._autonomy_live,
            )
            self.snapshot = Snapshot(
                self._trial,
                self._mode,
                self._paused,
                observation,
                record,
                spheres,
                self._obstacle_velocity.copy(),
                self._encountered.copy(),
                self._collided.copy(),
                alpha,
                tuple(sorted(self._lost_devices)),
                self._autonomy_live,
                self._dose_mj_per_um2,
            )

    @property
    def lost_devices(self) -> tuple[str, ...]:
        with self._lock:
            return tuple(sorted(self._lost_devices)) + tuple(UI_DEVICES[i] for i in sorted(self._lost_inputs))

    def take_finished(self) -> dict | None:
        with self._lock:
            return self._finished.popleft() if self._finished else None

    # --- what goes out ----------------------------------------------------------------
    def feed(self, index: int, sample: Sample) -> None:
        self.forwarded[index].feed(sample)

    def lose(self, index: int, reason: str) -> None:
        self.forwarded[index].lose(reason)

    def drag(self, robot: int, pointer_um, traps_um) -> None:
        self.drags[robot].drag_to(pointer_um, traps_um)

    def release_drag(self) -> None:
        for robot, device in enumerate(self.drags):
            was = device.dragging
            device.release()
            if was and device.primary is None:  # hand the robot back to its device node at once
                self._publish(
                    robot, Sample(time.monotonic(), (self._published[robot] or 0) + 1, np.zeros(3), np.zeros(3), 0)
                )

    def poll(self) -> None:
        """Publish each robot's new input sample (called every frame)."""
        for robot, device in enumerate(self.drags):
            if robot in self._lost_inputs:
                continue
            try:
                sample = device.read()
            except DeviceError:
                self._lost_inputs.add(robot)
                continue
            if sample is not None and sample.sequence != self._published[robot]:
                self._publish(robot, sample)

    def _publish(self, robot: int, sample: Sample) -> None:
        self._published[robot] = sample.sequence
        name, stamp_s = UI_DEVICES[robot], time.time()
        buttons = sample.buttons if self.clutch else sample.buttons | 1  # a device without a clutch holds it
        self.node.publish(msg.buttons_topic(name), msg.joy(buttons, stamp_s, name))
        self.node.publish(msg.twist_topic(name), msg.twist(sample, stamp_s, name))

    def _command(self, name: str, mode: str | None = None) -> None:
        self.node.publish(msg.COMMAND, msg.command(name, mode))

    def set_mode(self, mode: str) -> None:
        self._command("mode", mode)

    def toggle_pause(self) -> None:
        self._command("resume" if self._paused else "pause")

    def set_paused(self, paused: bool) -> None:
        self._command("pause" if paused else "resume")

    def reset(self) -> None:
        self._command("reset")

    def next_trial(self) -> None:
        self._command("next_trial")

    def finish(self, timeout_s: float = 10.0) -> None:
        """Ask the sim to end the session; wait for its ``session_end`` (its last
        trial's ``trial_end`` comes first) while it is alive, at most ``timeout_s``."""
        if not self.over and self.simulator_live:
            self._command("quit")
            deadline = time.monotonic() + timeout_s
            while not self.over and self.simulator_live and time.monotonic() < deadline:
                time.sleep(0.01)
        self.over = True
        for robot in range(len(self.drags)):
            self._publish(
                robot, Sample(time.monotonic(), (self._published[robot] or 0) + 1, np.zeros(3), np.zeros(3), 0)
            )

    def wait_for_simulator(self, timeout_s: float) -> bool:
        """Whether a simulator's token appeared within ``timeout_s``."""
        deadline = time.monotonic() + timeout_s
        while not self.simulator_live and time.monotonic() < deadline:
            time.sleep(0.05)
        return self.simulator_live


def run_window(
    node: Node,
    layout: TaskLayout,
    kind: str,
    device_names: list[str],
    out_dir,
    *,
    questionnaire: bool = True,
    screenshot=None,
    stop: threading.Event | None = None,
    start_timeout_s: float = 600.0,
    start_first_trial: bool = False,
):
    """The window on the bus until Esc, the window closing, the sim's session ending or
    ``stop`` set: trials.csv (and questionnaires.csv) in ``out_dir`` from the sim's
    ``trial_end`` rows, ``screenshot`` saved at the end. The window devices of
    ``kind`` are opened here (a missing gamepad: ``DeviceError`` before the window).
    With ``start_first_trial`` (a sim started with ``--wait-for-start``) the window, once
    open and subscribed, sends the ``next_trial`` that starts trial 1, after the sim's
    command subscriber is matched (``Node.wait_for_subscribers``, at most
    ``start_timeout_s``). Returns the ``PlayApp`` (frame times, trials written)."""
    import pygame

    from otgym.teleop.device import start_devices
    from otgym.ui.app import PlayApp
    from otgym.ui.bindings import window_devices

    windowed = window_devices(kind)  # none for the mouse alone
    pygame.display.init()
    pygame.font.init()
    try:
        start_devices(windowed)
        session = BusSession(node, layout, [d.caps for d in windowed], kind, device_names)
        app = PlayApp(session, out_dir, window_devices=windowed, questionnaire=questionnaire)
        done = threading.Event()

        def watch() -> None:  # a stop from outside (a signal, a failed node) closes the window
            while not done.is_set():
                if (stop is not None and stop.is_set()) or (
                    not session.simulator_live and time.monotonic() - started > start_timeout_s
                ):
                    app.running = False
                    return
                done.wait(0.05)

        started = time.monotonic()
        watcher = threading.Thread(target=watch, name="otgym-ui-watch", daemon=True)
        watcher.start()
        try:
            if start_first_trial:
                node.wait_for_subscribers(msg.COMMAND, start_timeout_s)
                session.next_trial()
            app.run()
            if screenshot is not None:
                app.save_screenshot(screenshot)
        finally:
            done.set()
        return app
    finally:
        for device in windowed:
            device.stop()
        pygame.quit()
