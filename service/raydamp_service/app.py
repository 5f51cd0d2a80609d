"""The FastAPI application: routers, and a lifespan that opens the store and runs the workers."""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

import raydamp
from fastapi import FastAPI
from fastapi.exceptions import RequestValidationError

from .config import Settings
from .errors import validation_error_handler
from .routes import catalogue, health, jobs
from .runner import Runner
from .store import JobStore

__all__ = ["create_app"]


def create_app(settings: Settings | None = None) -> FastAPI:
    settings = settings or Settings()

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        store = JobStore(settings.db)
        store.open()
        runner = Runner(store, settings)
        app.state.store, app.state.runner = store, runner
        runner.start()
        try:
            yield
        finally:
            runner.stop()
            store.close()

    app = FastAPI(title="raydamp", version=raydamp.__version__, lifespan=lifespan,
                  summary="Damped Hamiltonian integrations as jobs: submit, poll, fetch the trajectory.")
    app.state.settings = settings
    app.add_exception_handler(RequestValidationError, validation_error_handler)
    for router in (jobs.router, catalogue.router, health.router):
        app.include_router(router)
    return app
