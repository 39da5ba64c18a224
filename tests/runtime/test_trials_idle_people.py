"""A batch of trials in which nobody's hands count (every trial autonomous) skips the
simulated participants and still gives the same commands, bit for bit."""

import numpy as np
import pytest

from otgym.human.params import sample_population
from otgym.human.participants import SimulatedParticipants
from otgym.runtime import trials as tr
from tests.task import fast_scenario, shared_task

TICKS = 30


class _Enough(Exception):
    """Ends the batch after ``TICKS`` ticks."""


def _commands(monkeypatch, people_modes) -> tuple[np.ndarray, np.ndarray, int]:
    """The dP_s and cell positions of two autonomous trials over ``TICKS``
    ticks, and how often the simulated people were asked, with ``PEOPLE_MODES`` set to
    ``people_modes``."""
    monkeypatch.setattr(tr, "PEOPLE_MODES", people_modes)
    asked = []
    intend = SimulatedParticipants.intend
    monkeypatch.setattr(SimulatedParticipants, "intend", lambda self, *a: asked.append(1) or intend(self, *a))
    commands, cells = [], []

    def recorder(view):
        commands.append(np.array(view.command.shared_um))
        cells.append(np.array(view.obs.cell_xy_um))
        if len(commands) == TICKS:
            raise _Enough

    specs = [tr.TrialSpec(0, mode, 0, 7) for mode in ("autonomous", "autonomous")]
    with pytest.raises(_Enough):
        tr.run_trials(
            shared_task(),
            specs,
            {0: sample_population(1, 3)[0]},
            seed=3,
            scenarios=[fast_scenario(7)] * 2,
            recorder=recorder,
        )
    return np.stack(commands), np.stack(cells), len(asked)


@pytest.mark.slow
def test_an_autonomous_batch_skips_the_people_and_gives_the_same_commands(monkeypatch):
    """Fails if the batch asks the simulated people anyway, or if skipping them changes
    any command or cell position (their dP_h was blended with weight 0)."""
    skipped, skipped_cells, asked_when_skipped = _commands(monkeypatch, tr.PEOPLE_MODES)
    acted, acted_cells, asked = _commands(monkeypatch, tr.PEOPLE_MODES + ("autonomous",))
    assert asked_when_skipped == 0 and asked == TICKS
    assert np.array_equal(skipped, acted) and np.array_equal(skipped_cells, acted_cells)
    assert np.abs(skipped).max() > 0  # the autonomy moved the traps: the comparison is not of zeros
