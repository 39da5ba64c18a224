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

from otgym.study.figures import plot_fig8
from otgym.study.paper_fig8 import PAPER_FIG8
from otgym.study.stats import MODE_ORDER, compare_modes, participant_means, stars, wilson_interval
from otgym.study.summary import summarize, write_summary

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
