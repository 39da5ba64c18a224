"""``otgym study analyze`` from the command line: files written from a small synthetic study
(4 participants, two folders, with answers), four panels; bad input ends as one line
``error: ...`` and exit code 2."""

import json
import subprocess
import sys

import pandas as pd
import pytest

from otgym.cli.app import main
from tests.study.test_analyze import PARTICIPANTS, write_answers, write_trials

COMMAND = [sys.executable, "-c", "from otgym.cli.app import main; main()", "study", "analyze"]


def test_analyze_end_to_end(tmp_path):
    write_trials(tmp_path / "s1", PARTICIPANTS[:2])
    write_trials(tmp_path / "s2", PARTICIPANTS[2:])
    write_answers(tmp_path / "all")
    answers = pd.read_csv(tmp_path / "all" / "questionnaires.csv", dtype={"participant": str})
    answers[answers["participant"].isin(PARTICIPANTS[:2])].to_csv(tmp_path / "s1" / "questionnaires.csv", index=False)
    answers[answers["participant"].isin(PARTICIPANTS[2:])].to_csv(tmp_path / "s2" / "questionnaires.csv", index=False)
    out = tmp_path / "out"
    run = subprocess.run(COMMAND + [str(tmp_path / "s1"), str(tmp_path / "s2"), "--out", str(out)],
                         capture_output=True, text=True, timeout=300)
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
    assert "no study folder" in _fails([str(tmp_path / "missing"), "--out", str(out)], capsys)
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
