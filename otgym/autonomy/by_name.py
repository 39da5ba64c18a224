"""A registered navigator (``otgym list navigators``) built on a task by its name: the
registry's class, its ``for_task(task, max_speed_um_s=...)``, then its ``warm_up()``
where it has one (a navigator that compiles before its first answer), so the autonomy
node and ``otgym play`` run a lab's own navigator as they run otgym's."""

from __future__ import annotations

from otgym import registry


def navigator_for(name: str, task, max_speed_um_s: float = 20.0, warm_up: bool = True, **config):
    """Navigator ``name`` on ``task`` (an ``InteractiveTask``), ready to answer;
    ``config``: the navigator's own options, keywords of its ``for_task`` (the MPC's
    ``config``, the learned speed's ``policy``, the route follower's
    ``cruise_speed_um_s``); ValueError naming the choices for an unknown name."""
    found = registry.entry("navigators", registry.check("navigators", name))
    navigator = found.load().for_task(task, max_speed_um_s=max_speed_um_s, **config)
    if warm_up and hasattr(navigator, "warm_up"):
        navigator.warm_up()
    return navigator
