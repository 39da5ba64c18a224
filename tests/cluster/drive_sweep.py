"""``python -m tests.cluster.drive_sweep SWEEP.toml OUT ADDRESS``: the sweep engine as a
driver on the Ray cluster at ADDRESS, running a sweep of the stand-in command
(``fake_command``); exit code 0 when every cell finished, 1 otherwise.
``ADDRESS`` ``here:N`` runs the sweep on a Ray the engine starts itself with N workers."""

import sys
from pathlib import Path

from otgym.cluster.engine import run_sweep
from otgym.cluster.sweep_file import load_sweep
from tests.cluster import fake_command
from tests.cluster.helpers import FAKE

if __name__ == "__main__":
    sweep_file, out, address = sys.argv[1], Path(sys.argv[2]), sys.argv[3]
    out.mkdir(parents=True, exist_ok=True)
    sweep = load_sweep(sweep_file, {"fake": FAKE})
    if address.startswith("here:"):
        run = run_sweep(sweep, out, fake_command.main, workers=int(address.removeprefix("here:")))
    else:
        run = run_sweep(sweep, out, fake_command.main, address=address)
    sys.exit(1 if run.failed else 0)
