"""What every answer needs beyond the routes (RFC 9110): HEAD runs as its GET (marked in its scope; its body
dropped, the route told the client has gone); a JSON body naming a key twice is a 422 (UniqueKeysRoute); a 422's
echo of the input is encodable and short; a 405's Allow names every method the path takes."""

from __future__ import annotations

import asyncio
import functools
import json
import math
from collections.abc import Callable
from typing import Any

from fastapi import Request, Response
from fastapi.encoders import jsonable_encoder
from fastapi.exception_handlers import http_exception_handler
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from fastapi.routing import APIRoute
from starlette.concurrency import run_in_threadpool
from starlette.exceptions import HTTPException
from starlette.routing import compile_path
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from raydamp.jobs import client_path
from raydamp.jobs.build import unique_keys

__all__ = ["HEAD", "HeadAsGet", "UniqueKeysRoute", "http_error_handler", "validation_error_handler"]


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


class _UniqueKeysRequest(Request):
    async def json(self) -> Any:
        if not hasattr(self, "_json"):
            body = await self.body()
            try:
                # A large body is parsed on a worker thread, which hands the event loop the GIL back meanwhile.
                large = len(body) > self.app.state.settings.large_body_bytes
                self._json = await run_in_threadpool(_PARSE, body) if large else _PARSE(body)
            except json.JSONDecodeError:
                raise
            except ValueError as error:
                # A key named twice, an integer of over 4300 digits: as a JSONDecodeError, FastAPI's 422.
                raise json.JSONDecodeError(str(error), "", 0) from None
        return self._json


_PARSE = functools.partial(json.loads, object_pairs_hook=unique_keys)


class UniqueKeysRoute(APIRoute):
    def get_route_handler(self) -> Callable[[Request], Any]:
        handler = super().get_route_handler()

        async def unique_keys_handler(request: Request) -> Response:
            return await handler(_UniqueKeysRequest(request.scope, request.receive))

        return unique_keys_handler


MAX_ECHO = 200  # characters of an echoed string; items of an echoed list or object
MAX_MESSAGE = 2000  # a message lists the names it knows; it is ours, so only bounded


def _text(value: str, limit: int = MAX_ECHO) -> str:
    value = value.encode("utf-8", "backslashreplace").decode("utf-8")  # lone surrogates -> \ud800
    return value if len(value) <= limit else value[:limit] + f"... ({len(value)} characters)"


def _json_safe(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)  # "nan", "inf", "-inf"
    if isinstance(value, str):
        return _text(value)
    if isinstance(value, dict):
        return {_text(str(key)): _json_safe(item) for key, item in list(value.items())[:MAX_ECHO]}
    if isinstance(value, (list, tuple)):
        return [_json_safe(item) for item in list(value)[:MAX_ECHO]]
    return value


def _error(item: dict[str, Any]) -> dict[str, Any]:
    loc = list(item.get("loc", []))
    if loc[:1] == ["body"]:  # the JSON path the client wrote (client_path: without the tags of a field's form)
        loc = ["body", *client_path(loc[1:])]
    out = _json_safe({**item, "loc": loc})
    if isinstance(item.get("msg"), str):
        out["msg"] = _text(item["msg"].removeprefix("Value error, "), MAX_MESSAGE)  # our messages speak for themselves
    return out


async def validation_error_handler(request: Request, error: RequestValidationError) -> JSONResponse:
    # Cut short, then encoded: an error's input may be the whole body (a "missing" one's).
    return JSONResponse(status_code=422, content={"detail": jsonable_encoder(
        [_error(item) for item in error.errors()[:MAX_ECHO]])})


async def http_error_handler(request: Request, error: HTTPException) -> Response:
    """FastAPI's answer, with a 405's Allow listing the methods /openapi.json documents for the path."""
    cause = error.__cause__
    if error.status_code == 400 and isinstance(cause, (RecursionError, UnicodeDecodeError)):
        # A body JSON's parser refused other than by a JSONDecodeError: the 422 of every other body not JSON.
        why = "nested too deeply" if isinstance(cause, RecursionError) else "not UTF-8"
        return JSONResponse(status_code=422, content={"detail": [{
            "type": "json_invalid", "loc": ["body"], "msg": f"the body is not JSON this service can read ({why})",
            "input": None}]})
    if error.status_code == 405:  # Starlette's Allow names the methods of the first route whose path matched
        methods = {method.upper() for path, operations in request.app.openapi()["paths"].items()
                   if compile_path(path)[0].fullmatch(request.scope["path"]) for method in operations}
        if methods:
            error = HTTPException(405, detail=error.detail, headers={**(error.headers or {}),
                                                                   "Allow": ", ".join(sorted(methods))})
    return await http_exception_handler(request, error)
