"""otgym's own named parts, in one table: ``(kind, name, "module:attribute",
description, tags, extras)``. Chips are not listed: each ``NAME.png`` with its sidecar
``NAME.json`` in ``otgym/data/chips/`` is chip ``NAME``.

Tags say what a part is usable for. Devices: ``play`` (``otgym play --device``),
``node`` (``otgym node device --device``), ``window`` (the window node's own input),
``driver`` (a ``Device`` that ``otgym.teleop.device.open_device`` builds by name);
extra ``play_binding``: how it drives the two robots (``otgym.ui.bindings.PlayBinding``);
extra ``window_takeover``: the window device that takes over the robots' device nodes
while it drags (the window's input when those devices are nodes: ``otgym play
--distributed``, ``otgym node ui --device-names``); extra ``node_options``: the ``otgym node device`` options it takes, comma-separated
``OPTION=KEYWORD`` (the option ``--OPTION`` gives its driver's keyword ``KEYWORD``; a
trailing ``!``: required); extra ``node_driver``: the ``"module:attribute"`` factory
that node builds it with (default: its target). A ``node`` device that is not a ``driver`` is a node of its
own: its target is called as ``target(stop, endpoints, name, ready, **keywords)``.
Navigators (each a class with ``for_task(task, max_speed_um_s=...)``, and optionally
``warm_up()``, which the autonomy node calls before its first answer): ``trial-mode``
(also a mode of the batched trials, beside manual, shared and autonomous), ``shared``
(the autonomy that shared control blends with), ``in-process`` (cheap enough to answer
in the simulation's own process: ``otgym play`` runs it without ``--distributed``),
``session-default`` (the one a session runs itself when no other is named); extras
``label`` (its short name in reports), ``about`` (what it does, in a report's words),
``measured`` (its measured full-size result on the shared-control study, with where)
``acceptance_rate`` (the share of obstacles avoided and of goals reached that
``otgym experiment shared-control`` accepts of it, alone and as shared control's
autonomy) and ``start_note`` (for one that takes long to start: what it does meanwhile; the
autonomy node says so and ``otgym play --distributed`` starts it first and waits).
Plants (what moves the interactive task's bodies under the controller's trap
commands: ``otgym node sim --plant``): a callable ``(task, measured, send_start)`` that
returns what ``InteractiveLoop`` steps (``otgym.task.rig``); tag ``measured``: its
bodies come from outside, as measured poses on ``/otgym/rig/poses``.
Tasks' extras: ``gym_id`` and ``vector`` (the Gymnasium id and vector entry point),
``functional`` (the module of its pure ``make_params``, ``reset`` and ``step``, which
``otgym.envs.gymnax_env`` wraps as a gymnax environment); a task with a report-seed
comparison of its learned policy against its baseline (``otgym experiment NAME``,
``otgym.experiments.task_report.run``) names ``report_seed`` and ``training_seed`` (seed
registry: ``otgym.experiments.common.seeds``), ``report_preset``, ``report_policy`` (a file in
``otgym/data/policies/``), ``report_baseline`` (what the baseline is, in words),
``report_metrics`` (its own metrics, comma-separated), ``report_outcomes`` (the
``"module:function"`` that runs both policies on paired episodes) and, optionally,
``report_secondary`` (the plan's secondary outcome, a per-episode metric, higher is
better; without it, the time to success).
"""

from __future__ import annotations

ENTRIES: tuple[tuple[str, str, str, str, tuple[str, ...], dict[str, str]], ...] = (
    # tasks
    (
        "tasks",
        "speed-control",
        "otgym.tasks.transport:SpeedControl",
        "the paper's learning task: pick the robots' speed along the planned path past moving obstacles",
        (),
        {
            "gym_id": "otgym/SpeedControl-v0",
        },
    ),
    (
        "tasks",
        "cell-transport",
        "otgym.tasks.transport:CellTransport",
        "speed control with the gripped cell simulated: carry it to the goal without losing it",
        (),
        {
            "gym_id": "otgym/CellTransport-v0",
        },
    ),
    (
        "tasks",
        "interactive-speed",
        "otgym.tasks.transport.interactive_speed:InteractiveSpeed",
        "the interactive task's route follower past crossing obstacles: pick its speed every 0.5 s",
        (),
        {
            "gym_id": "otgym/interactive-speed-v0",
        },
    ),
    (
        "tasks",
        "assemble",
        "otgym.tasks.assemble:Assemble",
        "holographic micro-assembly: beads in N traps placed into a ring, lattice or letter, SLM-paced",
        (),
        {
            "gym_id": "otgym/assemble-v0",
            "report_seed": "75000",
            "training_seed": "38",
            "report_preset": "ring",
            "report_policy": "assemble_ring.npz",
            "report_baseline": "the plan at 0.3 um per frame",
            "report_metrics": "rms_error_um,beads_lost,collisions",
            "report_outcomes": "otgym.experiments.assemble.run:report_outcomes",
        },
    ),
    (
        "tasks",
        "orient",
        "otgym.tasks.orient:Orient",
        "two robots turn a gripped cell in place to a target angle without losing the grip",
        (),
        {
            "gym_id": "otgym/orient-v0",
            "report_seed": "76000",
            "training_seed": "39",
            "report_preset": "default",
            "report_policy": "orient_default.npz",
            "report_baseline": "the bang-bang controller",
            "report_metrics": "failed,overshoot,final_error_deg",
            "report_outcomes": "otgym.experiments.orient.run:report_outcomes",
        },
    ),
    (
        "tasks",
        "sort-cells",
        "otgym.tasks.sort_cells:SortCells",
        "cells of two sizes arrive with the flow; robots (or a trap) move each into its outlet",
        (),
        {
            "gym_id": "otgym/sort-cells-v0",
            "report_seed": "77000",
            "training_seed": "40",
            "report_preset": "robots",
            "report_policy": "sort_cells_robots.npz",
            "report_baseline": "the scripted baseline (each cell moved 5 um past the inlet's axis on its side)",
            "report_metrics": "purity,yield,cells_sorted,cells_missorted,cells_lost,light_dose_per_cell_mj_per_um2",
            "report_secondary": "throughput_cells_per_min",
            "report_outcomes": "otgym.experiments.sort_cells.run:report_outcomes",
        },
    ),
    # robots
    (
        "robots",
        "two-handle",
        "otgym.physics.robots:TWO_HANDLE",
        "the paper's microrobot: a rod of spheres with a trapped handle at each end",
        (),
        {},
    ),
    (
        "robots",
        "four-arm",
        "otgym.physics.robots:FOUR_ARM",
        "a hub with four arms at 90 degrees, a handle at each arm's end",
        (),
        {},
    ),
    # devices
    (
        "devices",
        "keyboard",
        "otgym.teleop.pygame_devices:KeyboardMouseDevice",
        "arrow keys move the robots, the mouse drags one (the window's keyboard and mouse)",
        ("play", "node", "window", "driver"),
        {"play_binding": "otgym.ui.bindings:ONE_WINDOW_DEVICE_FOR_BOTH"},
    ),
    (
        "devices",
        "gamepad",
        "otgym.teleop.pygame_devices:GamepadDevice",
        "a gamepad's two sticks, one robot each",
        ("play", "node", "window", "driver"),
        {"play_binding": "otgym.ui.bindings:A_STICK_EACH"},
    ),
    (
        "devices",
        "touch",
        "otgym.teleop.touch:TouchDevice",
        "3D Systems' Geomagic Touch haptic stylus, with force feedback (needs OpenHaptics)",
        ("play", "node", "driver"),
        {"play_binding": "otgym.ui.bindings:A_DEVICE_EACH_BY_NAME", "node_options": "device-name=device_name"},
    ),
    (
        "devices",
        "simulated",
        "otgym.teleop.servo:simulated_haptic_device",
        "a simulated haptic stylus in its own 1 kHz servo process, with force feedback",
        ("play", "node", "driver"),
        {"play_binding": "otgym.ui.bindings:ROBOT_0_ONLY"},
    ),
    (
        "devices",
        "replay",
        "otgym.teleop.replay:ReplayDevice",
        "a recorded stream of device samples (CSV), replayed in real time (looped in a device node)",
        ("node", "driver"),
        {"node_options": "replay=path!", "node_driver": "otgym.teleop.replay:looped_replay"},
    ),
    (
        "devices",
        "mouse",
        "otgym.teleop.mouse_drag:MouseDragDevice",
        "the window's mouse alone: drag a robot to grip and carry",
        ("window",),
        {"window_takeover": "yes"},
    ),
    (
        "devices",
        "twist",
        "otgym.bus.twist_source:run_node",
        "ROS 2 geometry_msgs/Twist commands from the bus (teleop_twist_keyboard, teleop_twist_joy)",
        ("node",),
        {"node_options": "twist-topic=topic"},
    ),
    # navigators
    (
        "navigators",
        "route",
        "otgym.autonomy.navigator:RouteNavigator",
        "the formation follows the planned route at a cruise speed (the paper's autonomy)",
        ("shared", "in-process", "session-default"),
        {"label": "route follower"},
    ),
    (
        "navigators",
        "mpc",
        "otgym.autonomy.mpc_navigator:MPCNavigator",
        "model-predictive navigation: replans the formation's motion around predicted obstacles",
        ("trial-mode", "shared"),
        {
            "label": "MPC",
            "start_note": "its model, grip calibration and first compile take about a minute on 2 cores; "
            "its replans, about 74 ms each, need a process of their own",
            "about": "the MPC (model-predictive navigation: it predicts the obstacles and steps aside or waits)",
            "measured": "the MPC's measured rate is 128 of 128 goals and 459 of 460 obstacles avoided on 128 "
            "held-out scenarios (`otgym experiment shared-control --modes mpc`, seed 13; docs/mpc.md)",
            "acceptance_rate": "0.99",
        },
    ),
    (
        "navigators",
        "rl",
        "otgym.autonomy.rl_navigator:RLNavigator",
        "the route navigator with a learned speed (a DQN trained on the interactive task)",
        ("trial-mode", "shared", "in-process"),
        {
            "label": "learned speed",
            "about": "the learned speed (the route follower whose speed a DQN chooses: it slows or waits for "
            "obstacles ahead, but never steps aside)",
            "measured": "the learned speed's measured rate is 294 of 449 obstacles avoided (65.5 %) against the "
            "5 um/s route follower's 285 of 480 on the held-out report seed 7800 (docs/rl-navigator.md)",
        },
    ),
    # shared-control laws
    (
        "laws",
        "paper",
        "otgym.shared.arbitration:paper_alpha",
        "the paper's Eq. 4: alpha falls linearly from 0.5 near an obstacle to 0.1 far from it",
        (),
        {},
    ),
    (
        "laws",
        "step",
        "otgym.shared.arbitration:step_alpha",
        "three steps: 0.5 below d1, 0.3 up to d2, 0.1 beyond",
        (),
        {},
    ),
    (
        "laws",
        "smooth",
        "otgym.shared.arbitration:smooth_alpha",
        "the paper's ramp through a smoothstep (same ends, zero slope there)",
        (),
        {},
    ),
    # plants
    (
        "plants",
        "simulator",
        "otgym.task.rig:simulator",
        "otgym's physics: the interactive task's simulated robots, cell and obstacles",
        (),
        {},
    ),
    (
        "plants",
        "rig",
        "otgym.task.rig:RigPlant",
        "a rig outside otgym: trap commands out on /otgym/traps, measured spheres in on /otgym/rig/poses",
        ("measured",),
        {},
    ),
)
