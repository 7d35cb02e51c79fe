"""The window of ``render_mode="human"``: each ``rgb_array`` frame shown with pygame.

pygame is an optional extra (``pip install 'sfa-gym[human]'``), the library Gymnasium's own
human renderers use. :func:`check_window` runs when an env is built in human mode, so a machine
without a display or without pygame fails there with a message naming what is missing; the
window itself opens with the first frame, in the process that steps the env.
"""

from __future__ import annotations

import os
import sys
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["HUMAN_EXTRA", "NoWindowError", "Window", "check_window"]

HUMAN_EXTRA = "pip install 'sfa-gym[human]'"
"""How to install what ``render_mode="human"`` needs (pygame)."""


class NoWindowError(RuntimeError):
    """``render_mode="human"`` cannot open a window here: no display, or no pygame."""


def _display_missing() -> str | None:
    """Why no window can open on this machine's display, or None when one can.

    On Linux and the BSDs a window needs an X11 or Wayland display; another SDL video driver
    chosen in ``SDL_VIDEODRIVER`` (e.g. ``dummy`` for tests, ``kmsdrm``) is taken as the user's
    decision. macOS and Windows always have their own display.
    """
    if not sys.platform.startswith(("linux", "freebsd", "openbsd", "netbsd")):
        return None
    if os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"):
        return None
    if os.environ.get("SDL_VIDEODRIVER", "x11") not in ("x11", "wayland"):
        return None
    return (
        "no display (DISPLAY and WAYLAND_DISPLAY are empty): run it on a desktop, over "
        "'ssh -X', or under a virtual display (xvfb-run)"
    )


def _import_pygame() -> Any:
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")  # no banner on import
    import pygame

    return pygame


def check_window() -> None:
    """Raise :class:`NoWindowError` naming everything that keeps a window from opening."""
    missing = []
    display = _display_missing()
    if display is not None:
        missing.append(display)
    try:
        _import_pygame()
    except ImportError:
        missing.append(f"pygame is not installed: {HUMAN_EXTRA}")
    if missing:
        raise NoWindowError(
            "render_mode='human' shows the frames in a window, but here: "
            + "; ".join(missing)
            + ". Without a window, use render_mode='rgb_array' and save or show the frames "
            "that render() returns."
        )


class Window:
    """A window showing frames at ``fps`` frames per second of wall time at most.

    Args:
        title: the window's caption.
        fps: frames per second; each :meth:`show` waits until its frame's time has come, so an
            episode plays at the speed of simulated time.

    pygame has one display per process: envs in human mode in one process share its window.
    """

    def __init__(self, title: str, fps: float) -> None:
        self.title = title
        self.fps = fps
        self._screen: Any = None
        self._clock: Any = None
        self.closed = False
        """Whether the user closed the window; later frames are then dropped."""

    def show(self, frame: NDArray[np.uint8]) -> None:
        """Show ``frame`` ``(height, width, 3)`` uint8 RGB."""
        if self.closed:
            return
        pygame = _import_pygame()
        height, width = frame.shape[:2]
        if self._screen is None:
            # A software framebuffer: SDL would back the window with an OpenGL renderer
            # whose context fights MuJoCo's offscreen ones in this thread (an X error,
            # BadAccess in GLXMakeCurrent, kills the process on Mesa).
            os.environ.setdefault("SDL_FRAMEBUFFER_ACCELERATION", "0")
            chosen = os.environ.get("SDL_VIDEODRIVER")
            try:
                pygame.display.init()
                driver = pygame.display.get_driver()
                # when no display answers, SDL falls back to a driver without windows
                if chosen is None and driver in ("offscreen", "dummy"):
                    raise pygame.error(f"SDL reached no display and fell back to {driver!r}")
                self._screen = pygame.display.set_mode((width, height))
            except pygame.error as error:  # e.g. DISPLAY names no running server
                pygame.display.quit()
                display = os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
                raise NoWindowError(
                    f"render_mode='human' could not open a window on display {display!r}: {error}"
                ) from error
            pygame.display.set_caption(self.title)
            self._clock = pygame.time.Clock()
        for event in pygame.event.get():  # a window that handles no events stops responding
            if event.type == pygame.QUIT:
                self.close()
                self.closed = True
                return
        # pygame's arrays are indexed (x, y): the transpose of an image's (row, column)
        pygame.surfarray.blit_array(self._screen, np.ascontiguousarray(frame.swapaxes(0, 1)))
        pygame.display.flip()
        self._clock.tick(self.fps)

    def shown(self) -> NDArray[np.uint8] | None:
        """What the window shows now, ``(height, width, 3)`` uint8; None before the first frame
        and after closing."""
        if self._screen is None:
            return None
        pygame = _import_pygame()
        return np.ascontiguousarray(pygame.surfarray.array3d(self._screen).swapaxes(0, 1))

    def close(self) -> None:
        if self._screen is not None:
            pygame = _import_pygame()
            pygame.display.quit()
            self._screen = None
