"""HEAD wherever GET works (RFC 9110: a GET route answers HEAD with the same status and headers, no body).
FastAPI's routes answer HEAD with 405; curl -I, link checkers and proxies' health checks send it.

The request runs as its GET, marked in its scope (HEAD); the body is dropped, and once the headers are sent
the route is told the client has gone, so a streamed trajectory stops being produced. A trajectory's HEAD
takes no large-fetch slot (routes/jobs.py): it reads no body."""

from __future__ import annotations

import asyncio

from starlette.types import ASGIApp, Message, Receive, Scope, Send

__all__ = ["HEAD", "HeadAsGet"]

HEAD = "raydamp.head"  # in the scope of a HEAD run as its GET: a route may skip what only the body needs


class HeadAsGet:
    def __init__(self, app: ASGIApp):
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or scope["method"] != "HEAD":
            await self.app(scope, receive, send)
            return
        started = asyncio.Event()
        body_read = False

        async def head_receive() -> Message:
            nonlocal body_read
            if not body_read:
                body_read = True
                return await receive()
            await started.wait()
            return {"type": "http.disconnect"}

        async def head_send(message: Message) -> None:
            if message["type"] == "http.response.start":
                await send(message)
                await send({"type": "http.response.body", "body": b"", "more_body": False})
                started.set()
            # the body's pieces are dropped: the response ended with its headers

        await self.app({**scope, "method": "GET", HEAD: True}, head_receive, head_send)
