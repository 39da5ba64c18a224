"""``otgym replay FILE.mcap``: what a recorded session holds."""

from __future__ import annotations

from pathlib import Path

import typer


def register(app: typer.Typer) -> None:
    @app.command("replay")
    def replay(path: Path = typer.Argument(..., help="An MCAP recording of otgym play.")) -> None:
        """Summarise a recording: messages per topic, session time, and each trial's result
        (a file whose writer was killed is read up to its last complete chunk)."""
        from otgym.bus.recording import summarize, summary_lines

        if not path.is_file():
            raise FileNotFoundError(f"no recording at {path}")
        try:
            summary = summarize(path)
        except Exception as error:  # the MCAP reader raises its own error types for a file that is not MCAP
            raise ValueError(f"{path} is not a readable MCAP recording ({type(error).__name__}: {error})") from None
        print("\n".join(summary_lines(summary)))
