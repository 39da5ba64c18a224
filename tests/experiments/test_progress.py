"""The experiment runs' progress lines: one per tenth reached, in order, never repeated."""

from otgym.experiments.common.progress import tenths


def test_each_tenth_is_reported_once_in_order_with_its_label():
    lines = []
    progress = tenths(lines.append, "shared")
    for fraction in (0.0, 0.0, 0.05, 0.12, 0.19, 0.35, 0.35, 1.0, 1.0):
        progress(fraction)
    assert lines == [
        "      shared: 0% of trials done",
        "      shared: 12% of trials done",
        "      shared: 35% of trials done",
        "      shared: 100% of trials done",
    ]
    unlabelled = []
    tenths(unlabelled.append)(0.5)
    assert unlabelled == ["      50% of trials done"]
