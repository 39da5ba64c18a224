"""The ``sort-cells`` task's scripted baseline against random and idle policies (``otgym experiment sort-cells-baselines``) and its report outcomes."""
