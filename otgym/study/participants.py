"""A participant's folder of ``otgym study run``: pseudonyms, the session's record, the
trials appended as they finish, and what a resumed session still has to do.

Pseudonyms: a counter. The first participant of a study folder ``DIR`` is ``S001``,
the next ``S002``, in the order they first run; the pseudonym's number is the
participant number that picks the Latin-square row (``protocol.mode_order``). The
mapping from the lab's participant id to the pseudonym is kept apart from the data, in
a key file (default: ``DIR.key.csv`` beside ``DIR``, never inside it), so ``DIR`` can be
shared without it. A counter rather than a hash: a hash of a short id can be undone by
trying every id, and without the key nothing in ``DIR`` leads back to a person.

``DIR/<pseudonym>/`` holds ``session.json`` (pseudonym, number, the modes' order, the
protocol's hash, the software version, whether the questionnaires were scripted),
``protocol.toml`` (the protocol as given), ``trials.csv`` (the modes' trials, one row
each with ``block`` and ``position``), ``practice.csv``, ``questionnaires.csv``,
``cut_trials.csv`` (trials cut mid-way: by a crash, a kill or the window closed) and
``session*.mcap`` (the recordings). Every row is appended, flushed and fsync'd the
moment it exists.

Resuming: the same command again reads the folder. Finished trials (rows in
``trials.csv`` or ``practice.csv``) are kept; the first trial of the plan without a row
runs next, under its own trial number and scenario. A trial that was started and has
no row was cut: it is marked in ``cut_trials.csv`` (its row, or ``ended_by``
``crashed`` where the process died before writing one) and run again; it never enters
``trials.csv``. A block whose trials are all done but whose questionnaires were not
answered asks them first."""

from __future__ import annotations

import collections
import csv
import json
import os
import re
import subprocess
from pathlib import Path

from otgym.study.protocol import Slot, StudyProtocol, mode_order, trial_plan

PARTICIPANT_ID = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")
"""A lab's participant id: letters, digits, ``_ . -``, at most 64 characters."""
PSEUDONYM_DIGITS = 3
KEY_COLUMNS = ["participant_id", "pseudonym", "number"]
STARTED_FILE = "started.csv"
"""Trials begun (trial, mode), appended before each starts: what ``cut_trials.csv`` is found from."""


def check_participant_id(text: str) -> str:
    if not PARTICIPANT_ID.fullmatch(text or ""):
        raise ValueError(
            f"--participant must be 1-64 letters, digits, '_', '.' or '-' (starting with a letter or digit), got {text!r}"
        )
    return text


def default_key_path(out_dir: Path) -> Path:
    out_dir = Path(out_dir)
    return out_dir.parent / f"{out_dir.name}.key.csv"


def software_version() -> dict:
    """``otgym.__version__`` and, where this is a git checkout with git installed, ``git
    describe --always --dirty`` of it (None otherwise)."""
    import otgym

    described = None
    try:
        found = subprocess.run(
            ["git", "describe", "--always", "--dirty", "--tags"],
            cwd=Path(otgym.__file__).resolve().parent,
            capture_output=True,
            text=True,
            timeout=10,
        )
        described = found.stdout.strip() or None if found.returncode == 0 else None
    except (OSError, subprocess.SubprocessError):
        pass
    return {"otgym": otgym.__version__, "git": described}


def _fsync_append(path: Path, rows: list[dict], columns: list[str]) -> None:
    new = not path.exists() or path.stat().st_size == 0
    with path.open("a", newline="", encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, fieldnames=columns, extrasaction="ignore")
        if new:
            writer.writeheader()
        writer.writerows(rows)
        handle.flush()
        os.fsync(handle.fileno())


def _read_rows(path: Path) -> list[dict]:
    if not path.is_file():
        return []
    with path.open(newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def read_key(key_path: Path) -> list[dict]:
    return _read_rows(Path(key_path))


def lookup(key_path: Path, participant_id: str) -> dict | None:
    """The key's row of ``participant_id`` (pseudonym, number), or None if it has none."""
    for row in read_key(key_path):
        if row["participant_id"] == participant_id:
            return row
    return None


def check_key(out_dir: Path, key_path: Path) -> None:
    """A key that ``out_dir``'s participant folders can be found in: ValueError if
    ``out_dir`` holds participants the key does not list (a lost or wrong key would hand
    out their pseudonyms again)."""
    out_dir, key_path = Path(out_dir), Path(key_path)
    if key_path.resolve().is_relative_to(out_dir.resolve()):
        raise ValueError(f"--key {key_path} lies inside {out_dir}: keep the key apart from the data")
    if key_path.exists() and not key_path.is_file():
        raise ValueError(f"--key {key_path} is a folder, not a file")
    folders = sorted(p.name for p in out_dir.iterdir() if (p / "session.json").is_file()) if out_dir.is_dir() else []
    known = {row["pseudonym"] for row in read_key(key_path)}
    unknown = [name for name in folders if name not in known]
    if unknown:
        raise ValueError(f"{out_dir} holds participant(s) {', '.join(unknown)} that the key {key_path} does not list")


def assign(key_path: Path, participant_id: str) -> dict:
    """The participant's key row, added (the next counter) if new; appended and fsync'd."""
    found = lookup(key_path, participant_id)
    if found is not None:
        return found
    number = len(read_key(key_path)) + 1
    row = {"participant_id": participant_id, "pseudonym": f"S{number:0{PSEUDONYM_DIGITS}d}", "number": number}
    Path(key_path).parent.mkdir(parents=True, exist_ok=True)
    _fsync_append(Path(key_path), [row], KEY_COLUMNS)
    return {key: str(value) for key, value in row.items()}


class ParticipantFolder:
    """``DIR/<pseudonym>/`` of one participant under ``protocol``."""

    def __init__(self, out_dir: Path, pseudonym: str, number: int, protocol: StudyProtocol):
        self.path = Path(out_dir) / pseudonym
        self.pseudonym = pseudonym
        self.number = int(number)
        self.protocol = protocol
        self.order = mode_order(protocol, self.number)
        self.plan = trial_plan(protocol, self.order)

    def check_resumable(self) -> None:
        """ValueError if the folder was begun under another protocol (its hash differs)."""
        meta = self.path / "session.json"
        if meta.is_file():
            recorded = json.loads(meta.read_text(encoding="utf-8"))
            if recorded.get("protocol_sha256") != self.protocol.sha256:
                raise ValueError(
                    f"{self.path} was begun under another protocol (sha256 {recorded.get('protocol_sha256')}, "
                    f"not {self.protocol.sha256}): finish it with that protocol, or use another output folder"
                )

    def begin(self, scripted: bool) -> None:
        """Create the folder with ``session.json`` and ``protocol.toml`` (once: a resumed
        session appends its own entry to ``session.json``'s ``runs``)."""
        self.path.mkdir(parents=True, exist_ok=True)
        meta_path = self.path / "session.json"
        run = {"software": software_version(), "scripted_answers": scripted}
        if meta_path.is_file():
            meta = json.loads(meta_path.read_text(encoding="utf-8"))
            meta["runs"].append(run)
        else:
            (self.path / "protocol.toml").write_text(self.protocol.text, encoding="utf-8")
            meta = {
                "pseudonym": self.pseudonym,
                "number": self.number,
                "mode_order": list(self.order),
                "latin_square": "Williams design over participant numbers (otgym.study.protocol.williams_square)",
                "protocol_sha256": self.protocol.sha256,
                "seed_base": self.protocol.seed_base,
                "runs": [run],
            }
        temporary = meta_path.with_suffix(".json.tmp")
        temporary.write_text(json.dumps(meta, indent=2) + "\n", encoding="utf-8")
        os.replace(temporary, meta_path)

    # --- what is done -----------------------------------------------------------------
    def finished_trials(self) -> set[int]:
        rows = _read_rows(self.path / "trials.csv") + _read_rows(self.path / "practice.csv")
        return {int(row["trial"]) for row in rows}

    def answered_trials(self) -> set[int]:
        return {int(row["trial"]) for row in _read_rows(self.path / "questionnaires.csv")}

    def remaining(self) -> list[Slot]:
        done = self.finished_trials()
        return [slot for slot in self.plan if slot.trial not in done]

    def unanswered_blocks(self) -> list[Slot]:
        """The last slots of finished mode blocks whose questionnaires are not answered."""
        if not self.protocol.questionnaires:
            return []
        done, answered = self.finished_trials(), self.answered_trials()
        return [
            slot
            for slot in self.plan
            if slot.last_in_block and not slot.practice and slot.trial in done and slot.trial not in answered
        ]

    def mark_cut_trials(self) -> list[int]:
        """Starts of unfinished trials that ``cut_trials.csv`` does not account for (more
        starts in ``started.csv`` than marks): each appended there with ``ended_by``
        ``crashed``; returns their trial numbers."""
        done = self.finished_trials()
        starts = collections.Counter(int(row["trial"]) for row in _read_rows(self.path / STARTED_FILE))
        marked = collections.Counter(int(row["trial"]) for row in _read_rows(self.path / "cut_trials.csv"))
        cut = [t for t, count in sorted(starts.items()) if t not in done for _ in range(count - marked[t])]
        rows = [
            {"participant": self.pseudonym, "mode": self._slot(t).mode, "trial": t, "ended_by": "crashed"} for t in cut
        ]
        if rows:
            _fsync_append(self.path / "cut_trials.csv", rows, ["participant", "mode", "trial", "ended_by"])
        return cut

    def _slot(self, trial: int) -> Slot:
        return self.plan[trial - 1]

    # --- appending ----------------------------------------------------------------------
    def started(self, trial: int) -> None:
        _fsync_append(self.path / STARTED_FILE, [{"trial": trial, "mode": self._slot(trial).mode}], ["trial", "mode"])

    def record_trial(self, row: dict, columns: list[str]) -> str:
        """Append a trial's row where it belongs: ``cut_trials.csv`` if it was cut
        (``ended_by`` ``aborted``), else ``practice.csv`` or ``trials.csv`` with its
        ``block`` and ``position``; returns the file's name."""
        slot = self._slot(int(row["trial"]))
        row = {**row, "participant": self.pseudonym, "block": slot.block, "position": slot.position}
        if row.get("ended_by") == "aborted":
            name = "cut_trials.csv"
            _fsync_append(self.path / name, [row], ["participant", "mode", "trial", "ended_by"])
            return name
        name = "practice.csv" if slot.practice else "trials.csv"
        _fsync_append(self.path / name, [row], columns + ["block", "position"])
        return name

    def record_answers(self, rows: list[dict]) -> None:
        from otgym.study.questionnaires import append_answers

        append_answers(self.path / "questionnaires.csv", [{**row, "participant": self.pseudonym} for row in rows])
        with (self.path / "questionnaires.csv").open("a") as handle:
            handle.flush()
            os.fsync(handle.fileno())


def start_participant(
    protocol: StudyProtocol, participant_id: str, out_dir: Path, key_path: Path, scripted: bool = False
) -> ParticipantFolder:
    """The participant's folder, ready to run: a known id's (checked to be under the
    same protocol) or a new pseudonym's (the key and the folder written)."""
    out_dir = Path(out_dir)
    known = lookup(key_path, participant_id)
    if known is not None:
        ParticipantFolder(out_dir, known["pseudonym"], int(known["number"]), protocol).check_resumable()
    out_dir.mkdir(parents=True, exist_ok=True)
    row = assign(key_path, participant_id)
    folder = ParticipantFolder(out_dir, row["pseudonym"], int(row["number"]), protocol)
    folder.begin(scripted)
    return folder


def study_participants(path: Path) -> dict[Path, list[str]] | None:
    """A study folder of ``otgym study run`` (participant sub-folders with
    ``session.json``, no ``trials.csv`` of its own): each participant folder that has
    finished trials, with its recorded order of modes; None for any other folder."""
    path = Path(path)
    if not path.is_dir() or (path / "trials.csv").is_file():
        return None
    folders = sorted(p for p in path.iterdir() if (p / "session.json").is_file())
    if not folders:
        return None
    return {
        folder: json.loads((folder / "session.json").read_text(encoding="utf-8"))["mode_order"]
        for folder in folders
        if (folder / "trials.csv").is_file()
    }
