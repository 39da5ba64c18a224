"""``otgym study analyze`` from the command line: files written from a small synthetic study
(4 participants, two folders, with answers), four panels; bad input ends as one line
``error: ...`` and exit code 2."""

import json

import pandas as pd
import pytest

from otgym.cli.app import main
from tests.otgym_cli import run_otgym
from tests.study.test_analyze import PARTICIPANTS, write_answers, write_trials

COMMAND = ["study", "analyze"]


@pytest.mark.slow
def test_analyze_end_to_end(tmp_path):
    write_trials(tmp_path / "s1", PARTICIPANTS[:2])
    write_trials(tmp_path / "s2", PARTICIPANTS[2:])
    write_answers(tmp_path / "all")
    answers = pd.read_csv(tmp_path / "all" / "questionnaires.csv", dtype={"participant": str})
    answers[answers["participant"].isin(PARTICIPANTS[:2])].to_csv(tmp_path / "s1" / "questionnaires.csv", index=False)
    answers[answers["participant"].isin(PARTICIPANTS[2:])].to_csv(tmp_path / "s2" / "questionnaires.csv", index=False)
    out = tmp_path / "out"
    run = run_otgym(COMMAND + [str(tmp_path / "s1"), str(tmp_path / "s2"), "--out", str(out)])
    assert run.returncode == 0, run.stderr
    for name in ("fig8.png", "questionnaire_scores.csv", "summary.md", "summary.csv", "stats.json", "analysis.json"):
        assert (out / name).stat().st_size > 0, name
    assert len(json.loads((out / "analysis.json").read_text())["panels"]) == 4
    assert len(pd.read_csv(out / "questionnaire_scores.csv")) == 8
    assert "(d) UEQ-S" in run.stdout


def _fails(argv, capsys) -> str:
    with pytest.raises(SystemExit) as exit_:
        main(["study", "analyze"] + argv)
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and err.count("\n") == 1 and "Traceback" not in err
    return err


def test_bad_input_is_one_line_and_exit_code_2(tmp_path, capsys):
    out = tmp_path / "out"
    assert "missing does not exist" in _fails([str(tmp_path / "missing"), "--out", str(out)], capsys)
    assert not out.exists()
    (tmp_path / "empty").mkdir()
    assert "has no trials.csv" in _fails([str(tmp_path / "empty"), "--out", str(out)], capsys)
    write_trials(tmp_path / "s")
    pd.read_csv(tmp_path / "s" / "trials.csv").drop(columns="mode").to_csv(tmp_path / "s" / "trials.csv")
    assert "lacks column(s) ['mode']" in _fails([str(tmp_path / "s"), "--out", str(out)], capsys)
    write_trials(tmp_path / "s")
    target = tmp_path / "file.txt"
    target.write_text("x")
    assert "is a file" in _fails([str(tmp_path / "s"), "--out", str(target)], capsys)


def record_trials(path, frame: pd.DataFrame) -> None:
    """An MCAP recording whose trial_end events carry ``frame``'s rows, as ``otgym play``
    records them (non-finite numbers as null), between trial_start events and ticks."""
    import math

    from otgym.bus import messages as m
    from otgym.bus import schemas
    from otgym.record.mcap_file import McapRecorder

    with McapRecorder(path) as recorder:

        def write(topic, data):
            recorder.write(topic, m.topic_type(topic), schemas.SCHEMAS[m.topic_type(topic)], data)

        for row in frame.to_dict("records"):
            write(m.EVENTS, m.event("trial_start", trial=row["trial"], mode=row["mode"]))
            write(m.ALPHA, m.float64(0.5))
            row = {
                key: None if isinstance(value, float) and not math.isfinite(value) else value
                for key, value in row.items()
            }
            write(m.EVENTS, m.event("trial_end", **{k: v.item() if hasattr(v, "item") else v for k, v in row.items()}))


@pytest.mark.slow
def test_recordings_give_the_same_analysis_as_trials_csv(tmp_path, capsys):
    """The CSV path and the MCAP path (one file per folder, and a folder of two
    sessions with its questionnaires.csv) write identical summaries and tests."""
    write_trials(tmp_path / "csv", PARTICIPANTS)
    write_answers(tmp_path / "csv")
    frame = pd.read_csv(tmp_path / "csv" / "trials.csv", dtype={"participant": str})
    frame.loc[0, "success"] = float("nan")  # a trial that met no obstacle: recorded as null
    frame.to_csv(tmp_path / "csv" / "trials.csv", index=False)
    recorded = tmp_path / "recorded"
    recorded.mkdir()
    record_trials(recorded / "session.mcap", frame[frame["participant"].isin(PARTICIPANTS[:2])])
    record_trials(recorded / "session-2.mcap", frame[frame["participant"].isin(PARTICIPANTS[2:])])
    (tmp_path / "csv" / "questionnaires.csv").rename(recorded / "questionnaires.csv")
    write_answers(tmp_path / "csv")
    for source, out in (([tmp_path / "csv"], tmp_path / "from_csv"), ([recorded], tmp_path / "from_mcap")):
        run = run_otgym(COMMAND + [*map(str, source), "--out", str(out)])
        assert run.returncode == 0, run.stderr
    assert "trials from session.mcap, session-2.mcap" in run.stdout
    for name in ("summary.csv", "stats.json", "questionnaire_scores.csv"):
        assert (tmp_path / "from_csv" / name).read_text() == (tmp_path / "from_mcap" / name).read_text(), name
    # one file: the same trials of its participants
    single = tmp_path / "single"
    assert run_otgym(COMMAND + [str(recorded / "session.mcap"), "--out", str(single)]).returncode == 0
    assert json.loads((single / "analysis.json").read_text())["participants"] == 2


def test_a_simulator_nodes_recording_is_refused_with_one_line(tmp_path, capsys):
    from otgym.bus import messages as m
    from otgym.bus import schemas
    from otgym.record.mcap_file import McapRecorder

    with McapRecorder(tmp_path / "session.mcap") as recorder:
        recorder.write(
            m.EVENTS,
            m.STRING,
            schemas.SCHEMAS[m.STRING],
            m.event("trial_end", trial=1, ended_by="duration", completion_time_s=3.0),
        )
    assert "carry no trial rows" in _fails([str(tmp_path / "session.mcap"), "--out", str(tmp_path / "o")], capsys)
    (tmp_path / "notes.mcap").write_text("not mcap")
    assert "is not an MCAP file" in _fails([str(tmp_path / "notes.mcap"), "--out", str(tmp_path / "o")], capsys)
    assert not (tmp_path / "o").exists()


@pytest.mark.slow
def test_one_participant_draws_the_figure_and_says_no_test_is_possible(tmp_path):
    write_trials(tmp_path / "s", PARTICIPANTS[:1])
    out = tmp_path / "out"
    run = run_otgym(COMMAND + [str(tmp_path / "s"), "--out", str(out)])
    assert run.returncode == 0, run.stderr
    summary = (out / "summary.md").read_text()
    assert summary.count("No test: no test is possible with n < 2 (n = 1 participant(s)") == 2  # success, time
    assert "F(" not in summary and (out / "fig8.png").stat().st_size > 0
    stats = json.loads((out / "stats.json").read_text())
    assert stats["time"]["anova"]["p"] is None and all(p["p_holm"] is None for p in stats["time"]["posthoc"])
    one_mode = tmp_path / "one_mode"
    one_mode.mkdir()
    frame = pd.read_csv(tmp_path / "s" / "trials.csv")
    frame[frame["mode"] == "shared"].to_csv(one_mode / "trials.csv", index=False)
    run = run_otgym(COMMAND + [str(one_mode), "--out", str(tmp_path / "out1")])
    assert run.returncode == 0, run.stderr
    assert "No test: only one mode (shared): nothing to compare" in (tmp_path / "out1" / "summary.md").read_text()
