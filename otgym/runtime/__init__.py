"""The interactive runtime: the task stepped at the control rate, scenarios, simulated
participants and the loop that runs trials (DESIGN.md, "The human half")."""
