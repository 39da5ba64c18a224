"""The human motor model: its population, delay, intermittency, noise, tremor and compliance.

Statistical checks run on fixed seeds, so they are deterministic; each tolerance is
the stated quantile (or 4 standard errors) of the statistic's sampling distribution
under the model, so a wrong model (a wrong SD, band or scaling) fails them.
"""

import dataclasses
import math

import numpy as np
import pytest
from scipy import signal, stats

from otgym.human.motor import TREMOR_WARMUP_S, HumanMotor, _tremor_filter
from otgym.human.params import MONOTONOUS_TRACKING_LAPSE_RATE_PER_H, POPULATION_CV, HumanParams, sample_population

# A hand without randomness: no tremor, motor noise, movement errors, jitter or lapses.
STILL = HumanParams(
    signal_dependent_noise=0.0,
    tremor_rms_mm=0.0,
    drift_rms_mm=0.0,
    extent_error_fraction=0.0,
    direction_error_deg=0.0,
    correction_jitter_fraction=0.0,
    lapse_rate_per_h=0.0,
)


def _run_until_due(motor):
    """Step a motor (no force) until every participant's sub-movement is due."""
    while not motor.decide_due().all():
        motor.step()


def test_population_is_reproducible_and_participant_i_does_not_depend_on_n():
    population = sample_population(20, seed=3)
    assert population == sample_population(20, seed=3)
    assert sample_population(5, seed=3) == population[:5]
    assert sample_population(20, seed=4) != population
    assert len({p.reaction_time_s for p in population}) == 20
    assert all(p.tremor_band_hz == (8.0, 12.0) and p.fitts_a_s == HumanParams().fitts_a_s for p in population)


def test_population_spread_is_the_stated_log_normal():
    """2000 participants. log(reaction time) ~ N(log(0.2) - s^2/2, s^2) with
    s^2 = log(1 + 0.15^2): its sample mean must lie in the 99 % t interval and its
    sample SD in the 99 % chi-square interval (n - 1 = 1999 degrees of freedom). Every
    other varied parameter's log-SD must lie in its 99.9 % chi-square interval (the lapse
    rate's around Peiris et al.'s 39.3 per hour: the default, 0, has no spread)."""
    n = 2000
    population = sample_population(n, seed=11, mean=HumanParams(lapse_rate_per_h=MONOTONOUS_TRACKING_LAPSE_RATE_PER_H))
    chi2_99 = np.sqrt(stats.chi2.ppf([0.005, 0.995], n - 1) / (n - 1))
    chi2_999 = np.sqrt(stats.chi2.ppf([0.0005, 0.9995], n - 1) / (n - 1))
    for name, cv in POPULATION_CV.items():
        logs = np.log([getattr(p, name) for p in population])
        sigma = math.sqrt(math.log1p(cv**2))
        low, high = chi2_99 if name == "reaction_time_s" else chi2_999
        assert low * sigma <= logs.std(ddof=1) <= high * sigma, name
        if name == "reaction_time_s":
            expected = math.log(0.2) - sigma**2 / 2
            half_width = stats.t.ppf(0.995, n - 1) * logs.std(ddof=1) / math.sqrt(n)
            assert abs(logs.mean() - expected) <= half_width
    reaction = np.array([p.reaction_time_s for p in population])
    assert 0.025 < reaction.std() < 0.035  # SD about 30 ms around 0.2 s


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda: HumanParams(reaction_time_s=-0.1), "reaction_time_s must be non-negative"),
        (lambda: HumanParams(neuromuscular_lag_s=0.0), "neuromuscular_lag_s must be positive"),
        (lambda: HumanParams(tremor_band_hz=(12.0, 8.0)), "tremor_band_hz"),
        (lambda: sample_population(3, 0, cv={"tremor_band_hz": 0.1}), "not a scalar"),
        (lambda: HumanMotor(HumanParams(), 20.0, 0), "tick_rate_hz 20 is too low"),
        (lambda: HumanMotor([HumanParams()] * 2, 50.0, 0, batch=3), "batch 3 differs"),
        (lambda: HumanMotor(HumanParams(), 50.0, 0).plan(np.zeros((2, 2)), 1.0), "shape"),
        (lambda: HumanMotor(HumanParams(), 50.0, 0).submovement_duration_s(1.0, 0.0), "tolerance_mm"),
    ],
)
def test_bad_parameters_are_rejected(make, message):
    with pytest.raises(ValueError, match=message):
        make()


def test_perceive_returns_the_observation_a_reaction_time_ago():
    reaction_s = (0.0, 0.126, 0.2, 0.37)  # 0, 6, 10, 18 ticks at 50 Hz
    motor = HumanMotor([dataclasses.replace(STILL, reaction_time_s=r) for r in reaction_s], 50.0, 0)
    assert motor.delay_ticks.tolist() == [0, 6, 10, 18]
    for k in range(40):
        seen = motor.perceive(np.stack([np.full(4, k), -np.full(4, k)], axis=1))
        assert seen[:, 0].tolist() == [max(k - d, 0) for d in (0, 6, 10, 18)]
        assert np.array_equal(seen[:, 1], -seen[:, 0])
    motor.reset(np.array([False, False, True, False]))  # a new trial for participant 2 only
    seen = motor.perceive(np.full((4, 2), 100.0))
    assert seen[:, 0].tolist() == [100.0, 34.0, 100.0, 22.0]


def test_corrections_start_a_reaction_time_after_reset_then_every_interval():
    motor = HumanMotor(dataclasses.replace(STILL, reaction_time_s=0.3, correction_interval_s=0.5), 100.0, 0)
    due = []
    for _ in range(300):
        due.append(motor.decide_due()[0])
        motor.step()
    assert np.flatnonzero(due).tolist() == [30, 80, 130, 180, 230, 280]


def test_jittered_intervals_have_the_stated_mean_and_spread():
    """About 2000 intervals (200 participants, 4.5 s) of 0.4 s with log-normal jitter of
    CV 0.2, rounded to 10 ms ticks: their mean within 4 standard errors
    (SE = 0.2 * 0.4 s / sqrt(count)) plus half a tick of rounding, their CV within 0.03."""
    motor = HumanMotor(dataclasses.replace(STILL, correction_jitter_fraction=0.2), 100.0, 5, batch=200)
    due = []
    for _ in range(450):
        due.append(motor.decide_due())
        motor.step()
    intervals = np.concatenate([np.diff(np.flatnonzero(column)) for column in np.array(due).T]) / 100.0
    assert intervals.size > 1500
    assert abs(intervals.mean() - 0.4) < 4 * 0.2 * 0.4 / math.sqrt(intervals.size) + 0.005
    assert abs(intervals.std() / intervals.mean() - 0.2) < 0.03


@pytest.mark.slow
def test_lapses_come_at_their_rate_and_stop_corrections():
    """100 participants with 360 lapses per hour (0.1 per s) lasting 2 s on average, for
    60 s at 50 Hz: the number of lapses started over the time not lapsed is Poisson; it
    must lie in its 99.9 % interval. No correction is due during a lapse."""
    params = dataclasses.replace(STILL, lapse_rate_per_h=360.0, lapse_duration_s=2.0)
    motor = HumanMotor(params, 50.0, 2, batch=100)
    lapsed = []
    for _ in range(3000):
        lapsed.append(motor.lapsed)
        assert not np.any(lapsed[-1] & motor.decide_due())
        motor.step()
    lapsed = np.array(lapsed)
    starts = int(np.sum(lapsed[1:] & ~lapsed[:-1]))
    low, high = stats.poisson.ppf([0.0005, 0.9995], 0.1 * np.sum(~lapsed[:-1]) / 50.0)
    assert low <= starts <= high
    assert abs(lapsed[500:].mean() - 0.2 / 1.2) < 0.03  # the fraction of time lapsed, r d / (1 + r d)


@pytest.mark.parametrize("rate_hz", [50.0, 100.0])
def test_tremor_sits_in_its_band_with_its_rms(rate_hz):
    """60 s of a still hand for two participants (0.05 and 0.1 mm RMS): the stylus
    displacement (the integrated velocity) has over 80 % of its Welch power in 8-12 Hz,
    and its RMS (both axes) lies within 4 standard errors of the target. The SE of a
    Gaussian process's sample variance is sqrt(2 / N * sum_tau rho(tau)^2) of the
    variance, rho the autocorrelation of the band-pass filter's impulse response."""
    targets = (0.05, 0.1)
    motor = HumanMotor([dataclasses.replace(STILL, tremor_rms_mm=r) for r in targets], rate_hz, 7)
    n = int(60 * rate_hz)
    velocity = np.array([motor.step() for _ in range(n)])
    displacement = np.cumsum(velocity, axis=0) / rate_hz
    displacement -= displacement.mean(axis=0)
    sos, gain = _tremor_filter((8.0, 12.0), rate_hz)
    impulse = np.zeros(int(4 * TREMOR_WARMUP_S * rate_hz))
    impulse[0] = 1.0
    h = signal.sosfilt(sos, impulse)
    rho = np.correlate(h, h, mode="full") / gain
    se_rms = 0.5 * math.sqrt(2.0 / (2 * n) * np.sum(rho**2))  # two axes pooled
    for i, target in enumerate(targets):
        rms = math.sqrt(np.mean(displacement[:, i] ** 2))
        assert abs(rms / target - 1) < 4 * se_rms, (rms, target, se_rms)
        for axis in range(2):
            frequency, power = signal.welch(displacement[:, i, axis], fs=rate_hz, nperseg=int(10 * rate_hz))
            in_band = (frequency >= 8.0) & (frequency <= 12.0)
            assert power[in_band].sum() > 0.8 * power.sum()


def test_signal_dependent_noise_grows_in_proportion_to_speed():
    """Two participants move steadily at 1 and 4 mm/s for 70 s with a noise fraction of
    0.1. After the 1 s lag transient the velocity error is an AR(1) sequence with
    coefficient phi = exp(-dt / lag) and SD 0.1 * speed per axis; the SE of its sample
    SD is 0.5 * sqrt(2 / N * (1 + phi^2) / (1 - phi^2)) of the SD (N samples, both
    axes pooled). Each SD must lie within 4 SE of 0.1 * speed."""
    params = dataclasses.replace(STILL, signal_dependent_noise=0.1)
    motor = HumanMotor(params, 100.0, 9, batch=2)
    speeds = np.array([1.0, 4.0])
    _run_until_due(motor)
    duration_s = 70.0
    motor.plan(np.stack([speeds * duration_s, np.zeros(2)], axis=1), 1.0, speeds)
    command = motor.command_mm_s
    assert np.allclose(command, [[1.0, 0.0], [4.0, 0.0]])
    errors = np.array([motor.step() - command for _ in range(int(duration_s * 100) - 10)])[100:]
    phi = math.exp(-0.01 / params.neuromuscular_lag_s)
    se = 0.5 * math.sqrt(2.0 / errors[:, 0].size / 2 * (1 + phi**2) / (1 - phi**2))
    sd = np.sqrt(np.mean(errors**2, axis=(0, 2)))
    assert np.all(np.abs(sd / (0.1 * speeds) - 1) < 4 * se), (sd, se)
    assert sd[1] > 3 * sd[0]


def test_no_motor_noise_without_a_command():
    motor = HumanMotor(dataclasses.replace(STILL, signal_dependent_noise=0.5), 100.0, 0)
    assert all(np.array_equal(motor.step(), np.zeros((1, 2))) for _ in range(50))


def test_a_smaller_tolerance_gives_a_longer_submovement():
    params = dataclasses.replace(STILL, correction_interval_s=0.05, preferred_speed_mm_s=1000.0)
    motor = HumanMotor(params, 100.0, 0, batch=2)
    tolerance = np.array([0.1, 2.0])
    duration = motor.submovement_duration_s(10.0, tolerance)
    assert np.allclose(duration, params.fitts_a_s + params.fitts_b_s_per_bit * np.log2(10.0 / tolerance + 1))
    assert duration[0] > 2 * duration[1]
    _run_until_due(motor)
    motor.plan(np.array([[10.0, 0.0], [10.0, 0.0]]), tolerance)
    moving = []
    for _ in range(100):
        moving.append(np.any(motor.command_mm_s != 0, axis=1))
        motor.step()
    assert np.sum(moving, axis=0).tolist() == np.rint(duration * 100).astype(int).tolist()
    # the preferred speed and a task's speed limit cap it too
    assert motor.submovement_duration_s(10.0, 2.0, max_speed_mm_s=1.0)[0] == pytest.approx(10.0)


@pytest.mark.slow
def test_planned_movements_carry_the_stated_extent_and_direction_errors():
    """2000 participants plan 10 mm along x: the executed displacement's extent factor
    has SD 0.1 and its direction SD 4 deg; both sample SDs in their 99.9 % chi-square
    intervals. Participants not due keep still."""
    n = 2000
    params = dataclasses.replace(HumanParams(), correction_jitter_fraction=0.0, lapse_rate_per_h=0.0)
    not_due = np.arange(n) % 10 == 0  # these react a tick later, so they are not due yet
    late = dataclasses.replace(params, reaction_time_s=0.21)
    motor = HumanMotor([late if slow else params for slow in not_due], 100.0, 13)
    while not motor.decide_due()[1]:
        motor.step()
    assert np.array_equal(motor.decide_due(), ~not_due)
    motor.plan(np.tile([10.0, 0.0], (n, 1)), 1.0)
    executed = motor.command_mm_s * motor.submovement_duration_s(10.0, 1.0)[:, None]
    assert np.all(executed[not_due] == 0)
    executed = executed[~not_due]
    extent = np.linalg.norm(executed, axis=1) / 10.0
    angle = np.degrees(np.arctan2(executed[:, 1], executed[:, 0]))
    low, high = np.sqrt(stats.chi2.ppf([0.0005, 0.9995], extent.size - 1) / (extent.size - 1))
    assert low * 0.1 <= extent.std(ddof=1) <= high * 0.1
    assert low * 4.0 <= angle.std(ddof=1) <= high * 4.0


def test_a_steady_force_displaces_the_hand_by_force_over_arm_stiffness():
    """The arm is a mass-spring-damper about the intended motion: under a steady
    opposing force F the hand falls behind its free path by F / k and then moves at
    the intended speed again; in the first tick it yields far less than F / b (the
    arm's mass), and a sideways push displaces it sideways. Catches a pure damper (an
    unbounded yield), a wrong sign, or a yield that ignores the stiffness."""
    params = dataclasses.replace(STILL, arm_damping_n_s_per_m=8.0, arm_stiffness_n_per_m=400.0, arm_mass_kg=1.0)
    motor = HumanMotor(params, 50.0, 0)
    _run_until_due(motor)
    motor.plan(np.array([[60.0, 0.0]]), 1.0, 2.0)  # 2 mm/s along x for 30 s
    for _ in range(150):  # 3 s: the 0.1 s lag has settled (to exp(-30))
        free = motor.step()
    assert np.allclose(free, [[2.0, 0.0]], rtol=0, atol=1e-9)
    force = np.array([[-0.01, 0.004]])
    first = motor.step(force)
    assert 0 < 2.0 - first[0, 0] < 0.2 * 0.01 / 8.0 * 1000.0 and first[0, 1] > 0
    behind = (np.array([2.0, 0.0]) - first) * 0.02
    for _ in range(499):  # 10 s: the arm's decay time 2 m / b = 0.25 s, 40 of them
        behind += (np.array([2.0, 0.0]) - motor.step(force)) * 0.02
    np.testing.assert_allclose(behind[0], [0.01 / 400.0 * 1000.0, -0.004 / 400.0 * 1000.0], rtol=1e-3)
    assert np.allclose(motor.step(force), [[2.0, 0.0]], rtol=0, atol=1e-6)  # settled: intended speed again


def test_the_motor_is_reproducible_by_seed():
    def run(seed):
        motor = HumanMotor(sample_population(3, seed=1), 50.0, seed)
        out = []
        for k in range(200):
            motor.perceive(np.zeros((3, 2)))
            motor.plan(np.full((3, 2), 5.0 - 0.02 * k), 0.5)
            out.append(motor.step())
        return np.array(out)

    assert np.array_equal(run(0), run(0))
    assert not np.allclose(run(0), run(1))


@pytest.mark.slow
def test_two_hands_of_one_person_err_together_on_the_common_part():
    """1000 persons (2000 hands, ``hands_per_person=2``) plan a common 10 mm along x plus
    +-0.5 mm along y (the hands move apart by 1 mm): the common part of the executed
    displacements carries the 10 % extent error, but the hands' separation errs only
    in proportion to the 1 mm difference (each hand's 0.5 mm errs on its own: SD
    0.1 mm / sqrt(2) along y and 4 deg of 1 mm / sqrt(2) across), in 99.9 % chi-square
    intervals. Uncoupled hands (one per person)
    given the same plans separate with the common part's errors, about 10 times more."""
    n = 1000
    params = dataclasses.replace(
        HumanParams(),
        correction_jitter_fraction=0.0,
        lapse_rate_per_h=0.0,
        signal_dependent_noise=0.0,
        tremor_rms_mm=0.0,
        drift_rms_mm=0.0,
    )
    plan = np.tile([[10.0, -0.5], [10.0, 0.5]], (n, 1))
    low, high = np.sqrt(stats.chi2.ppf([0.0005, 0.9995], n - 1) / (n - 1))
    separations = {}
    for hands in (2, 1):
        motor = HumanMotor(params, 100.0, 21, batch=2 * n, hands_per_person=hands)
        _run_until_due(motor)
        motor.plan(plan, 1.0)
        duration = motor.submovement_duration_s(np.hypot(10.0, 0.5), 1.0)[:, None]
        executed = (motor.command_mm_s * duration).reshape(n, 2, 2)
        separations[hands] = executed[:, 1] - executed[:, 0]
        if hands == 2:  # (uncoupled, the mean of two independent errors errs by 0.1 / sqrt(2))
            common = executed.mean(axis=1)
            assert low * 0.1 <= (np.linalg.norm(common, axis=1) / 10.0).std(ddof=1) <= high * 0.1
    coupled = separations[2]  # each hand's 0.5 mm difference errs on its own: 1 mm * error / sqrt(2)
    along = 0.1 / math.sqrt(2)
    assert low * along <= coupled[:, 1].std(ddof=1) <= high * along
    across = math.radians(4.0) / math.sqrt(2)
    assert low * across <= coupled[:, 0].std(ddof=1) <= high * across
    assert separations[1][:, 0].std(ddof=1) > 5 * coupled[:, 0].std(ddof=1)


def test_two_hands_of_one_person_start_together_and_lapse_together():
    """With jittered correction intervals and frequent lapses, a person's two hands are
    due on exactly the same ticks; one hand per person would not be."""
    params = dataclasses.replace(STILL, correction_jitter_fraction=0.3, lapse_rate_per_h=600.0)
    for hands, same in ((2, True), (1, False)):
        motor = HumanMotor(params, 100.0, 4, batch=20, hands_per_person=hands)
        due, lapsed = [], []
        for _ in range(3000):
            due.append(motor.decide_due().reshape(10, 2))
            lapsed.append(motor.lapsed.reshape(10, 2))
            motor.step()
        due, lapsed = np.array(due), np.array(lapsed)
        assert due.any() and lapsed.any()
        assert np.array_equal(due[..., 0], due[..., 1]) == same
        assert np.array_equal(lapsed[..., 0], lapsed[..., 1]) == same


def test_hands_per_person_must_divide_the_batch_and_share_parameters():
    with pytest.raises(ValueError, match="dividing"):
        HumanMotor(HumanParams(), 50.0, 0, batch=3, hands_per_person=2)
    with pytest.raises(ValueError, match="share"):
        HumanMotor([HumanParams(), HumanParams(reaction_time_s=0.3)], 50.0, 0, hands_per_person=2)
