"""What ``otgym experiment calibrate-scenarios`` offers before it runs: its default study
seed and the scenario parameters it sweeps. Apart from ``calibrate_scenarios`` (which
imports the task, the trials' runner and JAX) so that registering the command, which
every ``otgym`` process does (each node of ``otgym play --distributed`` among them),
imports none of that."""

DEFAULT_SEED = 90
"""The study seed of the original calibration (scenarios 900000-900063)."""
SWEEPABLE = (
    "timing_jitter_s",
    "obstacle_speed_um_s",
    "grip_time_s",
    "cruise_speed_um_s",
    "min_crossing_separation_um",
    "max_crossing_angle_deg",
    "park_clearance_um",
    "run_out_um",
    "wall_margin_um",
)
"""The scalar parameters that shape a scenario's tracks (``make_scenario``); the others
act while the task steps or change the number of obstacles."""
