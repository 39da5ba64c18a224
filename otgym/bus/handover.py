"""A hand-over between the thread that receives messages and one thread that sends them
on, so that a slow sender never holds up the receiver (``otgym.bus.ros2_bridge``: a
zenoh callback must return at once, or zenoh's reliable links fill and the publishers
upstream, the simulator's among them, wait on them).

``put(topic, item)`` never waits on the sender: it stores the item and returns. A
stream's topic (``keep_all(topic)`` false: QoS keep last, depth 1) keeps only its
latest item until the sender takes it; an item that replaces one not yet sent is
counted in ``replaced``. Every other topic's items (trial events, commands, latched
topics: keep all) queue and are all sent. One thread, ``run``, sends them in the order
their topics first became pending: a stream topic keeps its place in that order while
newer items replace its pending one. What is still pending at ``close`` is not sent.
"""

from __future__ import annotations

import collections
import logging
import threading
from collections.abc import Callable

log = logging.getLogger(__name__)


class Handover:
    """Latest-only for streams, keep-all for the rest (see the module's docstring);
    ``send(topic, item)`` runs on the thread ``start`` starts, named ``name``."""

    def __init__(self, send: Callable[[str, object], None], keep_all: Callable[[str], bool], name: str):
        self._send, self._keep_all = send, keep_all
        self._order: collections.deque = collections.deque()
        self._latest: dict[str, object] = {}
        self._condition = threading.Condition()
        self._closed = False
        self.sent = 0
        self.replaced = 0
        """Stream items replaced by a newer one before they were sent."""
        self.failed = 0
        """Items whose ``send`` raised (logged, then the next item is sent)."""
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)

    def start(self) -> None:
        self._thread.start()

    def put(self, topic: str, item) -> None:
        """Hand ``item`` over; returns at once (nothing is kept after ``close``)."""
        with self._condition:
            if self._closed:
                return
            if self._keep_all(topic):
                self._order.append((topic, item, True))
            else:
                if topic in self._latest:
                    self.replaced += 1
                else:
                    self._order.append((topic, None, False))
                self._latest[topic] = item
            self._condition.notify()

    def pending(self) -> int:
        with self._condition:
            return len(self._order)

    def _run(self) -> None:
        while True:
            with self._condition:
                while not self._order and not self._closed:
                    self._condition.wait()
                if self._closed:
                    return
                topic, item, kept = self._order.popleft()
                if not kept:
                    item = self._latest.pop(topic)
            try:
                self._send(topic, item)
            except Exception:  # noqa: BLE001  one bad item must not stop the rest
                log.exception("sending a message on %s failed", topic)
                with self._condition:
                    self.failed += 1
                continue
            with self._condition:
                self.sent += 1

    def close(self, timeout_s: float = 5.0) -> None:
        """Stop sending (an item being sent finishes first, within ``timeout_s``)."""
        with self._condition:
            self._closed = True
            self._condition.notify_all()
        if self._thread.is_alive() and threading.current_thread() is not self._thread:
            self._thread.join(timeout_s)
