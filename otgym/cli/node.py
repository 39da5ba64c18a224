"""``otgym node ROLE``: one part of the runtime as a process on the bus (``otgym.bus``),
one sub-command per role, each with only its own options:

- ``sim``: the simulator, its session ticking in a worker process;
- ``device``: a local device published under ``--name``;
- ``recorder``: every message into ``--out``/session.mcap;
- ``autonomy``: the navigator's dP_r for a sim started with ``--autonomy remote``
  (without it, shared control runs as manual);
- ``ui``: the window: draws from the sim's topics, sends the keyboard, gamepad or mouse
  as devices ui0, ui1 and the keys as commands; trials.csv and questionnaires.csv into
  ``--out``.

Every role takes the bus options (``--listen``, ``--connect``, ``--zenoh-config``;
loopback only unless they name other endpoints), prints one ``ready`` line once on the
bus, and ends cleanly on SIGTERM or Ctrl-C (devices at zero force, the recording
closed)."""

from __future__ import annotations

import functools
import signal
import sys
import threading
from pathlib import Path
from typing import Annotated

import typer

from otgym.cli import checks

SESSION_END_RECORDED = "recorded: session_end"
"""The recorder node's line once the simulator's ``session_end`` event is in its file."""

node_app = typer.Typer(
    name="node",
    help="Run one node of the distributed runtime (sim, device, recorder, autonomy, ui) until stopped.",
    no_args_is_help=True,
    add_completion=False,
)

Listen = Annotated[list[str] | None, typer.Option("--listen", help="zenoh endpoint to listen on (repeatable).")]
Connect = Annotated[list[str] | None, typer.Option("--connect", help="zenoh endpoint to connect to (repeatable).")]
ZenohConfig = Annotated[Path | None, typer.Option("--zenoh-config", help="zenoh config file (TLS, user/password).")]
Chip = Annotated[str, typer.Option("--chip", help="Chip name or PNG.")]


def register(app: typer.Typer) -> None:
    app.add_typer(node_app, name="node")


def _bus(listen, connect, zenoh_config) -> tuple[threading.Event, dict]:
    """The stop event (set by SIGTERM or Ctrl-C) and the node's endpoints, after the
    zenoh config file is checked."""
    checks.check_zenoh_config(zenoh_config)
    stop = threading.Event()
    for signum in (signal.SIGTERM, signal.SIGINT):
        signal.signal(signum, lambda *_: stop.set())
    endpoints = dict(
        listen=list(listen or []), connect=list(connect or []), config_file=str(zenoh_config) if zenoh_config else None
    )
    return stop, endpoints


def _ready(text: str) -> None:
    print(f"ready: {text}", flush=True)


@node_app.command("sim")
def sim(
    name: str = typer.Option(
        "device0", "--name", help="The device nodes it drives (robot i by the i-th), comma-separated."
    ),
    takeover: str = typer.Option(
        None,
        "--takeover",
        help="Devices (comma-separated, robot i by the i-th) that take robot i over while their clutch is held: "
        "a ui node's mouse (ui0,ui1).",
    ),
    mode: str = typer.Option("shared", "--mode", help="manual, shared or autonomous."),
    participant: str = typer.Option("P1", "--participant", help="The participant ID of its trials."),
    hold: bool = typer.Option(
        False, "--hold", help="After each trial wait for a next_trial command (a ui node's questionnaires)."
    ),
    chip: Chip = "default",
    autonomy: str = typer.Option(
        "local", "--autonomy", help="dP_r from its own navigator (local) or from an autonomy node (remote)."
    ),
    seed: int = typer.Option(0, "--seed", help="Trial t meets scenario seed * 10000 + t."),
    duration: float = typer.Option(None, "--duration", help="Seconds of simulated time (default: until stopped)."),
    listen: Listen = None,
    connect: Connect = None,
    zenoh_config: ZenohConfig = None,
) -> None:
    """The simulator (its session ticks in a worker process): devices, commands, dP_r in; bodies, events out."""
    from otgym.bus.sim_node import serve_sim_node
    from otgym.bus.transport import Node
    from otgym.cli.errors import report_worker_error
    from otgym.runtime.worker import WorkerError
    from otgym.sim.chip import load_chip
    from otgym.teleop.device import DeviceError

    names = checks.bus_names(name)
    takeovers = checks.bus_names(takeover, drop_empty=False)
    participant = checks.check_participant(participant)
    checks.check_mode(mode)
    remote_autonomy = checks.check_autonomy_source(autonomy) == "remote"
    checks.check_seed(seed)
    checks.check_duration(duration)
    stop, endpoints = _bus(listen, connect, zenoh_config)
    load_chip(chip)  # a bad chip is an error line before anything starts
    print("starting the simulation in its own process ...", flush=True)
    with Node("sim", "sim", **endpoints) as node:
        ready = functools.partial(
            _ready,
            f"sim for devices {', '.join(names)}"
            + (f", taken over by {', '.join(takeovers)}" if takeovers else "")
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
                takeover=takeovers,
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


@node_app.command("device")
def device(
    name: str = typer.Option("device0", "--name", help="Its name on the bus."),
    device: str = typer.Option(
        "simulated", "--device", help="Its driver: keyboard, gamepad, touch, simulated or replay."
    ),
    device_name: str = typer.Option(
        None, "--device-name", help="With --device touch: the Touch's name in Touch Setup."
    ),
    replay: Path = typer.Option(None, "--replay", help="With --device replay: the CSV to play (looped)."),
    listen: Listen = None,
    connect: Connect = None,
    zenoh_config: ZenohConfig = None,
) -> None:
    """A local device on the bus: its samples out, the simulator's feedback in."""
    from otgym.bus import messages as msg
    from otgym.bus.nodes import run_device_node
    from otgym.bus.transport import Node
    from otgym.teleop.device import DeviceError, open_device

    msg.check_name(name)
    if device == "replay" and replay is None:
        raise ValueError("--device replay needs --replay FILE")
    stop, endpoints = _bus(listen, connect, zenoh_config)
    options = {"path": replay, "loop": True} if device == "replay" else {}
    if device == "touch" and device_name:
        options["device_name"] = device_name
    try:
        driver = open_device(device, **options)
    except DeviceError as error:
        raise ValueError(str(error)) from None
    with Node("device", name, **endpoints) as node:
        _ready(f"device {name} ({driver.caps.name})")
        published = run_device_node(node, driver, name, stop)
    print(f"device {name}: {published} samples published", flush=True)


@node_app.command("recorder")
def recorder(
    out: Path = typer.Option(..., "--out", help="Folder for session.mcap."),
    listen: Listen = None,
    connect: Connect = None,
    zenoh_config: ZenohConfig = None,
) -> None:
    """Every message on the bus into one MCAP file."""
    from otgym.bus import messages as msg
    from otgym.bus.nodes import record_all
    from otgym.bus.schemas import SCHEMAS
    from otgym.bus.transport import Node
    from otgym.experiments.output_folder import check_out_dir
    from otgym.record.mcap_file import McapRecorder, session_path

    stop, endpoints = _bus(listen, connect, zenoh_config)
    path = session_path(check_out_dir(out))
    with McapRecorder(path) as recording, Node("recorder", "recorder", **endpoints) as node:

        def sink(topic: str, data: bytes) -> None:
            type_name = msg.topic_type(topic)
            recording.write(topic, type_name, SCHEMAS[type_name], data)
            if topic == msg.EVENTS and msg.event_fields(msg.decode(topic, data)).get("event") == "session_end":
                print(SESSION_END_RECORDED, flush=True)  # what otgym play --distributed waits for

        record_all(node, sink)
        _ready(f"recorder into {path}")
        while not stop.wait(0.25):
            recording.flush()
    print(
        f"recorder: {sum(recording.counts.values())} messages, {sum(node.dropped.values())} dropped, into {path}",
        flush=True,
    )


@node_app.command("autonomy")
def autonomy(
    chip: Chip = "default",
    navigator: str = typer.Option(
        "route", "--navigator", help="route (the route navigator) or mpc (the model-predictive navigator)."
    ),
    listen: Listen = None,
    connect: Connect = None,
    zenoh_config: ZenohConfig = None,
) -> None:
    """The autonomy's dP_r for a simulator started with --autonomy remote."""
    from otgym.bus.nodes import run_autonomy_node
    from otgym.bus.sim_node import build_task
    from otgym.bus.transport import Node

    checks.check_navigator(navigator)
    stop, endpoints = _bus(listen, connect, zenoh_config)
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


@node_app.command("ui")
def ui(
    out: Path = typer.Option(..., "--out", help="Folder for trials.csv and questionnaires.csv."),
    device: str = typer.Option(
        "keyboard", "--device", help="What the window sends as ui0, ui1: keyboard, gamepad or mouse."
    ),
    name: str = typer.Option(
        "device0",
        "--name",
        help="With --device mouse: the device nodes whose feedback and loss it shows (robot i by the i-th; "
        "'' for none).",
    ),
    chip: Chip = "default",
    no_questionnaire: bool = typer.Option(False, "--no-questionnaire", help="No questionnaires."),
    listen: Listen = None,
    connect: Connect = None,
    zenoh_config: ZenohConfig = None,
) -> None:
    """The window as a node: draws from the sim's topics, sends input and keys."""
    from otgym.bus.sim_node import build_task
    from otgym.bus.transport import Node
    from otgym.experiments.output_folder import check_out_dir
    from otgym.task.layout import layout_of
    from otgym.teleop.device import DeviceError
    from otgym.ui.node import WINDOW_KINDS, run_window

    names = checks.bus_names(name)
    if device not in WINDOW_KINDS:
        raise ValueError(f"unknown window device {device!r} for the ui node; choose one of {', '.join(WINDOW_KINDS)}")
    stop, endpoints = _bus(listen, connect, zenoh_config)
    check_out_dir(out)
    print("building the task ...", flush=True)
    layout = layout_of(build_task(chip))
    with Node("ui", "ui", **endpoints) as node:
        _ready(f"ui ({device})")
        try:
            app = run_window(
                node,
                layout,
                device,
                names if device == "mouse" else [],
                out,
                questionnaire=not no_questionnaire,
                stop=stop,
            )
        except DeviceError as error:
            raise ValueError(str(error)) from None
    print(f"ui: wrote {app.trials_written} trial(s) to {out / 'trials.csv'}", flush=True)
