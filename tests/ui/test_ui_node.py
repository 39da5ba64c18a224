"""The window as a node on the bus (``otgym.ui.node.BusSession``), over loopback zenoh
nodes in this process: the snapshot it rebuilds from a tick's messages matches the
simulator's own observation (traps, cell, handles, obstacle gaps) and the cell's light
dose its trial metric has; the mode, pause
and reset keys go out as checked commands; a device node or the autonomy lost shows
in the loss banner; a finished trial's row comes from its ``trial_end``."""

from __future__ import annotations

import socket
import time

import numpy as np
import pytest

from otgym.bus import messages as msg
from otgym.bus import task_messages
from otgym.bus.transport import Node
from otgym.ui import cues


def free_endpoint() -> str:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return f"tcp/127.0.0.1:{probe.getsockname()[1]}"


def wait_until(condition, timeout_s: float = 60.0, poll_s: float = 0.005) -> None:
    """Poll ``condition()`` every ``poll_s`` until it holds; the deadline only bounds a hang."""
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, f"not within {timeout_s} s"
        time.sleep(poll_s)


def publish_tick(sim, loop, record) -> None:
    """One tick's messages, as the sim publishes them."""
    for topic, data in task_messages.tick_messages(record, [], loop.sphere_xy_um(), mode="shared", stamp_s=time.time()):
        sim.publish(topic, data)


def publish_until(publish, condition, every_s: float = 0.5, timeout_s: float = 60.0) -> None:
    """``publish()``, then wait up to ``every_s`` for ``condition()``, again until it holds
    (the bus may drop a message under load); one copy is sent when none is lost."""
    deadline = time.monotonic() + timeout_s
    while True:
        publish()
        try:
            wait_until(condition, timeout_s=min(every_s, max(deadline - time.monotonic(), 0.0)))
            return
        except AssertionError:
            assert time.monotonic() < deadline, f"not within {timeout_s} s"


@pytest.fixture(scope="module")
def layout_and_loop():
    from otgym.runtime.loop import InteractiveLoop
    from otgym.task.layout import layout_of
    from tests.task import fast_scenario, shared_task

    task = shared_task()
    loop = InteractiveLoop(task, [], fast_scenario(7), "shared")
    return layout_of(task), loop


def test_the_window_on_the_bus_draws_what_the_sim_sees_and_sends_checked_commands(layout_and_loop):
    from otgym.ui.node import BusSession

    layout, loop = layout_and_loop
    endpoint = free_endpoint()
    commands = []
    with Node("sim", "sim", listen=[endpoint]) as sim, Node("ui", "ui", connect=[endpoint]) as ui:
        sim.subscribe(msg.COMMAND, lambda topic, message, data: commands.append(msg.event_fields(message)))
        session = BusSession(ui, layout, [], "mouse", ["device0"])
        wait_until(lambda: session.simulator_live)
        start = msg.event("trial_start", trial=4, scenario=7, mode="shared", participant="P9")
        # again until the window has it (until the subscriptions meet; a repeat of a trial's start is ignored)
        publish_until(lambda: sim.publish(msg.EVENTS, start), lambda: session._trial == 4, every_s=0.1)
        for _ in range(3):  # the tick's messages, again until they arrive (the bus may drop one under load)
            record = loop.tick()
            publish_until(
                lambda: publish_tick(sim, loop, record),
                lambda: (
                    session.snapshot is not None
                    and np.array_equal(session.snapshot.observation.trap_xy_um[0], record.trap_xy_um)
                ),
            )
        assert session.snapshot.time_s >= 3 * layout.tick_s  # its clock counts the ticks it saw
        seen, truth = session.snapshot.observation, loop.observation
        np.testing.assert_allclose(seen.trap_xy_um, truth.trap_xy_um)
        np.testing.assert_allclose(seen.cell_xy_um, truth.cell_xy_um, atol=1e-4)
        np.testing.assert_allclose(seen.handle_xy_um, truth.handle_xy_um, atol=1e-4)
        np.testing.assert_allclose(seen.obstacle_gap_um, truth.obstacle_gap_um, atol=1e-3)
        assert session.snapshot.trial == 4 and session.participant == "P9" and session.snapshot.mode == "shared"
        # the cell's light dose, added up over the ticks seen as the trial's metric adds it
        truth_dose = float(loop.state.metrics.light_dose_mj_per_um2[0])
        assert truth_dose > 0.0  # the gripped cell sees the handle traps' light
        if session._ticks == 3:  # each tick seen once (none sent again under load)
            assert session.snapshot.light_dose_mj_per_um2 == pytest.approx(truth_dose, rel=1e-2)
        else:  # a tick seen twice counts twice, as it does for the window's clock
            assert session.snapshot.light_dose_mj_per_um2 >= truth_dose * 0.99
        # the keys go out as commands the sim accepts
        session.set_mode("manual")
        session.toggle_pause()
        session.reset()
        wait_until(lambda: len(commands) == 3)
        assert commands == [{"command": "mode", "mode": "manual"}, {"command": "pause"}, {"command": "reset"}]
        # a device node that goes, and the autonomy lost: the banner says so
        with Node("device", "device0", connect=[endpoint]):
            wait_until(lambda: "device0" in session._alive_devices)
        wait_until(lambda: session.lost_devices == ("device0",))
        sim.publish(msg.EVENTS, msg.event("autonomy_lost", trial=4, time_s=0.06, mode="manual"))
        wait_until(lambda: not session.snapshot.autonomy_live)
        lines = cues.loss_warnings(session.lost_devices, session.snapshot.autonomy_live, session.snapshot.mode)
        assert lines == ["device0 LOST: its robot holds", "AUTONOMY LOST: manual control"]
        # the trial's row from its trial_end; the session's end
        sim.publish(msg.EVENTS, msg.event("trial_end", trial=4, participant="P9", ended_by="goal"))
        sim.publish(msg.EVENTS, msg.event("session_end", trials=4, ticks=3))
        wait_until(lambda: session.over)
        assert session.take_finished()["ended_by"] == "goal" and session.take_finished() is None


def test_a_window_that_joins_mid_trial_knows_the_trial_and_the_participant(layout_and_loop):
    """The sim's bus sink sends each trial_start also on the latched /otgym/trial/current:
    a ui node that connects after it still shows trial 2 of P5 (on the events alone it
    showed trial 0 of '?'). Trial 3 then starts; once a tick of it has been counted, the
    same trial_start arrives again on both topics (as a window that joins sees it twice)
    followed by a mode event: the window still shows trial 3 and keeps the ticks it
    counted (a repeated start does not restart the trial, which would zero them). The events topic's copy is
    known to be handled when the mode event after it is (one publisher, one key: in
    order); the latched copy when the test's own subscriber, declared after the
    window's, has seen it."""
    from otgym.bus.sim_node import BusSink
    from otgym.ui.node import BusSession

    layout, loop = layout_and_loop
    endpoint = free_endpoint()
    with Node("sim", "sim", listen=[endpoint]) as sim:
        sink = BusSink(lambda messages: [sim.publish(topic, data) for topic, data in messages])
        for trial in (1, 2):
            sink.event("trial_start", trial=trial, scenario=trial, mode="autonomous", participant="P5")
        with Node("ui", "ui", connect=[endpoint]) as ui:
            session = BusSession(ui, layout, [], "mouse", [])
            latched = []
            ui.subscribe(msg.TRIAL, lambda topic, message, data: latched.append(msg.event_fields(message)["trial"]))
            wait_until(lambda: session._trial == 2)
            assert session.participant == "P5" and session._mode == "autonomous"
            sink.event("trial_start", trial=3, scenario=3, mode="shared", participant="P5")
            wait_until(lambda: session._trial == 3 and latched.count(3) == 1)
            record = loop.tick()
            publish_until(lambda: publish_tick(sim, loop, record), lambda: session._ticks > 0)
            ticks = session._ticks
            again = msg.event("trial_start", trial=3, scenario=3, mode="shared", participant="P5")
            sim.publish(msg.TRIAL, again)
            sim.publish(msg.EVENTS, again)
            sim.publish(msg.EVENTS, msg.event("mode", trial=3, mode="manual"))
            wait_until(lambda: session._mode == "manual" and latched.count(3) == 2)
            assert session._trial == 3 and session._ticks >= ticks > 0  # a copy of the tick may still have come
