"""The interface of ``otgym play`` (paper Fig. 9): one
pygame-ce window with a global view of the chip, a local microscope-like view around
the cell and the paper's situational-awareness cues, over a session of the
interactive task (``otgym.runtime.session``) that runs in a process of its own
(``otgym.runtime.worker``) or behind the bus.

Modules, each with one job: ``cues`` (pure functions from the task's state to what a
cue shows), ``bindings`` (which devices drive which robot for each ``--device``, and
which of them the window reads), ``play_worker`` (what the session's process builds:
task, devices, recording), ``recording`` (the session's MCAP file), ``views``
(drawing the global view, the local view and the cue panel), ``app`` (the window:
events, keys, frames, trials.csv), ``records`` (trials.csv), ``questionnaire`` (the
post-trial NASA-TLX and UEQ-S form).
"""
