"""otgym.ui.questionnaire headless (SDL dummy drivers): clicks and keys give exactly the
answers chosen, a page with a missing item does not advance, the blocking loop returns
full rows that the answer file accepts, or None on Esc / closing the window."""

import os

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")

import pygame  # noqa: E402
import pytest  # noqa: E402

from otgym.study.questionnaires import (
    TLX_PAIRS,
    TLX_SUBSCALES,
    UEQ_ITEM_NAMES,
    append_answers,  # noqa: E402
    read_answers,
    score,
    weights_from_choices,
)
from otgym.ui.questionnaire import PAIRS_PAGE, UEQ_PAGE, QuestionnaireForm, run_questionnaire  # noqa: E402

SIZE = (1024, 700)


@pytest.fixture
def surface():
    pygame.init()
    yield pygame.Surface(SIZE)
    pygame.quit()


def click(form, pos):
    form.handle_event(pygame.event.Event(pygame.MOUSEBUTTONDOWN, pos=pos, button=1))
    form.handle_event(pygame.event.Event(pygame.MOUSEBUTTONUP, pos=pos, button=1))


def key(form, code):
    form.handle_event(pygame.event.Event(pygame.KEYDOWN, key=code))


def at_fraction(rect, fraction):
    return (round(rect.left + fraction * rect.width), rect.centery)


def as_dict(rows):
    return {(row["instrument"], row["item"]): row["value"] for row in rows}


def test_clicks_give_exactly_the_answers_clicked(surface):
    form = QuestionnaireForm(weighted=True)
    form.draw(surface)
    ratings = dict(zip(TLX_SUBSCALES, (85, 10, 55, 0, 100, 35)))
    for item, value in ratings.items():
        click(form, at_fraction(form.slider_rect(item), value / 100 + (0.01 if value < 100 else -0.01)))  # rounds to it
    click(form, form.next_rect.center)
    assert form.page_name == PAIRS_PAGE
    form.draw(surface)
    choices = {pair: pair[i % 2] for i, pair in enumerate(TLX_PAIRS)}
    for pair, chosen in choices.items():
        click(form, form.choice_rect(pair, pair.index(chosen)).center)
    click(form, form.next_rect.center)
    assert form.page_name == UEQ_PAGE
    form.draw(surface)
    ueq = dict(zip(UEQ_ITEM_NAMES, (7, 6, 5, 4, 3, 2, 1, 6)))
    for item, raw in ueq.items():
        click(form, form.radio_rect(item, raw).center)
    assert not form.done
    click(form, form.next_rect.center)
    assert form.done
    expected = {
        **{("nasa_tlx", k): v for k, v in ratings.items()},
        **{("nasa_tlx", k): v for k, v in weights_from_choices(choices).items()},
        **{("ueq_s", k): v for k, v in ueq.items()},
    }
    answers = form.answers()
    assert len(answers) == 20 and as_dict(answers) == expected


def test_drag_and_keys_set_the_sliders_and_the_radios(surface):
    form = QuestionnaireForm()
    form.draw(surface)
    rect = form.slider_rect("mental")
    form.handle_event(pygame.event.Event(pygame.MOUSEBUTTONDOWN, pos=at_fraction(rect, 0.2), button=1))
    form.handle_event(pygame.event.Event(pygame.MOUSEMOTION, pos=at_fraction(rect, 0.62), buttons=(1, 0, 0)))
    form.handle_event(pygame.event.Event(pygame.MOUSEBUTTONUP, pos=at_fraction(rect, 0.62), button=1))
    form.handle_event(pygame.event.Event(pygame.MOUSEMOTION, pos=at_fraction(rect, 0.9), buttons=(0, 0, 0)))
    assert form.ratings["mental"] == 60  # the drag's end, not the later hover
    key(form, pygame.K_DOWN)  # physical: unanswered, first Right starts at 50
    for code in (pygame.K_RIGHT, pygame.K_RIGHT, pygame.K_LEFT, pygame.K_LEFT):  # 50 55 50 45
        key(form, code)
    assert form.ratings["physical"] == 45
    for _ in range(4):
        key(form, pygame.K_DOWN)
        key(form, pygame.K_LEFT)  # 50, then Left again would be 45: one press each
    assert [form.ratings[k] for k in TLX_SUBSCALES[2:]] == [50, 50, 50, 50]
    key(form, pygame.K_RETURN)
    assert form.page_name == UEQ_PAGE
    for digit in (1, 2, 3, 4, 5, 6, 7, 7):
        key(form, getattr(pygame, f"K_{digit}"))
    key(form, pygame.K_RETURN)
    assert form.done
    assert [row["value"] for row in form.answers() if row["instrument"] == "ueq_s"] == [1, 2, 3, 4, 5, 6, 7, 7]


def test_the_form_will_not_finish_with_a_missing_item(surface):
    form = QuestionnaireForm()
    form.draw(surface)
    for item in TLX_SUBSCALES[:-1]:
        click(form, form.slider_rect(item).center)
    key(form, pygame.K_RETURN)
    assert form.page_name != UEQ_PAGE and form.missing == ["Frustration"]
    form.draw(surface)  # the warning is drawn without error
    click(form, form.slider_rect("frustration").center)
    key(form, pygame.K_RETURN)
    for item in UEQ_ITEM_NAMES:
        if item != "ueq5":
            click(form, form.radio_rect(item, 4).center)
    click(form, form.next_rect.center)
    assert not form.done and form.missing == ["boring - exciting"]
    with pytest.raises(ValueError, match="not finished"):
        form.answers()
    key(form, pygame.K_BACKSPACE)  # back to the TLX page keeps the answers
    assert form.page_name != UEQ_PAGE and form.ratings["frustration"] == 50


def test_the_layout_follows_the_surface(surface):
    form = QuestionnaireForm()
    form.draw(pygame.Surface((640, 480)))
    small = form.slider_rect("mental")
    form.draw(surface)
    assert form.slider_rect("mental").width > small.width
    assert surface.get_at(form.next_rect.center) != surface.get_at((2, 2))  # the button is drawn


def _post_keys(codes):
    for code in codes:
        pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=code))


def test_clicks_queued_before_the_first_frame_land_on_the_screens_layout():
    """Input already waiting when the form opens (a fast person, a script, X events) is
    read before anything is drawn: it must meet the screen's layout, not a default one."""
    pygame.init()
    try:
        screen, clock = pygame.display.set_mode(SIZE), pygame.time.Clock()
        pygame.event.clear()
        _post_keys([pygame.K_RIGHT, pygame.K_DOWN] * 6 + [pygame.K_RETURN])  # every TLX subscale 50
        aimed = QuestionnaireForm(size=SIZE)
        aimed.page = aimed.pages.index(UEQ_PAGE)  # where the clicks are aimed: the UEQ-S page, after Enter
        for raw, item in enumerate(UEQ_ITEM_NAMES, start=1):
            for kind in (pygame.MOUSEBUTTONDOWN, pygame.MOUSEBUTTONUP):
                pygame.event.post(pygame.event.Event(kind, pos=aimed.radio_rect(item, min(raw, 7)).center, button=1))
        for kind in (pygame.MOUSEBUTTONDOWN, pygame.MOUSEBUTTONUP):
            pygame.event.post(pygame.event.Event(kind, pos=aimed.next_rect.center, button=1))
        _post_keys([pygame.K_ESCAPE])  # left with Esc (None) where the clicks missed
        rows = run_questionnaire(screen, clock, "P4", "manual", 2, fps=1000)
        assert rows is not None
        assert [row["value"] for row in rows if row["instrument"] == "ueq_s"] == [1, 2, 3, 4, 5, 6, 7, 7]
    finally:
        pygame.event.clear()
        pygame.quit()


def test_run_questionnaire_returns_full_rows_the_answer_file_accepts(tmp_path):
    pygame.init()
    try:
        screen, clock = pygame.display.set_mode(SIZE), pygame.time.Clock()
        pygame.event.clear()
        tlx = [pygame.K_RIGHT, pygame.K_DOWN] * 6 + [pygame.K_RETURN]  # every subscale 50
        _post_keys(tlx + [pygame.K_1] * 15 + [pygame.K_RETURN] + [pygame.K_6] * 8 + [pygame.K_RETURN])
        rows = run_questionnaire(screen, clock, "P3", "shared", 2, weighted=True, fps=1000)
        assert rows is not None and len(rows) == 20
        assert {(r["participant"], r["mode"], r["trial"]) for r in rows} == {("P3", "shared", 2)}
        path = tmp_path / "questionnaires.csv"
        append_answers(path, rows)
        scores = score(read_answers(path)).iloc[0]
        assert scores["raw_tlx"] == 50 and scores["weighted_tlx"] == 50 and scores["ueq_overall"] == 2

        pygame.event.clear()
        _post_keys([pygame.K_RIGHT, pygame.K_ESCAPE])
        assert run_questionnaire(screen, clock, "P3", "shared", 3, fps=1000) is None
        pygame.event.clear()
        pygame.event.post(pygame.event.Event(pygame.QUIT))
        assert run_questionnaire(screen, clock, "P3", "shared", 3, fps=1000) is None
    finally:
        pygame.quit()
