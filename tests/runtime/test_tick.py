"""The one control tick (``otgym.runtime.tick``) that the batched trials and the
real-time loop share: modes, alpha, the human's call, the blend and the speed cap."""

from types import SimpleNamespace

import numpy as np

from otgym.runtime.tick import arbitration_modes, control_tick, mode_alpha
from otgym.shared import ArbitrationConfig

CONFIG = ArbitrationConfig()  # paper law: 0.5 at or below 10 um, 0.1 at or beyond 20 um


def test_mpc_is_autonomous_and_shared_without_autonomy_is_manual():
    modes = ["manual", "shared", "autonomous", "mpc", "shared"]
    live = np.array([False, False, False, False, True])
    assert arbitration_modes(modes, live).tolist() == ["manual", "manual", "autonomous", "autonomous", "shared"]
    assert arbitration_modes(modes).tolist() == ["manual", "shared", "autonomous", "autonomous", "shared"]


def test_alpha_follows_each_mode_and_the_papers_law():
    gaps = np.array([5.0, 15.0, 25.0, 5.0, 5.0])
    alpha = mode_alpha(["shared", "shared", "shared", "manual", "mpc"], gaps, CONFIG)
    np.testing.assert_allclose(alpha, [0.5, 0.3, 0.1, 1.0, 0.0])


def test_the_command_blends_with_the_share_the_human_was_given_and_caps_the_speed():
    obs = SimpleNamespace(nearest_obstacle_gap_um=np.array([15.0, 15.0, 15.0]))
    human_um = np.tile([[[1.0, 0.0]]], (3, 2, 1))  # (E, T, 2)
    robot_um = np.tile([[[0.0, 1.0]]], (3, 2, 1))
    seen = {}

    def human(modes, alpha):
        seen.update(modes=modes.tolist(), alpha=alpha.copy())
        return human_um

    command = control_tick(
        obs, ["shared", "shared", "autonomous"], robot_um, human, CONFIG, 0.5, np.array([True, False, True])
    )
    assert seen["modes"] == ["shared", "manual", "autonomous"] == command.modes.tolist()
    np.testing.assert_allclose(seen["alpha"], [0.3, 1.0, 0.0])
    np.testing.assert_allclose(np.linalg.norm(command.shared_um, axis=-1), 0.5)  # every trap at the cap
    # shared: the blend (0.3, 0.7), 0.76 um long, scaled down to the 0.5 um cap along its direction
    np.testing.assert_allclose(command.shared_um[0], [0.5 * np.array([0.3, 0.7]) / np.hypot(0.3, 0.7)] * 2)
    np.testing.assert_allclose(command.shared_um[1], [[0.5, 0.0]] * 2)  # manual: the human's alone
    np.testing.assert_allclose(command.shared_um[2], [[0.0, 0.5]] * 2)  # autonomous: the robot's alone
    assert command.human_um is human_um
