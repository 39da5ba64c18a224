"""RGB top-down view of a scene for people: channels, optional flow arrows, robots
(handles darker), traps (red rings), cell, obstacles, beads and a path, and a task's own
marks (``Line``, ``Disc``, ``Label``: a target direction, a port, a legend) beneath the
bodies or above them.

Speed: the chip background (and the flow arrows) are drawn once per ``SceneRenderer``;
a frame copies it and blends anti-aliased discs, rings and the path into small
windows with numpy. Inputs are plain numpy (um; origin at the chip's top-left corner,
x right, y down), so rendering does not depend on the physics state.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from otgym.physics.bodies import BodyKind
from otgym.sim.chip import Chip

CHANNEL_RGB = np.array([236, 242, 248], np.float32)
SOLID_RGB = np.array([70, 76, 88], np.float32)
ARROW_RGB = np.array([120, 160, 215], np.float32)
KIND_RGB = {
    BodyKind.ROBOT: np.array([235, 150, 50], np.float32),
    BodyKind.CELL: np.array([90, 185, 100], np.float32),
    BodyKind.OBSTACLE: np.array([130, 100, 170], np.float32),
    BodyKind.BEAD: np.array([230, 200, 60], np.float32),
}
UNKNOWN_KIND_RGB = np.array([160, 160, 160], np.float32)
"""A sphere whose kind is not a ``BodyKind`` (e.g. -1: unknown, in an old recording)."""
HANDLE_RGB = np.array([185, 70, 30], np.float32)
TRAP_RGB = np.array([220, 30, 40], np.float32)
PATH_RGB = np.array([200, 40, 200], np.float32)
ARROW_SPACING_PX = 24
LINE_WIDTH_PX = 1.2
LABEL_SIZE_PX = 15
"""The height of a ``Label``'s font (Pillow's default font) in a frame ``LABEL_FRAME_PX``
wide; in proportion to the frame's width otherwise, 11 px at the least."""
LABEL_FRAME_PX = 840


@dataclasses.dataclass(frozen=True)
class Line:
    """A polyline through ``points_um`` (M, 2), ``width_px`` wide; dashed (``dash_px``
    drawn, as much left out) when given; with an arrowhead at its last point when
    ``arrow``."""

    points_um: np.ndarray
    rgb: tuple[float, float, float]
    width_px: float = 2.0
    dash_px: float | None = None
    arrow: bool = False


@dataclasses.dataclass(frozen=True)
class Disc:
    """A disc of ``radius_um`` about ``centre_um`` blended at ``opacity``, or, with
    ``ring_px``, a ring that wide."""

    centre_um: tuple[float, float]
    radius_um: float
    rgb: tuple[float, float, float]
    opacity: float = 1.0
    ring_px: float | None = None


@dataclasses.dataclass(frozen=True)
class Label:
    """Text at ``xy`` (um; pixels when ``at_px``), placed by its Pillow ``anchor``
    (``"la"``: left, ascender), over a box of ``box_rgb`` when given. Labels are drawn
    last, above everything."""

    xy: tuple[float, float]
    text: str
    rgb: tuple[int, int, int]
    anchor: str = "la"
    at_px: bool = False
    box_rgb: tuple[int, int, int] | None = None


class SceneRenderer:
    """Renders frames of ``size_px`` = (width, height) pixels showing ``region_um`` =
    (x0, y0, x1, y1) of the chip (default: all of it), aspect ratio kept, centred.
    ``flow_velocity_um_s``: optional node velocity grid (H+1, W+1, 2) of the chip
    (``FlowSolution.node_velocity_um_s``) to draw arrows. ``chip`` None (its region
    then required): a plain channel-coloured field, for a scene whose chip is unknown."""

    def __init__(
        self,
        chip: Chip | None,
        size_px: tuple[int, int] = (512, 512),
        flow_velocity_um_s=None,
        region_um: tuple[float, float, float, float] | None = None,
    ):
        width, height = size_px
        if width < 16 or height < 16:
            raise ValueError(f"size_px must be at least 16 x 16, got {size_px}")
        if chip is None and (region_um is None or flow_velocity_um_s is not None):
            raise ValueError("without a chip, give region_um (and no flow)")
        x0, y0, x1, y1 = region_um if region_um is not None else (0.0, 0.0) + chip.size_um
        if not (x1 > x0 and y1 > y0):
            raise ValueError(f"region_um must be (x0, y0, x1, y1) with x1 > x0 and y1 > y0, got {region_um}")
        self.scale = min(width / (x1 - x0), height / (y1 - y0))
        self.offset = np.array(
            [
                (width - (x1 - x0) * self.scale) / 2 - x0 * self.scale,
                (height - (y1 - y0) * self.scale) / 2 - y0 * self.scale,
            ]
        )
        self.background = self._background(chip, (height, width))
        if flow_velocity_um_s is not None:
            _draw_arrows(self.background, self, np.asarray(flow_velocity_um_s), chip.pixel_size_um)
        self.background = np.round(self.background).astype(np.uint8)

    def to_px(self, xy_um) -> np.ndarray:
        return self.offset + np.asarray(xy_um, float) * self.scale

    def _background(self, chip: Chip | None, shape) -> np.ndarray:
        if chip is None:
            return np.broadcast_to(CHANNEL_RGB, (*shape, 3)).copy()
        rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]]
        x_um = (cols + 0.5 - self.offset[0]) / self.scale
        y_um = (rows + 0.5 - self.offset[1]) / self.scale
        index = [y_um / chip.pixel_size_um - 0.5, x_um / chip.pixel_size_um - 0.5]
        from scipy import ndimage  # a second to import: only where a chip is drawn

        gray = ndimage.map_coordinates(chip.image, index, order=1, mode="constant", cval=0.0)
        return SOLID_RGB + gray[..., None] * (CHANNEL_RGB - SOLID_RGB)

    def render(
        self,
        sphere_xy_um,
        sphere_radius_um,
        sphere_kind,
        handle_mask,
        trap_xy_um,
        path_um=None,
        *,
        sphere_rgb=None,
        under=(),
        over=(),
    ) -> np.ndarray:
        """One RGB frame (height, width, 3) uint8. Spheres (N, 2), (N,), (N,) kinds
        (``BodyKind``; any other value is drawn grey, beneath the rest), handles (N,)
        bool, traps (T, 2), path (M, 2) or None. ``sphere_rgb`` (N, 3): each sphere's
        colour instead of its kind's (handles keep theirs); ``under`` and ``over``: marks
        (``Line``, ``Disc``, ``Label``) drawn beneath the spheres and above the traps."""
        frame = self.background.astype(np.float32)
        if path_um is not None and len(path_um) > 1:
            _draw_polyline(frame, self.to_px(path_um), PATH_RGB, LINE_WIDTH_PX)
        self._draw_marks(frame, under)
        colours = None if sphere_rgb is None else np.asarray(sphere_rgb, np.float32).reshape(-1, 3)
        centres = self.to_px(np.asarray(sphere_xy_um, float).reshape(-1, 2))
        radii = np.asarray(sphere_radius_um, float).reshape(-1) * self.scale
        kinds = np.asarray(sphere_kind).reshape(-1)
        handles = np.asarray(handle_mask, bool).reshape(-1)
        for index in np.flatnonzero(~np.isin(kinds, list(KIND_RGB))):
            _blend_disc(frame, centres[index], radii[index], HANDLE_RGB if handles[index] else UNKNOWN_KIND_RGB)
        for order in (BodyKind.OBSTACLE, BodyKind.CELL, BodyKind.BEAD, BodyKind.ROBOT):
            for index in np.flatnonzero(kinds == order):
                colour = KIND_RGB[BodyKind(order)] if colours is None else colours[index]
                _blend_disc(frame, centres[index], radii[index], HANDLE_RGB if handles[index] else colour)
        trap_radius = max(3.0, 0.6 * self.scale)
        for centre in self.to_px(np.asarray(trap_xy_um, float).reshape(-1, 2)):
            _blend_disc(frame, centre, trap_radius, TRAP_RGB, ring_width=LINE_WIDTH_PX)
        self._draw_marks(frame, over)
        image = frame.astype(np.uint8)
        labels = [mark for mark in (*under, *over) if isinstance(mark, Label)]
        return _draw_labels(image, self, labels) if labels else image

    def _draw_marks(self, frame, marks) -> None:
        for mark in marks:
            if isinstance(mark, Disc):
                centre = self.to_px(np.asarray(mark.centre_um, float))
                colour = np.asarray(mark.rgb, np.float32)
                _blend_disc(frame, centre, mark.radius_um * self.scale, colour, mark.ring_px, mark.opacity)
            elif isinstance(mark, Line):
                points = self.to_px(np.asarray(mark.points_um, float).reshape(-1, 2))
                _stroke(frame, points, np.asarray(mark.rgb, np.float32), mark.width_px, mark.dash_px, mark.arrow)
            elif not isinstance(mark, Label):
                raise TypeError(f"a mark is a Line, a Disc or a Label, got {type(mark).__name__}")


def _blend_disc(frame, centre, radius, colour, ring_width=None, opacity=1.0):
    """Anti-aliased disc (or ring of ``ring_width``) blended into ``frame`` in place at
    ``opacity``."""
    height, width = frame.shape[:2]
    reach = radius + 1.5
    r0, r1 = max(int(centre[1] - reach), 0), min(int(centre[1] + reach) + 2, height)
    c0, c1 = max(int(centre[0] - reach), 0), min(int(centre[0] + reach) + 2, width)
    if r0 >= r1 or c0 >= c1:
        return
    dy = np.arange(r0, r1) + 0.5 - centre[1]
    dx = np.arange(c0, c1) + 0.5 - centre[0]
    distance = np.sqrt(dy[:, None] ** 2 + dx[None, :] ** 2)
    if ring_width is None:
        alpha = np.clip(radius - distance + 0.5, 0.0, 1.0)
    else:
        alpha = np.clip(ring_width / 2 - np.abs(distance - radius) + 0.5, 0.0, 1.0)
    window = frame[r0:r1, c0:c1]
    window += opacity * alpha[..., None] * (colour - window)


def _line_points(points_px, spacing=0.5):
    """Points every ``spacing`` pixels along a polyline (M, 2)."""
    start, end = points_px[:-1], points_px[1:]
    counts = np.maximum(np.ceil(np.linalg.norm(end - start, axis=1) / spacing).astype(int), 1)
    owner = np.repeat(np.arange(start.shape[0]), counts)
    fraction = (np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)) / counts[owner]
    return start[owner] + fraction[:, None] * (end - start)[owner]


def _draw_polyline(frame, points_px, colour, width_px):
    """Stamp the nearest pixels of densely sampled points (a line about one pixel wide)."""
    samples = _line_points(points_px)
    offsets = np.array([(0, 0), (0.5, 0), (-0.5, 0), (0, 0.5), (0, -0.5)]) * (width_px - 1.0)
    stamped = (samples[:, None, :] + offsets[None]).reshape(-1, 2)
    cols = np.floor(stamped[:, 0]).astype(int)
    rows = np.floor(stamped[:, 1]).astype(int)
    inside = (rows >= 0) & (rows < frame.shape[0]) & (cols >= 0) & (cols < frame.shape[1])
    frame[rows[inside], cols[inside]] = colour


def _stroke(frame, points_px, colour, width_px, dash_px=None, arrow=False):
    """A polyline ``width_px`` wide (stamped discs of sample points every half pixel),
    dashed when ``dash_px`` is given, with an arrowhead at its end when ``arrow``."""
    if len(points_px) < 2:
        return
    samples = _line_points(points_px)
    if dash_px:
        along = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(samples, axis=0), axis=1))])
        samples = samples[(along // dash_px) % 2 == 0]
    reach = max(width_px / 2 - 0.5, 0.0)
    grid = np.arange(-reach, reach + 0.25, 0.5)
    offsets = np.array([(x, y) for x in grid for y in grid if x * x + y * y <= reach * reach + 1e-9] or [(0.0, 0.0)])
    if arrow:
        tip, before = points_px[-1], points_px[-2]
        direction = (tip - before) / max(float(np.linalg.norm(tip - before)), 1e-9)
        side = np.array([-direction[1], direction[0]])
        head = max(10.0, 4.0 * width_px)
        wings = [tip - head * (direction + 0.55 * side), tip - head * (direction - 0.55 * side)]
        samples = np.concatenate([samples, *(_line_points(np.array([tip, wing])) for wing in wings)])
    stamped = (samples[:, None, :] + offsets[None]).reshape(-1, 2)
    cols = np.floor(stamped[:, 0]).astype(int)
    rows = np.floor(stamped[:, 1]).astype(int)
    inside = (rows >= 0) & (rows < frame.shape[0]) & (cols >= 0) & (cols < frame.shape[1])
    frame[rows[inside], cols[inside]] = colour


@functools.lru_cache(maxsize=4)
def _label_font(size_px: int):
    from PIL import ImageFont

    return ImageFont.load_default(size=size_px)


def _draw_labels(image, renderer: SceneRenderer, labels) -> np.ndarray:
    """``image`` (uint8) with each ``Label`` written on it (Pillow's default font)."""
    from PIL import Image, ImageDraw

    picture = Image.fromarray(image)
    draw = ImageDraw.Draw(picture)
    font = _label_font(max(11, round(LABEL_SIZE_PX * image.shape[1] / LABEL_FRAME_PX)))
    for label in labels:
        xy = tuple(float(v) for v in (label.xy if label.at_px else renderer.to_px(np.asarray(label.xy, float))))
        if label.box_rgb is not None:
            left, top, right, bottom = draw.textbbox(xy, label.text, font=font, anchor=label.anchor)
            draw.rectangle((left - 4, top - 3, right + 4, bottom + 3), fill=tuple(label.box_rgb))
        draw.text(xy, label.text, fill=tuple(int(v) for v in label.rgb), font=font, anchor=label.anchor)
    return np.asarray(picture)


def _draw_arrows(background, renderer: SceneRenderer, node_velocity, pixel_size_um):
    """Arrows on a lattice of ARROW_SPACING_PX, length proportional to the local speed
    (the fastest arrow spans 0.9 lattice steps), where the flow is non-zero."""
    height, width = background.shape[:2]
    speed = np.linalg.norm(node_velocity, axis=-1)
    peak = speed.max()
    if peak <= 0:
        return
    rows, cols = np.mgrid[
        ARROW_SPACING_PX // 2 : height : ARROW_SPACING_PX, ARROW_SPACING_PX // 2 : width : ARROW_SPACING_PX
    ]
    base_px = np.stack([cols.ravel(), rows.ravel()], axis=-1).astype(float)
    base_um = (base_px - renderer.offset) / renderer.scale
    index = [base_um[:, 1] / pixel_size_um, base_um[:, 0] / pixel_size_um]
    from scipy import ndimage

    velocity = np.stack([ndimage.map_coordinates(node_velocity[..., k], index, order=1, cval=0.0) for k in (0, 1)], -1)
    length = np.linalg.norm(velocity, axis=-1)
    for start, v, size in zip(base_px, velocity, length):
        if size < 0.05 * peak:
            continue
        tip = start + v / peak * 0.9 * ARROW_SPACING_PX
        direction = v / size
        side = np.array([-direction[1], direction[0]])
        head = 0.3 * np.linalg.norm(tip - start)
        for wing in (tip - head * (direction + 0.6 * side), tip - head * (direction - 0.6 * side)):
            _draw_polyline(background, np.array([tip, wing]), ARROW_RGB, 1.0)
        _draw_polyline(background, np.array([start, tip]), ARROW_RGB, 1.0)
