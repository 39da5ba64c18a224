"""Shared control: arbitration between the human's and the autonomy's trap commands
(paper section II-E, equation 4)."""

from otgym.shared.arbitration import (
    MODES,
    ArbitrationConfig,
    alpha_for_mode,
    blend,
    paper_alpha,
    smooth_alpha,
    step_alpha,
)

__all__ = [
    "MODES",
    "ArbitrationConfig",
    "alpha_for_mode",
    "blend",
    "paper_alpha",
    "smooth_alpha",
    "step_alpha",
]
