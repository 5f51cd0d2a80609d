"""Ctrl-C as a cancel: `raydamp run` and `raydamp sweep` stop their work and keep what it computed."""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["ctrl_c_cancels"]


@contextmanager
def ctrl_c_cancels(token) -> Iterator[None]:
    """Within: the first Ctrl-C cancels ``token`` (a raydamp.CancelToken: the run or sweep ends "cancelled"
    with what it computed); a second interrupts as usual (KeyboardInterrupt), for work that does not stop.
    Only the main thread can install a handler: elsewhere nothing changes."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupt(signum, frame) -> None:
        token.cancel()
        signal.signal(signal.SIGINT, signal.default_int_handler)

    previous = signal.signal(signal.SIGINT, interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous if previous is not None else signal.SIG_DFL)
