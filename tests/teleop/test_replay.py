"""Recorded device streams: exact CSV round trip, playback by time stamps (on a
scripted clock, so no test depends on the machine's speed), bad files."""

from __future__ import annotations

import numpy as np
import pytest

from otgym.teleop.device import DeviceError, Sample, open_device
from otgym.teleop.replay import COLUMNS, ReplayDevice, load_samples, record_samples


def _samples():
    rng = np.random.default_rng(0)
    times = 100.0 + np.array([0.0, 0.1, 0.2, 0.5])
    return [Sample(t, 7 + i, rng.normal(size=3) * 10, rng.normal(size=3), i % 2) for i, t in enumerate(times)]


class _Clock:
    def __init__(self):
        self.now = 50.0

    def __call__(self):
        return self.now


def test_round_trip_is_exact(tmp_path):
    path = tmp_path / "stream.csv"
    samples = _samples() + [Sample(101.0, 20, [np.nan, 0, 0], [0, 0, 0], 3)]
    record_samples(samples, path)
    assert path.read_text().splitlines()[0] == ",".join(COLUMNS)
    loaded = load_samples(path)
    assert len(loaded) == len(samples)
    for a, b in zip(samples, loaded):
        assert (a.time_s, a.sequence, a.buttons) == (b.time_s, b.sequence, b.buttons)
        np.testing.assert_array_equal(a.position_mm, b.position_mm)
        np.testing.assert_array_equal(a.velocity_mm_s, b.velocity_mm_s)


def test_playback_follows_the_recorded_time_stamps(tmp_path):
    path = tmp_path / "stream.csv"
    samples = _samples()
    record_samples(samples, path)
    clock = _Clock()
    device = ReplayDevice(path, clock=clock)
    assert device.read() is None
    device.start()
    expected = {0.0: 0, 0.05: 0, 0.1: 1, 0.19: 1, 0.3: 2, 0.5: 3, 7.0: 3}
    for elapsed, index in expected.items():
        clock.now = 50.0 + elapsed
        sample = device.read()
        assert sample.sequence == samples[index].sequence
        np.testing.assert_array_equal(sample.position_mm, samples[index].position_mm)
        assert sample.time_s == pytest.approx(50.0 + samples[index].time_s - samples[0].time_s)
    device.stop()
    assert device.read() is None


def test_looped_playback_keeps_sequences_increasing(tmp_path):
    """Median interval 0.1 s, so one loop lasts 0.5 + 0.1 = 0.6 s."""
    path = tmp_path / "stream.csv"
    samples = _samples()
    record_samples(samples, path)
    clock = _Clock()
    device = open_device("replay", path=path, loop=True, clock=clock)
    device.start()
    clock.now = 50.0 + 0.6 + 0.15
    sample = device.read()
    assert sample.sequence == samples[1].sequence + len(samples)
    np.testing.assert_array_equal(sample.velocity_mm_s, samples[1].velocity_mm_s)
    assert sample.time_s == pytest.approx(50.0 + 0.6 + 0.1)


@pytest.mark.parametrize(
    "content, reason",
    [
        (None, "No such file"),
        ("", "header"),
        ("a,b,c\n1,2,3\n", "header"),
        (",".join(COLUMNS) + "\n", "no samples"),
        (",".join(COLUMNS) + "\n1,1,0,0,0,0,0,0\n", "8 fields"),
        (",".join(COLUMNS) + "\n1,1,x,0,0,0,0,0,0\n", "line 2"),
        (",".join(COLUMNS) + "\n1,1,0,0,0,0,0,0,0\n0.5,2,0,0,0,0,0,0,0\n", "non-decreasing"),
    ],
)
def test_bad_files_give_one_line_device_errors(tmp_path, content, reason):
    path = tmp_path / "stream.csv"
    if content is not None:
        path.write_text(content)
    with pytest.raises(DeviceError, match=reason) as info:
        ReplayDevice(path)
    assert "\n" not in str(info.value) and str(path) in str(info.value)
