"""Demo experiment: the paper's two-handle microrobot carried by two optical traps.

The traps steer the robot around a rounded square at constant speed while Brownian
motion, the trap law and the robot's mobility act; the experiment records the robot's
pose and the handle-to-trap distances and writes them as a CSV, a figure and a short
summary. Everything runs through the public physics API.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from otgym import physics as ph


@dataclasses.dataclass(frozen=True)
class TrappedRobotDemo:
    speed_um_s: float = 5.0
    side_um: float = 20.0
    record_rate_hz: float = 50.0
    dt_s: float = 1e-4
    seed: int = 0
    trap_law: ph.TrapLaw = ph.TrapLaw("gaussian", stiffness_pn_per_um=50.0, waist_um=0.6)

    def __post_init__(self):
        ph.validation.require_positive_scalar("speed_um_s", self.speed_um_s)
        ph.validation.require_positive_scalar("side_um", self.side_um)
        ph.validation.require_positive_scalar("record_rate_hz", self.record_rate_hz)


def _square_velocities(demo: TrappedRobotDemo, n_records: int, period_s: float) -> np.ndarray:
    """Trap velocity for each record interval: round a square of the given side."""
    records_per_side = max(1, int(round(demo.side_um / demo.speed_um_s / period_s)))
    leg = (np.arange(n_records) // records_per_side) % 4
    directions = np.array([[1, 0], [0, 1], [-1, 0], [0, -1]], float)
    return directions[leg] * demo.speed_um_s


def run(demo: TrappedRobotDemo, out_dir: Path, progress=None) -> dict:
    """Simulate one lap and write ``trajectory.csv``, ``trajectory.png`` and
    ``summary.json`` into ``out_dir``; returns the summary."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    period = 1.0 / demo.record_rate_hz
    substeps = max(1, int(round(period / demo.dt_s)))
    config = ph.PhysicsConfig(dt_s=period / substeps, substeps=substeps, trap_law=demo.trap_law)
    model = ph.build_model([ph.two_handle_robot("robot")], config)
    state = ph.initial_state(model, [[0.0, 0.0, 0.0]])
    n_records = int(round(4 * demo.side_um / demo.speed_um_s / period))
    velocities = _square_velocities(demo, n_records, period)
    step = jax.jit(ph.control_step)
    key = jax.random.PRNGKey(demo.seed)
    rows = []
    for index in range(n_records):
        key, step_key = jax.random.split(key)
        controls = ph.Controls.zeros(model).replace(
            trap_velocity_um_s=jnp.tile(jnp.asarray(velocities[index], jnp.float32), (model.n_traps, 1)))
        state, report = step(model, state, controls, step_key)
        pose = np.asarray(state.pose[0], float)
        distance = np.asarray(report.trap_distance_um, float)
        force = np.asarray(model.trap_law.magnitude_pn(report.trap_distance_um), float)
        rows.append([(index + 1) * period, *pose, *distance, *force, bool(np.any(report.trap_lost))])
        if progress is not None:
            progress(index + 1, n_records)
    table = np.array(rows, float)
    header = "t_s,x_um,y_um,theta_rad,handle0_trap_distance_um,handle1_trap_distance_um," \
             "handle0_trap_force_pn,handle1_trap_force_pn,trap_lost"
    np.savetxt(out_dir / "trajectory.csv", table, delimiter=",", header=header, comments="",
               fmt=["%.4f"] + ["%.6f"] * 7 + ["%d"])
    summary = {
        "duration_s": float(table[-1, 0]),
        "trap_speed_um_s": demo.speed_um_s,
        "mean_handle_trap_distance_um": float(table[:, 4:6].mean()),
        "max_handle_trap_distance_um": float(table[:, 4:6].max()),
        "mean_trap_force_pn": float(table[:, 6:8].mean()),
        "trap_lost": bool(table[:, 8].any()),
        "escape_speed_um_s": float(demo.trap_law.max_force_pn * 2 * np.asarray(model.body_mobility)[0, 0]),
    }
    (out_dir / "summary.json").write_text(json.dumps(summary, indent=2))
    _plot(table, out_dir / "trajectory.png", summary)
    return summary


def _plot(table: np.ndarray, path: Path, summary: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4.2))
    left.plot(table[:, 1], table[:, 2], lw=1, color="tab:blue", label="robot drag centre")
    left.set_aspect("equal")
    left.set_xlabel("x (um)")
    left.set_ylabel("y (um)")
    left.set_title("Two-handle robot carried by two traps")
    left.legend(loc="center")
    right.plot(table[:, 0], 1000 * table[:, 4], lw=0.8, label="handle 0")
    right.plot(table[:, 0], 1000 * table[:, 5], lw=0.8, label="handle 1")
    right.set_xlabel("time (s)")
    right.set_ylabel("handle-to-trap distance (nm)")
    right.set_title(f"trap speed {summary['trap_speed_um_s']:g} um/s, "
                    f"mean force {summary['mean_trap_force_pn']:.2f} pN")
    right.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
