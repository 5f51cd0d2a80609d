"""Deadlines for slow clients, for a bare `make serve` (a reverse proxy in front does the same: README): request
headers within header_seconds (uvicorn has no such deadline), and each piece of a response sent within
send_timeout_seconds, then at min_send_bytes_per_second on average, or the response ends and gives back its slot."""

from __future__ import annotations

import asyncio
import logging
from typing import Any

from fastapi.responses import FileResponse, StreamingResponse
from starlette.types import Message, Receive, Scope, Send

__all__ = ["TimedFileResponse", "TimedStreamingResponse", "protocol"]

log = logging.getLogger("raydamp_service.edge")


def protocol(header_seconds: float) -> type:
    """uvicorn's httptools protocol class (for uvicorn.run(http=...)) whose timer, from connection_made and from
    each response's end, closes the connection unless a request's headers have arrived."""
    from uvicorn.protocols.http.httptools_impl import HttpToolsProtocol

    class Protocol(HttpToolsProtocol):
        _header_timer: asyncio.TimerHandle | None = None

        def connection_made(self, transport) -> None:
            super().connection_made(transport)
            self._arm()

        def connection_lost(self, exc) -> None:
            self._disarm()
            super().connection_lost(exc)

        def on_headers_complete(self) -> None:
            self._disarm()
            super().on_headers_complete()

        def on_response_complete(self) -> None:
            super().on_response_complete()
            if not self.transport.is_closing():
                self._arm()  # the next request's headers have header_seconds too

        def _arm(self) -> None:
            self._disarm()
            self._header_timer = self.loop.call_later(header_seconds, self._late)

        def _disarm(self) -> None:
            if self._header_timer is not None:
                self._header_timer.cancel()  # a no-op once it has run

        def _late(self) -> None:
            serving = self.cycle is not None and not self.cycle.response_complete
            if not serving and not self.transport.is_closing():
                self.transport.close()

    return Protocol


class _Stalled(Exception):
    pass


class _TimedSend:
    """A response whose every send must complete within `send_seconds`, and which, once `send_seconds` have
    passed, must have been read at `min_rate` bytes per second on average (0: no floor)."""

    send_seconds: float
    min_rate: float = 0.0
    source: Any = None  # a streamed body's iterator, closed when the client stalls

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        loop = asyncio.get_running_loop()
        started, sent = loop.time(), 0

        async def within(message: Message) -> None:
            nonlocal sent
            elapsed = loop.time() - started
            if self.min_rate and elapsed > self.send_seconds and sent < self.min_rate * elapsed:
                raise _Stalled  # read, but too slowly to give back its slot within a bounded time
            try:
                await asyncio.wait_for(send(message), self.send_seconds)
            except TimeoutError:
                raise _Stalled from None
            sent += len(message.get("body", b""))

        try:
            await super().__call__(scope, receive, within)
        except Exception as error:
            if not _stalled(error):
                raise
            log.warning("%s %s: the client read nothing for %g s (send_timeout_seconds), or slower than %g bytes/s "
                        "(min_send_bytes_per_second); response dropped", scope.get("method"), scope.get("path"),
                        self.send_seconds, self.min_rate)
            close = getattr(self.source, "close", None)
            if close is not None:
                try:
                    close()  # suspended between pieces (the stalled send awaited): its finally runs now
                except ValueError:  # "generator already executing": it ends with its garbage collection
                    pass
            if self.background is not None:
                await self.background()  # not run when a response fails


def _stalled(error: BaseException) -> bool:
    """_Stalled, alone or in the exception group of the task group Starlette sends the body from."""
    group = getattr(error, "exceptions", None)  # an ExceptionGroup's
    if group is not None:
        return all(_stalled(inner) for inner in group)
    return isinstance(error, _Stalled)


class TimedStreamingResponse(_TimedSend, StreamingResponse):
    def __init__(self, content, *args, send_seconds: float, min_rate: float = 0.0, **kwargs):
        super().__init__(content, *args, **kwargs)
        self.source, self.send_seconds, self.min_rate = content, send_seconds, min_rate


class TimedFileResponse(_TimedSend, FileResponse):
    def __init__(self, *args, send_seconds: float, min_rate: float = 0.0, **kwargs):
        super().__init__(*args, **kwargs)
        self.send_seconds, self.min_rate = send_seconds, min_rate
