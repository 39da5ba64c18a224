"""``otgym replay FILE.mcap``: a recording's summary, and PNG frames of its global
view (``otgym.record.replay``) with ``--out``. A file whose writer died reads up to
its last complete chunk and is reported as truncated."""

from __future__ import annotations

from pathlib import Path

import typer


def register(app: typer.Typer) -> None:
    @app.command("replay")
    def replay(
        file: Path = typer.Argument(..., help="An MCAP recording (otgym play's session.mcap or a recorder node's)."),
        out: Path = typer.Option(None, "--out", help="Folder for PNG frames of the global view (none without it)."),
        every: int = typer.Option(25, "--every", help="One frame per this many ticks (25: 0.5 s at 50 Hz)."),
    ) -> None:
        """Print a recording's duration, messages per topic and trials; with --out, draw frames."""
        from otgym.experiments.output_folder import check_out_dir
        from otgym.record.mcap_file import read_recording
        from otgym.record.replay import render_frames, summary

        if not file.is_file():
            raise FileNotFoundError(f"no recording {file}")
        if every < 1:
            raise ValueError(f"--every must be a positive number of ticks, got {every}")
        if out is not None:
            check_out_dir(out)
        recording = read_recording(file)
        info = summary(recording)
        state = "complete" if info["complete"] else "truncated (its writer stopped early; read to its last chunk)"
        print(f"{file}: {info['messages']} messages over {info['duration_s']:.2f} s, {state}")
        for topic, count in info["counts"].items():
            print(f"  {topic:40s} {count:8d}")
        print(f"trials: {info['trials']} started, {len(info['ended_by'])} finished"
              + (f" ({', '.join(str(e) for e in info['ended_by'])})" if info["ended_by"] else ""))
        if out is not None:
            frames = render_frames(recording, out, every)
            print(f"wrote {len(frames)} frame(s) to {out}")
