"""The FastAPI application: routers, and a lifespan that opens the store and runs the workers."""

from __future__ import annotations

import gc
import threading
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

from fastapi import FastAPI
from fastapi.exceptions import RequestValidationError
from starlette.exceptions import HTTPException

import raydamp

from .checks.pool import CheckPool, ChecksBusy
from .config import Settings
from .edge.guard import RequestGuard, needs_token
from .edge.http import HeadAsGet, http_error_handler, validation_error_handler
from .kinds.jobs import JobStore
from .kinds.sweeps import SweepStore
from .routes import catalogue, files, health, jobs, page, sweeps
from .routes.tasks import checks_busy_handler
from .tasks import lock
from .tasks.runner import Runner
from .tasks.store import Database

__all__ = ["ROUTERS", "create_app"]

ROUTERS = (jobs.router, sweeps.router, files.router, catalogue.router, health.router, page.router)


def create_app(settings: Settings | None = None) -> FastAPI:
    settings = settings or Settings()

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        lock.hold(settings.db)  # before the recovery, which would re-queue another service's running jobs
        try:
            async with _serving(app, settings):
                yield
        finally:
            lock.release(settings.db)

    # /docs is ours (routes/page.py: no CDN). No redirect_slashes: its Location is built from the Host header.
    app = FastAPI(title="raydamp", version=raydamp.__version__, lifespan=lifespan, docs_url=None, redoc_url=None,
                  redirect_slashes=False,
                  summary="Damped Hamiltonian integrations as jobs: submit, poll, fetch the trajectory.")
    app.state.settings = settings
    app.state.large_fetches = threading.Semaphore(settings.max_large_fetches)
    app.add_middleware(RequestGuard, settings=settings)
    app.add_middleware(HeadAsGet)  # outermost: the guard sees the HEAD as the GET it runs as
    app.add_exception_handler(RequestValidationError, validation_error_handler)
    app.add_exception_handler(HTTPException, http_error_handler)
    app.add_exception_handler(ChecksBusy, checks_busy_handler)
    for router in ROUTERS:
        app.include_router(router, responses=_guarded(settings, router is files.router))
    page.mount_assets(app)
    _document_settings(app, settings)
    return app


@asynccontextmanager
async def _serving(app: FastAPI, settings: Settings) -> AsyncIterator[None]:
    database = Database(settings.db)
    app.state.store, app.state.sweeps = stores = JobStore(database), SweepStore(database)
    for store in stores:
        store.open()
    app.state.checks = checks = CheckPool(settings)
    app.state.runner, app.state.sweep_runner = runners = [Runner(store, settings, store.work(settings, checks))
                                                          for store in stores]
    checks.start()
    for runner in runners:
        runner.start()
    gc.freeze()  # what is built so far lives as long as the process: collections walk only what requests make
    try:
        yield
    finally:
        checks.stop()
        for runner in reversed(runners):
            runner.stop()
        database.close()


def _guarded(settings: Settings, uploads: bool) -> dict[int | str, dict[str, Any]]:
    """The answers the guard (edge/) may give before any route runs, for /openapi.json."""
    limit = (f"the file is over max_file_bytes = {settings.max_file_bytes}" if uploads else
             f"the body is over max_body_bytes = {settings.max_body_bytes}")
    return {400: {"description": "the Host is not one of trusted_hosts"}, 413: {"description": limit},
            408: {"description": f"the body did not arrive within body_seconds = {settings.body_seconds:g} s"},
            429: {"description": "max_large_bodies large bodies are being handled; retry after Retry-After seconds"},
            **({401: {"description": "no or wrong Authorization: Bearer <token>"}} if settings.token else {})}


def _document_settings(app: FastAPI, settings: Settings) -> None:
    """What only the settings know, in /openapi.json: the list limit's maximum, and the token."""
    generate = app.openapi

    def openapi() -> dict[str, Any]:
        if app.openapi_schema is None:
            schema = generate()
            for listing in ("/v1/jobs", "/v1/sweeps", "/v1/files"):
                for parameter in schema["paths"][listing]["get"]["parameters"]:
                    if parameter["name"] == "limit":
                        parameter["schema"]["maximum"] = settings.max_list_limit
            if settings.token is not None:
                schema["components"]["securitySchemes"] = {"bearer": {"type": "http", "scheme": "bearer"}}
                for path, operations in schema["paths"].items():
                    for operation in operations.values():
                        operation["security"] = [{"bearer": []}] if needs_token(path) else []
        return app.openapi_schema

    app.openapi = openapi  # type: ignore[method-assign]
