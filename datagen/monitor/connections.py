"""The monitor server's connections, bounded: one thread accepts them and reads each request's
head (up to its blank line) without blocking, so a client that sends half a request and waits
holds a socket, never a thread; ``HANDLERS`` threads answer complete requests.

- At most ``MAX_OPEN`` connections wait for their head: a new one closes the oldest, so idle
  connections cannot lock a browser out.
- A head not complete ``HEAD_TIMEOUT_S`` after its connection opened, or longer than
  ``MAX_HEAD_BYTES``, is dropped; an answer that cannot be sent in ``SEND_TIMEOUT_S`` too.
- At most ``MAX_QUEUED`` complete requests wait for a handler; more are closed unanswered.
- A client that hangs up before its answer is sent is logged at debug level only: the terminal
  is the build's.
"""

from __future__ import annotations

import contextlib
import logging
import selectors
import socket
import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

log = logging.getLogger(__name__)
MAX_OPEN = 128
MAX_QUEUED = 64
HANDLERS = 4
HEAD_TIMEOUT_S = 10.0
SEND_TIMEOUT_S = 10.0
MAX_HEAD_BYTES = 16 * 1024
POLL_S = 0.5
HUNG_UP = (BrokenPipeError, ConnectionResetError, ConnectionAbortedError, TimeoutError)

Answer = Callable[[socket.socket, tuple, bytes], None]  # (connection, client address, head)


@dataclass
class _Waiting:
    address: tuple
    opened: float
    head: bytearray = field(default_factory=bytearray)


class Connections:
    """Serves ``listener`` until ``close()``: ``answer(connection, address, head)`` runs in a
    handler thread for each complete request head; the connection is closed after it."""

    def __init__(self, listener: socket.socket, answer: Answer):
        self.listener, self.answer = listener, answer
        self.selector = selectors.DefaultSelector()
        self.waiting: dict[socket.socket, _Waiting] = {}  # in the order they were opened
        self.handlers = ThreadPoolExecutor(HANDLERS, thread_name_prefix="monitor-answer")
        self.queued = threading.BoundedSemaphore(MAX_QUEUED)
        self._stop = threading.Event()
        self._wake, self._waker = socket.socketpair()

    def serve(self) -> None:
        """Runs in the server's thread until ``close()``."""
        self.listener.setblocking(False)
        self.selector.register(self.listener, selectors.EVENT_READ)
        self.selector.register(self._wake, selectors.EVENT_READ)
        try:
            while not self._stop.is_set():
                for key, _ in self.selector.select(POLL_S):
                    if key.fileobj is self.listener:
                        self._accept()
                    elif key.fileobj is not self._wake:
                        self._read(key.fileobj)  # type: ignore[arg-type]
                self._drop_late(time.monotonic())
        finally:
            for connection in list(self.waiting):
                self._drop(connection)
            self.selector.close()
            self.handlers.shutdown(wait=False, cancel_futures=True)

    def close(self) -> None:
        self._stop.set()
        self._waker.send(b"x")

    def _accept(self) -> None:
        while True:
            try:
                connection, address = self.listener.accept()
            except (BlockingIOError, InterruptedError):
                return
            except OSError as exc:  # out of file descriptors, a connection reset meanwhile
                log.debug("monitor: accept failed: %r", exc)
                return
            if len(self.waiting) >= MAX_OPEN:
                self._drop(next(iter(self.waiting)))
            connection.setblocking(False)
            self.waiting[connection] = _Waiting(address, time.monotonic())
            self.selector.register(connection, selectors.EVENT_READ)

    def _read(self, connection: socket.socket) -> None:
        waiting = self.waiting.get(connection)
        if waiting is None:  # dropped a moment ago, in this round
            return
        try:
            data = connection.recv(4096)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            data = b""
        waiting.head += data
        if not data or len(waiting.head) > MAX_HEAD_BYTES:
            self._drop(connection)
        elif b"\r\n\r\n" in waiting.head or b"\n\n" in waiting.head:
            self._hand_over(connection, waiting)

    def _hand_over(self, connection: socket.socket, waiting: _Waiting) -> None:
        self.selector.unregister(connection)
        del self.waiting[connection]
        if not self.queued.acquire(blocking=False):
            log.debug("monitor: %d requests wait already; one closed", MAX_QUEUED)
            connection.close()
            return
        connection.setblocking(True)
        connection.settimeout(SEND_TIMEOUT_S)
        self.handlers.submit(self._answer, connection, waiting.address, bytes(waiting.head))

    def _answer(self, connection: socket.socket, address: tuple, head: bytes) -> None:
        try:
            self.answer(connection, address, head)
        except HUNG_UP as exc:
            log.debug("monitor: %s hung up before its answer was sent: %r", address[0], exc)
        except Exception as exc:  # one line, never a traceback: a request the checks missed
            log.warning("monitor: a request from %s failed: %r", address[0], exc)
        finally:
            self.queued.release()
            _close(connection)

    def _drop_late(self, now: float) -> None:
        late = [c for c, w in self.waiting.items() if now - w.opened > HEAD_TIMEOUT_S]
        for connection in late:
            self._drop(connection)

    def _drop(self, connection: socket.socket) -> None:
        self.selector.unregister(connection)
        del self.waiting[connection]
        connection.close()


def _close(connection: socket.socket) -> None:
    with contextlib.suppress(OSError):  # the client has gone already
        connection.shutdown(socket.SHUT_WR)
    connection.close()
