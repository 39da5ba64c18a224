"""The interactive task on the host (paper section III-C): two trapped microrobots grip a
cell and carry it along the planned route past dynamic obstacles, stepped at the control
rate. ``task``: ``InteractiveTask``, the host wrapper (numpy in and out, phases, trial
metrics) of the functional core ``otgym.tasks.transport.interactive`` (whose obstacles
are ``otgym.tasks.transport.scenario``); what a view needs of the task (``layout``); the
plants that answer the trap commands (``rig``).

Everything here is the task itself, independent of who drives it: the autonomy
(``otgym.autonomy``), simulated people (``otgym.human``) and the runtime that paces
it for a person (``otgym.runtime``) sit above this package.
"""
