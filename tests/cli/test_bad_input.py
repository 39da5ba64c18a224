"""Every command's bad input ends in one ``error:`` line and exit code 2, before any
expensive work, with nothing written.

The commands and their options are read from the typer app itself, so a new command or
option is covered without editing this file. Each command's help carries an
``Example: otgym ...`` line, a valid invocation; each case changes one option of it to a
bad value chosen from the option's declaration:

- integers and floats: -1, 0, 2**64, NaN, +-inf, 1e-9 and 1e12, where outside the range
  the option declares (every number option must declare both ends);
- paths: a missing file for an input, a folder where a file is expected and the reverse,
  an existing file as an output folder;
- text, by its metavar: ``CHIP`` (unknown name, truncated PNG, not an image, a folder),
  ``NAME`` (an unknown name of a closed set), ``POLICY`` (unknown, a folder, a broken
  file), ``X,Y`` (three numbers, NaN, words), ``NUMBERS`` (NaN, empty), ``ENDPOINT``,
  ``NAMES`` (a name otgym's bus refuses), ``NAMESPACE``/``TOPIC`` (a name ROS 2 would
  refuse), ``HOST``, ``NAME=NUMBERS`` (an unknown parameter, NaN, no value, a value the
  parameter refuses), ``P:T`` (not two integers, one beyond the run's participants), ``PACE`` (a word other than
  baseline or all, a level beyond the last), ``LABEL=DIR`` (no label, a folder that is no
  finished run); ``TEXT`` is free text and left alone;
- options that only make sense together (``COMBINATIONS`` below).

"Before any expensive work" is checked, not timed: while a case runs, a JAX compilation,
a child process or a zenoh session ends it with a failure naming what was started.
"""

from __future__ import annotations

import shlex
import subprocess
from dataclasses import dataclass
from pathlib import Path

import pytest

from otgym.cli import app as cli_app
from otgym.tasks.base import Task


def _root():
    return cli_app.command()


def leaf_commands(group=None, path=()):
    """(("plan",), command), (("chip", "show"), command), ... in the app's order."""
    group = group if group is not None else _root()
    for name, command in group.commands.items():
        if hasattr(command, "commands"):
            yield from leaf_commands(command, (*path, name))
        else:
            yield (*path, name), command


def example_argv(path, command) -> list[str]:
    """The arguments of the ``Example: otgym ...`` line of ``command``'s help."""
    for line in (command.help or "").splitlines() + (command.epilog or "").splitlines():
        line = line.strip()
        if line.startswith("Example: otgym "):
            argv = shlex.split(line.removeprefix("Example: otgym "))
            assert tuple(argv[: len(path)]) == path, f"{' '.join(path)}'s example runs another command: {line}"
            return argv[len(path) :]
    raise AssertionError(f"'otgym {' '.join(path)}' has no 'Example: otgym ...' line in its help")


@dataclass(frozen=True)
class Case:
    label: str
    value: str | None  # None: the option is left out (a combination case)
    make: str = ""  # what to create in the case's folder first: "file", "folder", "truncated_png", ...


INT_CANDIDATES = (("negative", -1), ("zero", 0), ("huge", 2**64))
FLOAT_CANDIDATES = (("zero", 0.0), ("tiny", 1e-9), ("huge", 1e12), ("negative", -1.0))


def _outside(param, value: float) -> bool:
    low, high = param.min, param.max
    if low is not None and (value < low or (getattr(param, "min_open", False) and value == low)):
        return True
    return high is not None and (value > high or (getattr(param, "max_open", False) and value == high))


def cases_of(param) -> list[Case]:
    """The bad values of one option, from its declaration."""
    annotation = param.type_descriptor.annotation
    info = param.type_descriptor.parameter_info
    if annotation is bool:
        return []
    if annotation is int:
        assert param.min is not None and param.max is not None, f"{param.name}: declare min= and max="
        return [Case(label, str(value)) for label, value in INT_CANDIDATES if _outside(param, value)]
    if annotation is float:
        assert param.min is not None and param.max is not None, f"{param.name}: declare min= and max="
        bad = [Case(label, text) for label, text in (("nan", "nan"), ("inf", "inf"), ("-inf", "-inf"))]
        return bad + [Case(label, repr(value)) for label, value in FLOAT_CANDIDATES if _outside(param, value)]
    if annotation in (Path, list[Path]):
        if info.exists:
            bad = [Case("missing", "missing.dat")]
            if not info.dir_okay:
                bad.append(Case("folder for a file", "a-folder", "folder"))
            if not info.file_okay:
                bad.append(Case("file for a folder", "a-file.txt", "file"))
            return bad
        assert not (info.file_okay and info.dir_okay), f"{param.name}: say whether it is a file or a folder"
        if not info.file_okay:
            return [Case("existing file as a folder", "a-file.txt", "file")]
        return [Case("existing folder as a file", "a-folder", "folder")]
    metavar = info.metavar
    assert metavar in STRING_CASES, f"{param.name}: give a metavar from {sorted(STRING_CASES)}"
    return STRING_CASES[metavar]


STRING_CASES = {
    "CHIP": [
        Case("unknown chip", "no-such-chip"),
        Case("truncated png", "cut.png", "truncated_png"),
        Case("not an image", "text.png", "text_png"),
        Case("folder", "a-folder", "folder"),
    ],
    "NAME": [Case("unknown name", "no-such-name")],
    "KIND": [Case("unknown kind", "no-such-kind")],
    "POLICY": [
        Case("unknown policy", "no-such-policy"),
        Case("folder", "a-folder", "folder"),
        Case("broken file", "broken.npz", "text_npz"),
    ],
    "X,Y": [Case("three numbers", "1,2,3"), Case("nan", "nan,5"), Case("words", "x,y")],
    "NUMBERS": [Case("nan", "5,nan"), Case("empty", ""), Case("negative", "-1")],
    "MODES": [Case("unknown mode", "manual,flying"), Case("empty", "")],
    "ENDPOINT": [
        Case("not an endpoint", "nowhere"),
        Case("port out of range", "tcp/127.0.0.1:99999"),
        Case("no port", "tcp/127.0.0.1"),
    ],
    "NAMES": [Case("bad name", "bad name!")],
    "NAMESPACE": [Case("not a ROS 2 namespace", "/rig 1")],
    "TOPIC": [Case("not a ROS 2 topic", "/cmd vel")],
    "HOST": [Case("not an address", "no such host!")],
    "ADDRESS": [Case("no port", "127.0.0.2"), Case("bad port", "127.0.0.2:99999"), Case("bad host", "no host!:6379")],
    "NAME=NUMBERS": [
        Case("unknown parameter", "no_such_s=1,2"),
        Case("nan", "timing_jitter_s=5,nan"),
        Case("no values", "timing_jitter_s="),
        Case("refused value", "timing_jitter_s=-1"),
    ],
    "PACE": [Case("unknown pace", "fast"), Case("level beyond the last", "99")],
    "LABEL=DIR": [Case("no label", "a-folder", "folder"), Case("not a run folder", "run=a-folder", "folder")],
    "P:T": [Case("not P:T", "3"), Case("negative", "-1:0"), Case("beyond the run", "99:0")],
    "ID": [Case("empty", ""), Case("a comma", "lab,7"), Case("a path", "../lab7"), Case("a space", "lab 7")],
    "TEXT": [],
}

COMBINATIONS = [
    # (command, the arguments added to its example, a word of the error): options given
    # without the option they only make sense with
    (("node", "device"), ["--replay", "stylus.csv"], "--device replay"),
    (("node", "device"), ["--device", "replay"], "--replay"),
    (("node", "device"), ["--device-name", "Right Device"], "--device touch"),
    (("play",), ["--navigator", "mpc"], "--distributed"),
    (("play",), ["--ros2"], "--distributed"),
    (("play",), ["--preset", "paper"], "--task"),
    (("play",), ["--task", "speed-control", "--distributed"], "--task"),
]


def combination_cases():
    commands = dict(leaf_commands())
    for path, extra, word in COMBINATIONS:
        yield pytest.param(path, commands[path], extra, word, id=f"{' '.join(path)} {' '.join(extra)}")


@pytest.mark.parametrize("path, command, extra, word", list(combination_cases()))
def test_options_that_need_another_are_refused_without_it(tmp_path, monkeypatch, capsys, path, command, extra, word):
    folder = tmp_path / "case"
    folder.mkdir()
    monkeypatch.chdir(folder)
    argv = example_argv(path, command)
    _example_inputs(command, argv, folder)
    (folder / "stylus.csv").write_text("t_s,sequence,x_mm,y_mm,z_mm,vx_mm_s,vy_mm_s,vz_mm_s,buttons\n")
    before = sorted(p.relative_to(folder) for p in folder.rglob("*"))
    with pytest.raises(SystemExit) as exit_info:
        cli_app.main([*path, *argv, *extra])
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert exit_info.value.code == 2 and len(lines) == 1 and lines[0].startswith("error: "), err
    assert word in lines[0], lines[0]
    assert sorted(p.relative_to(folder) for p in folder.rglob("*")) == before


def _make(folder: Path, kind: str, name: str) -> None:
    target = folder / name
    if kind == "file":
        target.write_text("not what was asked for\n")
    elif kind == "folder":
        target.mkdir()
    elif kind == "truncated_png":
        from PIL import Image

        Image.new("L", (64, 48), 200).save(target)
        target.write_bytes(target.read_bytes()[:60])
    elif kind == "text_png":
        target.write_text("this is no image\n")
    elif kind == "text_npz":
        target.write_text("this is no policy\n")


def _replace(command, argv: list[str], param, value: str | None) -> list[str]:
    """``argv`` with ``param``'s value(s) replaced by ``value`` (left out when None)."""
    takes_value = {
        opt: not p.is_flag for p in command.params if p.param_type_name == "option" for opt in p.opts + p.secondary_opts
    }
    kept, positional, skip = [], [], False
    for i, token in enumerate(argv):
        if skip:
            skip = False
            continue
        if token in takes_value:
            skip = takes_value[token]
            if token not in param.opts:
                kept += argv[i : i + 1 + skip]
            continue
        positional.append(token)
    if param.param_type_name == "option":
        return kept + positional + ([param.opts[0], value] if value is not None else [])
    arguments = [p for p in command.params if p.param_type_name == "argument"]
    index = arguments.index(param)
    positional = positional[:index] + ([value] if value is not None else []) + positional[index + 1 :]
    return kept + positional


def all_cases():
    """One pytest param per bad value; a command or option that cannot be covered
    (no example, an undeclared range or kind) gives one param that fails saying so."""
    for path, command in leaf_commands():
        name = " ".join(path)
        try:
            argv = example_argv(path, command)
        except AssertionError as problem:
            yield pytest.param(path, command, [], None, str(problem), id=f"{name}: no example")
            continue
        for param in command.params:
            if param.name == "help":
                continue
            try:
                cases = cases_of(param)
            except AssertionError as problem:
                yield pytest.param(path, command, argv, param, str(problem), id=f"{name} {param.name}: undeclared")
                continue
            for case in cases:
                yield pytest.param(path, command, argv, param, case, id=f"{name} {param.name}: {case.label}")


_REGISTERED: list[bool] = []
_COMPILED: list[list[str]] = []
"""While a case runs: one list, of the XLA compilations seen (registered once: JAX offers
no way to remove one listener)."""


def _on_event(event: str, duration: float, **kwargs) -> None:
    if _COMPILED and "backend_compile" in event:
        _COMPILED[0].append(event)


class Started(Exception):
    """Expensive work began before the input was checked."""


@pytest.fixture
def no_expensive_work(monkeypatch):
    """Fail a case at once if it compiles with JAX, starts a process or opens a bus."""
    import multiprocessing

    import zenoh

    def refuse(what):
        def refuse_call(*args, **kwargs):
            raise Started(f"{what} started before the input was refused")

        return refuse_call

    monkeypatch.setattr(multiprocessing.Process, "start", refuse("a process"))
    monkeypatch.setattr(subprocess, "Popen", refuse("a child process"))
    monkeypatch.setattr(zenoh, "open", refuse("a zenoh session"))
    if not _REGISTERED:
        import jax

        jax.monitoring.register_event_duration_secs_listener(_on_event)
        _REGISTERED.append(True)

    _COMPILED.clear()
    _COMPILED.append([])
    yield _COMPILED[0]
    _COMPILED.clear()


def _example_inputs(command, argv: list[str], folder: Path) -> None:
    """Create the example's input paths (``exists=True``) in ``folder``: an empty file,
    or a folder where only a folder will do, so that only the case's value is bad."""
    for param in command.params:
        info = getattr(param.type_descriptor, "parameter_info", None)
        if not getattr(info, "exists", False):
            continue
        values = _values(command, argv, param)
        for value in values:
            target = folder / value
            target.parent.mkdir(parents=True, exist_ok=True)
            if info.dir_okay:
                target.mkdir(exist_ok=True)
            else:
                target.touch()


def _values(command, argv: list[str], param) -> list[str]:
    """The tokens of ``argv`` that are ``param``'s value(s)."""
    if param.param_type_name == "option":
        return [argv[i + 1] for i, token in enumerate(argv[:-1]) if token in param.opts]
    options = {opt: not p.is_flag for p in command.params if p.param_type_name == "option" for opt in p.opts}
    positional, skip = [], False
    for token in argv:
        if skip:
            skip = False
        elif token in options:
            skip = options[token]
        else:
            positional.append(token)
    arguments = [p for p in command.params if p.param_type_name == "argument"]
    index = arguments.index(param)
    return positional[index:] if param.nargs == -1 else positional[index : index + 1]


def run_case(tmp_path, monkeypatch, capsys, path, command, argv, param, case, compiled):
    assert isinstance(case, Case), case  # else: why the command or option cannot be covered
    folder = tmp_path / "case"
    folder.mkdir()
    monkeypatch.chdir(folder)
    _example_inputs(command, argv, folder)
    if case.make:
        _make(folder, case.make, case.value)
    before = sorted(p.relative_to(folder) for p in folder.rglob("*"))
    with pytest.raises(SystemExit) as exit_info:
        cli_app.main([*path, *_replace(command, argv, param, case.value)])
    captured = capsys.readouterr()
    lines = [line for line in captured.err.splitlines() if line.strip()]
    assert exit_info.value.code == 2, (exit_info.value.code, captured.err[-2000:], captured.out[-500:])
    assert len(lines) == 1 and lines[0].startswith("error: "), captured.err
    assert "Traceback" not in captured.err + captured.out
    names = [*param.opts, param.name, (case.value or "").split(",")[0]]
    assert any(name and name in lines[0] for name in names), f"the error does not name {param.opts}: {lines[0]}"
    assert sorted(p.relative_to(folder) for p in folder.rglob("*")) == before, "it wrote files"
    assert not compiled, f"compiled {len(compiled)} XLA program(s) before refusing the input"


@pytest.mark.parametrize("path, command, argv, param, case", list(all_cases()))
def test_a_bad_value_is_one_error_line_and_exit_2(
    tmp_path, monkeypatch, capsys, no_expensive_work, path, command, argv, param, case
):
    run_case(tmp_path, monkeypatch, capsys, path, command, argv, param, case, no_expensive_work)


def test_every_command_has_a_valid_example_and_bad_cases():
    """Not vacuous: every leaf command has an example that parses, and the cases above
    cover at least one option of most commands."""
    commands = list(leaf_commands())
    assert len(commands) >= 9
    covered = {c.values[0] for c in all_cases() if isinstance(c.values[4], Case)}
    for path, command in commands:
        command.make_context(" ".join(path), example_argv(path, command), resilient_parsing=True)
    assert len(covered) >= len(commands) - 1


BAD_PROTOCOLS = {
    "not TOML": ("[study\nseed_base = 1\n", "is not a TOML protocol"),
    "unknown mode": (
        '[study]\nseed_base = 1\n[modes]\nnames = ["manual", "telepathic"]\ntrials_per_mode = 2\n',
        "unknown mode 'telepathic'",
    ),
    "unknown practice mode": (
        '[study]\nseed_base = 1\n[practice]\ntrials = 1\nmode = "x"\n[modes]\nnames = ["manual"]\ntrials_per_mode = 2\n',
        "unknown mode 'x'",
    ),
    "a mode twice": (
        '[study]\nseed_base = 1\n[modes]\nnames = ["manual", "manual"]\ntrials_per_mode = 2\n',
        "names a mode twice",
    ),
    "unknown key": (
        '[study]\nseed_base = 1\nseeds = 2\n[modes]\nnames = ["manual"]\ntrials_per_mode = 2\n',
        "unknown key 'seeds'",
    ),
    "missing trials": ('[study]\nseed_base = 1\n[modes]\nnames = ["manual"]\n', "trials_per_mode is missing"),
    "zero trials": (
        '[study]\nseed_base = 1\n[modes]\nnames = ["manual"]\ntrials_per_mode = 0\n',
        "trials_per_mode must lie in",
    ),
    "unknown device": (
        '[study]\nseed_base = 1\ndevice = "joystick"\n[modes]\nnames = ["manual"]\ntrials_per_mode = 2\n',
        "unknown device 'joystick'",
    ),
    "wrong type": (
        '[study]\nseed_base = "one"\n[modes]\nnames = ["manual"]\ntrials_per_mode = 2\n',
        "seed_base must be int",
    ),
}
"""Protocols ``otgym study run`` must refuse (the file exists; its content is wrong)."""


@pytest.mark.parametrize("label", list(BAD_PROTOCOLS))
def test_study_run_refuses_a_bad_protocol(tmp_path, monkeypatch, capsys, no_expensive_work, label):
    text, word = BAD_PROTOCOLS[label]
    folder = tmp_path / "case"
    folder.mkdir()
    monkeypatch.chdir(folder)
    (folder / "protocol.toml").write_text(text)
    before = sorted(p.relative_to(folder) for p in folder.rglob("*"))
    with pytest.raises(SystemExit) as exit_info:
        cli_app.main(["study", "run", "protocol.toml", "--participant", "lab-1", "--out", "study", "--headless"])
    captured = capsys.readouterr()
    lines = [line for line in captured.err.splitlines() if line.strip()]
    assert exit_info.value.code == 2, (exit_info.value.code, captured.err[-2000:])
    assert len(lines) == 1 and lines[0].startswith("error: ") and word in lines[0], captured.err
    assert sorted(p.relative_to(folder) for p in folder.rglob("*")) == before, "it wrote files"
    assert not no_expensive_work


class Frameless(Task):
    """A task with no frame: nothing for a window to draw."""


class Deaf(Task):
    """A task that draws but takes no pointing-device input."""

    def frame(self, state, params, size_px=(600, 400)):
        raise AssertionError("never drawn: refused before any work")


@pytest.mark.parametrize("target, word", [("Frameless", "frame"), ("Deaf", "device")])
def test_play_refuses_a_task_it_cannot_show_or_drive(tmp_path, monkeypatch, capsys, no_expensive_work, target, word):
    from otgym import registry

    monkeypatch.chdir(tmp_path)
    registry.register("tasks", "unplayable", f"{__name__}:{target}")
    try:
        with pytest.raises(SystemExit) as exit_info:
            cli_app.main(["play", "--task", "unplayable", "--headless", "--out", "played"])
    finally:
        registry.unregister("tasks", "unplayable")
    lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert exit_info.value.code == 2 and len(lines) == 1 and lines[0].startswith("error: --task"), lines
    assert word in lines[0], lines[0]
    assert not any(tmp_path.iterdir()), "it wrote files"
    assert not no_expensive_work


NOT_MCAP = {
    "empty": b"",
    "shorter than MCAP's magic": b"abc",
    "text": b"this is no recording\n" * 4,
}
"""Files that ``otgym replay`` is given as recordings but that are not MCAP (the FILE
argument is checked for existence by the command-line library; its content by otgym)."""


@pytest.mark.parametrize("with_out", [False, True], ids=["summary", "--out"])
@pytest.mark.parametrize("label", list(NOT_MCAP))
def test_replay_refuses_a_file_that_is_not_mcap(tmp_path, monkeypatch, capsys, no_expensive_work, label, with_out):
    folder = tmp_path / "case"
    folder.mkdir()
    monkeypatch.chdir(folder)
    (folder / "session.mcap").write_bytes(NOT_MCAP[label])
    before = sorted(p.relative_to(folder) for p in folder.rglob("*"))
    with pytest.raises(SystemExit) as exit_info:
        cli_app.main(["replay", "session.mcap", *(["--out", "frames"] if with_out else [])])
    captured = capsys.readouterr()
    lines = [line for line in captured.err.splitlines() if line.strip()]
    assert exit_info.value.code == 2, (exit_info.value.code, captured.err[-2000:], captured.out[-500:])
    assert len(lines) == 1 and lines[0].startswith("error: ") and "not an MCAP file" in lines[0], captured.err
    assert captured.out == "", captured.out
    assert sorted(p.relative_to(folder) for p in folder.rglob("*")) == before, "it wrote files"
    assert not no_expensive_work
