"""The window of ``otgym study run``: one participant's session of a study protocol
(``otgym.study.protocol``) in ``otgym play``'s window and session process.

What the participant sees: the instructions (or, on a resumed session, where it goes
on), Enter to begin; each block's opening page (its mode and number of trials), Enter;
the trials, each in ``otgym play``'s window over a ``SessionProcess`` that runs the
whole session (its trials numbered as the protocol's plan numbers them); after each
mode's block, the questionnaires (NASA-TLX, UEQ-S) in the window. The protocol fixes
the mode: the mode keys 1/2/3 and R (abandon a trial) do nothing here; space (pause),
H (help) and Esc (quit: the trial under way is marked cut and runs again next time)
work as in ``otgym play``.

The folder's bookkeeping (what is finished, cut, answered; the files) is
``otgym.study.participants.ParticipantFolder``'s; this module only drives the window.
``answers`` (a scripted run, ``otgym.study.protocol.load_answer_script``) presses the
form's keys for the questionnaires and Enter on each page, as a person would."""

from __future__ import annotations

import functools

import pygame

from otgym.study.participants import ParticipantFolder
from otgym.study.protocol import Slot
from otgym.study.questionnaires import TLX_STEP
from otgym.ui.app import MODE_KEYS, PlayApp
from otgym.ui.palette import WINDOW_SIZE, fonts
from otgym.ui.questionnaire import TLX_START, run_questionnaire
from otgym.ui.records import PLAY_COLUMNS
from otgym.ui.views import BACKGROUND_RGB, DIM_TEXT_RGB, TEXT_RGB


def answer_keys(answers: dict, weighted: bool) -> list[int]:
    """The key presses that fill ``otgym.ui.questionnaire``'s form with ``answers``:
    per TLX scale, Right (to 50) then Right/Left by 5 to the rating, Down to the next;
    Enter; (the pairs: 1/2 each; Enter;) UEQ-S: a digit each; Enter."""
    keys: list[int] = []
    for rating in answers["nasa_tlx"]:
        steps = (rating - TLX_START) // TLX_STEP
        keys += [pygame.K_RIGHT] + [pygame.K_RIGHT if steps > 0 else pygame.K_LEFT] * abs(steps) + [pygame.K_DOWN]
    keys.append(pygame.K_RETURN)
    digit = {n: getattr(pygame, f"K_{n}") for n in range(1, 8)}
    if weighted:
        keys += [digit[choice] for choice in answers["tlx_pairs"]] + [pygame.K_RETURN]
    return keys + [digit[raw] for raw in answers["ueq_s"]] + [pygame.K_RETURN]


def press(keys: list[int]) -> None:
    for key in keys:
        pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=key, mod=0, unicode="", scancode=0))


def wait_for_enter(screen, clock, title: str, lines: list[str], scripted: bool, fps: int = 30) -> bool:
    """A page of text until Enter (True) or Esc / the window closed (False)."""
    type_ = fonts()
    if scripted:
        press([pygame.K_RETURN])
    while True:
        for event in pygame.event.get():
            if event.type == pygame.QUIT or (event.type == pygame.KEYDOWN and event.key == pygame.K_ESCAPE):
                return False
            if event.type == pygame.KEYDOWN and event.key in (pygame.K_RETURN, pygame.K_KP_ENTER):
                return True
        screen.fill(BACKGROUND_RGB)
        screen.blit(type_["title"].render(title, True, TEXT_RGB), (60, 60))
        y = 120
        for line in lines:
            screen.blit(type_["body"].render(line, True, TEXT_RGB), (60, y))
            y += 30
        screen.blit(type_["body"].render("Press Enter to begin (Esc: stop).", True, DIM_TEXT_RGB), (60, y + 30))
        pygame.display.flip()
        clock.tick(fps)


def block_page(slot: Slot, trials: int) -> tuple[str, list[str]]:
    if slot.practice:
        return "Practice", [f"{trials} practice trial(s) in {slot.mode} mode; they are not analysed."]
    return f"Block {slot.position}: {slot.mode} mode", [f"{trials} trial(s) in {slot.mode} mode."]


class StudyApp(PlayApp):
    """``PlayApp`` over a session that runs ``slots`` (the remaining plan; the first is
    the trial under way): each finished row to the folder, the questionnaires after a
    mode's last trial, the next block's page, then the next trial in its mode; the
    window closes when the plan is done."""

    def __init__(self, session, folder: ParticipantFolder, slots: list[Slot], answers: dict | None, **keywords):
        super().__init__(session, folder.path, questionnaire=False, **keywords)
        self.folder = folder
        self.slots = list(slots)
        self.answers = answers
        self.cut: list[int] = []
        for name in (answers or {}).get("hold_keys", ()):  # scripted driving: held from the first frame on
            press([getattr(pygame, f"K_{name.upper()}")])

    def handle_event(self, event) -> None:
        if event.type == pygame.KEYDOWN and (event.key in MODE_KEYS or event.key == pygame.K_r):
            return  # the protocol fixes the mode, and a trial is not abandoned
        super().handle_event(event)

    def _finish_trials(self, ask: bool = True) -> None:
        while (row := self.session.take_finished()) is not None:
            slot = self.slots[0]
            if int(row["trial"]) != slot.trial:
                raise RuntimeError(f"the session finished trial {row['trial']}, the plan expected {slot.trial}")
            self.folder.record_trial(row, PLAY_COLUMNS)
            if row["ended_by"] == "aborted":
                self.cut.append(slot.trial)
                continue
            self.trials_written += 1
            self.slots.pop(0)
            if not ask:
                continue
            if not self._between(slot):
                self.running = False
                return

    def _between(self, finished: Slot) -> bool:
        """After ``finished``: its block's questionnaires, the next block's page, the next
        trial; False when the plan is done or the person stopped."""
        protocol = self.folder.protocol
        if finished.last_in_block and not finished.practice and protocol.questionnaires:
            if not ask_block(self.screen, self.clock, self.folder, finished, self.answers, self.fps):
                return False
        if not self.slots:
            return False
        upcoming = self.slots[0]
        if upcoming.block != finished.block:
            count = sum(1 for s in self.slots if s.block == upcoming.block)
            if not wait_for_enter(self.screen, self.clock, *block_page(upcoming, count), self.answers is not None):
                return False
        self._full_redraw = True
        self.session.set_mode(upcoming.mode)
        self.folder.started(upcoming.trial)
        self.session.next_trial()
        return True


def ask_block(screen, clock, folder: ParticipantFolder, slot: Slot, answers: dict | None, fps: int = 60) -> bool:
    """The questionnaires for ``slot``'s mode block (keyed by its last trial); False if
    left with Esc (nothing saved: they are asked again on resuming)."""
    if answers is not None:
        press(answer_keys(answers, folder.protocol.weighted_tlx))
    rows = run_questionnaire(
        screen, clock, folder.pseudonym, slot.mode, slot.trial, weighted=folder.protocol.weighted_tlx, fps=fps
    )
    if rows is None:
        return False
    folder.record_answers(rows)
    return True


def run_study(folder: ParticipantFolder, answers: dict | None = None) -> dict:
    """The participant's remaining session in a window (``pygame`` opened and closed
    here). Returns what happened: trials finished, cut, still remaining."""
    from otgym.record.mcap_file import session_path
    from otgym.runtime.worker import SessionProcess, WorkerSpec
    from otgym.teleop.device import DeviceError, start_devices
    from otgym.ui.bindings import robot_primaries, window_devices
    from otgym.ui.play_worker import play_setup
    from otgym.ui.startup import StartupAborted, StartupStatus, wait_in_window

    protocol = folder.protocol
    crashed = folder.mark_cut_trials()
    remaining, pending = folder.remaining(), folder.unanswered_blocks()
    result = {"finished": 0, "cut": crashed, "remaining": len(remaining)}
    if not remaining and not pending:
        return result
    scripted = answers is not None
    pygame.display.init()
    pygame.font.init()
    windowed = []
    try:
        pygame.display.set_caption(f"otgym study: {protocol.name}")  # before the window: it opens with its title
        screen = pygame.display.set_mode(WINDOW_SIZE)
        clock = pygame.time.Clock()
        fresh = not folder.finished_trials()
        if fresh:
            lines = protocol.instructions.strip().splitlines() or [""]
            title = protocol.name
        else:
            first = remaining[0] if remaining else pending[0]
            title = "Welcome back"
            lines = [f"The session goes on at trial {first.trial} of {len(folder.plan)} ({first.mode} mode)."]
        if not wait_for_enter(screen, clock, title, lines, scripted):
            return result
        for slot in pending:
            if not ask_block(screen, clock, folder, slot, answers):
                return result
        if not remaining:
            return result
        first = remaining[0]
        if fresh or first.trial == next(s.trial for s in folder.plan if s.block == first.block):
            count = sum(1 for s in remaining if s.block == first.block)
            if not wait_for_enter(screen, clock, *block_page(first, count), scripted):
                return result
        try:
            windowed = window_devices(protocol.device)
            robot_primaries(protocol.device, windowed)  # the Touch fails here at once without its runtime
            start_devices(windowed)  # e.g. no gamepad plugged in
        except DeviceError as error:
            raise ValueError(str(error)) from None
        spec = WorkerSpec(
            functools.partial(
                play_setup,
                protocol.chip,
                protocol.device,
                session_path(folder.path),
                navigator=protocol.navigator,
                time_limit_s=protocol.trial_time_limit_s,
            ),
            folder.pseudonym,
            first.mode,
            protocol.seed_base,
            None,
            forwarded_caps=tuple(d.caps for d in windowed),
            first_trial=first.trial,
        )
        status = StartupStatus("starting the simulation process")
        session = SessionProcess(spec, on_status=status.set)
        try:
            wait_in_window(screen, session.start, f"otgym study: participant {folder.pseudonym}", status)
        except DeviceError as error:  # a Touch that would not open
            session.finish()
            raise ValueError(str(error)) from None
        except StartupAborted:  # closed while the simulation started: no trial ran
            session.finish()
            return result
        folder.started(first.trial)  # ready: the first trial runs from now on
        app = StudyApp(session, folder, remaining, answers, window_devices=windowed, screen=screen)
        try:
            app.run()
        finally:
            session.finish()
        result.update(finished=app.trials_written, cut=crashed + app.cut, remaining=len(folder.remaining()))
        return result
    finally:
        for each in windowed:
            each.stop()
        pygame.quit()
