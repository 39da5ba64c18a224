"""The window's colours and type sizes, in a module of their own that imports nothing
heavy: the start-up screen (``otgym.ui.startup``) draws with them before the views,
which import the simulator, are loaded."""

from __future__ import annotations

import pygame

WINDOW_SIZE = (1280, 720)
"""The window of ``otgym play``, in pixels."""
BACKGROUND_RGB = (24, 27, 33)
WALL_RGB = (62, 68, 80)
CHANNEL_RGB = (232, 236, 241)
FLOW_RGB = (120, 170, 230)
ROUTE_RGB = (40, 100, 220)
ROBOT_RGB = (240, 140, 40)
HANDLE_RGB = (190, 90, 20)
CELL_RGB = (60, 170, 90)
OBSTACLE_RGB = (150, 70, 190)
OTHER_RGB = (130, 130, 130)
TRAP_RGB = (250, 215, 30)
TEXT_RGB = (225, 229, 235)
DIM_TEXT_RGB = (150, 158, 170)


def fonts() -> dict[str, pygame.font.Font]:
    """The window's type sizes (pygame's default font; after ``pygame.font.init``)."""
    return {
        "small": pygame.font.Font(None, 20),
        "body": pygame.font.Font(None, 24),
        "title": pygame.font.Font(None, 30),
        "prompt": pygame.font.Font(None, 44),
    }
