"""Request bodies whose JSON names a key twice in one object are refused (422, as a body that is not JSON is),
not read with the last value winning: {"h": 0.1, ..., "h": 10} ran at h = 10 (a service audit), where an unknown key is refused. FastAPI reads
a body through Request.json(); the routers that take JSON bodies use this route class, whose Request parses it
with a hook that refuses a repeated key (as `raydamp run` does for a job file)."""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

from fastapi import Request, Response
from fastapi.routing import APIRoute
from raydamp.jobs.build import unique_keys

__all__ = ["UniqueKeysRoute"]


class _UniqueKeysRequest(Request):
    async def json(self) -> Any:
        if not hasattr(self, "_json"):
            try:
                self._json = json.loads(await self.body(), object_pairs_hook=unique_keys)
            except json.JSONDecodeError:
                raise
            except ValueError as error:
                # A key named twice (unique_keys), an integer of over 4300 digits (a 400 naming nothing before):
                # FastAPI answers a JSONDecodeError with its 422 (loc ["body", position], the message in ctx.error).
                raise json.JSONDecodeError(str(error), "", 0) from None
        return self._json


class UniqueKeysRoute(APIRoute):
    def get_route_handler(self) -> Callable[[Request], Any]:
        handler = super().get_route_handler()

        async def unique_keys_handler(request: Request) -> Response:
            return await handler(_UniqueKeysRequest(request.scope, request.receive))

        return unique_keys_handler
