"""Frames of a recording's global view: the chip's walls and channels, the planned route
and its destination, every sphere by kind (robots orange with darker trap handles, the
cell green, obstacles purple), the traps (red rings), under a strip that gives the
trial, the time in the trial, the mode and alpha.

The chip, spheres, traps and route are drawn by ``otgym.sim.render.SceneRenderer``
(the same drawing as the Gymnasium adapter's frames); the destination ring (the
route's end, radius the task's goal tolerance) and the strip's text by Pillow.
Without a recorded chip the view is fitted to every body of the recording on a blank
field (``SessionScene.chip_note`` says why). Frames are ``width_px`` wide; both sides
are even, as H.264's 4:2:0 video needs.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from otgym.record.mcap_file import Recording
from otgym.record.replay import BODIES, Decoder, SessionScene, Tick, session_scene, ticks, xy_um
from otgym.sim.render import PATH_RGB, SceneRenderer

STRIP_PX = 28
STRIP_RGB = (30, 34, 42)
TEXT_RGB = (235, 238, 242)
FIT_MARGIN_UM = 10.0
DEFAULT_WIDTH_PX = 960


def _even(value: float) -> int:
    return max(16, int(round(value / 2)) * 2)


def _fitted_region(recording: Recording) -> tuple[float, float, float, float]:
    """The box around every recorded sphere centre, FIT_MARGIN_UM wider each way."""
    decode = Decoder()
    arrays = [xy_um(decode(message).poses) for message in recording.topic(BODIES)]
    if not arrays:
        return (0.0, 0.0, 100.0, 100.0)
    points = np.concatenate(arrays)
    low, high = points.min(axis=0) - FIT_MARGIN_UM, points.max(axis=0) + FIT_MARGIN_UM
    return (float(low[0]), float(low[1]), float(high[0]), float(high[1]))


class FrameRenderer:
    """Draws ``Tick`` s of one recording as RGB frames (height, width, 3) uint8."""

    def __init__(self, recording: Recording, scene: SessionScene | None = None, width_px: int = DEFAULT_WIDTH_PX):
        if width_px < 64:
            raise ValueError(f"frames must be at least 64 pixels wide, got {width_px}")
        self.scene = scene if scene is not None else session_scene(recording)
        chip = self.scene.chip
        region = (0.0, 0.0) + tuple(chip.size_um) if chip is not None else _fitted_region(recording)
        width_um, height_um = region[2] - region[0], region[3] - region[1]
        self.width_px = _even(width_px)
        view_px = _even(self.width_px * height_um / width_um)
        self.height_px = view_px + STRIP_PX
        self.view = SceneRenderer(chip, (self.width_px, view_px), region_um=region)
        self.font = ImageFont.load_default(size=16)

    def draw(self, tick: Tick) -> np.ndarray:
        scene = self.scene
        n = len(tick.sphere_xy_um)
        radii = (
            tick.sphere_radius_um
            if tick.sphere_radius_um is not None and len(tick.sphere_radius_um) == n
            else np.ones(n)
        )
        kinds = scene.sphere_kind if len(scene.sphere_kind) == n else np.full(n, -1)
        handles = np.zeros(n, bool)
        handles[scene.handle_spheres[scene.handle_spheres < n]] = True
        view = self.view.render(tick.sphere_xy_um, radii, kinds, handles, tick.trap_xy_um, scene.route_um)
        frame = Image.new("RGB", (self.width_px, self.height_px), STRIP_RGB)
        frame.paste(Image.fromarray(view), (0, STRIP_PX))
        draw = ImageDraw.Draw(frame)
        if scene.route_um is not None and len(scene.route_um) and scene.goal_tolerance_um:
            x, y = self.view.to_px(scene.route_um[-1]) + (0, STRIP_PX)
            r = max(scene.goal_tolerance_um * self.view.scale, 5.0)
            draw.ellipse((x - r, y - r, x + r, y + r), outline=tuple(int(c) for c in PATH_RGB), width=2)
        draw.text((8, 5), label(tick), fill=TEXT_RGB, font=self.font)
        return np.asarray(frame)


def label(tick: Tick) -> str:
    """The strip's text: trial, time in the trial, mode and alpha ("?" where not recorded)."""
    alpha = f"{tick.alpha:.2f}" if tick.alpha is not None else "?"
    return f"trial {tick.trial}    t {tick.time_s:6.2f} s    mode {tick.mode or '?'}    alpha {alpha}"


def render_frames(
    recording: Recording, out_dir: Path, every: int = 25, width_px: int = DEFAULT_WIDTH_PX, progress=None
) -> list[Path]:
    """PNG frames ``frame_00000.png``... of the global view into ``out_dir``, one per
    ``every`` ticks; ``progress(done, total)`` after each."""
    if every < 1:
        raise ValueError(f"every must be a positive number of ticks, got {every}")
    renderer = FrameRenderer(recording, width_px=width_px)
    total = -(-len(recording.topic(BODIES)) // every)
    written = []
    for tick in ticks(recording, renderer.scene.tick_s, lambda index: index % every == 0):
        path = Path(out_dir) / f"frame_{len(written):05d}.png"
        Image.fromarray(renderer.draw(tick)).save(path)
        written.append(path)
        if progress is not None:
            progress(len(written), total)
    return written
