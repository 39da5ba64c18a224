"""What the window draws (paper Fig. 9: a global view, a local view, and cues).

* ``GlobalView``: the whole chip, to plan and to see what is coming. Static layers are
  drawn once into a background surface: the walls (dark) and channels (light), the
  flow as a faint blue tint by speed with arrows along it (the cell drifts with it
  when free), the planned route (blue polyline) and the destination (a ring at its
  end). Each frame adds the bodies as their spheres (robots orange, their handles
  darker, the cell green, obstacles purple with an arrow of where they go in the next
  ``VELOCITY_ARROW_S``), the traps (yellow crosses), the motion direction (an arrow
  from the cell toward the route ahead), the local view's field (a white square) and a
  drag in progress (a line from the robot's traps to the pointer).
* ``LocalView``: the microscope-like bright-field image around the cell
  (``sim.microscope.microscope_images``, the same image model the vision force sensor
  reads, at a coarser pixel: a lower-magnification camera), ``LOCAL_FIELD_UM`` square
  (the cell and both robots), at ``LOCAL_VIEW_HZ`` (a camera's rate; rendering
  it every frame would take a third of the frame budget), with the traps (crosses) and
  each handle-to-trap vector the sensor measured, magnified ``OFFSET_MAGNIFICATION``
  times (the offsets are tenths of a micrometre): these offsets drive the force the
  stylus feeds back.
* ``CuePanel``: the cues of ``otgym.ui.cues`` as bars, a compass and prompts.

Each view draws from the task's ``TaskLayout`` (``otgym.task.layout``) and a
``Snapshot``, and returns the rectangles it changed, so that the window presents only
those (``pygame.display.update(rects)``): under an X server without a GPU (Xvfb,
remote X) presenting the whole 1280 x 720 frame costs about 9 ms of CPU a frame.
"""

from __future__ import annotations

import math

import numpy as np
import pygame

from otgym.runtime.snapshot import Snapshot
from otgym.sim.microscope import MicroscopeParams, microscope_images
from otgym.task.layout import TaskLayout
from otgym.ui import cues
from otgym.ui.palette import (  # noqa: F401  (the views' colours, used by the window too)
    BACKGROUND_RGB,
    CELL_RGB,
    CHANNEL_RGB,
    DIM_TEXT_RGB,
    FLOW_RGB,
    HANDLE_RGB,
    OBSTACLE_RGB,
    OTHER_RGB,
    ROBOT_RGB,
    ROUTE_RGB,
    TEXT_RGB,
    TRAP_RGB,
    WALL_RGB,
    fonts,
)

FLOW_ARROW_SPACING_UM = 20.0
VELOCITY_ARROW_S = 3.0
LOCAL_FIELD_UM = 18.0
LOCAL_PIXEL_UM = 0.15
LOCAL_VIEW_HZ = 25.0
OFFSET_MAGNIFICATION = 10.0
MICROSCOPE = MicroscopeParams()


def arrow(surface, rgb, start, end, width: int = 2, head_px: float = 7.0) -> pygame.Rect | None:
    """A line from ``start`` to ``end`` (pixels) with a head at ``end``; the pixels it
    touched (None when too short to draw)."""
    start, end = np.asarray(start, float), np.asarray(end, float)
    delta = end - start
    length = float(np.linalg.norm(delta))
    if length < 1.0:
        return None
    line = pygame.draw.line(surface, rgb, start, end, width)
    unit = delta / length
    normal = np.array([-unit[1], unit[0]])
    head = min(head_px, 0.6 * length)
    return line.union(
        pygame.draw.polygon(
            surface, rgb, [end, end - head * unit + 0.5 * head * normal, end - head * unit - 0.5 * head * normal]
        )
    )


def cross(surface, rgb, centre, size_px: float = 5.0, width: int = 2) -> pygame.Rect:
    x, y = centre
    return pygame.draw.line(surface, rgb, (x - size_px, y), (x + size_px, y), width).union(
        pygame.draw.line(surface, rgb, (x, y - size_px), (x, y + size_px), width)
    )


def union(rects) -> pygame.Rect | None:
    """The smallest rectangle holding every one of ``rects`` (None entries skipped)."""
    rects = [r for r in rects if r is not None]
    return rects[0].unionall(rects[1:]) if rects else None


class GlobalView:
    """The chip fitted into ``rect`` (pixels), um <-> pixel transforms, and its drawing."""

    def __init__(self, layout: TaskLayout, rect: pygame.Rect):
        chip = layout.chip
        width_um, height_um = chip.size_um
        self.scale_px_per_um = min(rect.width / width_um, rect.height / height_um)
        self.rect = pygame.Rect(
            rect.x, rect.y, round(width_um * self.scale_px_per_um), round(height_um * self.scale_px_per_um)
        )
        self.layout = layout
        bodies = layout.sphere_body
        self.robot_spheres = np.flatnonzero(np.isin(bodies, layout.robots))
        self.handle_spheres = np.asarray(layout.trap_sphere)
        self.cell_spheres = np.flatnonzero(bodies == layout.payload)
        self.obstacle_spheres = np.flatnonzero(np.isin(bodies, layout.obstacles))
        self.obstacle_sphere_of = [np.flatnonzero(bodies == body) for body in layout.obstacles]
        robot_of_body = {body: index for index, body in enumerate(layout.robots)}
        self.sphere_robot_index = np.array([robot_of_body[b] for b in bodies[self.robot_spheres]], int)
        self.trap_robot_index = np.array([robot_of_body[b] for b in layout.trap_robot], int)
        self.background = self._background()
        self._previous_rects: list[pygame.Rect] = []

    def to_px(self, xy_um) -> np.ndarray:
        return np.asarray(xy_um, float) * self.scale_px_per_um + np.array(self.rect.topleft, float)

    def to_um(self, xy_px) -> np.ndarray:
        return (np.asarray(xy_px, float) - np.array(self.rect.topleft, float)) / self.scale_px_per_um

    def _background(self) -> pygame.Surface:
        chip = self.layout.chip
        height, width = chip.shape
        ys, xs = np.meshgrid(
            (np.arange(height) + 0.5) * chip.pixel_size_um, (np.arange(width) + 0.5) * chip.pixel_size_um, indexing="ij"
        )
        points = np.stack([xs, ys], axis=-1).reshape(-1, 2)
        velocity = self.layout.flow_velocity_um_s
        speed = np.linalg.norm(velocity, axis=-1)
        fluid = chip.fluid
        tint = np.clip(speed / max(float(speed[fluid].max(initial=0.0)), 1e-9), 0, 1)[..., None] * 0.35
        rgb = np.where(
            fluid[..., None], (1 - tint) * np.array(CHANNEL_RGB) + tint * np.array(FLOW_RGB), np.array(WALL_RGB)
        )
        chip_surface = pygame.surfarray.make_surface(np.ascontiguousarray(rgb.transpose(1, 0, 2)).astype(np.uint8))
        surface = pygame.transform.smoothscale(chip_surface, self.rect.size)
        offset = -np.array(self.rect.topleft, float)
        spacing_px = max(int(FLOW_ARROW_SPACING_UM / chip.pixel_size_um), 1)
        top = float(speed[fluid].max(initial=0.0))
        for row in range(spacing_px // 2, height, spacing_px):
            for col in range(spacing_px // 2, width, spacing_px):
                if not fluid[row, col] or speed[row, col] < 0.05 * top:
                    continue
                centre = self.to_px(points[row * width + col]) + offset
                tip = velocity[row, col] / top * 0.45 * FLOW_ARROW_SPACING_UM * self.scale_px_per_um
                arrow(surface, FLOW_RGB, centre - tip, centre + tip, 1, 5.0)
        route = self.to_px(self.layout.route_um) + offset
        pygame.draw.lines(surface, ROUTE_RGB, False, route, 3)
        goal = route[-1]
        ring_px = max(int(self.layout.goal_tolerance_um * self.scale_px_per_um), 6)
        pygame.draw.circle(surface, ROUTE_RGB, goal, ring_px + 4, 3)
        pygame.draw.circle(surface, ROUTE_RGB, goal, 3)
        return surface

    def robot_at(self, snapshot: Snapshot, xy_px, reach_px: float = 18.0) -> int | None:
        """The robot whose spheres or traps are nearest the pixel, within ``reach_px``."""
        points = [
            (self.to_px(snapshot.sphere_xy_um[s]), int(r)) for s, r in zip(self.robot_spheres, self.sphere_robot_index)
        ]
        points += [(self.to_px(xy), int(r)) for xy, r in zip(snapshot.observation.trap_xy_um[0], self.trap_robot_index)]
        best = min(points, key=lambda item: float(np.linalg.norm(item[0] - np.asarray(xy_px, float))))
        return best[1] if float(np.linalg.norm(best[0] - np.asarray(xy_px, float))) <= reach_px else None

    def trap_centre_um(self, snapshot: Snapshot, robot: int) -> np.ndarray:
        return snapshot.observation.trap_xy_um[0][self.trap_robot_index == robot].mean(axis=0)

    def draw(
        self, surface: pygame.Surface, snapshot: Snapshot, drag: tuple[int, np.ndarray] | None
    ) -> list[pygame.Rect]:
        """Draw the view; returns the rectangles that may differ from the previous
        draw (where moving things are now and where they were)."""
        surface.blit(self.background, self.rect.topleft)
        clip = surface.get_clip()
        surface.set_clip(self.rect)
        obs = snapshot.observation
        scale = self.scale_px_per_um
        radii = self.layout.sphere_radius_um
        spheres = self.to_px(snapshot.sphere_xy_um)
        circle = lambda s, rgb: pygame.draw.circle(surface, rgb, spheres[s], max(radii[s] * scale, 1.5))  # noqa: E731
        rects = []
        for spheres_of, centre, velocity in zip(
            self.obstacle_sphere_of, self.to_px(obs.obstacle_xy_um[0]), snapshot.obstacle_velocity_um_s
        ):
            drawn = [circle(s, OBSTACLE_RGB) for s in spheres_of]
            drawn.append(arrow(surface, OBSTACLE_RGB, centre, centre + velocity * VELOCITY_ARROW_S * scale, 2, 6.0))
            rects.append(union(drawn))
        assembly = [circle(s, CELL_RGB) for s in self.cell_spheres]
        assembly += [circle(s, ROBOT_RGB) for s in self.robot_spheres]
        assembly += [circle(s, HANDLE_RGB) for s in self.handle_spheres]
        assembly += [cross(surface, TRAP_RGB, trap, 4.0, 2) for trap in self.to_px(obs.trap_xy_um[0])]
        cell = self.to_px(obs.cell_xy_um[0])
        direction = cues.motion_direction(
            obs.cell_xy_um[0], float(obs.cell_arc_um[0]), self.layout.route_um, self.layout.route_arc_um
        )
        assembly.append(arrow(surface, ROUTE_RGB, cell, cell + direction * 14.0 * scale, 3, 9.0))
        half = 0.5 * LOCAL_FIELD_UM * scale
        assembly.append(
            pygame.draw.rect(
                surface, (255, 255, 255), pygame.Rect(cell[0] - half, cell[1] - half, 2 * half, 2 * half), 1
            )
        )
        if drag is not None:
            robot, pointer_um = drag
            assembly.append(
                pygame.draw.line(
                    surface, TRAP_RGB, self.to_px(self.trap_centre_um(snapshot, robot)), self.to_px(pointer_um), 1
                )
            )
            assembly.append(pygame.draw.circle(surface, TRAP_RGB, self.to_px(pointer_um), 6, 1))
        rects.append(union(assembly))
        surface.set_clip(clip)
        rects = [r.inflate(2, 2).clip(self.rect) for r in rects if r is not None]
        changed = rects + self._previous_rects
        self._previous_rects = rects
        return changed


class LocalView:
    """The microscope image around the cell, fitted into ``rect`` (a square)."""

    def __init__(self, layout: TaskLayout, rect: pygame.Rect, seed: int = 0):
        self.layout = layout
        self.rect = rect
        self.size_px = int(round(LOCAL_FIELD_UM / LOCAL_PIXEL_UM))
        self.scale_px_per_um = rect.width / LOCAL_FIELD_UM
        self.params = MicroscopeParams(pixel_size_um=LOCAL_PIXEL_UM)
        self.radius_um = np.asarray(layout.sphere_radius_um, float)
        self.rng = np.random.default_rng(seed)
        self.image: pygame.Surface | None = None
        self.origin_um = np.zeros(2)
        self._rendered_at_s = -math.inf
        self._rendered_key = None

    def update(self, snapshot: Snapshot, now_s: float) -> bool:
        """Render a new frame if the snapshot changed and a camera frame is due; True if it did."""
        key = (snapshot.trial, snapshot.time_s)
        if key == self._rendered_key or now_s - self._rendered_at_s < 1.0 / LOCAL_VIEW_HZ:
            return False
        self._rendered_key, self._rendered_at_s = key, now_s
        centre = snapshot.observation.cell_xy_um[0]
        origin = (np.floor(centre / LOCAL_PIXEL_UM) - self.size_px // 2) * LOCAL_PIXEL_UM
        spheres = snapshot.sphere_xy_um
        gap = np.max(np.abs(spheres - (origin + 0.5 * LOCAL_FIELD_UM)), axis=1) - self.radius_um
        near = gap < 0.5 * LOCAL_FIELD_UM + 1.0
        image = microscope_images(
            spheres[near][None],
            self.radius_um[near],
            origin[None],
            (self.size_px, self.size_px),
            self.params,
            self.rng,
            self.layout.chip,
        )[0]
        gray = np.round(image * 255).astype(np.uint8)
        rgb = np.repeat(gray.T[..., None], 3, axis=2)
        self.image = pygame.transform.scale(pygame.surfarray.make_surface(rgb), self.rect.size)
        self.origin_um = origin
        return True

    def to_px(self, xy_um) -> np.ndarray:
        return (np.asarray(xy_um, float) - self.origin_um) * self.scale_px_per_um + np.array(self.rect.topleft, float)

    def draw(self, surface: pygame.Surface, snapshot: Snapshot, font: pygame.font.Font) -> list[pygame.Rect]:
        if self.image is None:
            return []
        surface.blit(self.image, self.rect.topleft)
        clip = surface.get_clip()
        surface.set_clip(self.rect)
        traps = snapshot.observation.trap_xy_um[0]
        for trap in self.to_px(traps):
            cross(surface, TRAP_RGB, trap, 7.0, 2)
        record = snapshot.record
        if record is not None:
            # the sensed offset (of the frame the sensor read, a tick old) drawn from the handle as it is now
            offsets = record.frame_trap_xy_um - record.sensed_handle_xy_um
            for handle, offset, valid in zip(snapshot.observation.handle_xy_um[0], offsets, record.sensed_valid):
                if valid:
                    start = self.to_px(handle)
                    arrow(
                        surface,
                        (0, 200, 230),
                        start,
                        start + offset * OFFSET_MAGNIFICATION * self.scale_px_per_um,
                        2,
                        6.0,
                    )
        bar_px = 2.0 * self.scale_px_per_um
        x, y = self.rect.left + 10, self.rect.bottom - 14
        pygame.draw.line(surface, (255, 255, 255), (x, y), (x + bar_px, y), 3)
        surface.blit(font.render("2 um", True, (255, 255, 255)), (x, y - 18))
        note = font.render(f"handle->trap x{OFFSET_MAGNIFICATION:g}", True, (0, 200, 230))
        surface.blit(note, (self.rect.right - note.get_width() - 8, self.rect.bottom - 22))
        surface.set_clip(clip)
        pygame.draw.rect(surface, DIM_TEXT_RGB, self.rect, 1)
        return [self.rect]


def bar(surface, rect: pygame.Rect, fraction: float, rgb, marks=()) -> None:
    """A horizontal bar filled to ``fraction`` (clipped to [0, 1]), with tick marks at fractions."""
    pygame.draw.rect(surface, (48, 53, 62), rect)
    fill = rect.copy()
    fill.width = int(round(rect.width * min(max(fraction, 0.0), 1.0)))
    pygame.draw.rect(surface, rgb, fill)
    for mark in marks:
        x = rect.left + int(round(rect.width * mark))
        pygame.draw.line(surface, (255, 255, 255), (x, rect.top - 3), (x, rect.bottom + 2), 2)
    pygame.draw.rect(surface, DIM_TEXT_RGB, rect, 1)


class CuePanel:
    """The cues, stacked in ``rect``."""

    CONTACT_FULL_SCALE = 1.5
    """The contact gauge spans 1.5 times the limit, so the limit is a visible mark."""

    def __init__(self, layout: TaskLayout, rect: pygame.Rect, force_limits_n, contact_limit_pn: float = 10.0):
        self.layout = layout
        self.rect = rect
        self.force_limits_n = np.asarray(force_limits_n, float)
        self.contact_limit_pn = contact_limit_pn
        self.escape_distance_um = layout.escape_distance_um

    def draw(self, surface: pygame.Surface, snapshot: Snapshot, type_: dict) -> list[pygame.Rect]:
        """Clear the panel and draw every cue; returns the panel's rectangle."""
        surface.fill(BACKGROUND_RGB, self.rect)
        clip = surface.get_clip()
        surface.set_clip(self.rect)
        self._draw(surface, snapshot, type_)
        surface.set_clip(clip)
        return [self.rect]

    def _draw(self, surface: pygame.Surface, snapshot: Snapshot, type_: dict) -> None:
        x, y, width = self.rect.left, self.rect.top, self.rect.width
        label_w = 120
        bar_rect = lambda top: pygame.Rect(x + label_w, top + 3, width - label_w - 70, 14)  # noqa: E731
        text = lambda s, pos, rgb=TEXT_RGB, size="body": surface.blit(type_[size].render(s, True, rgb), pos)  # noqa: E731
        obs = snapshot.observation
        # mode and alpha
        alpha = snapshot.alpha
        mode = text(f"{snapshot.mode.upper()}", (x, y), TEXT_RGB, "title")
        text(f"alpha {alpha:.2f}", (max(x + label_w, mode.right + 12), y + 4))  # after a long mode name
        y += 28
        text("human share", (x, y), DIM_TEXT_RGB, "small")
        bar(surface, bar_rect(y - 2), alpha, (90, 150, 240), marks=(cues.FINE_TUNE_ALPHA,))
        y += 22
        # obstacle proximity
        gap = float(obs.nearest_obstacle_gap_um[0])
        level = cues.proximity_level(gap)
        pygame.draw.circle(surface, cues.ramp_rgb(level), (x + 8, y + 9), 8)
        label = (
            "no obstacle"
            if not math.isfinite(gap)
            else ("obstacle touching" if gap <= 0.05 else f"nearest obstacle {gap:5.1f} um")
        )
        text(label, (x + 24, y), cues.ramp_rgb(level))
        y += 26
        # contact force
        contact = float(obs.contact_force_pn[0].max())
        text("contact force", (x, y), DIM_TEXT_RGB, "small")
        if math.isfinite(contact):
            gauge = cues.contact_gauge(contact, self.contact_limit_pn)
            bar(
                surface,
                bar_rect(y - 2),
                gauge.fraction / self.CONTACT_FULL_SCALE,
                cues.DANGER_RGB if gauge.over else CELL_RGB,
                marks=(1.0 / self.CONTACT_FULL_SCALE,),
            )
            text(f"{contact:4.1f} pN", (x + width - 64, y - 2), TEXT_RGB, "small")
        else:  # a window on the bus: the simulator does not publish it
            text("not on the bus", (x + label_w, y), DIM_TEXT_RGB, "small")
        y += 24
        # haptic force per device
        record = snapshot.record
        forces = record.feedback_n if record is not None else np.zeros((len(self.force_limits_n), 3))
        for robot, gauge in enumerate(cues.haptic_gauges(forces, self.force_limits_n)):
            text(f"haptic, robot {robot}", (x, y), DIM_TEXT_RGB, "small")
            if gauge is None:
                text("no haptics", (x + label_w, y), DIM_TEXT_RGB, "small")
            else:
                bar(surface, bar_rect(y - 2), gauge.fraction, cues.DANGER_RGB if gauge.over else ROBOT_RGB)
                text(
                    f"{gauge.fraction * self.force_limits_n[robot]:4.2f} N", (x + width - 64, y - 2), TEXT_RGB, "small"
                )
            y += 22
        # trap loss
        if record is not None:
            offsets = np.where(
                record.sensed_valid[:, None], record.frame_trap_xy_um - record.sensed_handle_xy_um, np.nan
            )
        else:
            offsets = np.zeros((1, 2))
        lag = float(np.nan_to_num(np.linalg.norm(offsets, axis=-1), nan=0.0).max())
        warn = cues.trap_loss_warning(offsets, self.escape_distance_um)
        text("handle lag", (x, y), DIM_TEXT_RGB, "small")
        bar(
            surface,
            bar_rect(y - 2),
            lag / self.escape_distance_um,
            cues.ramp_rgb(cues.trap_loss_level(offsets, self.escape_distance_um)),
            marks=(cues.TRAP_WARNING_FRACTION,),
        )
        text(f"{lag:4.2f} um", (x + width - 64, y - 2), TEXT_RGB, "small")
        y += 22
        # the cell's light dose so far in the trial
        text("cell light dose", (x, y), DIM_TEXT_RGB, "small")
        dose = snapshot.light_dose_mj_per_um2
        text(cues.light_dose_text(dose), (x + label_w, y - 2), DIM_TEXT_RGB if math.isnan(dose) else TEXT_RGB, "small")
        y += 30
        # motion direction compass (bottom right) beside the prompts
        centre = np.array([x + width - 36.0, self.rect.bottom - 44.0])
        pygame.draw.circle(surface, DIM_TEXT_RGB, centre, 30, 1)
        direction = cues.motion_direction(
            obs.cell_xy_um[0], float(obs.cell_arc_um[0]), self.layout.route_um, self.layout.route_arc_um
        )
        arrow(surface, ROUTE_RGB, centre - direction * 20, centre + direction * 22, 4, 11.0)
        text("route", (centre[0] - 18, centre[1] - 52), DIM_TEXT_RGB, "small")
        if warn:
            text("TRAP LOSS RISK: slow down", (x, y - 4), cues.DANGER_RGB, "title")
        if cues.fine_tune_prompt(alpha, snapshot.mode):
            box = pygame.Rect(x, y + 26, width - 84, 46)
            pygame.draw.rect(surface, (250, 180, 30), box, border_radius=6)
            label = type_["prompt"].render("FINE-TUNE", True, (30, 20, 0))
            surface.blit(label, label.get_rect(center=box.center))
