"""The runtime's and the autonomy's protocols (``otgym.runtime.protocols``,
``otgym.autonomy.protocol``): every implementation offers every member, each method
with the protocol's parameters (same names, kinds and order; extra ones only with a
default), and the worker proxy forwards each session command as it is declared."""

import inspect
from types import SimpleNamespace

import numpy as np
import pytest

from otgym.autonomy.mpc_navigator import MPCNavigator
from otgym.autonomy.mpc_policy import DAggerNavigator, PolicyNavigator, RecordingMPCNavigator
from otgym.autonomy.navigator import RouteNavigator
from otgym.autonomy.protocol import Autonomy, Navigator
from otgym.autonomy.rl_navigator import RLNavigator, TrialAutonomy
from otgym.bus.nodes import RemoteAutonomy
from otgym.bus.sim_node import BusSink
from otgym.runtime.protocols import SessionCommands, SessionControl, Sink, protocol_members, protocol_methods
from otgym.runtime.session import Session
from otgym.runtime.worker import SESSION_COMMANDS, ForwardedAutonomy, SessionProcess, WorkerSpec
from otgym.ui.node import BusSession
from otgym.ui.recording import SessionRecording


def conformance_problems(protocol: type, implementation) -> list[str]:
    """What ``implementation`` (a class, or an instance where attributes are set in
    ``__init__``) lacks of ``protocol``: a missing member, or a method whose parameters
    differ from the protocol's. Read statically (no property is called)."""
    problems = []
    for name in protocol_members(protocol):
        try:
            actual = inspect.getattr_static(implementation, name)
        except AttributeError:
            problems.append(f"{name}: missing")
            continue
        if name not in protocol_methods(protocol):
            continue
        if not callable(actual):
            problems.append(f"{name}: not a method")
            continue
        owner = implementation if isinstance(implementation, type) else type(implementation)
        declared = list(inspect.signature(getattr(protocol, name)).parameters.values())[1:]
        offered = list(inspect.signature(getattr(owner, name)).parameters.values())[1:]
        for position, parameter in enumerate(declared):
            match = offered[position] if position < len(offered) else None
            if match is None or (match.name, match.kind) != (parameter.name, parameter.kind):
                problems.append(f"{name}: parameter {parameter} offered as {match}")
        for extra in offered[len(declared) :]:
            if extra.default is inspect.Parameter.empty and extra.kind not in (extra.VAR_POSITIONAL, extra.VAR_KEYWORD):
                problems.append(f"{name}: extra parameter {extra} without a default")
    return problems


class _StubNode:
    """What ``BusSession`` and ``RemoteAutonomy`` ask of a bus node at construction."""

    session = SimpleNamespace(liveliness=lambda: SimpleNamespace(declare_token=lambda key: key))

    def subscribe(self, topic, callback):
        pass

    def watch(self, kind, callback):
        pass


def session_controls():
    """One of each ``SessionControl``: in this process, the worker proxy (not started),
    the bus proxy (over a stub node)."""
    layout = SimpleNamespace(robots=(0, 1), obstacles=(2, 3))
    return {
        "Session": Session(SimpleNamespace(), [], "P1", "shared", 0),
        "SessionProcess": SessionProcess(WorkerSpec(setup=dict, participant="P1", mode="shared", seed=0)),
        "BusSession": BusSession(_StubNode(), layout, [], "mouse"),
    }


@pytest.mark.parametrize("name", ["Session", "SessionProcess", "BusSession"])
def test_the_window_drivers_offer_the_session_control(name):
    driver = session_controls()[name]
    assert conformance_problems(SessionControl, driver) == []
    assert issubclass(type(driver), SessionCommands)


@pytest.mark.parametrize("sink", [SessionRecording, BusSink])
def test_the_sinks_offer_the_sink_protocol(sink):
    assert issubclass(sink, Sink)
    assert conformance_problems(Sink, sink) == []


@pytest.mark.parametrize(
    "navigator", [RouteNavigator, MPCNavigator, RecordingMPCNavigator, PolicyNavigator, DAggerNavigator, RLNavigator]
)
def test_the_navigators_offer_the_navigator_protocol(navigator):
    assert issubclass(navigator, Navigator)
    assert conformance_problems(Navigator, navigator) == []


def test_the_autonomies_of_the_loop_offer_the_autonomy_protocol():
    route = RouteNavigator(np.array([[0.0, 0.0], [10.0, 0.0]]), np.array([0.0, 10.0]), np.zeros((4, 2)), 0.02)
    for autonomy in (ForwardedAutonomy(0.1), RemoteAutonomy(_StubNode(), 4), route.increments, TrialAutonomy(route)):
        assert isinstance(autonomy, Autonomy)
    for autonomy in (ForwardedAutonomy, RemoteAutonomy, TrialAutonomy):
        assert conformance_problems(Autonomy, autonomy) == []


def test_the_check_fails_on_a_missing_method_or_other_parameters():
    class Partial:
        def set_mode(self, name: str) -> None:  # the protocol's parameter is ``mode``
            pass

        def drag(self, robot: int, pointer_um, traps_um, extra) -> None:  # an extra one without a default
            pass

        def lose(self, index: int, reason: str, quiet: bool = False) -> None:  # an extra one with a default: fine
            pass

    problems = conformance_problems(SessionCommands, Partial)
    assert "toggle_pause: missing" in problems and "release_drag: missing" in problems
    assert any(p.startswith("set_mode: parameter mode") for p in problems)
    assert any(p.startswith("drag: extra parameter extra") for p in problems)
    assert not any(p.startswith("lose") for p in problems)


def test_the_worker_proxy_forwards_every_command_as_declared():
    assert SESSION_COMMANDS == protocol_methods(SessionCommands)
    process = session_controls()["SessionProcess"]
    sent = []
    process.send = lambda name, *arguments: sent.append((name, arguments))
    for name in SESSION_COMMANDS:
        parameters = list(inspect.signature(getattr(SessionCommands, name)).parameters)[1:]
        arguments = tuple(f"{name}.{parameter}" for parameter in parameters)
        getattr(process, name)(*arguments)
        assert sent[-1] == (name, arguments)
    process.drag(1, pointer_um=(2.0, 3.0), traps_um=(4.0, 5.0))  # keywords travel in the declared order
    assert sent[-1] == ("drag", (1, (2.0, 3.0), (4.0, 5.0)))
    with pytest.raises(TypeError):
        process.set_mode()  # a wrong call fails here, not in the worker
    assert len(sent) == len(SESSION_COMMANDS) + 1
