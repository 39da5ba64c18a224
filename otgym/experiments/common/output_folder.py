"""The output folder every command writes into, checked before any work starts."""

from __future__ import annotations

import tempfile
from pathlib import Path


def check_out_dir(out_dir: Path) -> Path:
    """Refuse an output folder that is a file or cannot be written, before any work:
    create it (with its parents) and write and delete a probe file in it."""
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise ValueError(f"--out {out_dir} is a file, not a folder")
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=out_dir):
            pass
    except OSError as error:
        raise ValueError(f"--out {out_dir} cannot be written: {error.strerror or error}") from None
    return out_dir
