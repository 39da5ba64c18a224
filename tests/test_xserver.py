"""The tests' X server helper (``tests.xserver``): two servers started at once get
different displays (``-displayfd``: each server takes a free number itself, no race
between choosing and binding), each accepts X clients, and ``stop`` ends its own
process."""

import pytest

from tests.xserver import MISSING, Xvfb, available


@pytest.mark.skipif(not available(), reason=MISSING)
def test_two_servers_get_their_own_displays_and_stop():
    xlib = pytest.importorskip("Xlib.display", reason="needs python-xlib (the test extra)")
    first, second = Xvfb().start(), Xvfb().start()
    try:
        assert first.display != second.display
        for server in (first, second):
            client = xlib.Display(server.display)
            assert client.screen().width_in_pixels == server.screen[0]
            client.close()
    finally:
        first.stop()
        second.stop()
    assert first.process.returncode is not None and second.process.returncode is not None
