"""A task's learned policy against its scripted baseline on the report seed (``otgym experiment assemble``, ``orient``, ``sort-cells``)."""
