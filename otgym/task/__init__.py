"""The interactive task (paper section III-C): two trapped microrobots grip a cell and
carry it along the planned route past dynamic obstacles, stepped at the control rate
(``task``); the obstacles' scenarios (``scenario``); what a view needs of the task
(``layout``); and the planar geometry its drivers share (``geometry``).

Everything here is the task itself, independent of who drives it: the autonomy
(``otgym.autonomy``), simulated people (``otgym.human``) and the runtime that paces
it for a person (``otgym.runtime``) sit above this package.
"""
