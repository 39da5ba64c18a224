"""Chips, their derived fields, rendering and sensing (numpy at the edges, JAX samplers
for the physics core).

* ``chip``: ``load_chip("default" | path.png, pixel_size_um=None)``, ``Chip``, ``Port``,
  ``save_chip``; ``default_chip``: the generated four-branch chip.
* ``walls`` (signed distance), ``flow`` (depth-averaged Stokes-Brinkman solve),
  ``cache`` (``chip_fields(chip)``: both, cached on disk by content).
* ``fields``: ``chip_fields(chip) -> (GridFlow, GridWalls)``, the JAX hooks of
  ``otgym.physics.fields``.
* ``render`` (``SceneRenderer``: RGB for people), ``microscope`` (bright-field frames),
  ``sensor`` (``VisionForceSensor``: handle positions and trap forces from images).
"""
