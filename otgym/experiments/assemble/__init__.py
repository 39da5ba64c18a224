"""The ``assemble`` task's scripted baseline and the episode metrics of any policy (``otgym experiment assemble-baseline``)."""
