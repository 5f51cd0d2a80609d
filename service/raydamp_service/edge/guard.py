"""The checks every request passes before any route sees it, before its body is read: Host, bearer token, body
size and deadline, and the number of large bodies handled at once."""

from __future__ import annotations

import asyncio
import hmac

from starlette.datastructures import Headers
from starlette.responses import JSONResponse
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from ..config import Settings

__all__ = ["RequestGuard", "UNGUARDED_PATHS", "file_too_large", "needs_token"]

# Open without the token: the probe, and what holds no job data and a browser navigates to (without a header).
UNGUARDED_PATHS = frozenset({"/healthz", "/", "/docs", "/openapi.json"})
UNGUARDED_PREFIXES = ("/static/", "/vendor/")
UPLOAD_PATH = "/v1/files"  # POST: a Matrix Market upload, limited by max_file_bytes rather than max_body_bytes
MULTIPART_ALLOWANCE = 64 * 1024


def needs_token(path: str) -> bool:
    return path not in UNGUARDED_PATHS and not path.startswith(UNGUARDED_PREFIXES)


def file_too_large(limit: int) -> str:
    """The 413's detail for an upload over max_file_bytes (here, or from the route that counts the file part)."""
    return f"the file is larger than max_file_bytes = {limit} bytes (RAYDAMP_MAX_FILE_BYTES)"


class _BodyRefused(Exception):
    """The body is over its limit, or late: the app's reading of it is cut short."""


def host_name(header: str) -> str:
    """"example.org:8000" -> "example.org", "[::1]:8000" -> "::1"."""
    header = header.strip().lower()
    if header.startswith("["):
        return header[1:header.find("]")] if "]" in header else header
    return header.rsplit(":", 1)[0] if header.count(":") == 1 else header


class RequestGuard:
    def __init__(self, app: ASGIApp, settings: Settings):
        self.app = app
        self.trusted = {name.strip("[]").lower() for name in settings.trusted_hosts}
        self.token = settings.token.get_secret_value().encode() if settings.token else None
        # An upload's is its file's, with room for the multipart framing (the route checks the file part exactly).
        self.upload_limit = (settings.max_file_bytes + MULTIPART_ALLOWANCE, file_too_large(settings.max_file_bytes))
        self.body_limit = (settings.max_body_bytes, f"the request body is larger than max_body_bytes = "
                           f"{settings.max_body_bytes} bytes (RAYDAMP_MAX_BODY_BYTES)")
        self.large_body, self.max_large = settings.large_body_bytes, settings.max_large_bodies
        self.retry_after = str(settings.retry_after_seconds)
        self.body_seconds, self.body_rate = settings.body_seconds, settings.min_body_bytes_per_second
        self.large_bodies = 0  # being handled now (one event loop: no lock needed)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        headers = Headers(scope=scope)
        refusal = self._refusal(scope, headers)
        if refusal is not None:
            await refusal(scope, receive, send)
            return
        if not self._large(headers):
            await self._with_body_limit(scope, receive, send)
            return
        # Its parse and validation hold the event loop: max_large_bodies at once.
        if self.large_bodies >= self.max_large:
            await JSONResponse({"detail": f"{self.max_large} large request bodies are being handled "
                                          "(max_large_bodies); retry later"}, status_code=429,
                               headers={"Retry-After": self.retry_after})(scope, receive, send)
            return
        self.large_bodies += 1
        try:
            await self._with_body_limit(scope, receive, send)
        finally:
            self.large_bodies -= 1

    def _large(self, headers: Headers) -> bool:
        """A body over large_body_bytes, or one of unknown length (chunked), which may be."""
        length = headers.get("content-length")
        if length is not None:
            return int(length) > self.large_body  # (a malformed length was refused with 413)
        return "chunked" in headers.get("transfer-encoding", "").lower()

    def _refusal(self, scope: Scope, headers: Headers) -> JSONResponse | None:
        host = host_name(headers.get("host", ""))
        if "*" not in self.trusted and host not in self.trusted:
            return JSONResponse({"detail": f"Host {host[:100]!r} is not one of this service's trusted_hosts "
                                           "(RAYDAMP_TRUSTED_HOSTS)"}, status_code=400)
        if self.token is not None and needs_token(scope["path"]):
            scheme, _, credentials = headers.get("authorization", "").partition(" ")
            if scheme.lower() != "bearer" or not hmac.compare_digest(credentials.strip().encode(), self.token):
                return JSONResponse({"detail": "this service needs Authorization: Bearer <RAYDAMP_TOKEN>"},
                                    status_code=401, headers={"WWW-Authenticate": "Bearer"})
        length = headers.get("content-length")
        limit, too_large = self._limit(scope)
        if length is not None and (not length.isdigit() or int(length) > limit):
            return JSONResponse({"detail": too_large}, status_code=413)
        return None

    def _limit(self, scope: Scope) -> tuple[int, str]:
        """(a body's limit, the 413's detail past it)."""
        return self.upload_limit if scope["path"] == UPLOAD_PATH and scope.get("method") == "POST" else self.body_limit

    async def _with_body_limit(self, scope: Scope, receive: Receive, send: Send) -> None:
        """The body is counted as it arrives (chunked: no Content-Length), and must arrive within body_seconds,
        plus 1 / min_body_bytes_per_second for each byte received."""
        received = 0
        refused: JSONResponse | None = None
        limit, too_large = self._limit(scope)
        deadline = asyncio.get_running_loop().time() + self.body_seconds
        body_done = False

        async def counting_receive() -> Message:
            nonlocal received, refused, body_done, deadline
            if body_done:
                return await receive()
            try:
                async with asyncio.timeout_at(deadline):  # a timer, not a task of its own as wait_for makes
                    message = await receive()
            except TimeoutError:
                refused = JSONResponse({"detail": f"the request body did not arrive within body_seconds = "
                                                  f"{self.body_seconds:g} s (RAYDAMP_BODY_SECONDS)"}, status_code=408,
                                       headers={"Connection": "close"})
                raise _BodyRefused from None
            if message["type"] == "http.request":
                piece = len(message.get("body", b""))
                received += piece
                if self.body_rate:  # an upload that keeps coming keeps its connection
                    deadline += piece / self.body_rate
                body_done = not message.get("more_body", False)
                if received > limit:
                    refused = JSONResponse({"detail": too_large}, status_code=413)
                    raise _BodyRefused
            return message

        async def guarded_send(message: Message) -> None:
            if refused is None:  # whatever the app made of the interrupted read is replaced by the refusal
                await send(message)

        try:
            await self.app(scope, counting_receive, guarded_send)
        except _BodyRefused:
            pass
        if refused is not None:
            await refused(scope, receive, send)

