"""Where otgym keeps what it derives once and reuses: chip fields, compiled XLA
programs. A module of its own that imports nothing heavy, so that the command line can
name the folder before it loads the simulator."""

from __future__ import annotations

import os
from pathlib import Path


def cache_dir() -> Path:
    """``$OTGYM_CACHE_DIR``, else ``~/.cache/otgym``."""
    return Path(os.environ.get("OTGYM_CACHE_DIR") or Path.home() / ".cache" / "otgym")
