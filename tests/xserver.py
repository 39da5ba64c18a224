"""A real X server for window tests: Xvfb on a free display, and X input events sent to it.

``Xvfb`` starts one virtual X server, picks its display number race-free (``-displayfd``:
the server itself takes the first free number and writes it to a pipe once it accepts
connections), and stops only its own process. ``Xvfb.env`` is the environment for a
child process that opens its window on that server through SDL's x11 video driver (set
explicitly, so a window that cannot open under X fails instead of falling back to the
dummy driver that the other window tests use).

``XInput`` sends key presses and mouse clicks to the server through the XTEST
extension (python-xlib, of the ``test`` extra): what a person's keyboard and mouse
would send, delivered by the X server to the window that has the focus, never pygame
events posted in-process. Key auto-repeat is switched off on the server so that a held
key is one press and one release.

The ``xvfb`` fixture (``tests/conftest.py``) gives one server per test session and
skips, saying why, where Xvfb is not installed."""

from __future__ import annotations

import os
import select
import shutil
import subprocess
import tempfile
import time

SCREEN = (1600, 1200, 24)
"""Width, height (larger than every otgym window) and depth of the virtual screen."""
KEY_GAP_S = 0.02
"""Wall time between one key's release and the next press (``XInput.key``)."""
MISSING = "needs Xvfb for real windows (Debian: apt-get install xvfb); the other window tests use SDL's dummy driver"


def available() -> bool:
    return shutil.which("Xvfb") is not None


class Xvfb:
    """One Xvfb process; ``display`` (``":N"``) once ``start`` has returned."""

    def __init__(self, screen: tuple[int, int, int] = SCREEN):
        self.screen = screen
        self.display: str | None = None
        self.process: subprocess.Popen | None = None
        self._log = tempfile.TemporaryFile()

    def start(self, timeout_s: float = 30.0) -> Xvfb:
        read_fd, write_fd = os.pipe()
        width, height, depth = self.screen
        try:
            self.process = subprocess.Popen(
                ["Xvfb", "-displayfd", str(write_fd), "-screen", "0", f"{width}x{height}x{depth}", "-nolisten", "tcp"],
                pass_fds=(write_fd,),
                stdin=subprocess.DEVNULL,
                stdout=self._log,
                stderr=self._log,
            )
        finally:
            os.close(write_fd)
        try:
            self.display = ":" + self._read_display(read_fd, timeout_s)
        except BaseException:
            self.stop()
            raise
        finally:
            os.close(read_fd)
        return self

    def _read_display(self, read_fd: int, timeout_s: float) -> str:
        """The display number Xvfb writes (a line) once it is ready."""
        deadline, text = time.monotonic() + timeout_s, b""
        while not text.endswith(b"\n"):
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([read_fd], [], [], left)[0]:
                raise RuntimeError(f"Xvfb gave no display number within {timeout_s} s: {self.log()}")
            chunk = os.read(read_fd, 64)
            if not chunk:
                raise RuntimeError(f"Xvfb ended before it was ready (exit {self.process.wait()}): {self.log()}")
            text += chunk
        return text.decode().strip()

    def log(self) -> str:
        self._log.seek(0)
        return self._log.read().decode(errors="replace")[-2000:]

    def env(self, base: dict | None = None) -> dict:
        """``base`` (default: this process's environment) for a child that opens its
        windows on this server: DISPLAY set, SDL's video driver x11, audio dummy."""
        env = dict(os.environ if base is None else base)
        env.update(DISPLAY=self.display, SDL_VIDEODRIVER="x11", SDL_AUDIODRIVER="dummy")
        env.pop("XAUTHORITY", None)  # the server runs without authorisation: local clients connect
        return env

    def stop(self) -> None:
        """Terminate this server's own process (and only it), killing it after 10 s."""
        if self.process is not None and self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(10.0)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(10.0)
        self._log.close()


class XInput:
    """Keyboard and mouse input sent through XTEST to ``display``: keys reach the window
    ``wait_window`` found and focused, clicks are placed in its coordinates."""

    def __init__(self, display: str):
        from Xlib import X
        from Xlib import display as xdisplay

        self._x = X
        self.connection = xdisplay.Display(display)
        if not self.connection.has_extension("XTEST"):
            raise RuntimeError(f"the X server {display} has no XTEST extension")
        self.connection.change_keyboard_control(auto_repeat_mode=X.AutoRepeatModeOff)
        self.connection.sync()
        self.window = None

    def close(self) -> None:
        self.connection.close()

    def wait_window(self, title: str, timeout_s: float, alive=lambda: True):
        """The mapped top-level window whose name starts with ``title``, waited for up
        to ``timeout_s`` (while ``alive()``); it gets the input focus."""
        from Xlib.error import XError

        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline and alive():
            for child in self.connection.screen().root.query_tree().children:
                try:
                    found = self._name(child).startswith(title)
                    found = found and child.get_attributes().map_state == self._x.IsViewable
                except XError:  # a window destroyed between the query and the look
                    continue
                if found:
                    self.window = child
                    child.set_input_focus(self._x.RevertToParent, self._x.CurrentTime)
                    self.connection.sync()
                    return child
            time.sleep(0.1)
        raise RuntimeError(f"no window {title!r} within {timeout_s} s")

    def _name(self, window) -> str:
        """The window's title (SDL sets it as UTF-8, ``_NET_WM_NAME``)."""
        atom = self.connection.intern_atom
        value = window.get_full_property(atom("_NET_WM_NAME"), atom("UTF8_STRING"))
        return bytes(value.value).decode(errors="replace") if value is not None else ""

    def _keycode(self, name: str) -> int:
        from Xlib import XK

        code = self.connection.keysym_to_keycode(XK.string_to_keysym(name))
        if not code:
            raise ValueError(f"no key {name!r} on the X server's keyboard")
        return code

    def key_down(self, name: str) -> None:
        """Press the key with X keysym name ``name`` (``Return``, ``Right``, ``3``) and hold it."""
        from Xlib.ext import xtest

        xtest.fake_input(self.connection, self._x.KeyPress, self._keycode(name))
        self.connection.sync()

    def key_up(self, name: str) -> None:
        """Release ``name``, then wait ``KEY_GAP_S``: SDL takes a release followed within
        2 ms by a press of the same key for auto-repeat and drops both (pygame then
        sees one press for many)."""
        from Xlib.ext import xtest

        xtest.fake_input(self.connection, self._x.KeyRelease, self._keycode(name))
        self.connection.sync()
        time.sleep(KEY_GAP_S)

    def key(self, name: str) -> None:
        """Press and release ``name``."""
        self.key_down(name)
        self.key_up(name)

    def click(self, x: int, y: int) -> None:
        """Move the pointer to ``(x, y)`` of the window and press and release button 1."""
        from Xlib.ext import xtest

        origin = self.window.translate_coords(self.connection.screen().root, 0, 0)
        xtest.fake_input(self.connection, self._x.MotionNotify, x=x - origin.x, y=y - origin.y)
        xtest.fake_input(self.connection, self._x.ButtonPress, 1)
        xtest.fake_input(self.connection, self._x.ButtonRelease, 1)
        self.connection.sync()


class WindowWatcher:
    """The titles of the top-level windows viewable on ``display``, polled every
    ``period_s`` in a thread of its own (its own X connection) while in the ``with``."""

    def __init__(self, display: str, period_s: float = 0.05):
        import threading

        self.display, self.period_s = display, period_s
        self.titles: list[str] = []  # each title once, in the order first seen
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._watch, name="xvfb-window-watcher", daemon=True)

    def _watch(self) -> None:
        from Xlib import X
        from Xlib.error import XError

        watcher = XInput(self.display)
        try:
            while not self._stop.wait(self.period_s):
                for child in watcher.connection.screen().root.query_tree().children:
                    try:
                        viewable = child.get_attributes().map_state == X.IsViewable
                        title = watcher._name(child) if viewable else ""
                    except XError:  # a window destroyed between the query and the look
                        continue
                    if title and title not in self.titles:
                        self.titles.append(title)
        finally:
            watcher.close()

    def __enter__(self) -> WindowWatcher:
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self._thread.join(10.0)
