"""What the session's process of ``otgym play`` builds (``otgym.runtime.worker``'s
``WorkerSpec.setup``, called there): the interactive task on the chip, each robot's
device (the haptic ones opened there, the window's forwarded), the feedback at the
scale where the hand-trap loop is stable, and the session's MCAP recording."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from otgym import registry
from otgym.runtime.worker import WorkerParts


def play_setup(
    chip: str,
    device: str,
    recording_path: Path,
    forwarded,
    outbox,
    navigator: str = "route",
    time_limit_s: float | None = None,
) -> WorkerParts:
    """``time_limit_s``: each trial's limit of simulated time (None: the task's own,
    ``InteractiveConfig.time_limit_s``); a study protocol may shorten it."""
    from otgym.runtime.trials import stylus_feedback
    from otgym.sim.chip import load_chip
    from otgym.task.task import InteractiveConfig, InteractiveTask
    from otgym.tasks.transport.interactive import interactive_scene
    from otgym.ui.bindings import play_binding, play_bindings, robot_primaries
    from otgym.ui.recording import SessionRecording

    config = InteractiveConfig(scene=interactive_scene(chip=load_chip(chip)))
    if time_limit_s is not None:
        config = dataclasses.replace(config, time_limit_s=time_limit_s)
    task = InteractiveTask(config)
    feedback = stylus_feedback(task)
    primaries = robot_primaries(device, list(forwarded))
    recording = SessionRecording(recording_path)
    bindings = recording.wrap(play_bindings(primaries, clutch=play_binding(device).clutch, feedback=feedback))

    def discard() -> None:  # the session never started: leave no recording behind
        recording.close()
        recording.path.unlink(missing_ok=True)

    autonomy = None
    if "session-default" not in registry.entry("navigators", navigator).tags:  # answers in this process
        from otgym.autonomy.by_name import navigator_for
        from otgym.autonomy.rl_navigator import TrialAutonomy
        from otgym.runtime.trials import TASK_RETARGET

        autonomy = TrialAutonomy(navigator_for(navigator, task, TASK_RETARGET.max_trap_speed_um_s))
    return WorkerParts(task, bindings, sink=recording, autonomy=autonomy, on_failure=discard)
