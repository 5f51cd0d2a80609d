"""422 responses that survive the input they complain about; 405 responses whose Allow header is right.

FastAPI echoes the offending input in each error; a request carrying NaN or Infinity (which
Python's JSON parser accepts) or a lone surrogate (valid JSON escape, invalid UTF-8) would make
that echo unencodable and turn the 422 into a 500, and a megabyte-long expression would come
back whole. The echo is made encodable and cut short.

A 405 names in Allow every method the path takes: Starlette's names only those of the first route whose
path matched (OPTIONS /v1/jobs answered "Allow: POST", though GET lists the jobs).
"""

from __future__ import annotations

import math
import re
from typing import Any

from fastapi import Request
from fastapi.encoders import jsonable_encoder
from fastapi.exception_handlers import http_exception_handler
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException
from starlette.responses import Response

from raydamp.jobs import client_path

__all__ = ["validation_error_handler", "http_error_handler"]


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


def _path(loc: list[Any]) -> list[Any]:
    """The JSON path the client wrote (raydamp.jobs.client_path: without the tags of a field's form)."""
    return ["body", *client_path(loc[1:])] if loc and loc[0] == "body" else loc


def _error(item: dict[str, Any]) -> dict[str, Any]:
    out = _json_safe({**item, "loc": _path(list(item.get("loc", [])))})
    if isinstance(item.get("msg"), str):
        out["msg"] = _text(item["msg"].removeprefix("Value error, "), MAX_MESSAGE)  # our messages speak for themselves
    return out


async def validation_error_handler(request: Request, error: RequestValidationError) -> JSONResponse:
    # Cut short, then encoded: an error's input may be the whole body (a "missing" one's), which encoded
    # first took 0.75 s for a body of 160,000 keys, on the event loop.
    return JSONResponse(status_code=422, content={"detail": jsonable_encoder(
        [_error(item) for item in error.errors()[:MAX_ECHO]])})


async def http_error_handler(request: Request, error: HTTPException) -> Response:
    """FastAPI's own answer to an HTTPException, with a 405's Allow listing the methods /openapi.json
    documents for the path (a path it does not document, as the page's, keeps Starlette's)."""
    cause = error.__cause__
    if error.status_code == 400 and isinstance(cause, (RecursionError, UnicodeDecodeError)):
        # FastAPI's 400 "There was an error parsing the body", without a loc, for a body JSON's parser refused
        # other than by a JSONDecodeError (which is a 422): the 422 of every other body that is not JSON.
        why = "nested too deeply" if isinstance(cause, RecursionError) else "not UTF-8"
        return JSONResponse(status_code=422, content={"detail": [{
            "type": "json_invalid", "loc": ["body"], "msg": f"the body is not JSON this service can read ({why})",
            "input": None}]})
    if error.status_code == 405:
        path = request.scope["path"]
        methods = {method.upper() for pattern, operations in _documented_paths(request.app)
                   if pattern.fullmatch(path) for method in operations}
        if methods:
            error = HTTPException(405, detail=error.detail, headers={**(error.headers or {}),
                                                                   "Allow": ", ".join(sorted(methods))})
    return await http_exception_handler(request, error)


def _documented_paths(app: Any) -> list[tuple[re.Pattern, list[str]]]:
    """The paths of /openapi.json as patterns ({job_id} matches one segment), with their methods."""
    found = getattr(app.state, "documented_paths", None)
    if found is None:
        found = app.state.documented_paths = [
            (re.compile(re.sub(r"\\{[^/]+?\\}", "[^/]+", re.escape(path))), list(operations))
            for path, operations in app.openapi()["paths"].items()]
    return found
