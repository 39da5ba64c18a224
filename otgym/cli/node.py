"""``otgym node ROLE``: one part of the runtime as a process on the bus (``otgym.bus``),
one sub-command per role, each with only its own options:

- ``sim``: the simulator, its session ticking in a worker process;
- ``device``: a local device published under ``--name``;
- ``recorder``: every message into ``--out``/session.mcap;
- ``autonomy``: the navigator's dP_r for a sim started with ``--autonomy remote``
  (without it, shared control runs as manual);
- ``ui``: the window: draws from the sim's topics, sends the keyboard, gamepad or mouse
  as devices ui0, ui1 and the keys as commands; trials.csv and questionnaires.csv into
  ``--out``;
- ``foxglove``: the running session served to Foxglove over a WebSocket
  (``otgym.cli.node_foxglove``);
- ``ros2``: the session bridged to a ROS 2 graph through rclpy (``otgym.bus.ros2_bridge``).

Every role takes the bus options (``--listen``, ``--connect``, ``--zenoh-config``;
loopback only unless they name other endpoints) and ``--namespace``: every node is a
ROS 2 node to rmw_zenoh (``otgym.bus.ros_graph``), placed by ``--namespace`` and
``ROS_DOMAIN_ID``. Each prints what it is doing while it starts, one ``ready`` line
once it is on the bus and ready to work, and ends cleanly on SIGTERM or Ctrl-C
(devices at zero force, the recording closed)."""

from __future__ import annotations

import functools
import signal
import sys
import threading
import time
from pathlib import Path
from typing import Annotated

import typer

from otgym.cli import checks, options

SESSION_END_RECORDED = "recorded: session_end"
"""The recorder node's line once the simulator's ``session_end`` event is in its file."""
EVENT_RECOVERY_GRACE_S = 1.0
"""How long the sim's bus stays open after its session, so that a subscriber that
missed the last events (its link closed while it stalled) recovers them from the events
publisher's cache (``otgym.bus.transport.RECOVERED``) before the cache is gone."""
RECORDERS_WAIT_S = 15.0
"""How long, at most, the sim's bus stays open after its session until every recorder
node on it has the session's end in its file (``Node.wait_for``): the sim is the bus's
router, and what a recorder starved of CPU has not yet received goes with it."""

node_app = typer.Typer(
    name="node",
    help="Run one node of the distributed runtime (sim, device, recorder, autonomy, ui, foxglove, ros2) until stopped.",
    no_args_is_help=True,
    add_completion=False,
)

Listen = Annotated[
    list[str] | None,
    typer.Option(
        "--listen",
        metavar="ENDPOINT",
        callback=options.check_endpoints,
        help="zenoh endpoint to listen on, e.g. tcp/127.0.0.1:7447 (repeatable).",
    ),
]
Connect = Annotated[
    list[str] | None,
    typer.Option(
        "--connect",
        metavar="ENDPOINT",
        callback=options.check_endpoints,
        help="zenoh endpoint to connect to, e.g. tcp/127.0.0.1:7447 (repeatable).",
    ),
]
ZenohConfig = Annotated[
    Path | None,
    typer.Option("--zenoh-config", exists=True, dir_okay=False, help="zenoh config file (TLS, user/password)."),
]
Namespace = Annotated[
    str,
    typer.Option(
        "--namespace",
        metavar="NAMESPACE",
        callback=options.check_namespace,
        help="The ROS 2 namespace of the node and of otgym's topics (e.g. /rig1).",
    ),
]
Chip = Annotated[
    str,
    typer.Option("--chip", metavar="CHIP", callback=options.check_chip, help="Shipped chip name or a PNG file."),
]


def register(app: typer.Typer) -> None:
    app.add_typer(node_app, name="node")


def _bus(listen, connect, zenoh_config, namespace: str = "/") -> tuple[threading.Event, dict]:
    """The stop event (set by SIGTERM or Ctrl-C) and the node's endpoints and namespace,
    after the zenoh config file and ``ROS_DOMAIN_ID`` are checked."""
    from otgym.bus import ros_graph

    checks.check_zenoh_config(zenoh_config)
    ros_graph.domain_id()  # a bad ROS_DOMAIN_ID is an error line before anything starts
    stop = threading.Event()
    for signum in (signal.SIGTERM, signal.SIGINT):
        signal.signal(signum, lambda *_: stop.set())
    endpoints = dict(
        listen=list(listen or []),
        connect=list(connect or []),
        config_file=str(zenoh_config) if zenoh_config else None,
        namespace=namespace,
    )
    return stop, endpoints


def _ready(text: str) -> None:
    print(f"ready: {text}", flush=True)


@node_app.command("sim")
def sim(
    name: str = typer.Option(
        "device0",
        "--name",
        metavar="NAMES",
        callback=options.check_bus_names,
        help="The device nodes it drives (robot i by the i-th), comma-separated.",
    ),
    takeover: str = typer.Option(
        None,
        "--takeover",
        metavar="NAMES",
        callback=options.check_bus_names,
        help="Devices (comma-separated, robot i by the i-th) that take robot i over while their clutch is held: "
        "a ui node's mouse (ui0,ui1).",
    ),
    mode: str = options.mode("shared"),
    participant: str = options.participant("P1"),
    hold: bool = typer.Option(
        False, "--hold", help="After each trial wait for a next_trial command (a ui node's questionnaires)."
    ),
    wait_for_start: bool = typer.Option(
        False,
        "--wait-for-start",
        help="Start the first trial on a next_trial command, not at once (otgym play sends it when every node "
        "of its session is ready and the window is open).",
    ),
    chip: Chip = "default",
    autonomy: str = options.name(
        "local",
        "--autonomy",
        checks.AUTONOMY_SOURCES,
        "dP_r from its own navigator (local) or from an autonomy node (remote).",
    ),
    seed: int = options.trial_seed(0),
    duration: float = options.duration(),
    plant: str = options.registered(
        "simulator",
        "--plant",
        "plants",
        None,
        "What moves the bodies under the trap commands: otgym's physics, or a rig that answers "
        "/otgym/traps with its measured spheres on /otgym/rig/poses.",
    ),
    listen: Listen = None,
    connect: Connect = None,
    zenoh_config: ZenohConfig = None,
    namespace: Namespace = "/",
) -> None:
    """The simulator (its session ticks in a worker process): devices, commands, dP_r in; bodies, events out.
    With --plant rig it is the controller of a rig outside otgym.

    Example: otgym node sim --name device0 --mode shared --seed 0
    """
    from otgym.bus.router import place_sim
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
    stop, endpoints = _bus(listen, connect, zenoh_config, namespace)
    load_chip(chip)  # a bad chip is an error line before anything starts
    placement = place_sim(endpoints["listen"], endpoints["connect"], endpoints["config_file"], namespace=namespace)
    endpoints.update(listen=placement.listen, connect=placement.connect, mode=placement.mode)
    print(f"sim: {placement.describe()}", flush=True)
    print("starting the simulation in its own process ...", flush=True)
    with Node("sim", "sim", **endpoints) as node:
        ready = functools.partial(
            _ready,
            f"sim for devices {', '.join(names)}"
            + (f", taken over by {', '.join(takeovers)}" if takeovers else "")
            + (" with a remote autonomy" if remote_autonomy else "")
            + (f", plant {plant}" if plant != "simulator" else "")
            + ("; trial 1 waits for next_trial" if wait_for_start else ""),
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
                hold_first_trial=wait_for_start,
                plant=plant,
                on_ready=ready,
                on_status=lambda text: print(f"sim: {text} ...", flush=True),
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
        time.sleep(EVENT_RECOVERY_GRACE_S)
        unrecorded = node.wait_for("session_end", "recorder", RECORDERS_WAIT_S)
        if unrecorded:
            print(f"sim: closing the bus; the session's end not recorded by {', '.join(unrecorded)}", flush=True)
    sys.stdout.flush()


@node_app.command("device")
def device(
    name: str = typer.Option(
        "device0", "--name", metavar="NAMES", callback=options.check_bus_names, help="Its name on the bus."
    ),
    device: str = options.registered("simulated", "--device", "devices", "node", "Its driver."),
    device_name: str = typer.Option(
        None, "--device-name", metavar="TEXT", help="With --device touch: the Touch's name in Touch Setup."
    ),
    replay: Path = typer.Option(
        None, "--replay", exists=True, dir_okay=False, help="With --device replay: the CSV to play (looped)."
    ),
    twist_topic: str = typer.Option(
        None,
        "--twist-topic",
        metavar="TOPIC",
        callback=options.check_topic,
        help="With --device twist: the ROS 2 topic of its geometry_msgs/Twist commands (default /cmd_vel).",
    ),
    listen: Listen = None,
    connect: Connect = None,
    zenoh_config: ZenohConfig = None,
    namespace: Namespace = "/",
) -> None:
    """A local device on the bus: its samples out, the simulator's feedback in.

    Example: otgym node device --device simulated --name device0
    """
    from otgym import registry
    from otgym.bus.nodes import run_device_node
    from otgym.bus.transport import Node
    from otgym.teleop.device import DeviceError, open_device

    keywords = checks.device_node_options(
        device, {"device-name": device_name, "replay": replay, "twist-topic": twist_topic}
    )
    stop, endpoints = _bus(listen, connect, zenoh_config, namespace)
    entry = registry.entry("devices", device, "node")
    if "driver" not in entry.tags:  # a node of its own (twist)
        entry.load()(stop, endpoints, name, _ready, **keywords)
        return
    try:
        if "node_driver" in entry.extras:
            driver = entry.load_extra("node_driver")(**keywords)
        else:
            driver = open_device(device, **keywords)
    except DeviceError as error:
        raise ValueError(str(error)) from None
    with Node("device", name, **endpoints) as node:
        _ready(f"device {name} ({driver.caps.name})")
        published = run_device_node(node, driver, name, stop)
    print(f"device {name}: {published} samples published", flush=True)


@node_app.command("recorder")
def recorder(
    out: Path = options.out_dir(..., "Folder for session.mcap."),
    listen: Listen = None,
    connect: Connect = None,
    zenoh_config: ZenohConfig = None,
    namespace: Namespace = "/",
) -> None:
    """Every message on the bus into one MCAP file, with the 3D scene Foxglove replays.

    Example: otgym node recorder --out results/session
    """
    from otgym.bus import messages as msg
    from otgym.bus.foxglove_scene import SceneRecording
    from otgym.bus.schemas import SCHEMAS
    from otgym.bus.transport import Node
    from otgym.experiments.common.output_folder import check_out_dir
    from otgym.record.mcap_file import McapRecorder, session_path

    stop, endpoints = _bus(listen, connect, zenoh_config, namespace)
    path = session_path(check_out_dir(out))
    with McapRecorder(path) as recording, Node("recorder", "recorder", **endpoints) as node:
        scene = SceneRecording(recording.write_encoded)

        ended = threading.Event()

        def sink(topic: str, message, data: bytes) -> None:
            type_name = msg.topic_type(topic)
            recording.write(topic, type_name, SCHEMAS[type_name], data)
            scene.take(topic, message)
            if topic == msg.EVENTS and msg.event_fields(message).get("event") == "session_end":
                ended.set()

        node.subscribe("/otgym/**", sink)
        _ready(f"recorder into {path}")
        announced = False
        while not stop.wait(0.25):
            recording.flush()
            if ended.is_set() and not announced:  # in its file: the sim may close the bus
                node.announce("session_end")
                print(SESSION_END_RECORDED, flush=True)  # what otgym play --distributed waits for
                announced = True
    print(
        f"recorder: {sum(recording.counts.values())} messages, {sum(node.dropped.values())} dropped, into {path}",
        flush=True,
    )


@node_app.command("autonomy")
def autonomy(
    chip: Chip = "default",
    navigator: str = options.navigator("route"),
    listen: Listen = None,
    connect: Connect = None,
    zenoh_config: ZenohConfig = None,
    namespace: Namespace = "/",
) -> None:
    """The autonomy's dP_r for a simulator started with --autonomy remote.

    Example: otgym node autonomy --navigator route
    """
    from otgym import registry
    from otgym.autonomy.by_name import navigator_for
    from otgym.bus.nodes import run_autonomy_node
    from otgym.bus.sim_node import build_task
    from otgym.bus.transport import Node

    checks.check_navigator(navigator)
    stop, endpoints = _bus(listen, connect, zenoh_config, namespace)
    print("building the task ...", flush=True)
    task = build_task(chip)
    note = registry.entry("navigators", navigator).extras.get("start_note")
    print(f"building the {navigator} navigator{f' ({note})' if note else ''} ...", flush=True)
    planner = navigator_for(navigator, task)
    with Node("autonomy", "autonomy", **endpoints) as node:
        _ready(f"autonomy ({navigator} navigator)")
        answered = run_autonomy_node(node, task, stop, navigator=planner)
        print(
            f"autonomy: {answered} ticks answered; dropped {sum(node.dropped.values())} malformed messages", flush=True
        )


@node_app.command("ui")
def ui(
    out: Path = options.out_dir(..., "Folder for trials.csv and questionnaires.csv."),
    device: str = options.registered("keyboard", "--device", "devices", "window", "What the window sends as ui0, ui1."),
    name: str = typer.Option(
        "device0",
        "--name",
        metavar="NAMES",
        callback=options.check_bus_names,
        help="With --device mouse: the device nodes whose feedback and loss it shows (robot i by the i-th; "
        "'' for none).",
    ),
    chip: Chip = "default",
    no_questionnaire: bool = typer.Option(False, "--no-questionnaire", help="No questionnaires."),
    listen: Listen = None,
    connect: Connect = None,
    zenoh_config: ZenohConfig = None,
    namespace: Namespace = "/",
) -> None:
    """The window as a node: draws from the sim's topics, sends input and keys.

    Example: otgym node ui --out results/session --device keyboard
    """
    from otgym.bus.sim_node import build_task
    from otgym.bus.transport import Node
    from otgym.experiments.common.output_folder import check_out_dir
    from otgym.task.layout import layout_of
    from otgym.teleop.device import DeviceError
    from otgym.ui.bindings import takes_over
    from otgym.ui.node import run_window

    names = checks.bus_names(name)
    stop, endpoints = _bus(listen, connect, zenoh_config, namespace)
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
                names if takes_over(device) else [],
                out,
                questionnaire=not no_questionnaire,
                stop=stop,
            )
        except DeviceError as error:
            raise ValueError(str(error)) from None
    print(f"ui: wrote {app.trials_written} trial(s) to {out / 'trials.csv'}", flush=True)


@node_app.command("foxglove")
def foxglove(
    host: str = typer.Option(
        "127.0.0.1",
        "--host",
        metavar="HOST",
        callback=options.check_host,
        help="The address its WebSocket listens on (loopback unless told otherwise).",
    ),
    port: int = typer.Option(8765, "--port", min=0, max=65535, help="The WebSocket's port (0: any free port)."),
    listen: Listen = None,
    connect: Connect = None,
    zenoh_config: ZenohConfig = None,
    namespace: Namespace = "/",
) -> None:
    """The running session served to Foxglove: the 3D scene, alpha, contact force and handle lag.

    Example: otgym node foxglove --port 8765
    """
    from otgym.cli.node_foxglove import foxglove_node

    stop, endpoints = _bus(listen, connect, zenoh_config, namespace)
    foxglove_node(stop, endpoints, host=host, port=port)


@node_app.command("ros2", context_settings={"allow_extra_args": True, "ignore_unknown_options": True})
def ros2(
    ctx: typer.Context,
    listen: Listen = None,
    connect: Connect = None,
    zenoh_config: ZenohConfig = None,
    namespace: Namespace = "/",
) -> None:
    """The session bridged to a ROS 2 graph (rclpy, RMW_IMPLEMENTATION): otgym's outputs and
    /otgym/markers to ROS 2, teleoperation, commands and autonomy increments back. Settings
    are ROS 2 parameters after --ros-args (devices, autonomy, twist_topics,
    twist_stamped_topics, markers_period_s).

    Example: otgym node ros2 --namespace /
    """
    from otgym.bus.ros2_bridge import serve

    extra = list(ctx.args)
    if extra and extra[0] != "--ros-args":
        raise ValueError(f"unexpected argument {extra[0]!r}: ROS 2 arguments follow --ros-args")
    stop, endpoints = _bus(listen, connect, zenoh_config, namespace)
    counts = serve(stop, endpoints, extra, _ready)
    print(
        f"ros2: {counts['to_ros']} messages to ROS 2, {counts['to_otgym']} to otgym; "
        f"{counts['dropped']} dropped by the checks; {counts['superseded']} stream messages superseded by newer ones",
        flush=True,
    )
