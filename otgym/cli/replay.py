"""``otgym replay FILE.mcap``: a recording's summary; with ``--out`` PNG frames of its
global view, with ``--video`` an MP4 of it (``otgym.record``). A file whose writer
died reads up to its last complete chunk and is reported as truncated; a recording
without its chip (made before chips were recorded) replays with a one-line note."""

from __future__ import annotations

import time
from pathlib import Path

import typer

from otgym.cli import options


def register(app: typer.Typer) -> None:
    @app.command("replay")
    def replay(
        file: Path = typer.Argument(
            ...,
            exists=True,
            dir_okay=False,
            help="An MCAP recording (otgym play's session.mcap or a recorder node's).",
        ),
        out: Path = options.out_dir(
            None,
            "Folder for PNG frames of the global view (none without it); with --video, the folder for the MP4.",
        ),
        every: int = typer.Option(
            25, "--every", min=1, max=10**6, help="PNG frames: one per this many ticks (25: 0.5 s at 50 Hz)."
        ),
        video: bool = typer.Option(
            False,
            "--video",
            help="Write an MP4 (H.264) instead of PNG frames: FILE's name with .mp4, beside FILE or in --out.",
        ),
        fps: float = typer.Option(25.0, "--fps", min=1.0, max=240.0, help="Video frames per second."),
        speed: float = typer.Option(
            1.0, "--speed", min=0.01, max=100.0, help="Video speed: 1 plays simulated time in real time."
        ),
        width: int = typer.Option(
            960, "--width", min=64, max=7680, help="Frame width in pixels (the height follows the chip)."
        ),
    ) -> None:
        """Print a recording's duration, messages per topic and trials (for a recording of
        otgym play --task: its episodes' success, time and the task's own metrics); with
        --out, draw frames of the global view; with --video, encode them as an MP4.

        Example: otgym replay results/play/session.mcap --out results/frames --every 25
        """
        from rich.console import Console
        from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

        from otgym.experiments.common.output_folder import check_out_dir
        from otgym.record.frames import render_frames
        from otgym.record.mcap_file import check_mcap, read_recording
        from otgym.record.replay import session_scene, summary
        from otgym.record.video import frame_ticks, write_video

        if not file.is_file():
            raise FileNotFoundError(f"no recording {file}")
        if every < 1:
            raise ValueError(f"--every must be a positive number of ticks, got {every}")
        if not 64 <= width <= 7680:
            raise ValueError(f"--width must lie in [64, 7680] pixels, got {width}")
        frame_ticks(1, 0.02, fps, speed)  # checks --fps and --speed before any work
        check_mcap(file)  # a file that is not MCAP, before any folder is made
        if out is not None or video:
            check_out_dir(out if out is not None else file.parent)  # writable, before any work
        recording = read_recording(file)
        info = summary(recording)
        state = "complete" if info["complete"] else "truncated (its writer stopped early; read to its last chunk)"
        print(f"{file}: {info['messages']} messages over {info['duration_s']:.2f} s, {state}")
        for topic, count in info["counts"].items():
            print(f"  {topic:40s} {count:8d}")
        print(
            f"trials: {info['trials']} started, {len(info['ended_by'])} finished"
            + (f" ({', '.join(str(e) for e in info['ended_by'])})" if info["ended_by"] else "")
        )
        if info["task"] is not None:
            print_task_episodes(info["task"])
        if out is None and not video:
            return
        if info["task"] is not None:
            raise ValueError(
                f"{file} records otgym play --task {info['task']['task']}: it has no chip view to draw "
                "(--out and --video draw the interactive task's; Foxglove shows its /otgym/scene)"
            )
        scene = session_scene(recording)
        print(f"note: {scene.chip_note}" if scene.chip_note else f"chip: {scene.chip.name}")
        console = Console()
        columns = (
            TextColumn("{task.description}"),
            BarColumn(),
            TextColumn("{task.completed}/{task.total} frames"),
            TimeElapsedColumn(),
        )
        started = time.perf_counter()
        with Progress(*columns, console=console, transient=True) as progress:
            bar = progress.add_task("encoding" if video else "drawing", total=None)

            def report(done: int, total: int) -> None:
                progress.update(bar, completed=done, total=total)

            if video:
                target = (out if out is not None else file.parent) / f"{file.stem}.mp4"
                made = write_video(recording, target, fps, speed, width, report)
            else:
                frames = render_frames(recording, out, every, width, report)
        wall_s = time.perf_counter() - started
        if video:
            print(
                f"wrote {target}: {made['frames']} frames, {made['width']}x{made['height']}, H.264 at "
                f"{made['fps']:g} fps ({made['simulated_s']:.2f} s of simulated time at {speed:g}x) in "
                f"{wall_s:.1f} s"
            )
        else:
            print(f"wrote {len(frames)} frame(s) to {out} in {wall_s:.1f} s")


def print_task_episodes(task: dict) -> None:
    """The lines ``otgym replay`` prints for a recording of ``otgym play --task``."""
    ended = ", ".join(f"{count} {how}" for how, count in sorted(task["ended_by"].items()))
    time_text = (
        f"; mean time to success {task['mean_time_to_success_s']:.2f} s"
        if task["mean_time_to_success_s"] is not None
        else ""
    )
    preset = f"preset {task['preset']}, " if task["preset"] else ""
    print(
        f"task {task['task']} ({preset}seed {task['seed']}): {task['episodes']} episode(s)"
        + (f" ({ended})" if ended else "")
        + f", {task['successes']} succeeded{time_text}"
    )
    if task["metrics"]:
        print(f"  metrics, mean over the {task['metrics_over']} episode(s) that ended on their own:")
        for name, value in task["metrics"].items():
            print(f"    {name:30s} {value:12.4g}")
