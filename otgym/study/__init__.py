"""Study tooling for the shared-control experiment (paper Sec. III-C, Fig. 8): per-mode
summaries, repeated-measures statistics (pingouin) and the Fig. 8 figure, from a trials
table with one row per trial.

Modules: ``stats`` (participant means, ANOVA + Holm post-hoc, stars, Wilson intervals),
``summary`` (per-mode table and the summary files), ``figures`` (Fig. 8 (a, b), and (c,
d) from answers), ``paper_fig8`` (the paper's values), ``questionnaires`` (NASA-TLX and
UEQ-S: items, answer file, scoring), ``questionnaire_stats`` (paired tests per panel),
``analyze`` (``otgym study analyze``: recorded sessions to Fig. 8 and summaries),
``protocol`` (study protocols for ``otgym study run``, the Williams square),
``participants`` (pseudonyms, a participant's folder, resuming), ``mixed``
(mixed-effects models, order effects), ``report`` (``report.md``)."""

import importlib

_HOMES = {
    "MODE_ORDER": "stats",
    "PAPER_FIG8": "paper_fig8",
    "compare_modes": "stats",
    "participant_means": "stats",
    "plot_fig8": "figures",
    "stars": "stats",
    "summarize": "summary",
    "wilson_interval": "stats",
    "write_summary": "summary",
}
"""The module of each name above, imported on first use (PEP 562): the statistics and
figure libraries take seconds to import, and the window and the nodes need neither."""


def __getattr__(name: str):
    if name not in _HOMES:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{_HOMES[name]}"), name)


__all__ = [
    "MODE_ORDER",
    "PAPER_FIG8",
    "compare_modes",
    "participant_means",
    "plot_fig8",
    "stars",
    "summarize",
    "wilson_interval",
    "write_summary",
]
