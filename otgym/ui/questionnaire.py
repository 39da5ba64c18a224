"""The post-trial questionnaire drawn inside the pygame-ce window, by mouse or keys.

Pages, each finished with Enter or the Next button (Backspace or Back returns):

1. NASA-TLX: six sliders 0-100 in steps of 5 (click or drag on the scale; Left/Right
   move the focused one by 5, starting from 50; Up/Down switch the focus).
2. Only when ``weighted``: the 15 TLX pairwise comparisons, "which contributed more to
   your workload?" (click one of the two; keys 1/2 choose for the focused pair).
3. UEQ-S: eight items, 7 radio buttons between the two poles (click; keys 1-7).

Items start unanswered; a page with unanswered items does not advance and names them.
Scales, item texts and scoring: ``otgym.study.questionnaires``. Widget rectangles
(``slider_rect``, ``choice_rect``, ``radio_rect``, ``next_rect``, ``back_rect``) are
public, for tests and for anyone driving the form by events."""

from __future__ import annotations

import os

from otgym.study.questionnaires import (
    NASA_TLX,
    TLX_ITEMS,
    TLX_PAIRS,
    TLX_STEP,
    TLX_SUBSCALES,
    UEQ_ITEM_NAMES,
    UEQ_ITEMS,
    UEQ_S,
    weights_from_choices,
)

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
import pygame  # noqa: E402  (after silencing its banner)

TLX_PAGE, PAIRS_PAGE, UEQ_PAGE = "nasa_tlx", "tlx_pairs", "ueq_s"
UEQ_POINTS = 7
"""Radio buttons per UEQ-S item: raw values 1 (negative pole) .. 7 (positive pole)."""
TLX_START = 50
"""Where Left/Right start on an unanswered slider."""

_BACKGROUND, _INK, _MUTED, _ACCENT, _WARN = (
    (248, 248, 245),
    (25, 25, 25),
    (120, 120, 120),
    (40, 110, 200),
    (190, 30, 30),
)
_FOCUS = (228, 236, 250)
_TITLES = {
    TLX_PAGE: "NASA-TLX: how was your workload in this trial?",
    PAIRS_PAGE: "NASA-TLX weights: which of the two contributed more to your workload?",
    UEQ_PAGE: "UEQ-S: how would you describe the interface you just used?",
}
_HELP = {
    TLX_PAGE: "Click or drag on a scale, or Up/Down to pick a scale and Left/Right to move it by 5.",
    PAIRS_PAGE: "Click one of the two, or Up/Down to pick a pair and 1 / 2 to choose.",
    UEQ_PAGE: "Click a circle, or Up/Down to pick an item and 1-7 to choose (1 = left word, 7 = right word).",
}


class QuestionnaireForm:
    """NASA-TLX (optionally weighted) then UEQ-S for one trial; ``done`` once every item
    is answered and the last page is confirmed; then ``answers()`` gives the rows.
    ``size``: the surface it is laid out for until ``draw`` gives it another (clicks
    are placed by the layout of the last surface drawn on, or this one before the first)."""

    def __init__(self, weighted: bool = False, size: tuple[int, int] = (960, 720)):
        self.weighted = weighted
        self.pages = [TLX_PAGE] + ([PAIRS_PAGE] if weighted else []) + [UEQ_PAGE]
        self.page = 0
        self.focus = 0
        self.done = False
        self.missing: list[str] = []  # shown after a refused Next
        self.ratings: dict[str, int | None] = dict.fromkeys(TLX_SUBSCALES)
        self.choices: dict[tuple, str | None] = dict.fromkeys(TLX_PAIRS)
        self.ueq: dict[str, int | None] = dict.fromkeys(UEQ_ITEM_NAMES)
        self._size = tuple(size)
        self._dragging: str | None = None
        self._fonts: dict[int, pygame.font.Font] = {}

    # --- what is on the current page --------------------------------------------------
    @property
    def page_name(self) -> str:
        return self.pages[self.page]

    def _keys(self) -> list:
        return {TLX_PAGE: list(TLX_SUBSCALES), PAIRS_PAGE: list(TLX_PAIRS), UEQ_PAGE: list(UEQ_ITEM_NAMES)}[
            self.page_name
        ]

    def _values(self) -> dict:
        return {TLX_PAGE: self.ratings, PAIRS_PAGE: self.choices, UEQ_PAGE: self.ueq}[self.page_name]

    def _label(self, key) -> str:
        if self.page_name == TLX_PAGE:
            return TLX_ITEMS[key][0]
        if self.page_name == PAIRS_PAGE:
            return f"{TLX_ITEMS[key[0]][0]} / {TLX_ITEMS[key[1]][0]}"
        return "{} - {}".format(*UEQ_ITEMS[UEQ_ITEM_NAMES.index(key)])

    # --- layout: rectangles for a surface of size self._size ---------------------------
    def _body(self) -> tuple[int, int, float]:
        """Left margin, top of the first row and row height of the current page."""
        width, height = self._size
        top, bottom = int(0.15 * height), int(0.86 * height)
        return int(0.05 * width), top, (bottom - top) / len(self._keys())

    def slider_rect(self, item: str) -> pygame.Rect:
        """The clickable scale of TLX subscale ``item``: its left edge is 0, its right edge 100."""
        width, _ = self._size
        _, top, row = self._body()
        y = top + TLX_SUBSCALES.index(item) * row
        return pygame.Rect(int(0.2 * width), int(y + 0.45 * row), int(0.6 * width), max(int(0.45 * row), 8))

    def choice_rect(self, pair: tuple, side: int) -> pygame.Rect:
        """The button of ``pair``'s first (``side`` 0) or second (1) subscale."""
        width, _ = self._size
        _, top, row = self._body()
        y = top + TLX_PAIRS.index(pair) * row
        return pygame.Rect(
            int((0.2 if side == 0 else 0.55) * width), int(y + 0.1 * row), int(0.25 * width), max(int(0.8 * row), 8)
        )

    def radio_rect(self, item: str, raw: int) -> pygame.Rect:
        """The radio button for raw value ``raw`` (1 = negative pole .. 7) of UEQ-S ``item``."""
        width, _ = self._size
        _, top, row = self._body()
        y = top + (UEQ_ITEM_NAMES.index(item) + 0.5) * row
        pitch = 0.36 * width / UEQ_POINTS
        side = int(min(0.7 * pitch, 0.8 * row))
        return pygame.Rect(0, 0, side, side).move(int(0.32 * width + (raw - 0.5) * pitch - side / 2), int(y - side / 2))

    @property
    def next_rect(self) -> pygame.Rect:
        width, height = self._size
        return pygame.Rect(int(0.78 * width), int(0.89 * height), int(0.17 * width), int(0.08 * height))

    @property
    def back_rect(self) -> pygame.Rect:
        width, height = self._size
        return pygame.Rect(int(0.05 * width), int(0.89 * height), int(0.17 * width), int(0.08 * height))

    # --- input -------------------------------------------------------------------------
    def _slider_value(self, item: str, x: float) -> int:
        rect = self.slider_rect(item)
        fraction = min(max((x - rect.left) / rect.width, 0.0), 1.0)
        return int(round(fraction * 100 / TLX_STEP) * TLX_STEP)

    def _click(self, pos) -> None:
        if self.next_rect.collidepoint(pos):
            self.next_page()
        elif self.back_rect.collidepoint(pos):
            self.previous_page()
        elif self.page_name == TLX_PAGE:
            for i, item in enumerate(TLX_SUBSCALES):
                if self.slider_rect(item).collidepoint(pos):
                    self.focus, self._dragging = i, item
                    self.ratings[item] = self._slider_value(item, pos[0])
        elif self.page_name == PAIRS_PAGE:
            for i, pair in enumerate(TLX_PAIRS):
                for side in (0, 1):
                    if self.choice_rect(pair, side).collidepoint(pos):
                        self.focus, self.choices[pair] = i, pair[side]
        else:
            for i, item in enumerate(UEQ_ITEM_NAMES):
                for raw in range(1, UEQ_POINTS + 1):
                    if self.radio_rect(item, raw).collidepoint(pos):
                        self.focus, self.ueq[item] = i, raw

    def _key(self, key: int) -> None:
        keys = self._keys()
        digit = {getattr(pygame, f"K_{n}"): n for n in range(1, 10)} | {
            getattr(pygame, f"K_KP{n}"): n for n in range(1, 10)
        }
        if key in (pygame.K_RETURN, pygame.K_KP_ENTER):
            self.next_page()
        elif key == pygame.K_BACKSPACE:
            self.previous_page()
        elif key in (pygame.K_UP, pygame.K_DOWN):
            self.focus = (self.focus + (1 if key == pygame.K_DOWN else -1)) % len(keys)
        elif key in (pygame.K_LEFT, pygame.K_RIGHT) and self.page_name == TLX_PAGE:
            item = keys[self.focus]
            step = TLX_STEP if key == pygame.K_RIGHT else -TLX_STEP
            current = self.ratings[item]
            self.ratings[item] = TLX_START if current is None else min(max(current + step, 0), 100)
        elif key in digit and self.page_name == PAIRS_PAGE and digit[key] <= 2:
            pair = keys[self.focus]
            self.choices[pair] = pair[digit[key] - 1]
            self.focus = min(self.focus + 1, len(keys) - 1)
        elif key in digit and self.page_name == UEQ_PAGE and digit[key] <= UEQ_POINTS:
            self.ueq[keys[self.focus]] = digit[key]
            self.focus = min(self.focus + 1, len(keys) - 1)

    def handle_event(self, event: pygame.event.Event) -> None:
        """Mouse button 1 down/up and motion, and key presses; other events are ignored."""
        if self.done:
            return
        if event.type == pygame.MOUSEBUTTONDOWN and event.button == 1:
            self._click(event.pos)
        elif event.type == pygame.MOUSEBUTTONUP and event.button == 1:
            self._dragging = None
        elif event.type == pygame.MOUSEMOTION and self._dragging and self.page_name == TLX_PAGE:
            self.ratings[self._dragging] = self._slider_value(self._dragging, event.pos[0])
        elif event.type == pygame.KEYDOWN:
            self._key(event.key)

    def next_page(self) -> None:
        """Advance (or finish on the last page) if every item of this page is answered;
        otherwise list the unanswered ones in ``missing``."""
        values = self._values()
        self.missing = [self._label(key) for key in self._keys() if values[key] is None]
        if self.missing:
            return
        if self.page == len(self.pages) - 1:
            self.done = True
        else:
            self.page, self.focus = self.page + 1, 0

    def previous_page(self) -> None:
        if self.page > 0:
            self.page, self.focus, self.missing = self.page - 1, 0, []

    def answers(self) -> list[dict]:
        """Rows ``{"instrument", "item", "value"}``: six TLX ratings, the six TLX weights
        when weighted, the eight UEQ-S raw values (1-7). ValueError before ``done``."""
        if not self.done:
            raise ValueError("the questionnaire is not finished")
        rows = [{"instrument": NASA_TLX, "item": item, "value": value} for item, value in self.ratings.items()]
        if self.weighted:
            rows += [
                {"instrument": NASA_TLX, "item": item, "value": value}
                for item, value in weights_from_choices(self.choices).items()
            ]
        return rows + [{"instrument": UEQ_S, "item": item, "value": value} for item, value in self.ueq.items()]

    # --- drawing -----------------------------------------------------------------------
    def _font(self, size: int) -> pygame.font.Font:
        if not pygame.font.get_init():
            pygame.font.init()
        if size not in self._fonts:
            self._fonts[size] = pygame.font.Font(None, size)
        return self._fonts[size]

    def _text(self, surface, text, size, color, pos, anchor="topleft") -> pygame.Rect:
        image = self._font(size).render(text, True, color)
        rect = image.get_rect(**{anchor: pos})
        surface.blit(image, rect)
        return rect

    def draw(self, surface: pygame.Surface) -> None:
        """Draw the current page over the whole of ``surface``, laid out to its size."""
        self._size = surface.get_size()
        width, height = self._size
        big, normal, small = max(int(height / 22), 16), max(int(height / 30), 14), max(int(height / 38), 12)
        surface.fill(_BACKGROUND)
        margin, top, row = self._body()
        self._text(
            surface,
            f"{_TITLES[self.page_name]}   (page {self.page + 1} of {len(self.pages)})",
            big,
            _INK,
            (margin, int(0.03 * height)),
        )
        self._text(surface, _HELP[self.page_name], small, _MUTED, (margin, int(0.09 * height)))
        focus_rect = pygame.Rect(margin // 2, int(top + self.focus * row), width - margin, int(row))
        pygame.draw.rect(surface, _FOCUS, focus_rect, border_radius=6)
        {TLX_PAGE: self._draw_tlx, PAIRS_PAGE: self._draw_pairs, UEQ_PAGE: self._draw_ueq}[self.page_name](
            surface, normal, small
        )
        if self.missing:
            self._text(
                surface,
                "Please answer: " + ", ".join(self.missing),
                small,
                _WARN,
                (width // 2, int(0.875 * height)),
                "midtop",
            )
        for rect, label, shown in (
            (self.back_rect, "Back", self.page > 0),
            (self.next_rect, "Finish" if self.page == len(self.pages) - 1 else "Next", True),
        ):
            if shown:
                pygame.draw.rect(surface, _ACCENT, rect, border_radius=8)
                self._text(surface, label, normal, (255, 255, 255), rect.center, "center")

    def _draw_tlx(self, surface, normal, small) -> None:
        margin, top, row = self._body()
        for i, item in enumerate(TLX_SUBSCALES):
            title, question, low, high = TLX_ITEMS[item]
            y = top + i * row
            self._text(surface, f"{title}: {question}", normal, _INK, (margin, int(y + 0.08 * row)))
            rect = self.slider_rect(item)
            mid = rect.centery
            pygame.draw.line(surface, _INK, (rect.left, mid), (rect.right, mid), 2)
            for k in range(0, 101, TLX_STEP):
                x = rect.left + rect.width * k / 100
                tall = 0.4 if k % 50 == 0 else 0.25
                pygame.draw.line(surface, _INK, (x, mid - tall * rect.height), (x, mid), 1)
            self._text(surface, low, small, _MUTED, (rect.left - 12, mid), "midright")
            self._text(surface, high, small, _MUTED, (rect.right + 12, mid), "midleft")
            value = self.ratings[item]
            if value is None:
                self._text(surface, "not answered", small, _WARN, (rect.centerx, mid + 4), "midtop")
            else:
                x = rect.left + rect.width * value / 100
                pygame.draw.circle(surface, _ACCENT, (int(x), mid), max(rect.height // 4, 5))
                self._text(surface, str(value), small, _ACCENT, (int(x), mid + rect.height // 4 + 2), "midtop")

    def _draw_pairs(self, surface, normal, small) -> None:
        margin, top, row = self._body()
        for i, pair in enumerate(TLX_PAIRS):
            self._text(surface, f"{i + 1}.", small, _MUTED, (margin, int(top + (i + 0.5) * row)), "midleft")
            for side in (0, 1):
                rect = self.choice_rect(pair, side)
                chosen = self.choices[pair] == pair[side]
                pygame.draw.rect(surface, _ACCENT if chosen else (255, 255, 255), rect, border_radius=6)
                pygame.draw.rect(surface, _ACCENT, rect, 2, border_radius=6)
                self._text(
                    surface,
                    f"{side + 1}: {TLX_ITEMS[pair[side]][0]}",
                    normal,
                    (255, 255, 255) if chosen else _INK,
                    rect.center,
                    "center",
                )
            between = (self.choice_rect(pair, 0).right + self.choice_rect(pair, 1).left) // 2
            self._text(surface, "or", small, _MUTED, (between, self.choice_rect(pair, 0).centery), "center")

    def _draw_ueq(self, surface, normal, small) -> None:
        for item, (negative, positive) in zip(UEQ_ITEM_NAMES, UEQ_ITEMS):
            first, last = self.radio_rect(item, 1), self.radio_rect(item, UEQ_POINTS)
            self._text(surface, negative, normal, _INK, (first.left - 16, first.centery), "midright")
            self._text(surface, positive, normal, _INK, (last.right + 16, last.centery), "midleft")
            for raw in range(1, UEQ_POINTS + 1):
                rect = self.radio_rect(item, raw)
                pygame.draw.circle(surface, _INK, rect.center, rect.width // 2, 2)
                if self.ueq[item] == raw:
                    pygame.draw.circle(surface, _ACCENT, rect.center, rect.width // 2 - 4)
            if self.ueq[item] is None:
                self._text(surface, "not answered", small, _WARN, (int(0.85 * self._size[0]), last.centery), "midleft")


def run_questionnaire(
    screen: pygame.Surface,
    clock: pygame.time.Clock,
    participant,
    mode: str,
    trial: int,
    weighted: bool = False,
    fps: int = 60,
) -> list[dict] | None:
    """Show a ``QuestionnaireForm`` on ``screen`` until it is finished; return its rows
    with ``participant``, ``mode`` and ``trial`` (the keys of ``QUESTIONNAIRE_COLUMNS``,
    ready for ``append_answers``), or None if the window is closed or Esc is pressed
    (nothing is saved here either way). Laid out for ``screen`` from the start, so
    clicks already queued before its first frame land where they were aimed."""
    form = QuestionnaireForm(weighted=weighted, size=screen.get_size())
    while not form.done:
        for event in pygame.event.get():
            if event.type == pygame.QUIT or (event.type == pygame.KEYDOWN and event.key == pygame.K_ESCAPE):
                return None
            form.handle_event(event)
            if form.done:
                break
        form.draw(screen)
        pygame.display.flip()
        clock.tick(fps)
    return [{"participant": participant, "mode": mode, "trial": trial, **row} for row in form.answers()]
