"""Demo experiment: two microrobots carry a cell through the default chip.

The paper's autonomous pipeline at constant speed: plan on the chip image (A* and
B-spline, ``otgym.planning``) for the whole robot-cell assembly, then carry the four
traps along the path as one formation (``otgym.planning.formation``) while the physics
core simulates robots, cell, flow, walls and the four moving obstacles. Writes the
trajectory (CSV), a figure, the planned path and a summary.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from otgym import physics as ph
from otgym.physics.validation import require_positive_scalar
from otgym.planning import formation, plan_path, save_path_csv
from otgym.sim import scene as sc
from otgym.sim.chip import load_chip

CSV_HEADER = (
    "t_s,arc_um,cell_x_um,cell_y_um,robot_a_x_um,robot_a_y_um,robot_a_theta_rad,"
    "robot_b_x_um,robot_b_y_um,robot_b_theta_rad,contact_force_a_pn,contact_force_b_pn,"
    "gap_a_um,gap_b_um,max_trap_distance_um,trap_lost,cell_detached,obstacle_collision,wall_collision"
)


@dataclasses.dataclass(frozen=True)
class TransportDemo:
    start_um: tuple[float, float] = (15.0, 40.0)
    goal_um: tuple[float, float] = (285.0, 160.0)
    speed_um_s: float = 4.0
    n_runs: int = 8
    seed: int = 0
    scene: sc.SceneConfig = sc.SceneConfig()

    def __post_init__(self):
        require_positive_scalar("speed_um_s", self.speed_um_s)
        if not isinstance(self.n_runs, int) or self.n_runs < 1:
            raise ValueError(f"n_runs must be a positive integer, got {self.n_runs!r}")


def _step_function(scene: sc.Scene, path: formation.DensePath, offsets, period_s: float):
    @jax.jit
    def advance(states: sc.SceneState, arc_um, key):
        velocity = jax.vmap(lambda traps: formation.formation_velocity(path, offsets, traps, arc_um, period_s))(
            states.physics.trap_xy_um
        )
        return sc.step_batch(scene, states, velocity, key)

    return advance


def run(demo: TransportDemo, out_dir: Path, progress=None) -> dict:
    """Carry the cell along the planned path in ``n_runs`` environments at once (same
    start, different noise and obstacles); write ``path.csv``, ``trajectory.csv`` and
    ``transport.png`` of the first run that reached the goal (else the first run),
    and ``summary.json`` over all runs."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    scene = sc.build_scene(demo.scene)
    chip = load_chip(demo.scene.chip) if isinstance(demo.scene.chip, str) else demo.scene.chip
    plan = plan_path(
        chip.image,
        chip.pixel_size_um,
        demo.start_um,
        demo.goal_um,
        robot_radius_um=scene.assembly_radius_um,
        threshold=0.5,
    )
    save_path_csv(out_dir / "path.csv", plan.smoothed_um)
    path = formation.dense_path(plan.smoothed_um)
    period = demo.scene.control_period_s
    key, reset_key = jax.random.split(jax.random.PRNGKey(demo.seed))
    heading = formation.heading_at(path, 0.0)
    states = jax.vmap(lambda k: sc.reset_at(scene, k, path.points_um[0], heading))(
        jax.random.split(reset_key, demo.n_runs)
    )
    offsets = formation.formation_offsets(states.physics.trap_xy_um[0], path.points_um[0], heading)
    advance = _step_function(scene, path, offsets, period)
    length = float(path.length_um)
    n_steps = int(np.ceil(length / (demo.speed_um_s * period)))
    rows = [[] for _ in range(demo.n_runs)]
    outcome = ["reached the goal"] * demo.n_runs
    active = np.ones(demo.n_runs, bool)
    frames, arc = [], 0.0
    end_pose = np.array(states.physics.pose)
    end_traps = np.array(states.physics.trap_xy_um)
    for index in range(n_steps):
        arc = min(arc + demo.speed_um_s * period, length)
        key, step_key = jax.random.split(key)
        states, events = advance(states, jnp.asarray(arc, jnp.float32), step_key)
        host_states, host_events = jax.device_get((states, events))
        failed = np.asarray(host_events.failed)
        for run_index in np.flatnonzero(active):
            rows[run_index].append(_row(scene, host_states, host_events, run_index, arc))
            if failed[run_index]:
                outcome[run_index] = _failure(host_events, run_index)
        # where each run ended: a stopped run's environment keeps stepping with the batch
        end_pose[active] = np.asarray(host_states.physics.pose)[active]
        end_traps[active] = np.asarray(host_states.physics.trap_xy_um)[active]
        active &= ~failed
        if index % 10 == 0:
            frames.append(np.asarray(ph.sphere_positions_um(scene.model, host_states.physics.pose)))
        if progress is not None:
            progress(index + 1, n_steps)
        if not active.any():
            break
    successes = [i for i, text in enumerate(outcome) if text == "reached the goal"]
    shown = successes[0] if successes else 0
    table = np.array(rows[shown], float)
    np.savetxt(out_dir / "trajectory.csv", table, delimiter=",", header=CSV_HEADER, comments="", fmt="%.5g")
    ends = np.array([r[-1][2:4] for r in rows])
    summary = {
        "runs": demo.n_runs,
        "reached_goal": len(successes),
        "outcomes": outcome,
        "mean_completed_fraction": round(float(np.mean([r[-1][1] for r in rows]) / length), 4),
        "path_length_um": round(length, 2),
        "speed_um_s": demo.speed_um_s,
        "shown_run": shown,
        "shown_time_s": round(float(table[-1, 0]), 2),
        "shown_cell_to_goal_um": round(float(np.linalg.norm(ends[shown] - np.asarray(demo.goal_um))), 2),
        "mean_contact_force_pn": round(float(np.mean([np.mean(np.array(r)[:, 10:12]) for r in rows])), 3),
        "max_contact_force_pn": round(float(np.max([np.max(np.array(r)[:, 10:12]) for r in rows])), 3),
        "max_trap_distance_um": round(float(np.max([np.max(np.array(r)[:, 14]) for r in rows])), 4),
    }
    (out_dir / "summary.json").write_text(json.dumps(summary, indent=2))
    last_frame = np.asarray(ph.sphere_positions_um(scene.model, jnp.asarray(end_pose[shown])))
    _figure(
        chip,
        scene,
        last_frame,
        end_traps[shown],
        plan,
        table,
        [f[shown] for f in frames][: len(table) // 10 + 1],
        out_dir / "transport.png",
        summary,
    )
    return summary


def _row(scene, states, events, index, arc):
    pose = np.asarray(states.physics.pose[index], float)
    force = np.asarray(events.contact_force_pn[index], float)
    gap = np.asarray(events.cell_gap_um[index], float)
    return [
        float(states.time_s[index]),
        arc,
        *pose[scene.payload, :2],
        *pose[0],
        *pose[1],
        *force,
        *gap,
        float(np.max(events.trap_distance_um[index])),
        bool(np.any(events.trap_lost[index])),
        bool(events.cell_detached[index]),
        bool(events.obstacle_collision[index]),
        bool(events.wall_collision[index]),
    ]


def _failure(events, index) -> str:
    for name in ("trap_lost", "cell_detached", "obstacle_collision", "wall_collision"):
        if bool(np.any(getattr(events, name)[index])):
            return f"stopped: {name.replace('_', ' ')}"
    return "stopped"


def _figure(chip, scene, sphere_xy, trap_xy, plan, table, frames, path, summary):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from otgym.sim.render import SceneRenderer

    model = scene.model
    kinds = np.array([model.body_kinds[b] for b in model.sphere_body])
    handles = np.zeros(len(kinds), bool)
    handles[list(model.trap_sphere)] = True
    renderer = SceneRenderer(chip, size_px=(900, 600))
    image = renderer.render(sphere_xy, np.asarray(model.sphere_radius_um), kinds, handles, trap_xy, plan.smoothed_um)
    fig = plt.figure(figsize=(13, 5.2))
    ax = fig.add_axes([0.02, 0.08, 0.55, 0.86])
    ax.imshow(image)
    cell_px = renderer.to_px(table[:, 2:4])
    ax.plot(cell_px[:, 0], cell_px[:, 1], color="tab:green", lw=1.5, label="cell")
    for sphere_xy in frames:  # faint snapshots every 2 s
        robot_px = renderer.to_px(sphere_xy[[s for s, b in enumerate(model.sphere_body) if b in scene.robots]])
        ax.scatter(robot_px[:, 0], robot_px[:, 1], s=2, color="tab:orange", alpha=0.35)
    ax.set_title(
        f"Two robots carry a cell at {summary['speed_um_s']:g} um/s: "
        f"{summary['reached_goal']} of {summary['runs']} runs reached the goal (run {summary['shown_run']} shown)"
    )
    ax.axis("off")
    ax.legend(loc="lower left")
    force_ax = fig.add_axes([0.63, 0.56, 0.35, 0.36])
    force_ax.plot(table[:, 0], table[:, 10], lw=0.8, label="robot a")
    force_ax.plot(table[:, 0], table[:, 11], lw=0.8, label="robot b")
    force_ax.set_ylabel("robot-cell contact force (pN)")
    force_ax.legend()
    trap_ax = fig.add_axes([0.63, 0.1, 0.35, 0.36], sharex=force_ax)
    trap_ax.plot(table[:, 0], 1000 * table[:, 14], lw=0.8, color="tab:red")
    trap_ax.set_ylabel("largest handle-trap distance (nm)")
    trap_ax.set_xlabel("time (s)")
    fig.savefig(path, dpi=110)
    plt.close(fig)
