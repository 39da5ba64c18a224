"""The interface of ``otgym play`` (DESIGN.md, "The human half"; paper Fig. 9): one
pygame-ce window with a global view of the chip, a local microscope-like view around
the cell and the paper's situational-awareness cues, over the real-time interactive
loop (``otgym.runtime.loop``).

Modules, each with one job: ``cues`` (pure functions from the task's state to what a
cue shows), ``mouse_device`` (the mouse dragging a robot, as an input device),
``bindings`` (which devices drive which robot for each ``--device``), ``simulation``
(the loop paced by the wall clock, trials, pause and reset), ``views`` (drawing the
global view, the local view and the cue panel), ``app`` (the window: events, keys,
frames, trials.csv), ``questionnaire`` (the post-trial NASA-TLX and UEQ-S form).
"""
