"""A connection's request headers must all arrive within header_seconds of its opening (or of its previous
response's end), or it is closed.

uvicorn has no such deadline: a connection that sent "G" and nothing more was held for as long as its client
liked, and two clients holding 10,500 such connections each made the server drop 463 of 731 /healthz probes
(a service audit). This protocol is uvicorn's own (httptools', else h11's) with the deadline added; it bounds
how long each half-sent connection lives, not how many a flood opens at once (a proxy in front limits that).
"""

from __future__ import annotations

import asyncio

__all__ = ["protocol"]


class _Deadline:
    """Mixed into uvicorn's protocol class: a timer from connection_made (and from each response's end) that
    closes the connection unless a request's headers have arrived."""

    header_seconds: float = 10.0
    _header_timer: asyncio.TimerHandle | None = None

    def connection_made(self, transport) -> None:
        super().connection_made(transport)  # type: ignore[misc]
        self._arm()

    def connection_lost(self, exc) -> None:
        self._disarm()
        super().connection_lost(exc)  # type: ignore[misc]

    def on_response_complete(self) -> None:
        super().on_response_complete()  # type: ignore[misc]
        if not self.transport.is_closing():  # type: ignore[attr-defined]
            self._arm()  # the next request's headers have header_seconds too

    def _serving(self) -> bool:
        cycle = self.cycle  # type: ignore[attr-defined]
        return cycle is not None and not cycle.response_complete

    def _arm(self) -> None:
        self._disarm()
        self._header_timer = self.loop.call_later(self.header_seconds, self._late)  # type: ignore[attr-defined]

    def _disarm(self) -> None:
        if self._header_timer is not None:
            self._header_timer.cancel()
            self._header_timer = None

    def _late(self) -> None:
        self._header_timer = None
        if not self._serving() and not self.transport.is_closing():  # type: ignore[attr-defined]
            self.transport.close()  # type: ignore[attr-defined]


def protocol(header_seconds: float) -> type:
    """uvicorn's HTTP protocol class (for uvicorn.run(http=...)) with the header deadline."""
    try:
        from uvicorn.protocols.http.httptools_impl import HttpToolsProtocol as base

        class Protocol(_Deadline, base):
            def on_headers_complete(self) -> None:
                self._disarm()
                super().on_headers_complete()
    except ImportError:  # uvicorn without httptools: h11, whose cycle starts in handle_events
        from uvicorn.protocols.http.h11_impl import H11Protocol as base

        class Protocol(_Deadline, base):  # type: ignore[no-redef]
            def handle_events(self) -> None:
                super().handle_events()
                if self._serving():
                    self._disarm()

    Protocol.header_seconds = header_seconds
    return Protocol
