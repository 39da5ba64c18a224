"""Planar geometry that the task's drivers share (numpy): the autonomy places its
formation with it, the simulated participants their robots."""

from __future__ import annotations

from otgym.tasks.transport.route_follow import rotate

__all__ = ["rotate"]
