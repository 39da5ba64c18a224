"""Training of the interactive task's learned speed policy (navigator ``rl``)."""
