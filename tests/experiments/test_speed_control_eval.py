"""Evaluation against constant speeds (Table II): the RL row is the greedy policy on the
same episodes, constant rows take the exact time of their speed, the safety samples
and the acceptance checks are those of the rows."""

import math

import numpy as np
import pytest

from otgym.experiments.speed_control.evaluate import (
    SAFE_FRACTION,
    Evaluation,
    acceptance,
    evaluate,
    passes,
)
from otgym.experiments.speed_control.report import write_safety_figure, write_table
from tests.conftest import FIXED_POLICY_HIDDEN as HIDDEN

EPISODES = 4  # shared with the demo test, so both run one compiled rollout


pytestmark = pytest.mark.slow  # module fixtures that compile or solve for seconds


def steps_to_goal(params, speed_um_s):
    """Control steps a constant speed needs for a whole segment (float32 arcs round the last step)."""
    period = params.config.scene.control_period_s
    return math.ceil(params.config.segment_um / (speed_um_s * period) - 1e-3)


@pytest.fixture(scope="module")
def fastest_policy_evaluation(paper_params, fixed_action_q_params):
    return evaluate(paper_params, fixed_action_q_params(5), HIDDEN, EPISODES, seed=3)


def test_rows_carry_the_exact_times_of_their_speeds(paper_params, fastest_policy_evaluation):
    """The slowest group and the RL policy that always picks the fastest level take the
    exact times of their speeds whenever they succeed; the slowest group succeeds in
    every one of these episodes (P(failure) per episode < 0.005, measured in
    tests/envs/test_speed_control.py)."""
    rows = {row["policy"]: row for row in fastest_policy_evaluation.rows()}
    period = paper_params.config.scene.control_period_s
    levels = paper_params.config.speed_levels_um_s
    assert rows["G1"]["success_rate"] == 1.0 and rows["G1"]["ASR"] == pytest.approx(1.0, abs=1e-3)
    assert rows["G1"]["ATCT_s"] == pytest.approx(steps_to_goal(paper_params, levels[0]) * period, abs=1e-4)
    assert rows["RL"]["speed_um_s"] is None and rows["G6"]["speed_um_s"] == levels[5]
    # at the fastest level an episode succeeds with p ~ 0.94 (tests/envs/test_speed_control.py),
    # so P(none of 4) ~ 1e-5
    assert fastest_policy_evaluation.success[0].any()
    assert rows["RL"]["ATCT_s"] == pytest.approx(steps_to_goal(paper_params, levels[5]) * period, abs=1e-4)
    assert all(row["episodes"] == EPISODES for row in rows.values())


def test_repeats_pool_batches_of_consecutive_seeds(paper_params, fixed_action_q_params, fastest_policy_evaluation):
    """--repeats 2 from seed 3 is the seed-3 batch followed by the seed-4 batch: the same
    first episodes, twice the samples, and the interval narrows with the pooled count."""
    pooled = evaluate(paper_params, fixed_action_q_params(5), HIDDEN, EPISODES, seed=3, repeats=2)
    single = fastest_policy_evaluation
    np.testing.assert_array_equal(pooled.success[:, :EPISODES], single.success)
    np.testing.assert_allclose(pooled.time_s[:, :EPISODES], single.time_s)
    assert pooled.success.shape[1] == 2 * EPISODES
    assert pooled.force_pn[1].size == 2 * single.force_pn[1].size  # G1 always runs to the goal
    row = next(r for r in pooled.rows() if r["policy"] == "G1")
    assert (
        row["episodes"] == 2 * EPISODES
        and row["success_ci95_low"] > next(r for r in single.rows() if r["policy"] == "G1")["success_ci95_low"]
    )
    with pytest.raises(ValueError, match="repeats"):
        evaluate(paper_params, fixed_action_q_params(5), HIDDEN, EPISODES, seed=3, repeats=0)


def test_safety_samples_are_the_steps_each_policy_ran(paper_params, fastest_policy_evaluation):
    """Two force samples (one per robot) and four distance samples (one per handle)
    per control step of each episode, up to its end."""
    evaluation = fastest_policy_evaluation
    g1 = evaluation.names.index("G1")
    steps = steps_to_goal(paper_params, paper_params.config.speed_levels_um_s[0]) * EPISODES
    assert evaluation.force_pn[g1].size == 2 * steps and evaluation.distance_um[g1].size == 4 * steps
    safety = evaluation.safety("G1", 10.0, 0.2)
    assert safety["force_below_limit"] == pytest.approx(np.mean(evaluation.force_pn[g1] < 10.0))
    assert safety["distance_p99_um"] >= safety["distance_median_um"] > 0


def _paired_evaluation(rl_time_s: float, g3_success: int) -> Evaluation:
    """40 episodes: RL loses episode 0; G1 none; G2 loses episode 5; G3 keeps ``g3_success``.
    Times: G1 15 s, G2 11 s, G3 9 s, RL ``rl_time_s`` in every episode but the last
    four (11 s there, ties with G2)."""
    n = 40
    success = np.ones((5, n), bool)
    success[0, 0] = success[2, 5] = False
    success[3, g3_success:] = False
    time_s = np.stack([np.full(n, rl_time_s), np.full(n, 15.0), np.full(n, 11.0), np.full(n, 9.0), np.full(n, 20.0)])
    time_s[0, -4:] = 11.0
    empty = [np.zeros(0)] * 5
    return Evaluation(
        ["RL", "G1", "G2", "G3", "untrained"],
        [None, 1.0, 2.0, 3.0, None],
        success.astype(float),
        success,
        time_s,
        empty,
        empty,
    )


SAFE = {"force_below_limit": 1.0, "distance_within_limit": 1.0}


def test_acceptance_tests_rl_against_the_fastest_constant_speed_as_safe():
    """The reference is the fastest constant speed with a success rate >= RL's; RL must
    finish first significantly often on the episodes both completed (sign test), and
    McNemar's test counts the episodes only one of them lost."""
    checks = acceptance(_paired_evaluation(10.0, g3_success=30), SAFE)
    assert checks["reference"] == "G2"  # G3 (30/40) is less safe than RL (39/40), G2 (39/40) as safe
    # both completed 38 episodes; 4 of them tied at 11 s, RL first in the other 34
    assert (checks["faster_episodes"], checks["slower_episodes"]) == (34, 0)
    assert checks["speed_p"] == pytest.approx(0.5**34) and checks["beats_reference"] and passes(checks)
    assert (checks["rl_only_lost"], checks["reference_only_lost"], checks["safety_p"]) == (1, 1, 0.75)
    slower = acceptance(_paired_evaluation(12.0, g3_success=30), SAFE)
    assert slower["faster_episodes"] == 0 and slower["speed_p"] == 1.0 and not passes(slower)
    # G3 as safe as RL and quicker than it: RL is beaten
    faster_reference = acceptance(_paired_evaluation(10.0, g3_success=40), SAFE)
    assert faster_reference["reference"] == "G3" and not faster_reference["beats_reference"]
    forceful = dict(SAFE, force_below_limit=SAFE_FRACTION - 0.01)
    assert acceptance(_paired_evaluation(10.0, g3_success=30), forceful)["beats_reference"]
    assert not passes(acceptance(_paired_evaluation(10.0, g3_success=30), forceful))
    wandering = acceptance(_paired_evaluation(10.0, g3_success=30), dict(SAFE, distance_within_limit=0.5))
    assert not wandering["distance_safe"] and passes(wandering)


def test_acceptance_without_an_as_safe_constant_speed():
    evaluation = _paired_evaluation(10.0, g3_success=30)
    evaluation.success[0] = True  # RL loses none; every constant speed loses some
    evaluation.success[1, 7] = False
    checks = acceptance(evaluation, SAFE)
    assert checks["reference"] is None and checks["beats_reference"] and passes(checks)


def test_table_and_figure_files(tmp_path, fastest_policy_evaluation):
    rows = write_table(fastest_policy_evaluation, tmp_path)
    assert [row["policy"] for row in rows] == ["RL"] + [f"G{i}" for i in range(1, 7)]
    table = (tmp_path / "table.md").read_text()
    # our slowest group sits beside the paper's slowest column (66.56 s, printed as G6)
    assert next(line for line in table.splitlines() if line.startswith("| G1 ")).endswith("| 1.000 | 66.56 |")
    csv_lines = (tmp_path / "table.csv").read_text().splitlines()
    assert csv_lines[0].startswith("policy,speed_um_s,ASR,ATCT_s") and len(csv_lines) == 8
    write_safety_figure(fastest_policy_evaluation, tmp_path / "safety.png", 10.0, 0.2)
    assert (tmp_path / "safety.png").stat().st_size > 10_000


def test_paper_values_stand_beside_only_the_papers_speeds():
    """The ``realistic`` preset's 2-12 um/s groups are not the paper's: no paper column."""
    from otgym.experiments.common.paper_tables import table_ii_markdown
    from otgym.tasks.transport.presets import PAPER_SPEEDS_UM_S, realistic

    def rows(speeds):
        interval = {"success_ci95_low": 0.51, "success_ci95_high": 1.0}
        return [
            {
                "policy": "RL",
                "speed_um_s": None,
                "ASR": 1.0,
                "ATCT_s": 10.0,
                "success_rate": 1.0,
                **interval,
                "episodes": 4,
            }
        ] + [
            {
                "policy": f"G{i + 1}",
                "speed_um_s": v,
                "ASR": 1.0,
                "ATCT_s": 20.0,
                "success_rate": 1.0,
                **interval,
                "episodes": 4,
            }
            for i, v in enumerate(speeds)
        ]

    paper_lines = table_ii_markdown(rows(PAPER_SPEEDS_UM_S))
    assert "paper ASR" in paper_lines[0] and paper_lines[2].endswith("| 1.000 | 38.92 |")
    realistic_lines = table_ii_markdown(rows(realistic().speed_levels_um_s))
    assert "paper" not in realistic_lines[0] and realistic_lines[2].endswith("| 0.510-1.000 | 4 |")
