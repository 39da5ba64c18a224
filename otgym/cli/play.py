"""``otgym play``: drive the robots yourself in the interactive task's window
(``otgym.ui``). Every argument, the chip, the devices and the output folder are
checked before the window opens; a bad one is one ``error:`` line and exit 2."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import typer


def register(app: typer.Typer) -> None:
    @app.command("play")
    def play(
        chip: str = typer.Option("default", "--chip", help="Chip name or PNG."),
        mode: str = typer.Option("shared", "--mode", help="manual, shared or autonomous (keys 1/2/3 switch)."),
        device: str = typer.Option("keyboard", "--device", help="keyboard, gamepad, touch or simulated."),
        participant: str = typer.Option("P1", "--participant", help="Participant ID written with every trial."),
        seed: int = typer.Option(0, "--seed", help="Trial t meets scenario seed * 10000 + t."),
        duration: float = typer.Option(None, "--duration", help="Seconds of simulated time in all (default: until Esc)."),
        no_questionnaire: bool = typer.Option(False, "--no-questionnaire", help="No questionnaires after trials."),
        screenshot: Path = typer.Option(None, "--screenshot", help="Save the last frame as this PNG."),
        headless: bool = typer.Option(False, "--headless", help="No window (SDL dummy drivers); for tests and CI."),
        out: Path = typer.Option(..., "--out", help="Folder for trials.csv, session.mcap (and questionnaires.csv)."),
    ) -> None:
        """The interactive task in a window: global and microscope views, cues, keys 1/2/3
        for the mode, space to pause, R to reset, H for help, Esc to quit; trials.csv and
        the session's MCAP recording (session.mcap)."""
        from otgym.shared import MODES
        from otgym.ui.bindings import check_device_name

        if mode not in MODES:
            raise ValueError(f"unknown mode {mode!r}; choose one of {', '.join(MODES)}")
        check_device_name(device)
        if duration is not None and not 0 < duration <= 24 * 3600:
            raise ValueError(f"--duration must lie in (0, 86400] seconds, got {duration}")
        if not 0 <= seed < 2**32 // 10_000:
            raise ValueError(f"--seed must lie in [0, {2**32 // 10_000}), got {seed}")
        if screenshot is not None and screenshot.suffix.lower() != ".png":
            raise ValueError(f"--screenshot must name a .png file, got {screenshot}")
        if not participant.strip() or "," in participant:
            raise ValueError(f"--participant must be a non-empty ID without commas, got {participant!r}")
        if headless:
            os.environ["SDL_VIDEODRIVER"] = "dummy"
            os.environ["SDL_AUDIODRIVER"] = "dummy"
        run_play(chip, mode, device, participant.strip(), seed, duration, not no_questionnaire, screenshot, out)


def run_play(chip: str, mode: str, device: str, participant: str, seed: int, duration_s: float | None,
             questionnaire: bool, screenshot: Path | None, out: Path) -> None:
    from otgym.experiments.output_folder import check_out_dir
    from otgym.runtime.task import InteractiveConfig, InteractiveTask, interactive_scene
    from otgym.runtime.trials import TASK_RETARGET, task_feedback
    from otgym.sim.chip import load_chip
    from otgym.teleop.device import DeviceError
    from otgym.ui.bindings import play_bindings, primary_devices

    chip_data = load_chip(chip)
    try:
        primaries = primary_devices(device)
    except DeviceError as error:
        raise ValueError(str(error)) from None
    if screenshot is not None and screenshot.parent and not screenshot.parent.is_dir():
        raise ValueError(f"--screenshot {screenshot}: folder {screenshot.parent} does not exist")
    created_out = not out.exists()
    check_out_dir(out)
    import pygame

    pygame.display.init()  # no audio: nothing plays sound
    pygame.font.init()
    try:
        print(f"building the task on chip {chip_data.name!r} ...", flush=True)
        task = InteractiveTask(InteractiveConfig(scene=interactive_scene(chip=chip_data)))
        feedback = task_feedback(task.config.scene.trap_law, TASK_RETARGET, int((task.trap_robot == task.trap_robot[0]).sum()))
        from otgym.ui.app import PlayApp
        from otgym.record.mcap_file import session_path
        from otgym.ui.recording import SessionRecording
        from otgym.ui.simulation import Simulation

        recording = SessionRecording(session_path(out))
        bindings = recording.wrap(play_bindings(primaries, keyboard=device == "keyboard", feedback=feedback))
        simulation = Simulation(task, bindings, participant, mode, seed, duration_s, recording=recording)
        try:
            simulation.start()
        except DeviceError as error:  # e.g. no gamepad plugged in: leave no recording or empty --out behind
            recording.close()
            recording.path.unlink(missing_ok=True)
            if created_out and not any(out.iterdir()):
                out.rmdir()
            raise ValueError(str(error)) from None
        try:
            app = PlayApp(simulation, out, keyboard=primaries[0] if device == "keyboard" else None,
                          questionnaire=questionnaire)
            app.run()
            if screenshot is not None:
                app.save_screenshot(screenshot)
        finally:
            simulation.close()
        frames = np.asarray(app.frame_times_s[1:]) if len(app.frame_times_s) > 1 else None
        if frames is not None:
            print(f"{len(frames)} frames, median {1 / np.median(frames):.0f} fps; "
                  f"{simulation.ticks} ticks, {simulation.late_ticks} schedule restarts")
        print(f"wrote {app.trials_written} trial(s) to {out / 'trials.csv'}; recording {recording.path}"
              + (f"; screenshot {screenshot}" if screenshot is not None else ""))
    finally:
        pygame.quit()
