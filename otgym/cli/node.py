"""``otgym node ROLE``: one part of the runtime as a process on the bus
(``otgym.bus``): ``sim`` (the simulator, listening on tcp/127.0.0.1:7447; its session
ticks in a worker process), ``device`` (a local device published as ``--name``),
``recorder`` (every message into ``--out``/session.mcap), ``autonomy`` (the route
navigator's dP_r for a simulator started with ``--autonomy remote``; without it,
shared control runs as manual), ``ui`` (the window: draws from the sim's topics, sends
the keyboard, gamepad or mouse as devices ui0, ui1 and the keys as commands; trials.csv
and questionnaires.csv into ``--out``). Loopback only unless ``--listen``/``--connect``
name other endpoints. Prints one ``ready`` line once on the bus; SIGTERM or Ctrl-C ends it
cleanly (devices at zero force, the recording closed)."""

from __future__ import annotations

import functools
import signal
import sys
import threading
from pathlib import Path

import typer

BUILT = ("sim", "device", "recorder", "autonomy", "ui")
NAVIGATORS = ("route", "mpc")


def register(app: typer.Typer) -> None:
    @app.command("node")
    def node(
        role: str = typer.Argument(..., help="sim, device, recorder, autonomy or ui."),
        name: str = typer.Option(
            "device0",
            "--name",
            help="device node: its name on the bus; sim node: the device "
            "names it drives (robot i by the i-th), comma-separated; "
            "ui node: the device nodes whose feedback and loss it "
            "shows (robot i by the i-th; '' for none).",
        ),
        device: str = typer.Option(
            None,
            "--device",
            help="device node: its driver (keyboard, gamepad, touch, simulated, replay; "
            "default simulated); ui node: what the window sends as ui0, ui1 "
            "(keyboard, gamepad, mouse; default keyboard).",
        ),
        device_name: str = typer.Option(
            None, "--device-name", help="device node with --device touch: the Touch's name in Touch Setup."
        ),
        replay: Path = typer.Option(
            None, "--replay", help="device node with --device replay: the CSV to play (looped)."
        ),
        takeover: str = typer.Option(
            None,
            "--takeover",
            help="sim node: devices (comma-separated, robot i by the "
            "i-th) that take robot i over while their clutch is "
            "held: a ui node's mouse (ui0,ui1).",
        ),
        mode: str = typer.Option("shared", "--mode", help="sim node: manual, shared or autonomous."),
        participant: str = typer.Option("P1", "--participant", help="sim node: the participant ID of its trials."),
        hold: bool = typer.Option(
            False,
            "--hold",
            help="sim node: after each trial wait for a next_trial command (a ui node's questionnaires).",
        ),
        chip: str = typer.Option("default", "--chip", help="sim, autonomy, ui nodes: chip name or PNG."),
        autonomy: str = typer.Option(
            "local",
            "--autonomy",
            help="sim node: dP_r from its own navigator (local) or from an autonomy node (remote).",
        ),
        seed: int = typer.Option(0, "--seed", help="sim node: trial t meets scenario seed * 10000 + t."),
        duration: float = typer.Option(
            None, "--duration", help="sim node: seconds of simulated time (default: until stopped)."
        ),
        listen: list[str] = typer.Option(None, "--listen", help="zenoh endpoint to listen on (repeatable)."),
        connect: list[str] = typer.Option(None, "--connect", help="zenoh endpoint to connect to (repeatable)."),
        zenoh_config: Path = typer.Option(None, "--zenoh-config", help="zenoh config file (TLS, user/password)."),
        out: Path = typer.Option(
            None,
            "--out",
            help="recorder node: folder for session.mcap; ui node: for trials.csv and questionnaires.csv.",
        ),
        no_questionnaire: bool = typer.Option(False, "--no-questionnaire", help="ui node: no questionnaires."),
        navigator: str = typer.Option(
            "route",
            "--navigator",
            help="autonomy node: route (the route navigator) or mpc (the model-predictive navigator).",
        ),
    ) -> None:
        """Run one node of the distributed runtime until stopped."""
        from otgym.bus import messages as msg
        from otgym.shared import MODES

        if role not in BUILT:
            raise ValueError(f"unknown or unbuilt node {role!r}; choose one of {', '.join(BUILT)}")
        names = [n.strip() for n in name.split(",") if n.strip()] if role in ("sim", "ui") else [name]
        takeovers = [n.strip() for n in takeover.split(",")] if takeover else []
        for each in names + takeovers:
            msg.check_name(each)
        if not participant.strip() or "," in participant:
            raise ValueError(f"--participant must be a non-empty ID without commas, got {participant!r}")
        if mode not in MODES:
            raise ValueError(f"unknown mode {mode!r}; choose one of {', '.join(MODES)}")
        if autonomy not in ("local", "remote"):
            raise ValueError(f"--autonomy must be local or remote, got {autonomy!r}")
        if navigator not in NAVIGATORS:
            raise ValueError(f"--navigator must be one of {', '.join(NAVIGATORS)}, got {navigator!r}")
        if role in ("recorder", "ui") and out is None:
            raise ValueError(f"the {role} node needs --out")
        device = device or {"device": "simulated", "ui": "keyboard"}.get(role)
        if zenoh_config is not None and not zenoh_config.is_file():
            raise FileNotFoundError(f"no zenoh config file {zenoh_config}")
        stop = threading.Event()
        for signum in (signal.SIGTERM, signal.SIGINT):
            signal.signal(signum, lambda *_: stop.set())
        endpoints = dict(
            listen=list(listen or []),
            connect=list(connect or []),
            config_file=str(zenoh_config) if zenoh_config else None,
        )
        {"sim": _sim, "device": _device, "recorder": _recorder, "autonomy": _autonomy, "ui": _ui}[role](
            stop,
            endpoints,
            name=name,
            names=names,
            device=device,
            replay=replay,
            mode=mode,
            seed=seed,
            duration=duration,
            out=out,
            remote_autonomy=autonomy == "remote",
            takeover=takeovers,
            participant=participant.strip(),
            hold=hold,
            chip=chip,
            device_name=device_name,
            questionnaire=not no_questionnaire,
            navigator=navigator,
        )


def _ready(text: str) -> None:
    print(f"ready: {text}", flush=True)


def _device(stop, endpoints, *, name, device, replay, device_name, **_):
    from otgym.bus.nodes import run_device_node
    from otgym.bus.transport import Node
    from otgym.teleop.device import DeviceError, open_device

    options = {"path": replay, "loop": True} if device == "replay" else {}
    if device == "touch" and device_name:
        options["device_name"] = device_name
    if device == "replay" and replay is None:
        raise ValueError("--device replay needs --replay FILE")
    try:
        driver = open_device(device, **options)
    except DeviceError as error:
        raise ValueError(str(error)) from None
    with Node("device", name, **endpoints) as node:
        _ready(f"device {name} ({driver.caps.name})")
        published = run_device_node(node, driver, name, stop)
    print(f"device {name}: {published} samples published", flush=True)


SESSION_END_RECORDED = "recorded: session_end"
"""The recorder node's line once the simulator's ``session_end`` event is in its file."""


def _recorder(stop, endpoints, *, out, **_):
    from otgym.bus import messages as msg
    from otgym.bus.nodes import record_all
    from otgym.bus.transport import Node
    from otgym.experiments.output_folder import check_out_dir
    from otgym.record.mcap_file import McapRecorder, session_path

    path = session_path(check_out_dir(out))
    with McapRecorder(path) as recorder, Node("recorder", "recorder", **endpoints) as node:

        def sink(topic: str, data: bytes) -> None:
            type_name = msg.topic_type(topic)
            recorder.write(topic, type_name, msg.SCHEMAS[type_name], data)
            if topic == msg.EVENTS and msg.event_fields(msg.decode(topic, data)).get("event") == "session_end":
                print(SESSION_END_RECORDED, flush=True)  # what otgym play --distributed waits for

        record_all(node, sink)
        _ready(f"recorder into {path}")
        while not stop.wait(0.25):
            recorder.flush()
    print(
        f"recorder: {sum(recorder.counts.values())} messages, {sum(node.dropped.values())} dropped, into {path}",
        flush=True,
    )


def _ui(stop, endpoints, *, names, device, chip, out, questionnaire, **_):
    from otgym.bus.sim_node import build_task
    from otgym.bus.transport import Node
    from otgym.experiments.output_folder import check_out_dir
    from otgym.task.layout import layout_of
    from otgym.teleop.device import DeviceError
    from otgym.ui.node import WINDOW_KINDS, run_window

    if device not in WINDOW_KINDS:
        raise ValueError(f"unknown window device {device!r} for the ui node; choose one of {', '.join(WINDOW_KINDS)}")
    check_out_dir(out)
    print("building the task ...", flush=True)
    layout = layout_of(build_task(chip))
    with Node("ui", "ui", **endpoints) as node:
        _ready(f"ui ({device})")
        try:
            app = run_window(
                node, layout, device, names if device == "mouse" else [], out, questionnaire=questionnaire, stop=stop
            )
        except DeviceError as error:
            raise ValueError(str(error)) from None
    print(f"ui: wrote {app.trials_written} trial(s) to {out / 'trials.csv'}", flush=True)


def _autonomy(stop, endpoints, *, chip, navigator, **_):
    from otgym.bus.nodes import run_autonomy_node
    from otgym.bus.sim_node import build_task
    from otgym.bus.transport import Node

    print("building the task ...", flush=True)
    task = build_task(chip)
    planner = None
    if navigator == "mpc":
        from otgym.autonomy.mpc_navigator import MPCNavigator

        print(
            "building the model-predictive navigator (its model, grip calibration and first compile take about "
            "a minute on 2 cores) ...",
            flush=True,
        )
        planner = MPCNavigator(task)
        planner.warm_up()
    with Node("autonomy", "autonomy", **endpoints) as node:
        _ready(f"autonomy ({'model-predictive' if planner else 'route'} navigator)")
        answered = run_autonomy_node(node, task, stop, navigator=planner)
        print(
            f"autonomy: {answered} ticks answered; dropped {sum(node.dropped.values())} malformed messages", flush=True
        )


def _sim(stop, endpoints, *, names, mode, seed, duration, remote_autonomy, takeover, participant, hold, chip, **_):
    from otgym.bus.sim_node import serve_sim_node
    from otgym.bus.transport import Node
    from otgym.cli.errors import report_worker_error
    from otgym.runtime.worker import WorkerError
    from otgym.sim.chip import load_chip
    from otgym.teleop.device import DeviceError

    load_chip(chip)  # a bad chip is an error line before anything starts
    print("starting the simulation in its own process ...", flush=True)
    with Node("sim", "sim", **endpoints) as node:
        ready = functools.partial(
            _ready,
            f"sim for devices {', '.join(names)}"
            + (f", taken over by {', '.join(takeover)}" if takeover else "")
            + (" with a remote autonomy" if remote_autonomy else ""),
        )
        try:
            stats = serve_sim_node(
                node,
                names,
                mode,
                seed,
                stop,
                duration,
                remote_autonomy,
                chip=chip,
                takeover=takeover,
                participant=participant,
                hold_between_trials=hold,
                on_ready=ready,
            )
        except DeviceError as error:
            raise ValueError(str(error)) from None
        except WorkerError as error:
            report_worker_error(error)
        print(
            f"sim: {stats.get('ticks', 0)} ticks, {stats.get('late_ticks', 0)} schedule restarts; dropped "
            f"{sum(node.dropped.values())} malformed messages",
            flush=True,
        )
    sys.stdout.flush()
