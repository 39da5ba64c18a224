"""The interactive runtime: the task stepped at the control rate, scenarios, simulated
participants and the loop that runs trials (DESIGN.md, "The human half"); a person's
session of trials paced by the wall clock (``session``), in a process of its own when
something else must keep its core (``worker``), and what a view needs of the task
(``layout``)."""
