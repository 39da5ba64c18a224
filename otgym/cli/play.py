"""``otgym play``: drive the robots yourself in the interactive task's window
(``otgym.ui``). Every argument, the chip, the devices and the output folder are
checked before the window opens; a bad one is one ``error:`` line and exit 2."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np
import typer

from otgym.cli import checks, options


def register(app: typer.Typer) -> None:
    @app.command("play")
    def play(
        chip: str = options.chip("default"),
        mode: str = options.mode("shared"),
        device: str = options.registered("keyboard", "--device", "devices", "play", "What drives the robots."),
        participant: str = options.participant("P1"),
        seed: int = options.trial_seed(0),
        duration: float = options.duration(),
        no_questionnaire: bool = typer.Option(False, "--no-questionnaire", help="No questionnaires after trials."),
        screenshot: Path = typer.Option(
            None, "--screenshot", file_okay=True, dir_okay=False, help="Save the last frame as this PNG."
        ),
        headless: bool = typer.Option(False, "--headless", help="No window (SDL dummy drivers); for tests and CI."),
        distributed: bool = typer.Option(
            False,
            "--distributed",
            help="Run the sim, device, recorder (and autonomy) "
            "as local node processes on loopback, the "
            "window as the ui node.",
        ),
        navigator: str = options.navigator("route"),
        ros2: bool = typer.Option(
            False,
            "--ros2",
            help="With --distributed: also run otgym node ros2, the session on a ROS 2 graph (extra ros2).",
        ),
        task_name: str = options.registered(
            None,
            "--task",
            "tasks",
            None,
            "Play this task in a generic window (its frame, the device's velocity as its action) "
            "instead of the interactive task; writes episodes.csv and session.mcap.",
        ),
        preset: str = typer.Option(None, "--preset", metavar="NAME", help="With --task: the task's preset."),
        out: Path = options.out_dir(..., "Folder for trials.csv, session.mcap (and questionnaires.csv)."),
    ) -> None:
        """The interactive task in a window: global and microscope views, cues, keys 1/2/3
        for the mode, space to pause, R to reset, H for help, Esc to quit; trials.csv and
        the session's MCAP recording (session.mcap). The simulation runs in a process of
        its own (with --distributed: as nodes on the bus).

        With --task NAME any registered task (otgym list tasks) is played in a generic
        window instead: its frame each step, the device's velocity turned into its action;
        --device, --seed, --duration, --screenshot, --headless and --out apply; episodes.csv
        and the recording (session.mcap: the episodes with the task's metrics, the scene)
        are written to --out.

        Example: otgym play --device keyboard --mode shared --out results/play
        """
        from otgym.ui.device_names import check_device_name

        checks.check_mode(mode)
        check_device_name(device)
        if task_name is None and preset is not None:
            raise ValueError("--preset needs --task (the interactive task has no presets)")
        if task_name is not None:
            checks.check_duration(duration)
            checks.check_seed(seed)
            _play_task(task_name, preset, device, seed, duration, screenshot, headless, distributed, out)
            return
        checks.check_duration(duration)
        checks.check_seed(seed)
        if screenshot is not None and screenshot.suffix.lower() != ".png":
            raise ValueError(f"--screenshot must name a .png file, got {screenshot}")
        participant = checks.check_participant(participant)
        from otgym import registry

        checks.check_navigator(navigator)
        found = registry.entry("navigators", navigator)
        if "in-process" not in found.tags and not distributed:
            raise ValueError(
                f"--navigator {navigator} needs --distributed: it answers from the autonomy node's own process, "
                f"not the simulation's ({found.extras.get('start_note') or 'not tagged in-process'})"
            )
        if ros2 and not distributed:
            raise ValueError("--ros2 needs --distributed: the ROS 2 bridge is a node on the session's bus")
        if ros2:
            from otgym.bus.ros2_bridge import available, install_hint

            if not available():
                raise ValueError(f"--ros2 {install_hint()}")
        if headless:
            os.environ["SDL_VIDEODRIVER"] = "dummy"
            os.environ["SDL_AUDIODRIVER"] = "dummy"
        arguments = (chip, mode, device, participant, seed, duration, not no_questionnaire, screenshot, out)
        if distributed:
            run_distributed(*arguments, navigator=navigator, ros2=ros2)
        else:
            run_play(*arguments, navigator=navigator)


def _play_task(
    task_name: str,
    preset: str | None,
    device: str,
    seed: int,
    duration_s: float | None,
    screenshot: Path | None,
    headless: bool,
    distributed: bool,
    out: Path,
) -> None:
    """``otgym play --task``: its checks, then ``otgym.ui.task_window.play_task``."""
    from otgym import tasks
    from otgym.experiments.common.output_folder import check_out_dir
    from otgym.ui.task_window import check_playable

    if distributed:
        raise ValueError("--task runs in one process: it cannot be combined with --distributed")
    task = check_playable(tasks.load(task_name))
    try:
        task.config(preset)
    except ValueError as error:
        raise ValueError(f"--preset: {error}") from None
    if screenshot is not None and screenshot.suffix.lower() != ".png":
        raise ValueError(f"--screenshot must name a .png file, got {screenshot}")
    _check_screenshot_folder(screenshot, out)
    check_out_dir(out)
    if headless:
        os.environ["SDL_VIDEODRIVER"] = "dummy"
        os.environ["SDL_AUDIODRIVER"] = "dummy"
    from otgym.ui.task_window import play_task

    window = play_task(task_name, preset, device, seed, duration_s, screenshot, out)
    if window is None:
        print("closed before the task was ready; nothing written", flush=True)
        return
    episodes = len(window.rows)
    print(
        f"{window.steps} steps of {task_name}, {episodes} episode(s), {window.successes} reached success; "
        f"wrote {out / 'episodes.csv'}; recording {window.recording.path}"
        + (f"; screenshot {screenshot}" if screenshot is not None else "")
    )


def _check_screenshot_folder(screenshot: Path | None, out: Path) -> None:
    """The screenshot's folder must exist, or be ``out`` (created before the window opens)."""
    if screenshot is None or screenshot.parent.is_dir() or screenshot.parent.resolve() == out.resolve():
        return
    raise ValueError(f"--screenshot {screenshot}: folder {screenshot.parent} does not exist")


def run_play(
    chip: str,
    mode: str,
    device: str,
    participant: str,
    seed: int,
    duration_s: float | None,
    questionnaire: bool,
    screenshot: Path | None,
    out: Path,
    navigator: str = "route",
) -> None:
    """The window in this process, the session in its own (``otgym.runtime.worker``);
    ``navigator`` ``rl`` runs the learned-speed navigator there (``route``: the loop's own).
    The window opens first, before the simulator is imported, and shows what the
    session's process is doing until it runs (``otgym.ui.startup``)."""
    import functools

    import pygame

    from otgym.experiments.common.output_folder import check_out_dir
    from otgym.sim.chip import load_chip
    from otgym.ui.palette import WINDOW_SIZE, fonts
    from otgym.ui.startup import StartupAborted, StartupStatus, draw_startup, wait_in_window

    chip_data = load_chip(chip)
    _check_screenshot_folder(screenshot, out)
    created_out = not out.exists()
    check_out_dir(out)

    def remove_empty_out() -> None:
        if created_out and out.is_dir() and not any(out.iterdir()):
            out.rmdir()

    title = f"otgym play: chip {chip_data.name!r}, {mode}, participant {participant}"
    pygame.display.init()  # no audio: nothing plays sound
    pygame.font.init()
    screen = pygame.display.set_mode(WINDOW_SIZE)
    pygame.display.set_caption("otgym play")
    status = StartupStatus("loading the simulator")
    draw_startup(screen, fonts(), title, status.text, 0.0)
    windowed = []
    try:
        from otgym.cli.errors import report_worker_error
        from otgym.record.mcap_file import session_path
        from otgym.runtime.worker import SessionProcess, WorkerError, WorkerSpec
        from otgym.teleop.device import DeviceError, start_devices
        from otgym.ui.app import PlayApp
        from otgym.ui.bindings import robot_primaries, window_devices
        from otgym.ui.play_worker import play_setup

        try:
            windowed = window_devices(device)
            robot_primaries(device, windowed)  # the Touch fails here at once without its runtime
            start_devices(windowed)  # e.g. no gamepad plugged in: nothing written
        except DeviceError as error:
            remove_empty_out()
            raise ValueError(str(error)) from None
        recording_path = session_path(out)
        spec = WorkerSpec(
            functools.partial(play_setup, chip, device, recording_path, navigator=navigator),
            participant,
            mode,
            seed,
            duration_s,
            forwarded_caps=tuple(d.caps for d in windowed),
        )
        session = SessionProcess(spec, on_status=status.set)
        status.set("starting the simulation process")
        print(f"starting the simulation on chip {chip_data.name!r} in its own process ...", flush=True)
        try:
            wait_in_window(screen, session.start, title, status)
        except DeviceError as error:  # a Touch that would not open: the worker left no recording behind
            remove_empty_out()
            raise ValueError(str(error)) from None
        except StartupAborted:
            session.finish()
            print("closed before the simulation was ready; nothing recorded", flush=True)
            return
        try:
            app = PlayApp(session, out, window_devices=windowed, questionnaire=questionnaire, screen=screen)
            app.run()
            if screenshot is not None:
                app.save_screenshot(screenshot)
        except WorkerError as error:
            report_worker_error(error)
        finally:
            session.finish()
        frames = np.asarray(app.frame_times_s[1:]) if len(app.frame_times_s) > 1 else None
        stats = session.stats or {}
        if frames is not None:
            print(
                f"{len(frames)} frames, median {1 / np.median(frames):.0f} fps "
                f"({app.frames_with_new_state} with a new simulation state); "
                f"{stats.get('ticks', 0)} ticks, {stats.get('late_ticks', 0)} schedule restarts"
            )
        print(
            f"wrote {app.trials_written} trial(s) to {out / 'trials.csv'}; recording {recording_path}"
            + (f"; screenshot {screenshot}" if screenshot is not None else "")
        )
    finally:
        for each in windowed:
            each.stop()
        pygame.quit()


def node_plan(device: str, endpoint: str) -> tuple[list[tuple[str, list[str]]], list[str], str, list[str]]:
    """For ``--device``: the device nodes (label, arguments), the sim's device
    arguments, what the window sends and the device nodes whose feedback it shows. A
    window device (the keyboard, the gamepad) is the window's own (sent as ui0, ui1);
    any other is a device node per robot its play binding opens (the simulated stylus:
    robot 0; the Touches: one each, by name), which the window's takeover device (the
    mouse) takes over while it drags."""
    from otgym import registry
    from otgym.cli.checks import device_node_arguments
    from otgym.ui.bindings import play_binding, takeover_device

    if "window" in registry.entry("devices", device).tags:
        return [], ["--name", "ui0,ui1"], device, []
    nodes = [
        (
            f"device{robot}",
            ["device", "--device", device, *device_node_arguments(device, options), "--name", f"device{robot}"]
            + ["--connect", endpoint],
        )
        for robot, options in enumerate(play_binding(device).session)
        if options is not None
    ]
    names = [label for label, _ in nodes]
    return nodes, ["--name", ",".join(names), "--takeover", "ui0,ui1"], takeover_device(), names


RECORDER_DRAIN_S = 10.0
"""How long ``otgym play --distributed`` waits, after the sim's end, for the recorder to
have the session's last message."""


def _window_over_nodes(
    nodes,
    endpoint: str,
    layout,
    window_kind: str,
    shown: list[str],
    out: Path,
    questionnaire: bool,
    screenshot: Path | None,
    failed: list[str],
):
    """The window as the ui node until it closes, a node fails (its line appended to
    ``failed``) or the sim ends; then the sim's own end is awaited."""
    import threading

    from otgym.bus.transport import Node
    from otgym.cli.node import SESSION_END_RECORDED
    from otgym.teleop.device import DeviceError
    from otgym.ui.node import run_window

    stop, done = threading.Event(), threading.Event()

    def watch() -> None:  # a failed node, or the sim gone without a word, closes the window
        while not done.wait(0.1):
            failure = nodes.failure()
            if failure:
                failed.append(failure)
                stop.set()
                return
            if nodes.ended("sim") and not done.wait(1.0):
                stop.set()
                return

    threading.Thread(target=watch, name="otgym-nodes-watch", daemon=True).start()
    with Node("ui", "ui", connect=[endpoint]) as node:
        try:
            app = run_window(
                node,
                layout,
                window_kind,
                shown,
                out,
                questionnaire=questionnaire,
                screenshot=screenshot,
                stop=stop,
                start_first_trial=True,
            )
        except DeviceError as error:  # e.g. no gamepad: the nodes stop all the same
            raise ValueError(str(error)) from None
        finally:
            done.set()
    if not nodes.wait_exit("sim", 30.0) and not failed:
        failed.append("the sim node did not end within 30 s of the session's end")
    # the recorder says when the sim's last message, session_end, is in its file (a fixed
    # half second lost the trial_end once on a loaded machine); a sim that died sends none
    nodes.wait_output("recorder", SESSION_END_RECORDED, RECORDER_DRAIN_S)
    return app


def run_distributed(
    chip: str,
    mode: str,
    device: str,
    participant: str,
    seed: int,
    duration_s: float | None,
    questionnaire: bool,
    screenshot: Path | None,
    out: Path,
    navigator: str = "route",
    ros2: bool = False,
) -> None:
    """The sim, device, recorder (and, in shared or autonomous mode, autonomy; with
    ``ros2``, the ROS 2 bridge, driving no device: the window's stay the window's) nodes
    as local processes on a loopback port; this process is the ui node (the window).
    All stop when the window closes or when one of them fails (one ``error:`` line,
    exit code 1)."""
    from otgym import registry
    from otgym.bus.sim_node import build_task
    from otgym.cli.launch import NodeProcesses, free_loopback_endpoint
    from otgym.experiments.common.output_folder import check_out_dir
    from otgym.sim.chip import load_chip
    from otgym.task.layout import layout_of
    from otgym.teleop.device import DeviceError
    from otgym.ui.bindings import robot_primaries, window_devices

    load_chip(chip)
    try:
        robot_primaries(device, window_devices(device))  # the Touch fails here at once without its runtime
    except DeviceError as error:
        raise ValueError(str(error)) from None
    _check_screenshot_folder(screenshot, out)
    check_out_dir(out)
    endpoint = free_loopback_endpoint()
    device_nodes, sim_devices, window_kind, shown = node_plan(device, endpoint)
    remote_autonomy = mode in ("shared", "autonomous")
    sim = [
        "sim",
        "--listen",
        endpoint,
        "--mode",
        mode,
        "--seed",
        str(seed),
        "--participant",
        participant,
        "--chip",
        chip,
        *sim_devices,
    ]
    sim += (["--duration", repr(duration_s)] if duration_s is not None else []) + (["--hold"] if questionnaire else [])
    sim += ["--wait-for-start"]  # trial 1 once every node is ready and the window open (_window_over_nodes)
    sim += ["--autonomy", "remote"] if remote_autonomy else []
    nodes = NodeProcesses(out / "nodes")  # each node's own output, kept beside the session's files
    failed: list[str] = []
    app = None
    autonomy = ["autonomy", "--chip", chip, "--navigator", navigator, "--connect", endpoint]
    try:
        note = registry.entry("navigators", navigator).extras.get("start_note")
        if remote_autonomy and note:  # ready before the sim starts its first trial
            print(f"starting the {navigator} autonomy node first ({note}) ...", flush=True)
            nodes.start("autonomy", autonomy)
            try:
                nodes.wait_ready(900.0)
            except RuntimeError as error:
                failed.append(str(error))
        if not failed:
            nodes.start("sim", sim)
            for label, arguments in device_nodes:
                nodes.start(label, arguments)
            nodes.start("recorder", ["recorder", "--out", str(out), "--connect", endpoint])
            if ros2:
                nodes.start("ros2", ["ros2", "--connect", endpoint, "--ros-args", "-p", "devices:=[]"])
            if remote_autonomy and "autonomy" not in nodes.children:
                nodes.start("autonomy", autonomy)
            print(f"starting {len(nodes.children)} nodes on {endpoint} ({', '.join(nodes.children)}) ...", flush=True)
            layout = layout_of(build_task(chip))
            try:
                nodes.wait_ready(900.0)
            except RuntimeError as error:
                failed.append(str(error))
        if not failed:
            print("nodes ready; the window opens", flush=True)
            app = _window_over_nodes(
                nodes, endpoint, layout, window_kind, shown, out, questionnaire, screenshot, failed
            )
    finally:
        nodes.stop_all(order=["ros2", "sim", "autonomy", *[label for label, _ in device_nodes], "recorder"])
    if failed:
        print(f"error: {failed[0]}", file=sys.stderr)
        raise SystemExit(1)
    print(
        f"wrote {app.trials_written} trial(s) to {out / 'trials.csv'}; recording {out}/session*.mcap"
        + (f"; screenshot {screenshot}" if screenshot is not None else "")
    )
