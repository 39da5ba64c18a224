"""The main job, ``otgym demo``: the paper's autonomous pipeline end to end on the
default chip, headless.

1. ``plan/``: A* + B-spline on the chip image against a simulated manual path
   (Table I, ``otgym.planning``).
2. ``speed_control/``: the shipped DQN speed controller against the six constant
   speeds on the same seeded episodes of the ``paper`` preset (Table II and the safety
   violins of Fig. 7, ``otgym.experiments.speed_control_eval``).
3. ``transport/``: the cell carried along the whole planned path at a constant speed
   in the ``realistic`` preset (``otgym.experiments.transport``).
4. ``report.md``: our numbers beside the paper's.
"""

from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path
from typing import Callable

from otgym.envs import speed_control as spc
from otgym.envs import transport as tr
from otgym.envs.presets import preset
from otgym.experiments import report
from otgym.experiments.speed_control_eval import evaluate, write_safety_figure, write_table
from otgym.experiments.transport import TransportDemo
from otgym.experiments.transport import run as run_transport
from otgym.planning.pipeline import write_plan
from otgym.rl.policy import load_policy, policy_meta, resolve_policy
from otgym.sim.chip import load_chip

PLAN_ROBOT_RADIUS_UM = 5.0
"""Robot radius of the Table I plan (the ``otgym plan`` default: one robot, as the
paper's Table I); the transport plans for the whole two-robot assembly instead."""


@dataclasses.dataclass(frozen=True)
class DemoConfig:
    policy: str = "pretrained"
    episodes: int = 256
    seed: int = 1
    transport: TransportDemo = TransportDemo()

    def __post_init__(self):
        if not isinstance(self.episodes, int) or self.episodes < 1:
            raise ValueError(f"episodes must be a positive integer, got {self.episodes!r}")


def run_demo(config: DemoConfig, out_dir: Path, stage: Callable[[str], None] = lambda _: None,
             progress: Callable[[int, int], None] | None = None) -> dict:
    """Run the four parts into ``out_dir``; ``stage(text)`` announces each part and
    ``progress(done, total)`` follows the transport's control steps. Returns a summary
    (also written as ``summary.json``). Policy problems raise before any work."""
    out_dir = Path(out_dir)
    policy_path = resolve_policy(config.policy)
    task = preset(policy_meta(policy_path).get("preset", "paper"))
    q_params, meta = load_policy(policy_path, tr.OBS_SIZE, task.n_actions)
    timings = {}

    stage("planning on the default chip (Table I)")
    start = time.perf_counter()
    chip = load_chip("default")
    transport = config.transport
    metrics = write_plan(chip.image, chip.pixel_size_um, transport.start_um, transport.goal_um, out_dir / "plan",
                         robot_radius_um=PLAN_ROBOT_RADIUS_UM, threshold=0.5)
    timings["plan_s"] = time.perf_counter() - start

    stage(f"speed control: RL and constant speeds, {config.episodes} episodes each (Table II)")
    start = time.perf_counter()
    evaluation = evaluate(spc.make_params(task), q_params, meta["hidden"], config.episodes, config.seed)
    speed_dir = out_dir / "speed_control"
    rows = write_table(evaluation, speed_dir)
    limits = task.force_band_pn[1], task.deviation_limit_um
    write_safety_figure(evaluation, speed_dir / "safety.png", *limits)
    safety = {name: evaluation.safety(name, *limits) for name in ("RL", "untrained")}
    (speed_dir / "safety.json").write_text(json.dumps(safety, indent=2))
    timings["speed_control_s"] = time.perf_counter() - start

    stage("carrying the cell along the whole path")
    start = time.perf_counter()
    transport_summary = run_transport(transport, out_dir / "transport", progress)
    timings["transport_s"] = time.perf_counter() - start

    header = (f"Policy `{policy_path.name}` (preset `{task.name}`, trained {meta.get('env_steps', '?')} steps), "
              f"evaluation seed {config.seed}. Wall times: " +
              ", ".join(f"{name[:-2]} {seconds:.0f} s" for name, seconds in timings.items()) + ".")
    report.write_report(out_dir / "report.md", [
        report.speed_control_section(rows, safety, *limits, task.name),
        report.planning_section(metrics),
        report.transport_section(transport_summary),
    ], header)
    rl = next(row for row in rows if row["policy"] == "RL")
    summary = {"table_ii": rows, "safety": safety, "transport": transport_summary,
               "table_i": {name: dataclasses.asdict(row) for name, row in metrics.items()},
               "rl_asr": rl["ASR"], "rl_atct_s": rl["ATCT_s"],
               "limits": {"force_pn": limits[0], "distance_um": limits[1]},
               "timings_s": {name: round(seconds, 1) for name, seconds in timings.items()}}
    (out_dir / "summary.json").write_text(json.dumps(summary, indent=2))
    return summary
