"""otgym: an open platform for optical-tweezer (OT) driven microrobotics.

Layers (data flows downward only, see ../shared/DESIGN.md):
``cli`` -> ``envs``/``rl``/``control`` -> ``planning`` -> ``sim`` -> ``physics``.
Units everywhere: micrometre (um), second (s), piconewton (pN), kelvin (K).
"""

__version__ = "0.1.0"
